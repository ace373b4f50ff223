//! The accelerator layer: one trait, [`Accel`], with three backends that the
//! same integrators run on.
//!
//! - [`native`]: the project's own SAH BVH with Möller–Trumbore (or
//!   watertight) triangles and analytic spheres;
//! - [`embree`]: Embree through FFI;
//! - [`brute`]: every primitive for every ray, the baseline.
//!
//! The trait answers only "which primitive, where" ([`Hit`]); the shading
//! data of a hit are derived above it, from the scene
//! ([`crate::scene::Scene::surface_point`]), the same way for every backend.
//! [`Backend`] is the tagged union the program chooses at run time: the
//! backend is swapped in that one place.

pub mod brute;
pub mod embree;
pub mod native;

use glam::Vec3;

use crate::scene::Scene;

/// A ray `origin + t * dir` for `t` in `[t_min, t_max]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub t_min: f32,
    pub t_max: f32,
}

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Ray {
        Ray {
            origin,
            dir,
            t_min: 0.0,
            t_max: f32::INFINITY,
        }
    }

    pub fn segment(origin: Vec3, dir: Vec3, t_max: f32) -> Ray {
        Ray {
            origin,
            dir,
            t_min: 0.0,
            t_max,
        }
    }

    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }

    /// Rays with NaN or infinite components, a zero direction or an empty
    /// interval are reported as misses by every backend, never traced.
    #[inline]
    pub fn is_traceable(&self) -> bool {
        self.origin.is_finite()
            && self.dir.is_finite()
            && self.dir != Vec3::ZERO
            && self.t_min >= 0.0
            && self.t_min <= self.t_max
            && !self.t_max.is_nan()
    }
}

/// The closest hit along a ray: what every backend reports.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Global primitive id: triangles first, then spheres.
    pub prim: u32,
    /// Barycentric weights of the triangle's corners 1 and 2 (corner 0 has
    /// `1 - u - v`); zero for spheres.
    pub u: f32,
    pub v: f32,
    /// Unit geometric normal: `normalize((v1 - v0) x (v2 - v0))` for
    /// triangles, outward for spheres.
    pub normal: Vec3,
}

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
    fn stats(&self) -> AccelStats;
}

/// Which backend to build.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum AccelKind {
    Native,
    Embree,
    None,
}

impl AccelKind {
    pub fn name(self) -> &'static str {
        match self {
            AccelKind::Native => "native",
            AccelKind::Embree => "embree",
            AccelKind::None => "none",
        }
    }
}

/// Options for building any backend.
#[derive(Clone, Copy, Debug, Default)]
pub struct AccelOptions {
    pub native: native::NativeOptions,
    pub embree: embree::EmbreeOptions,
}

/// The backend chosen at run time, as a tagged union: static dispatch on
/// the per-ray path, one match per query.
pub enum Backend<'s> {
    Native(native::NativeBvh),
    Embree(embree::EmbreeAccel<'s>),
    Brute(brute::BruteForce),
}

/// Why a backend could not be built.
#[derive(Debug, thiserror::Error)]
pub enum AccelError {
    #[error("embree: {0}")]
    Embree(String),
}

impl<'s> Backend<'s> {
    /// Builds the chosen backend over `scene`.
    pub fn build(
        kind: AccelKind,
        scene: &'s Scene,
        options: &AccelOptions,
    ) -> Result<Backend<'s>, AccelError> {
        Ok(match kind {
            AccelKind::Native => Backend::Native(native::NativeBvh::build(scene, &options.native)),
            AccelKind::Embree => {
                Backend::Embree(embree::EmbreeAccel::build(scene, &options.embree)?)
            }
            AccelKind::None => Backend::Brute(brute::BruteForce::build(scene)),
        })
    }
}

impl Accel for Backend<'_> {
    #[inline]
    fn closest_hit(&self, ray: &Ray, counters: &mut TraceCounters) -> Option<Hit> {
        match self {
            Backend::Native(a) => a.closest_hit(ray, counters),
            Backend::Embree(a) => a.closest_hit(ray, counters),
            Backend::Brute(a) => a.closest_hit(ray, counters),
        }
    }

    #[inline]
    fn occluded(&self, ray: &Ray, counters: &mut TraceCounters) -> bool {
        match self {
            Backend::Native(a) => a.occluded(ray, counters),
            Backend::Embree(a) => a.occluded(ray, counters),
            Backend::Brute(a) => a.occluded(ray, counters),
        }
    }

    fn stats(&self) -> AccelStats {
        match self {
            Backend::Native(a) => a.stats(),
            Backend::Embree(a) => a.stats(),
            Backend::Brute(a) => a.stats(),
        }
    }
}
