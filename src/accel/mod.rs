//! The accelerator layer: one trait, [`Accel`], with three backends that the
//! same integrators run on.
//!
//! - [`native`]: the project's own SAH BVH with Möller–Trumbore (or
//!   watertight) triangles and analytic spheres;
//! - [`embree`]: Embree 3 and Embree 4 through FFI, loaded at run time;
//! - [`brute`]: every primitive for every ray, the baseline.
//!
//! The trait answers only "which primitive, where" ([`Hit`]); the shading
//! data of a hit are derived above it, from the scene
//! ([`crate::scene::Scene::surface_point`]), the same way for every backend.
//! [`Backend`] is the tagged union the program chooses at run time; which
//! one, with which options, is a [`BackendConfig`] (`config.rs`), the one
//! place that names them. Rays and hits are the base layer's
//! ([`crate::geom`]).

pub mod brute;
pub mod config;
pub mod embree;
pub mod native;

pub use self::config::{Backend, BackendConfig};
use crate::geom::{Hit, Ray};

/// Per-thread counters of the work a backend did; summed at the end of a
/// render. Backends that cannot count tests (Embree) count rays only.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TraceCounters {
    pub rays: u64,
    /// Ray/box tests.
    pub box_tests: u64,
    /// Ray/primitive tests.
    pub prim_tests: u64,
}

impl std::ops::AddAssign for TraceCounters {
    fn add_assign(&mut self, o: TraceCounters) {
        self.rays += o.rays;
        self.box_tests += o.box_tests;
        self.prim_tests += o.prim_tests;
    }
}

/// What a backend reports about its acceleration structure.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AccelStats {
    pub backend: String,
    pub primitives: usize,
    pub build_ms: f64,
    /// Bytes of the acceleration structure and the primitive data it keeps.
    pub memory_bytes: usize,
    /// Native BVH only (zero elsewhere).
    pub nodes: usize,
    pub leaves: usize,
    pub depth: usize,
    pub sah_cost: f64,
    /// Free-form details (Embree version and ISA, build quality).
    pub details: String,
}

/// The three queries an integrator may ask (pbrt-v4's aggregate interface).
pub trait Accel: Sync + Send {
    /// The closest hit in `[ray.t_min, ray.t_max]`, if any.
    fn closest_hit(&self, ray: &Ray, counters: &mut TraceCounters) -> Option<Hit>;
    /// True if anything lies in `[ray.t_min, ray.t_max]`.
    fn occluded(&self, ray: &Ray, counters: &mut TraceCounters) -> bool;
    /// The closest hits of a batch of rays, one answer per ray in `out`
    /// (cleared first): the same answers as [`Accel::closest_hit`], through
    /// the backend's batched mode where it has one.
    fn closest_hits(&self, rays: &[Ray], out: &mut Vec<Option<Hit>>) {
        let mut counters = TraceCounters::default();
        out.clear();
        out.extend(rays.iter().map(|r| self.closest_hit(r, &mut counters)));
    }
    fn stats(&self) -> AccelStats;
}

/// Why a backend could not be built.
#[derive(Debug, thiserror::Error)]
pub enum AccelError {
    #[error("embree: {0}")]
    Embree(String),
    /// The backend's library is not installed (the message says what to
    /// install).
    #[error("{0}")]
    Unavailable(String),
    #[error("{0}")]
    TooLarge(String),
    /// A structure failed its own check after it was built: a bug,
    /// reported as an error rather than traversed.
    #[error("{0}")]
    Internal(String),
}
