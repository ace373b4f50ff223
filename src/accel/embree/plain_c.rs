//! The report's Embree baseline: Embree traced by C code
//! (`csrc/embree_plain.c`, compiled by `build.rs`) exactly as a plain C
//! program traces it, so that hybrid's wrapper costs are measured against
//! it instead of being credited to the native backend.

use std::ffi::c_void;

pub use crate::accel::BatchMode;
use crate::geom::ray::FlatRay;

/// A committed Embree scene (`RTCScene`).
type Handle = *mut c_void;

/// A committed Embree scene as the C driver sees it.
///
/// # Safety
/// `c_calls` gives the scene's handle, committed and alive for as long as
/// `self` is borrowed, and the query functions of the library version
/// that made it (`Api::c_functions`), whose struct layouts the C function
/// of that major assumes.
pub(super) unsafe trait CommittedScene {
    fn c_calls(&self) -> (CFunctions, Handle);
}

/// An Embree version's query functions, as C function pointers: single
/// rays, packets of 8 and 16, and (Embree 3 only; null for 4) the stream.
#[derive(Clone, Copy, Debug)]
pub struct CFunctions {
    pub(super) version: EmbreeMajor,
    pub(super) intersect1: *const c_void,
    pub(super) occluded1: *const c_void,
    pub(super) intersect8: *const c_void,
    pub(super) occluded8: *const c_void,
    pub(super) intersect16: *const c_void,
    pub(super) occluded16: *const c_void,
    pub(super) intersect1m: *const c_void,
    pub(super) occluded1m: *const c_void,
}

/// One answer of the C driver's batched modes (`struct hybrid_hit`):
/// `geom` is `INVALID_GEOMETRY_ID` for a miss.
#[repr(C)]
#[derive(Clone, Copy, Debug, Default)]
pub struct CHit {
    pub t: f32,
    pub u: f32,
    pub v: f32,
    pub prim: u32,
    pub geom: u32,
}

/// Where a batched call puts its answers.
pub enum Answers<'a> {
    /// Only count hits (and sum their primitive ids).
    Count,
    Closest(&'a mut [CHit]),
    Blocked(&'a mut [u8]),
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
    fn hybrid_embree_packets(
        version: u32,
        width: u32,
        occluded: i32,
        f: *const c_void,
        scene: Handle,
        hint: u32,
        rays: *const f32,
        n: usize,
        out: *mut CHit,
        blocked: *mut u8,
        checksum: *mut u64,
    ) -> usize;
    fn hybrid_embree3_stream(
        occluded: i32,
        f: *const c_void,
        scene: Handle,
        hint: u32,
        rays: *const f32,
        n: usize,
        out: *mut CHit,
        blocked: *mut u8,
        checksum: *mut u64,
    ) -> usize;
}

/// The coherent-rays hint as Embree 3 spells it: the context flag
/// `RTC_INTERSECT_CONTEXT_FLAG_COHERENT`, bit 0 (`sys3.rs` checks it
/// against the header).
pub const COHERENT3: u32 = 1;
/// The same hint as Embree 4 spells it: the query flag
/// `RTC_RAY_QUERY_FLAG_COHERENT` of `RTCIntersectArguments`, bit 16
/// (`sys4.rs` checks it). Bit 0 means nothing there: given Embree 3's
/// value, Embree 4 took its incoherent path.
pub const COHERENT4: u32 = 1 << 16;

/// Traces `rays` in `mode` on the committed `scene`, with the coherent
/// hint or without: the hit (or
/// blocked) count and the sum of hit primitive ids, or `None` when this
/// version lacks the mode. Answers go where `answers` says; its slice
/// must be as long as `rays`, and match `occluded`.
pub(super) fn trace_batched(
    scene: &impl CommittedScene,
    mode: BatchMode,
    coherent: bool,
    rays: &[FlatRay],
    occluded: bool,
    answers: Answers,
) -> Option<(usize, u64)> {
    let (out, blocked) = match answers {
        Answers::Count => (std::ptr::null_mut(), std::ptr::null_mut()),
        Answers::Closest(o) if !occluded && o.len() == rays.len() => {
            (o.as_mut_ptr(), std::ptr::null_mut())
        }
        Answers::Blocked(b) if occluded && b.len() == rays.len() => {
            (std::ptr::null_mut(), b.as_mut_ptr())
        }
        _ => return None,
    };
    let (c, scene) = scene.c_calls();
    let f = match (mode, occluded) {
        (BatchMode::Packet8, false) => c.intersect8,
        (BatchMode::Packet8, true) => c.occluded8,
        (BatchMode::Packet16, false) => c.intersect16,
        (BatchMode::Packet16, true) => c.occluded16,
        (BatchMode::Stream, false) => c.intersect1m,
        (BatchMode::Stream, true) => c.occluded1m,
    };
    if f.is_null() {
        return None;
    }
    let (version, coherent_flag) = match c.version {
        EmbreeMajor::Three => (3, COHERENT3),
        EmbreeMajor::Four => (4, COHERENT4),
    };
    let hint = if coherent { coherent_flag } else { 0 };
    let mut checksum = 0u64;
    let (p, n) = (rays.as_ptr().cast::<f32>(), rays.len());
    // SAFETY: `f` is this version's function for the mode (non-null), the
    // layouts the C code fills are that version's (`version`), `scene` is
    // a live committed scene of the library, `p` points at `n` rays of
    // eight floats, and `out` / `blocked` are null or hold `n` answers.
    let hits = unsafe {
        match mode {
            BatchMode::Stream => hybrid_embree3_stream(
                occluded as i32,
                f,
                scene,
                hint,
                p,
                n,
                out,
                blocked,
                &mut checksum,
            ),
            BatchMode::Packet8 | BatchMode::Packet16 => hybrid_embree_packets(
                version,
                if mode == BatchMode::Packet8 { 8 } else { 16 },
                occluded as i32,
                f,
                scene,
                hint,
                p,
                n,
                out,
                blocked,
                &mut checksum,
            ),
        }
    };
    (hits != usize::MAX).then_some((hits, checksum))
}

/// Traces `rays` on the committed `scene`; returns the hit count and the
/// sum of hit primitive ids.
pub(super) fn trace(scene: &impl CommittedScene, rays: &[FlatRay], occluded: bool) -> (usize, u64) {
    let (c, scene) = scene.c_calls();
    let mut checksum = 0u64;
    let (p, n) = (rays.as_ptr().cast::<f32>(), rays.len());
    // SAFETY: `c` holds the functions of the version whose layouts the C
    // function of its major assumes (`Api::c_functions`), `scene` is the
    // handle of the live committed scene borrowed for this call, and `p`
    // points at `n` rays of eight floats.
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
