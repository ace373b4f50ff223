//! The report's Embree baseline: Embree traced by C code
//! (`csrc/embree_plain.c`, compiled by `build.rs`) exactly as a plain C
//! program traces it, so that hybrid's wrapper costs are measured against
//! it instead of being credited to the native backend.

use std::ffi::c_void;

use crate::geom::ray::FlatRay;

/// A committed Embree scene (`RTCScene`).
type Handle = *mut c_void;

/// An Embree version's single-ray functions, as C function pointers.
#[derive(Clone, Copy, Debug)]
pub struct CFunctions {
    pub version: EmbreeMajor,
    pub intersect1: *const c_void,
    pub occluded1: *const c_void,
}

/// Which header layout the C driver uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EmbreeMajor {
    Three,
    Four,
}

extern "C" {
    fn hybrid_embree3_closest(
        f: *const c_void,
        scene: Handle,
        rays: *const f32,
        n: usize,
        checksum: *mut u64,
    ) -> usize;
    fn hybrid_embree3_occluded(
        f: *const c_void,
        scene: Handle,
        rays: *const f32,
        n: usize,
    ) -> usize;
    fn hybrid_embree4_closest(
        f: *const c_void,
        scene: Handle,
        rays: *const f32,
        n: usize,
        checksum: *mut u64,
    ) -> usize;
    fn hybrid_embree4_occluded(
        f: *const c_void,
        scene: Handle,
        rays: *const f32,
        n: usize,
    ) -> usize;
}

/// Traces `rays` on the committed `scene` of the version whose functions
/// are `c`; returns the hit count and the sum of hit primitive ids.
pub(super) fn trace(
    c: CFunctions,
    scene: Handle,
    rays: &[FlatRay],
    occluded: bool,
) -> (usize, u64) {
    let mut checksum = 0u64;
    let (p, n) = (rays.as_ptr().cast::<f32>(), rays.len());
    // SAFETY: `c` holds the functions of the version whose layouts the C
    // function of its major assumes (`Api::c_functions`), `scene` is a live
    // committed scene of that library (the caller's `Scene` borrows it),
    // and `p` points at `n` rays of eight floats.
    let hits = unsafe {
        match (c.version, occluded) {
            (EmbreeMajor::Three, false) => {
                hybrid_embree3_closest(c.intersect1, scene, p, n, &mut checksum)
            }
            (EmbreeMajor::Three, true) => hybrid_embree3_occluded(c.occluded1, scene, p, n),
            (EmbreeMajor::Four, false) => {
                hybrid_embree4_closest(c.intersect1, scene, p, n, &mut checksum)
            }
            (EmbreeMajor::Four, true) => hybrid_embree4_occluded(c.occluded1, scene, p, n),
        }
    };
    (hits, checksum)
}
