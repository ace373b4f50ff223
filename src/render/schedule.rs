//! One integrator, two schedulers. A wave of camera rays (a row's
//! unfinished pixels times a few of their samples) is traced through the
//! backend's batch query; then either
//! - [`Mode::Reference`]: each path is walked alone from its first hit,
//!   every ray traced as it is needed ([`Integrator::radiance_from`]): the
//!   readable specification, which renders everything (normal shading
//!   too) on any CPU; or
//! - [`Mode::Wavefront`]: the wave's paths advance together bounce by
//!   bounce, every bounce's rays and shadow rays through batch queries,
//!   their state in lists stepped sixteen at a time
//!   ([`crate::render::wavefront`]).
//!
//! Both take every path's steps in the same order with the same numbers,
//! so they give the same bits (tested); how rays reach the backend, in
//! batches or one at a time ([`crate::accel::OneByOne`]), changes nothing
//! either. [`Mode::choose`] is the one place the mode is decided.

use std::time::Instant;

use glam::Vec3;

use super::integrator::{Integrator, Shading};
use super::times::{held, WaveTimes};
use super::wavefront::{lanes_take, Plan, Wave};
use crate::accel::{Accel, Coherence, TraceCounters};
use crate::geom::sampling::Rng;
use crate::geom::{Hit, Ray};
use crate::scene::Scene;

/// How a render advances its paths; the image is the same in both.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Mode {
    /// Each path alone from its first hit.
    Reference,
    /// A wave's paths together, bounce by bounce.
    Wavefront,
}

crate::choice!(Mode { Reference => "reference", Wavefront => "wavefront" });

impl Mode {
    /// The mode a render of `scene` shaded as `shading` runs in, and why,
    /// in words: the one `asked` for where it can run; by default the
    /// wavefront where its lanes take the scene's vertices (where it
    /// measured faster), else the reference. Normal shading is the
    /// reference's alone.
    pub fn choose(asked: Option<Mode>, scene: &Scene, shading: Shading) -> (Mode, &'static str) {
        match (asked, shading) {
            (_, Shading::Normals) => (Mode::Reference, "normal shading runs in the reference mode"),
            (Some(mode), _) => (mode, "as asked"),
            (None, _) if lanes_take(scene, shading) => (
                Mode::Wavefront,
                "the default where the wavefront's lanes take the scene's vertices",
            ),
            (None, _) => (
                Mode::Reference,
                "the default where the wavefront's lanes do not take the scene (emitting triangles or spheres, an environment map, hemisphere sampling, flat shading or over 8 light samples a vertex)",
            ),
        }
    }

    /// Paths a wave holds at most. The wavefront's hold up to about 0.85
    /// KB a path with their rays, hits and tape, so about 1.7 MB a thread
    /// however wide the row; 2048 measured faster than 1024 and 4096 on
    /// the meshes and level on the Cornell boxes. Where only camera rays
    /// travel together, Embree's camera packets measured 4% faster in
    /// waves of 4096 than of 1024, native's the same (docs/experiments.md).
    pub fn wave_paths(self) -> usize {
        match self {
            Mode::Reference => 4096,
            Mode::Wavefront => 2048,
        }
    }
}

/// Samples of each pixel a wave holds side by side at least, where the
/// batch has them: a row wider than a wave's paths over this goes in
/// pieces. A pixel's samples start along nearly one camera ray, so the
/// more of them travel together, the tighter a wave's camera packets, the
/// more its bounce rays share origins, and the more a wave's paths all
/// hit or all miss; 256 against 4 took 5-14% off the meshes' frames and
/// left the Cornell boxes level (docs/experiments.md).
pub const SIDE_BY_SIDE: u32 = 256;

/// A wave's camera rays and their random streams, filled by the caller,
/// and the lists the schedulers reuse from wave to wave: kept for the next
/// row a thread renders.
#[derive(Default)]
pub struct WaveLists {
    pub(super) rays: Vec<Ray>,
    pub(super) streams: Vec<Rng>,
    pub(super) values: Vec<Vec3>,
    hits: Vec<Option<Hit>>,
    wave: Wave,
}

impl WaveLists {
    /// The radiance along each of the wave's camera rays, path `k` drawing
    /// from `streams[k]`, into `values`: each path walked alone where
    /// `plan` is `None` (the reference), else the wavefront's. Where the
    /// wavefront's time went is added to `times`.
    pub(super) fn radiance<A: Accel>(
        &mut self,
        integrator: &Integrator<'_, A>,
        plan: Option<&Plan>,
        counters: &mut TraceCounters,
        times: &mut WaveTimes,
    ) {
        let n = self.rays.len();
        let clock = Instant::now();
        self.hits.resize(n, None);
        let accel = integrator.accel();
        accel.closest_hits(
            &self.rays,
            Coherence::Coherent,
            &mut self.hits[..n],
            counters,
        );
        self.values.clear();
        let Some(plan) = plan else {
            let paths = self.rays.iter().zip(&mut self.streams).zip(&self.hits);
            for ((ray, stream), &hit) in paths {
                let value = integrator.radiance_from(ray, hit, stream, counters);
                self.values.push(value);
            }
            return;
        };
        times.closest += clock.elapsed().as_secs_f64();
        self.wave.radiance(
            integrator,
            plan,
            &self.rays,
            &self.hits[..n],
            &mut self.streams,
            counters,
            &mut self.values,
            times,
        );
    }

    /// The bytes the lists hold.
    pub(super) fn held_bytes(&self) -> usize {
        held(&self.rays)
            + held(&self.streams)
            + held(&self.values)
            + held(&self.hits)
            + self.wave.held_bytes()
    }
}
