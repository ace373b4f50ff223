//! The wavefront: a wave's paths with their state in lists, one per value
//! (structure of arrays), stepped by passes that work sixteen paths at a
//! time, every bounce's rays and shadow rays through the backend's batch
//! queries (breadth-first path tracing, as MoonRay, Lee et al. 2017, and
//! pbrt-v4's `wavefront/` do). It computes what the reference integrator
//! ([`crate::render::integrator`]) computes, path by path in the same
//! operations and order, so the image has the reference's bits (tested).
//!
//! The stages, one file each:
//! - this file: the [`Plan`] (which vertices and lights the lanes take),
//!   the wave's lists and the bounce loop ([`Wave::radiance`]);
//! - `arrive`: what each path sees at its hit (the sky, emission), the
//!   paths that go on moved to the front of the slots, their hit data
//!   gathered, and the vertices the lanes do not take stepped alone by
//!   the reference's own code;
//! - `surface`: surface points, facing, shading frames and the
//!   terminator lift, in lanes;
//! - `light`: each vertex's light stream and light samples with their
//!   MIS-weighted terms and shadow rays, in lanes, and the direct light
//!   summed once the shadow rays are answered;
//! - `leave`: Russian roulette and the BSDF's sample, in lanes, and the
//!   next bounce's rays;
//! - `rng`: sixteen generators side by side, each with its own bits;
//! - `lists`: the lists' helpers (loads, stores, sizes).
//!
//! The lanes take Lambertian vertices of smoothly shaded scenes lit by
//! point, directional, rectangular area and ambient lights under light
//! sampling or MIS; a sphere's surface point is the scalar function's.
//! Every other vertex (a mirror, glass, a rough conductor, or any vertex
//! of a scene whose lights the lanes do not sample) takes the bounce
//! through the reference integrator's own steps, path by path, its shadow
//! rays on a tape that joins the same batch query: so every material and
//! light the reference renders, the wavefront renders too. The passes run
//! in AVX-512 or AVX2 registers where the CPU has them and as portable
//! scalar code elsewhere ([`crate::simd::lanes`]), all with the same bits.

mod arrive;
mod leave;
mod light;
mod lists;
mod rng;
mod surface;

use glam::Vec3;

use self::lists::{lane, set_lane, sized, Lists, Rngs};
use super::integrator::DirectEstimator;
use super::integrator::{Integrator, PathSettings, Previous, Shading, ShadowTape, Span, Walk};
use super::light::{Facing, LightSet};
use super::times::{held, WaveTimes};
use crate::accel::{Accel, Coherence, TraceCounters};
use crate::geom::sampling::Rng;
use crate::geom::{Hit, Ray};
use crate::scene::{AreaLight, Light, NormalMode, Scene};
use crate::simd::lanes::{Vectors, LANES};

/// Lanes of a pass.
const L: usize = LANES;

/// Light samples a vertex takes at most here (lights times `-l`).
const MOST_SAMPLES: usize = 8;

/// What a wave of an integrator steps in lanes: the vectors the CPU runs
/// and, where the lanes sample the scene's lights, those lights. The
/// lanes take them where the scene is smoothly shaded, every light a
/// vertex samples is a point, directional, rectangular area or ambient
/// light of the file's ([`crate::render::light::LightSet::plain`]), light
/// sampling or MIS estimates them, and a vertex takes at most
/// [`MOST_SAMPLES`] samples. Every other vertex (a mirror, glass, a rough
/// conductor; any vertex where the lanes do not take the lights) takes the
/// integrator's own steps, one path at a time, inside the same passes and
/// batch queries.
pub struct Plan<'l> {
    lanes: Option<Lanes<'l>>,
    s: PathSettings,
    vectors: Vectors,
    /// Whether the sky gives light (an ambient light or a map): where it
    /// does not, a ray that escapes adds nothing to its path.
    sky: bool,
}

/// The lights of a vertex in lanes: the delta lights, then the area and
/// ambient lights in their order.
struct Lanes<'l> {
    delta: &'l [Light],
    each: &'l [Light],
}

impl<'l> Plan<'l> {
    /// The plan of `integrator`'s waves: `None` for normal shading, which
    /// only the reference renders.
    pub fn new<A: Accel>(integrator: &'l Integrator<'_, A>) -> Option<Plan<'l>> {
        let Shading::Path(s) = integrator.shading else {
            return None;
        };
        let sky = integrator.ambient != Vec3::ZERO || integrator.lights.environment.is_some();
        Some(Plan {
            lanes: lanes(integrator.scene, &integrator.lights, &s),
            s,
            vectors: Vectors::widest(),
            sky,
        })
    }

    /// The vectors its passes run on.
    pub fn vectors(&self) -> Vectors {
        self.vectors
    }

    /// Whether the lanes take the scene's Lambertian vertices (else every
    /// vertex is stepped alone, and the wavefront buys nothing).
    pub fn in_lanes(&self) -> bool {
        self.lanes.is_some()
    }
}

/// Whether the wavefront's lanes take `scene`'s Lambertian vertices when
/// shaded as `shading`: where the default mode is the wavefront.
pub fn lanes_take(scene: &Scene, shading: Shading) -> bool {
    let Shading::Path(s) = shading else {
        return false;
    };
    lanes(scene, &LightSet::new(scene), &s).is_some()
}

/// The lights the lanes sample, if they take the scene's.
fn lanes<'l>(scene: &Scene, lights: &'l LightSet, s: &PathSettings) -> Option<Lanes<'l>> {
    let (delta, each) = lights.plain()?;
    let delta_kinds = delta
        .iter()
        .all(|l| matches!(l, Light::Point { .. } | Light::Directional { .. }));
    let estimated = matches!(
        s.estimator,
        DirectEstimator::LightSampling | DirectEstimator::Mis
    );
    let takes = estimated
        && delta_kinds
        && scene.normal_mode == NormalMode::Smooth
        && delta.len() + each.len() * s.light_samples.max(1) as usize <= MOST_SAMPLES;
    takes.then_some(Lanes { delta, each })
}

impl Plan<'_> {
    /// What a vertex in lanes samples for its direct light, in
    /// `Integrator::direct`'s order: one sample of each delta light, then
    /// `-l` of each area and ambient light; each group's terms are
    /// averaged.
    fn groups(&self) -> impl Iterator<Item = (Source<'_>, u32)> {
        let n = self.s.light_samples.max(1);
        let (delta, each) = match &self.lanes {
            Some(l) => (l.delta, l.each),
            None => (&[][..], &[][..]),
        };
        fn source(l: &Light) -> Option<Source<'_>> {
            Some(match *l {
                Light::Point {
                    position,
                    intensity,
                } => Source::Point {
                    position,
                    intensity,
                },
                Light::Directional { to_light, radiance } => {
                    Source::Directional { to_light, radiance }
                }
                Light::Ambient { radiance } => Source::Ambient { radiance },
                // Refused by the plan: emitting triangles and spheres.
                Light::Area(ref a) if a.triangle => return None,
                Light::Area(ref a) => Source::Area(a),
                Light::Sphere { .. } => return None,
            })
        }
        let delta = delta.iter().filter_map(source).map(|s| (s, 1));
        delta.chain(each.iter().filter_map(source).map(move |s| (s, n)))
    }
}

/// A light as the light pass samples it.
#[derive(Clone, Copy)]
enum Source<'l> {
    /// A rectangle, sampled uniformly by area with two numbers, weighted
    /// against BSDF sampling under MIS.
    Area(&'l AreaLight),
    /// Delta lights: one sample each, no numbers drawn, no MIS weight.
    Point {
        position: Vec3,
        intensity: Vec3,
    },
    Directional {
        to_light: Vec3,
        radiance: Vec3,
    },
    /// The sky's ambient light, sampled by two numbers around the
    /// vertex's normals, weighted against BSDF sampling under MIS.
    Ambient {
        radiance: Vec3,
    },
}

/// A wave's paths and the lists its passes reuse from bounce to bounce.
///
/// The paths still going sit in slots, in the order of the paths: each
/// bounce, the ones that go on from their hits move to the front, their
/// order kept (a stable compaction, in place). A slot's state is in
/// lists indexed by the slot, so the passes read and write it sixteen
/// slots at a time, with no index between a vertex and its path.
#[derive(Default)]
pub struct Wave {
    /// Each path's radiance so far (index: the path).
    total: Vec<Vec3>,
    // Each slot's state: its path, depth and throughput; where its ray
    // left (the BSDF's density, the point, its normals, and whether it
    // faces by the smooth one too, a mask); its generator.
    path: Vec<u32>,
    depth: Vec<u32>,
    beta: Lists,
    prev_pdf: Vec<f32>,
    prev_from: Lists,
    prev_ng: Lists,
    prev_ns: Lists,
    prev_smooth: Vec<f32>,
    rng: Rngs,
    /// The rays of this bounce, the slots they leave from, and their hits.
    rays: Vec<Ray>,
    traced: Vec<u32>,
    hits: Vec<Option<Hit>>,
    /// Each slot kept at a vertex: the slot its path was in, and the ray
    /// that found the vertex.
    from: Vec<u32>,
    ray_of: Vec<u32>,
    /// The paths at a vertex of another material this bounce, stepped
    /// by the integrator's own code: their direct light's terms and
    /// shadow rays on `tape`.
    alone: Vec<Alone>,
    tape: ShadowTape,
    /// Whether a slot is a Lambertian vertex in lanes, and whether it
    /// takes direct light (masks; a slot of a path that went on alone is
    /// neither).
    lanes: Vec<f32>,
    lit: Vec<f32>,
    /// The slots at a vertex this bounce, and that count padded to whole
    /// groups of sixteen: the extent of every pass (the lists may be
    /// longer).
    count: usize,
    padded: usize,
    /// Each slot's vertex: hit data gathered, padded to whole groups of
    /// sixteen with the last.
    albedo: Lists,
    dir: Lists,
    w: Lists,
    corner: [Lists; 3],
    normal: [Lists; 3],
    p: Lists,
    error: Lists,
    ng: Lists,
    ns: Lists,
    s: Lists,
    t: Lists,
    lift: Lists,
    lifted: Vec<f32>,
    /// Whether a vertex's normals took the plain case in lanes (a mask),
    /// and whether it is on a sphere.
    plain: Vec<f32>,
    sphere: Vec<bool>,
    /// Each vertex's light stream.
    light_rng: Rngs,
    /// Each light sample of every vertex: its term, whether it has a
    /// shadow ray (a mask), and the ray.
    term: Vec<Lists>,
    has_ray: Vec<Vec<f32>>,
    shadow: Vec<[Vec<f32>; 8]>,
    shadow_rays: Vec<Ray>,
    blocked: Vec<bool>,
    /// Where each shadow ray in lanes came from (its sample and slot),
    /// whether each sample's light arrived (a mask), and each vertex's
    /// direct light times its throughput.
    shadow_at: Vec<(u32, u32)>,
    open: Vec<Vec<f32>>,
    direct: Lists,
    /// The numbers of an area light's sample (in the light pass) and of
    /// the BSDF's with its density (when leaving), which paths go on (a
    /// mask), and their next rays.
    draws: Lists,
    going: Vec<f32>,
    next: [Vec<f32>; 6],
}

/// A path at a vertex the lanes do not take, stepped alone: its
/// throughput before it left the vertex (its direct light's weight), its
/// direct light on the tape, if the vertex takes any, and, if it went on,
/// its slot, its state after leaving and its generator.
struct Alone {
    path: u32,
    beta: Vec3,
    direct: Option<Span>,
    goes: Option<(u32, Walk, Rng)>,
}

impl Wave {
    /// The bytes the wave's lists hold.
    pub fn held_bytes(&self) -> usize {
        let lists = |l: &[Vec<f32>]| l.iter().map(held).sum::<usize>();
        let mut bytes = held(&self.total)
            + held(&self.path)
            + held(&self.depth)
            + held(&self.prev_pdf)
            + held(&self.prev_smooth)
            + self.rng.held_bytes()
            + self.light_rng.held_bytes()
            + held(&self.rays)
            + held(&self.traced)
            + held(&self.from)
            + held(&self.ray_of)
            + held(&self.hits)
            + held(&self.alone)
            + self.tape.held_bytes()
            + held(&self.lanes)
            + held(&self.lit)
            + held(&self.lifted)
            + held(&self.plain)
            + held(&self.sphere)
            + held(&self.shadow_rays)
            + held(&self.shadow_at)
            + self.open.iter().map(held).sum::<usize>()
            + lists(&self.direct)
            + held(&self.blocked)
            + held(&self.going)
            + lists(&self.draws)
            + lists(&self.next);
        for l in [
            &self.beta,
            &self.prev_from,
            &self.prev_ng,
            &self.prev_ns,
            &self.albedo,
            &self.dir,
            &self.w,
            &self.p,
            &self.error,
            &self.ng,
            &self.ns,
            &self.s,
            &self.t,
            &self.lift,
        ] {
            bytes += lists(l);
        }
        for k in 0..3 {
            bytes += lists(&self.corner[k]) + lists(&self.normal[k]);
        }
        for j in 0..self.term.len() {
            bytes += lists(&self.term[j]) + held(&self.has_ray[j]) + lists(&self.shadow[j]);
        }
        bytes
    }

    /// The radiance along each of `camera_rays`, whose closest hits are
    /// `first`, path `k` drawing from `streams[k]`, into `values`; where
    /// the time went into `times`.
    #[allow(clippy::too_many_arguments)]
    pub fn radiance<A: Accel>(
        &mut self,
        integrator: &Integrator<A>,
        plan: &Plan,
        camera_rays: &[Ray],
        first: &[Option<Hit>],
        streams: &mut [Rng],
        counters: &mut TraceCounters,
        values: &mut Vec<Vec3>,
        times: &mut WaveTimes,
    ) {
        let mut clock = std::time::Instant::now();
        let mut lap = |into: &mut f64| {
            let now = std::time::Instant::now();
            let took = (now - clock).as_secs_f64();
            *into += took;
            clock = now;
            took
        };
        let n = camera_rays.len();
        self.total.clear();
        self.total.resize(n, Vec3::ZERO);
        // Every path in its own slot, at the camera: the slots' lists are
        // as long as the wave, padded, from here on.
        let slots = n.div_ceil(L) * L;
        self.path.clear();
        self.path.extend(0..n as u32);
        self.path.resize(slots, 0);
        self.depth.clear();
        self.depth.resize(slots, 0);
        for a in 0..3 {
            self.beta[a].clear();
            self.beta[a].resize(slots, 1.0);
            self.prev_ng[a].clear();
            self.prev_ng[a].resize(slots, Vec3::Y[a]);
        }
        sized(&mut self.prev_from, slots);
        sized(&mut self.prev_ns, slots);
        self.prev_pdf.clear();
        self.prev_pdf.resize(slots, 0.0);
        self.prev_smooth.clear();
        self.prev_smooth.resize(slots, 0.0);
        self.rng.sized(slots);
        for (v, (r, stream)) in camera_rays.iter().zip(&*streams).enumerate() {
            set_lane(&mut self.prev_from, v, r.origin);
            self.rng.set(v, stream);
        }
        self.traced.clear();
        self.traced.extend(0..n as u32);
        self.rays.clear();
        self.rays.extend_from_slice(camera_rays);
        self.hits.clear();
        self.hits.extend_from_slice(first);
        loop {
            self.arrive(integrator, plan, counters);
            self.vertices(plan);
            times.paths += lap(&mut times.steps.arrive);
            self.light(plan);
            self.shadow_gather();
            let in_lanes = self.shadow_rays.len();
            self.shadow_rays.extend_from_slice(self.tape.rays());
            times.paths += lap(&mut times.steps.light);
            self.blocked.clear();
            self.blocked.resize(self.shadow_rays.len(), false);
            integrator
                .accel()
                .occluded_all(&self.shadow_rays, &mut self.blocked, counters);
            lap(&mut times.occluded);
            self.sum(plan);
            for a in &self.alone {
                if let Some(span) = &a.direct {
                    let sum = self.tape.sum(span, &self.blocked[in_lanes..]);
                    self.total[a.path as usize] += a.beta * sum;
                }
            }
            self.leave(plan);
            times.paths += lap(&mut times.steps.leave);
            if self.rays.is_empty() {
                break;
            }
            self.hits.clear();
            self.hits.resize(self.rays.len(), None);
            integrator.accel().closest_hits(
                &self.rays,
                Coherence::Incoherent,
                &mut self.hits,
                counters,
            );
            lap(&mut times.closest);
        }
        values.clear();
        values.extend_from_slice(&self.total);
    }

    /// Where slot `v`'s ray left.
    fn prev(&self, v: usize) -> Previous {
        Previous {
            bsdf_pdf: self.prev_pdf[v],
            from: lane(&self.prev_from, v),
            facing: Facing {
                geometric: lane(&self.prev_ng, v),
                smooth: (self.prev_smooth[v] != 0.0).then(|| lane(&self.prev_ns, v)),
            },
        }
    }
}
