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

/// The shape of a tree that a backend built and can see into (the native
/// BVH; Embree's trees are its own).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TreeFacts {
    pub nodes: usize,
    pub leaves: usize,
    /// Levels of wide nodes.
    pub depth: usize,
    /// SAH cost of the binary tree (see the native builder).
    pub sah_cost: f64,
    /// SAH cost of the wide tree, a node test per wide node.
    pub wide_sah_cost: f64,
}

/// What a backend reports about its acceleration structure, and the one
/// line that describes it ([`AccelStats::describe`]): nothing above the
/// trait needs to know which backend it was.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AccelStats {
    /// The backend's name (`native`, `embree3`, `embree4`, `none`).
    pub backend: String,
    pub primitives: usize,
    pub build_ms: f64,
    /// Bytes of the acceleration structure and the primitive data it keeps.
    pub memory_bytes: usize,
    /// The tree's shape, where the backend can see it.
    pub tree: Option<TreeFacts>,
    /// What was built, in words (Embree's version and ISA, build quality;
    /// the native triangle test and leaf size).
    pub details: String,
    /// How [`Accel::closest_hits`] and [`Accel::occluded_all`] trace a
    /// batch, in words.
    pub batch_call: &'static str,
}

impl AccelStats {
    /// The build as one line: backend, time, shape where known, memory and
    /// details.
    pub fn describe(&self) -> String {
        let shape = self.tree.map_or(String::new(), |t| {
            format!(
                "{} nodes, {} leaves, depth {}, SAH cost {:.2} (binary), {:.2} (wide), ",
                t.nodes, t.leaves, t.depth, t.sah_cost, t.wide_sah_cost
            )
        });
        format!(
            "{} built in {:.1} ms: {shape}{:.1} MiB ({})",
            self.backend,
            self.build_ms,
            self.memory_bytes as f64 / (1 << 20) as f64,
            self.details
        )
    }
}

/// How alike the rays of a batch are, as the caller knows them: a hint
/// some backends take (Embree's coherent flag, made for camera rays);
/// the answers never depend on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Coherence {
    /// Rays from one point through neighbouring pixels: camera rays.
    Coherent,
    /// Anything else: bounces, shadow rays, a wave's rays.
    Incoherent,
}

/// The three queries an integrator may ask (pbrt-v4's aggregate interface).
pub trait Accel: Sync + Send {
    /// The closest hit in `[ray.t_min, ray.t_max]`, if any.
    fn closest_hit(&self, ray: &Ray, counters: &mut TraceCounters) -> Option<Hit>;
    /// True if anything lies in `[ray.t_min, ray.t_max]`.
    fn occluded(&self, ray: &Ray, counters: &mut TraceCounters) -> bool;
    /// The closest hits of a batch of rays, answer `i` into `out[i]` (the
    /// caller's buffer, as long as `rays`; no allocation per call): the
    /// same answers as [`Accel::closest_hit`], through the backend's
    /// batched mode where it has one (native and Embree: packets), told
    /// how alike the rays are.
    fn closest_hits(
        &self,
        rays: &[Ray],
        coherence: Coherence,
        out: &mut [Option<Hit>],
        counters: &mut TraceCounters,
    ) {
        let _ = coherence;
        debug_assert_eq!(rays.len(), out.len());
        for (ray, answer) in rays.iter().zip(out) {
            *answer = self.closest_hit(ray, counters);
        }
    }
    /// Whether each ray of a batch is blocked, as [`Accel::occluded`], into
    /// `out` like [`Accel::closest_hits`].
    fn occluded_all(&self, rays: &[Ray], out: &mut [bool], counters: &mut TraceCounters) {
        debug_assert_eq!(rays.len(), out.len());
        for (ray, answer) in rays.iter().zip(out) {
            *answer = self.occluded(ray, counters);
        }
    }
    fn stats(&self) -> AccelStats;
}

/// A backend whose batch queries are answered one ray at a time, each by
/// `inner`'s single-ray query: the renderer's rays as a caller without
/// packets would trace them (`hybrid render --no-packets`, and the
/// report's batched-against-alone frames). The answers are `inner`'s, so
/// the image is the same.
pub struct OneByOne<'a, A>(pub &'a A);

impl<A: Accel> Accel for OneByOne<'_, A> {
    fn closest_hit(&self, ray: &Ray, counters: &mut TraceCounters) -> Option<Hit> {
        self.0.closest_hit(ray, counters)
    }
    fn occluded(&self, ray: &Ray, counters: &mut TraceCounters) -> bool {
        self.0.occluded(ray, counters)
    }
    fn stats(&self) -> AccelStats {
        AccelStats {
            batch_call: "one ray at a time (--no-packets)",
            ..self.0.stats()
        }
    }
}

/// A library's batched query mode, as a plain C caller uses it
/// ([`embree::PlainC::trace_batched`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BatchMode {
    /// Packets of 8 rays (Embree: `rtcIntersect8` / `rtcOccluded8`).
    Packet8,
    /// Packets of 16 (`rtcIntersect16` / `rtcOccluded16`).
    Packet16,
    /// A stream of rays in one call (Embree 3's `rtcIntersect1M` /
    /// `rtcOccluded1M`).
    Stream,
}

impl BatchMode {
    pub const ALL: [BatchMode; 3] = [BatchMode::Packet8, BatchMode::Packet16, BatchMode::Stream];

    pub fn name(self) -> &'static str {
        match self {
            BatchMode::Packet8 => "packet8",
            BatchMode::Packet16 => "packet16",
            BatchMode::Stream => "stream",
        }
    }
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
