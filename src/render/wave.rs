//! Many paths advanced together, bounce by bounce: each bounce's
//! extension rays through one batch query, then every shadow ray of their
//! vertices' direct lighting through another (breadth-first path tracing,
//! as in MoonRay, Lee et al. 2017, and Áfra et al. 2016's ray streams).
//! A path keeps its own random stream and takes the same steps in the
//! same order as when it is walked alone ([`super::integrator::PathState`]),
//! so the radiance of every path, and the image, does not depend on how
//! paths are grouped.

use std::time::Instant;

use glam::Vec3;

use super::integrator::{ArrayWave, Integrator, PathState, ShadowTape};
use super::lanes::surface_points;
use crate::accel::native::cpu::Avx2;
use crate::accel::{Accel, Coherence, TraceCounters};
use crate::geom::sampling::Rng;
use crate::geom::{Hit, Ray};
use crate::scene::SurfacePoint;

/// How the renderer hands rays to the backend. The default is the one
/// that measured fastest (docs/design.md, Batching in the renderer).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum Batching {
    /// Camera rays in one batch query per wave; each path goes on alone
    /// from its first hit.
    #[default]
    Camera,
    /// Every ray of a wave of paths in batch queries, bounce by bounce
    /// (`--waves`).
    Waves,
    /// Every ray alone (`--no-packets`).
    Alone,
}

impl Batching {
    /// What `hybrid render` says about it.
    pub fn describe(self) -> &'static str {
        match self {
            Batching::Camera => "camera rays together, each path alone from its first hit",
            Batching::Waves => "every bounce's rays of a wave of paths together (--waves)",
            Batching::Alone => "one ray at a time (--no-packets)",
        }
    }
}

/// Where a wave renderer's time went, in seconds of the threads that
/// rendered (summed over them): its batch queries of extension rays and of
/// shadow rays, and the rest, which steps the paths (shading each hit,
/// choosing its light samples and next direction) and gathers the moving
/// paths' rays. Each phase is timed once per bounce of a wave, a few clock
/// reads per thousand paths. Zero unless the renderer ran `--waves`.
/// With them, the memory a wave held: the most bytes any one row's lists
/// reached (a thread renders one row at a time), the most over the rows.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct WaveTimes {
    pub closest: f64,
    pub occluded: f64,
    pub paths: f64,
    /// Where a wave in arrays spent `paths` ([`Steps`]); zeros otherwise.
    pub steps: Steps,
    pub peak_bytes: usize,
}

/// The stepping of a wave in arrays, in seconds, by what it does: taking
/// each path's hit (the sky or emission it sees, its vertex gathered, its
/// surface point and shading frame), sampling the lights (each vertex's
/// light samples and the gathering of their shadow rays), and leaving
/// (the direct light summed once the shadow rays are answered, Russian
/// roulette, the BSDF's sample and the next rays gathered).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Steps {
    pub arrive: f64,
    pub light: f64,
    pub leave: f64,
}

impl Steps {
    /// Each step's share of the stepping it breaks down, in the fields'
    /// order; `None` when nothing was timed.
    pub fn shares(&self) -> Option<[f64; 3]> {
        let total = self.arrive + self.light + self.leave;
        (total > 0.0).then(|| [self.arrive, self.light, self.leave].map(|t| t / total))
    }
}

impl std::ops::AddAssign for Steps {
    fn add_assign(&mut self, o: Steps) {
        self.arrive += o.arrive;
        self.light += o.light;
        self.leave += o.leave;
    }
}

impl WaveTimes {
    pub fn total(&self) -> f64 {
        self.closest + self.occluded + self.paths
    }

    /// Each phase's share of the total, in the fields' order (zeros when
    /// nothing was timed).
    pub fn shares(&self) -> [f64; 3] {
        let total = self.total();
        if total <= 0.0 {
            return [0.0; 3];
        }
        [self.closest, self.occluded, self.paths].map(|t| t / total)
    }
}

impl std::ops::AddAssign for WaveTimes {
    fn add_assign(&mut self, o: WaveTimes) {
        self.closest += o.closest;
        self.occluded += o.occluded;
        self.paths += o.paths;
        self.steps += o.steps;
        self.peak_bytes = self.peak_bytes.max(o.peak_bytes);
    }
}

/// Paths traced together, and the lists they reuse from wave to wave.
#[derive(Default)]
pub struct Wave<'s> {
    /// Where the waves' time went so far.
    pub times: WaveTimes,
    states: Vec<PathState<'s>>,
    tape: ShadowTape,
    blocked: Vec<bool>,
    hits: Vec<Option<Hit>>,
    /// The moving paths (indices into `states`) and their rays.
    moving: Vec<u32>,
    /// The paths paused at a vertex (indices into `states`, ascending):
    /// the passes after a batch of hits visit only these, not the ended.
    paused: Vec<u32>,
    rays: Vec<Ray>,
    /// The surface points of their hits, computed in lanes.
    points: Vec<SurfacePoint>,
    /// The wave in arrays, where its plan takes the scene.
    arrays: ArrayWave,
}

impl<'s> Wave<'s> {
    /// The bytes the wave's lists hold (their capacity: what they grew to
    /// over the waves so far).
    pub fn held_bytes(&self) -> usize {
        held(&self.states)
            + self.tape.held_bytes()
            + held(&self.blocked)
            + held(&self.hits)
            + held(&self.moving)
            + held(&self.paused)
            + held(&self.rays)
            + held(&self.points)
            + self.arrays.held_bytes()
    }

    /// The radiance along each of `camera_rays`, path `k` drawing from
    /// `streams[k]`, into `values` (cleared first).
    pub fn radiance<A: Accel>(
        &mut self,
        integrator: &Integrator<'s, A>,
        batching: Batching,
        camera_rays: &[Ray],
        streams: &mut [Rng],
        counters: &mut TraceCounters,
        values: &mut Vec<Vec3>,
    ) {
        values.clear();
        let accel = integrator.accel();
        let n = camera_rays.len();
        // The phases of a wave, timed from here (the camera rays).
        let mut clock = Instant::now();
        let mut lap = |into: &mut f64| {
            let now = Instant::now();
            *into += (now - clock).as_secs_f64();
            clock = now;
        };
        self.hits.resize(n, None);
        if batching == Batching::Alone {
            for (ray, hit) in camera_rays.iter().zip(&mut self.hits) {
                *hit = accel.closest_hit(ray, counters);
            }
        } else {
            accel.closest_hits(
                camera_rays,
                Coherence::Coherent,
                &mut self.hits[..n],
                counters,
            );
        }
        if batching != Batching::Waves {
            for ((ray, stream), &hit) in camera_rays.iter().zip(streams).zip(&self.hits) {
                values.push(integrator.radiance_from(ray, hit, stream, counters));
            }
            return;
        }
        lap(&mut self.times.closest);
        let avx2 = Avx2::detect();
        if let Some(plan) = integrator.array_plan(avx2) {
            self.arrays.radiance(
                integrator,
                &plan,
                camera_rays,
                &self.hits[..n],
                streams,
                counters,
                values,
                &mut self.times,
            );
            return;
        }
        self.tape.clear();
        self.states.clear();
        self.states.resize_with(n, || PathState::Done(Vec3::ZERO));
        surface_points(
            integrator.scene(),
            avx2,
            camera_rays,
            &self.hits[..n],
            &mut self.points,
        );
        self.paused.clear();
        for (k, (state, stream)) in self.states.iter_mut().zip(&mut *streams).enumerate() {
            let (ray, hit) = (&camera_rays[k], self.hits[k]);
            let point = hit.map(|_| &self.points[k]);
            integrator.begin(ray, hit, point, stream, counters, state);
            if matches!(state, PathState::Paused(_)) {
                self.paused.push(k as u32);
            }
        }
        self.light(integrator, streams, counters);
        lap(&mut self.times.paths);
        self.answer_shadows(integrator, counters);
        lap(&mut self.times.occluded);
        loop {
            self.moving.clear();
            self.rays.clear();
            for &k in &self.paused {
                let (state, stream) = (&mut self.states[k as usize], &mut streams[k as usize]);
                integrator.go_on(state, &self.tape, &self.blocked, stream);
                if let Some(ray) = state.ray() {
                    self.moving.push(k);
                    self.rays.push(*ray);
                }
            }
            lap(&mut self.times.paths);
            if self.moving.is_empty() {
                break;
            }
            let m = self.rays.len();
            self.hits.resize(m, None);
            accel.closest_hits(
                &self.rays,
                Coherence::Incoherent,
                &mut self.hits[..m],
                counters,
            );
            lap(&mut self.times.closest);
            self.tape.clear();
            surface_points(
                integrator.scene(),
                avx2,
                &self.rays,
                &self.hits[..m],
                &mut self.points,
            );
            self.paused.clear();
            for ((&k, &hit), point) in self.moving.iter().zip(&self.hits).zip(&self.points) {
                let point = hit.map(|_| point);
                let state = &mut self.states[k as usize];
                integrator.arrive_at(state, hit, point);
                if matches!(state, PathState::Paused(_)) {
                    self.paused.push(k);
                }
            }
            self.light(integrator, streams, counters);
            lap(&mut self.times.paths);
            self.answer_shadows(integrator, counters);
            lap(&mut self.times.occluded);
        }
        values.extend(self.states.iter().map(|s| s.value().unwrap_or(Vec3::ZERO)));
    }

    /// The direct lighting of every path paused at a vertex, onto the
    /// tape (in path order).
    fn light<A: Accel>(
        &mut self,
        integrator: &Integrator<'s, A>,
        streams: &mut [Rng],
        counters: &mut TraceCounters,
    ) {
        for &k in &self.paused {
            let (state, stream) = (&mut self.states[k as usize], &mut streams[k as usize]);
            integrator.light_at(state, stream, &mut self.tape, counters);
        }
    }

    /// The tape's shadow rays through one batch query.
    fn answer_shadows<A: Accel>(
        &mut self,
        integrator: &Integrator<'s, A>,
        counters: &mut TraceCounters,
    ) {
        self.blocked.clear();
        self.blocked.resize(self.tape.rays().len(), false);
        integrator
            .accel()
            .occluded_all(self.tape.rays(), &mut self.blocked, counters);
    }
}

/// The bytes `list`'s allocation holds.
pub fn held<T>(list: &Vec<T>) -> usize {
    list.capacity() * std::mem::size_of::<T>()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wave's path states, the largest part of its memory, stay within
    /// the bound docs/design.md states (Waves): at most 256 bytes a path,
    /// 512 KiB a wave.
    #[test]
    fn a_wave_of_paths_stays_within_its_memory_bound() {
        let per_path = std::mem::size_of::<PathState>();
        eprintln!("{per_path} bytes per path state");
        assert!(per_path <= 256, "{per_path} bytes per path state");
        assert!(per_path * super::super::WAVE_PATHS <= 1 << 19);
    }
}
