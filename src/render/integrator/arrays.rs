//! A wave's paths with their state in lists, one per value (structure of
//! arrays), stepped by passes that work eight paths at a time: the design
//! `examples/soa_step.rs` measured at 2.9-3.05x the `PathState` step on
//! the same hits, the same rays to the bit (docs/experiments.md, stop
//! 51). Each bounce: the extension rays' closest hits in one batch; what
//! each path sees there (emission, the sky), in the order and operations
//! of [`Integrator::arrive`]; the surface points and vertices (facing,
//! frame, the point lifted onto the smooth surface) in lanes; one light
//! stream split off each path; every light sample with its MIS-weighted
//! term and shadow ray in lanes; the shadow rays in one batch; each path's
//! direct light summed as [`super::ShadowTape::sum`] sums it; Russian
//! roulette and the BSDF's numbers path by path, its direction and ray in
//! lanes, as [`Integrator::leave`] takes them. Every operation is the
//! scalar code's, in its order (sine and cosine are libm's, lane by lane),
//! so the image has the bits of the paths walked alone (tested).
//!
//! The lanes take Lambertian vertices of smoothly shaded scenes lit by
//! point, directional, rectangular area and ambient lights under light
//! sampling or MIS ([`ArrayPlan`]); a sphere's surface point is the
//! scalar function's. Every other vertex (a mirror, glass, a rough
//! conductor, or any vertex of a scene whose lights the lanes do not
//! sample) takes the bounce through the integrator's own steps, path by
//! path, its shadow rays on a tape that joins the same batch query.

use glam::Vec3;

use super::paths::Walk;
use super::shadows::{Deferred, Span};
use super::{Background, DirectEstimator, Integrator, PathSettings, Previous, Shading, ShadowTape};
use crate::accel::native::cpu::Avx2;
use crate::accel::{Accel, Coherence, TraceCounters};
use crate::geom::sampling::Rng;
use crate::geom::{gamma, Hit, Ray};
use crate::render::f8::F8;
use crate::render::light::Facing;
use crate::render::light::LightSet;
use crate::render::wave::{held, WaveTimes};
use crate::scene::{AreaLight, Light, Material, NormalMode, Scene};
use crate::{each3, map3};

/// Lanes of a pass.
const L: usize = 8;

/// Light samples a vertex takes at most here (lights times `-l`).
const MOST_SAMPLES: usize = 8;

/// Proof that a wave may run in arrays: the CPU runs AVX2 and the
/// integrator traces paths. With it, the lights Lambertian vertices
/// sample in lanes, where they do: the scene is smoothly shaded, every
/// light a vertex samples is a point, directional, rectangular area or
/// ambient light of the file's
/// ([`crate::render::light::LightSet::plain`]), light sampling or MIS
/// estimates them, and a vertex takes at most [`MOST_SAMPLES`] samples.
/// Every other vertex (a mirror, glass, a rough conductor; any vertex
/// where the lanes do not take the lights) takes the integrator's own
/// steps, one path at a time, inside the same passes and batch queries.
pub struct ArrayPlan<'l> {
    lanes: Option<Lanes<'l>>,
    s: PathSettings,
    avx2: Avx2,
}

/// The lights of a vertex in lanes: the delta lights, then the area and
/// ambient lights in their order.
struct Lanes<'l> {
    delta: &'l [Light],
    each: &'l [Light],
}

impl<A: Accel> Integrator<'_, A> {
    /// The plan of a wave in arrays, if this integrator's scene and
    /// settings are ones it takes.
    pub fn array_plan(&self, avx2: Option<Avx2>) -> Option<ArrayPlan<'_>> {
        plan(self.scene, &self.lights, self.shading, avx2)
    }
}

/// Whether a wave in arrays steps `scene`'s Lambertian vertices in lanes
/// when shaded as `shading` on this CPU: where the renderer's default
/// mode runs waves (`hybrid render`).
pub fn arrays_take(scene: &Scene, shading: Shading) -> bool {
    plan(scene, &LightSet::new(scene), shading, Avx2::detect()).is_some_and(|p| p.lanes.is_some())
}

fn plan<'l>(
    scene: &Scene,
    lights: &'l LightSet,
    shading: Shading,
    avx2: Option<Avx2>,
) -> Option<ArrayPlan<'l>> {
    let (Shading::Path(s), Some(avx2)) = (shading, avx2) else {
        return None;
    };
    let lanes = lights.plain().and_then(|(delta, each)| {
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
    });
    Some(ArrayPlan { lanes, s, avx2 })
}

impl ArrayPlan<'_> {
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

/// Three lists, one per coordinate.
type Lists = [Vec<f32>; 3];

/// A wave's paths and the lists its passes reuse from bounce to bounce.
#[derive(Default)]
pub struct ArrayWave {
    // Each path's state (index: the path).
    total: Vec<Vec3>,
    beta: Vec<Vec3>,
    depth: Vec<u32>,
    prev: Vec<Previous>,
    ray: Vec<Ray>,
    /// The paths with a ray this bounce, and their rays and hits; the
    /// next bounce's, as they are found.
    live: Vec<u32>,
    next_live: Vec<u32>,
    rays: Vec<Ray>,
    hits: Vec<Option<Hit>>,
    /// The paths at a vertex of another material this bounce, stepped
    /// by the integrator's own code: their direct light's terms and
    /// shadow rays on `tape`.
    alone: Vec<Alone>,
    tape: ShadowTape,
    /// The paths at a Lambertian vertex this bounce (index: the vertex),
    /// and each vertex's lists, padded to whole groups of eight.
    at: Vec<u32>,
    albedo: Vec<Vec3>,
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
    /// Each vertex's light stream, if it takes direct light.
    light_stream: Vec<Option<Rng>>,
    /// Each light sample of every vertex: its term, whether it has a
    /// shadow ray (a mask), and the ray.
    term: Vec<Lists>,
    has_ray: Vec<Vec<f32>>,
    shadow: Vec<[Vec<f32>; 8]>,
    shadow_rays: Vec<Ray>,
    blocked: Vec<bool>,
    /// The numbers of an area light's sample (in the light pass) and of
    /// the BSDF's with its density (when leaving), which paths go on (a
    /// mask), and their next rays.
    draws: Lists,
    going: Vec<f32>,
    next: [Vec<f32>; 6],
}

/// A path at a vertex the lanes do not take, stepped alone: its
/// throughput before it left the vertex (its direct light's weight), its
/// direct light on the tape, if the vertex takes any, and whether it went
/// on.
struct Alone {
    path: u32,
    beta: Vec3,
    direct: Option<Span>,
    goes: bool,
}

/// Clears `lists` and gives them `n` zeros each.
fn zeros(lists: &mut [Vec<f32>], n: usize) {
    for l in lists {
        l.clear();
        l.resize(n, 0.0);
    }
}

/// Gives `lists` `n` values each, for a pass that writes every one of
/// them: what they held before stays until then (zeroing them first
/// took 25 ms of the 0.6 s of stepping in CBempty's frame).
fn sized(lists: &mut [Vec<f32>], n: usize) {
    for l in lists {
        l.resize(n, 0.0);
    }
}

/// Three coordinates of eight vertices from `lists` at vertex `i`.
#[inline(always)]
fn v3(lists: &Lists, i: usize) -> [F8; 3] {
    each3!(|a| F8::load(&lists[a][i..]))
}

#[inline(always)]
fn store3(v: [F8; 3], lists: &mut Lists, i: usize) {
    for (a, v) in v.into_iter().enumerate() {
        v.store(&mut lists[a][i..]);
    }
}

#[inline(always)]
fn dot(a: [F8; 3], b: [F8; 3]) -> F8 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
fn lane(lists: &Lists, i: usize) -> Vec3 {
    Vec3::new(lists[0][i], lists[1][i], lists[2][i])
}

/// `Ray::spawn`'s origin: the point moved past its error bound along the
/// normal, to the side `dir` leaves on, then one ulp further away.
#[inline(always)]
fn spawn(p: [F8; 3], error: [F8; 3], ng: [F8; 3], dir: [F8; 3]) -> [F8; 3] {
    let zero = F8::splat(0.0);
    let d = ng[0].abs() * error[0] + ng[1].abs() * error[1] + ng[2].abs() * error[2];
    let d = F8::select(dot(dir, ng).lt(zero), -d, d);
    let mut origin = [zero; 3];
    for k in 0..3 {
        let offset = ng[k] * d;
        origin[k] = (p[k] + offset).away(offset);
    }
    origin
}

impl ArrayWave {
    /// The bytes the wave's lists hold.
    pub fn held_bytes(&self) -> usize {
        let lists = |l: &[Vec<f32>]| l.iter().map(held).sum::<usize>();
        let mut bytes = held(&self.total)
            + held(&self.beta)
            + held(&self.depth)
            + held(&self.prev)
            + held(&self.ray)
            + held(&self.live)
            + held(&self.next_live)
            + held(&self.alone)
            + self.tape.held_bytes()
            + held(&self.rays)
            + held(&self.hits)
            + held(&self.at)
            + held(&self.albedo)
            + held(&self.lifted)
            + held(&self.plain)
            + held(&self.sphere)
            + held(&self.light_stream)
            + held(&self.shadow_rays)
            + held(&self.blocked)
            + held(&self.going)
            + lists(&self.draws)
            + lists(&self.next);
        for l in [
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
        plan: &ArrayPlan,
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
        self.beta.clear();
        self.beta.resize(n, Vec3::ONE);
        self.depth.clear();
        self.depth.resize(n, 0);
        // The same state for every path, then each camera ray's origin:
        // built per path in one expression, the compiler stored it to the
        // stack in parts and reloaded it whole (a stalled store
        // forwarding, 2% of CBbunny's frame).
        let start = Previous {
            bsdf_pdf: 0.0,
            from: Vec3::ZERO,
            facing: Facing::geometric(Vec3::Y),
        };
        self.prev.clear();
        self.prev.resize(n, start);
        for (prev, r) in self.prev.iter_mut().zip(camera_rays) {
            prev.from = r.origin;
        }
        self.ray.clear();
        self.ray.extend_from_slice(camera_rays);
        self.live.clear();
        self.live.extend(0..n as u32);
        self.rays.clear();
        self.rays.extend_from_slice(camera_rays);
        self.hits.clear();
        self.hits.extend_from_slice(first);
        loop {
            self.arrive(integrator, plan, streams, counters);
            self.vertices(plan);
            times.paths += lap(&mut times.steps.arrive);
            self.light(plan, streams);
            self.shadow_rays.clear();
            for (i, stream) in self.light_stream.iter().enumerate() {
                if stream.is_none() {
                    continue;
                }
                for j in 0..self.term.len() {
                    if self.has_ray[j][i] != 0.0 {
                        let r = &self.shadow[j];
                        self.shadow_rays
                            .push(Ray::from_flat(&std::array::from_fn(|c| r[c][i])));
                    }
                }
            }
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
            self.leave(plan, streams);
            self.rays.clear();
            self.rays
                .extend(self.live.iter().map(|&k| self.ray[k as usize]));
            times.paths += lap(&mut times.steps.leave);
            if self.live.is_empty() {
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

    /// What each live path sees at its hit, as [`Integrator::arrive`]
    /// counts it: the sky where it missed, emission where it hit a light.
    /// The paths that scatter there from a Lambertian vertex (below the
    /// last bounce) go into `at`, their vertices' hit data gathered into
    /// the lists and their surface points computed in lanes; the paths at
    /// a vertex of another material take the whole bounce alone
    /// ([`Self::alone`]).
    fn arrive<A: Accel>(
        &mut self,
        integrator: &Integrator<A>,
        plan: &ArrayPlan,
        streams: &mut [Rng],
        counters: &mut TraceCounters,
    ) {
        let (scene, s) = (integrator.scene, &plan.s);
        self.at.clear();
        self.albedo.clear();
        self.alone.clear();
        self.tape.clear();
        for i in 0..self.live.len() {
            let k = self.live[i];
            let k = k as usize;
            let (ray, depth) = (self.rays[i], self.depth[k]);
            let Some(hit) = self.hits[i] else {
                if s.counts(depth) && !(depth == 0 && s.background == Background::Black) {
                    self.total[k] += self.beta[k] * integrator.escaped(s, &self.prev[k], ray.dir);
                }
                continue;
            };
            let m = &scene.materials[scene.material_of(hit.prim) as usize];
            let in_lanes = matches!(m, Material::Lambertian { .. } | Material::Emission { .. });
            if !in_lanes || plan.lanes.is_none() {
                self.alone(integrator, s, k, hit, &mut streams[k], counters);
                continue;
            }
            if s.counts(depth) && m.emission() != Vec3::ZERO {
                let sp = scene.surface_point(&ray, &hit);
                let (beta, prev) = (self.beta[k], &self.prev[k]);
                self.total[k] =
                    integrator.with_emission(self.total[k], beta, s, prev, m, &hit, &sp, ray.dir);
            }
            // An emitter's vertex adds nothing more: its light samples
            // and BSDF give zero.
            let Material::Lambertian { albedo, .. } = *m else {
                continue;
            };
            if depth >= s.last_bounce() {
                continue;
            }
            self.at.push(i as u32);
            self.albedo.push(albedo);
        }
        // The vertices' lists: hit data gathered, padded with the last.
        // Every value is written here or by the surface pass.
        let count = self.at.len();
        let padded = count.div_ceil(L) * L;
        for lists in [
            &mut self.dir,
            &mut self.w,
            &mut self.p,
            &mut self.error,
            &mut self.ng,
            &mut self.ns,
        ] {
            sized(lists, padded);
        }
        for k in 0..3 {
            sized(&mut self.corner[k], padded);
            sized(&mut self.normal[k], padded);
        }
        sized(std::slice::from_mut(&mut self.plain), padded);
        self.sphere.resize(padded, false);
        for v in 0..padded {
            let i = self.at[v.min(count - 1)] as usize;
            let (ray, hit) = (&self.rays[i], self.hits[i].expect("a vertex's hit"));
            let p = hit.prim as usize;
            // A sphere's point is the scalar function's (below), and it
            // has no lift: its lanes take zeros meanwhile.
            self.sphere[v] = p >= scene.mesh.len();
            let (corners, normals, w) = if self.sphere[v] {
                ([Vec3::ZERO; 3], [Vec3::ZERO; 3], [0.0; 3])
            } else {
                (
                    scene.mesh.corners(p),
                    scene.corner_normals(p),
                    crate::scene::barycentric_weights(&hit),
                )
            };
            for a in 0..3 {
                self.dir[a][v] = ray.dir[a];
                self.w[a][v] = w[a];
                for c in 0..3 {
                    self.corner[c][a][v] = corners[c][a];
                    self.normal[c][a][v] = normals[c][a];
                }
            }
        }
        surface_pass(plan.avx2, self);
        // Spheres, and lanes whose normals left the plain case: the
        // scalar function.
        for v in 0..count {
            if self.plain[v] != 0.0 && !self.sphere[v] {
                continue;
            }
            let i = self.at[v] as usize;
            let sp = scene.surface_point(&self.rays[i], &self.hits[i].expect("a vertex's hit"));
            for a in 0..3 {
                self.p[a][v] = sp.position[a];
                self.error[a][v] = sp.error[a];
                self.ng[a][v] = sp.geometric_normal[a];
                self.ns[a][v] = sp.shading_normal[a];
            }
        }
    }

    /// Path `k`, whose ray's closest hit is `hit` at a vertex the lanes
    /// do not take, takes the bounce as the paths' states take it
    /// ([`Integrator::arrive_at`], `light_at`, `go_on`), its shadow rays
    /// on the tape: it arrives, records its direct light, and leaves at
    /// once (leaving draws from the path's stream after the light stream
    /// is split off, as alone); its direct light joins its total when the
    /// shadow rays are answered.
    fn alone<A: Accel>(
        &mut self,
        integrator: &Integrator<A>,
        s: &PathSettings,
        k: usize,
        hit: Hit,
        rng: &mut Rng,
        counters: &mut TraceCounters,
    ) {
        let mut walk = Walk {
            total: self.total[k],
            beta: self.beta[k],
            ray: self.ray[k],
            prev: self.prev[k],
            depth: self.depth[k],
        };
        let vertex = integrator.arrive(&mut walk, Some(hit), None, s);
        self.total[k] = walk.total;
        let Some(vertex) = vertex else {
            return;
        };
        let (first_term, first_ray) = self.tape.ends();
        let mut deferred = Deferred {
            tape: &mut self.tape,
            counters,
        };
        let lit = integrator.light(walk.depth, &vertex, s, rng, &mut deferred);
        let direct = lit.then(|| Span::since(first_term, first_ray, &self.tape));
        let beta = walk.beta;
        let goes = integrator.leave(&mut walk, &vertex, s, rng);
        (self.beta[k], self.prev[k], self.ray[k], self.depth[k]) =
            (walk.beta, walk.prev, walk.ray, walk.depth);
        self.alone.push(Alone {
            path: k as u32,
            beta,
            direct,
            goes,
        });
    }

    /// Each vertex's facing, shading frame and terminator lift, in lanes
    /// (the operations of `Integrator::arrive`, `Frame::new` and
    /// `Scene::shadow_lift`).
    fn vertices(&mut self, plan: &ArrayPlan) {
        let padded = self.dir[0].len();
        for lists in [&mut self.s, &mut self.t, &mut self.lift] {
            sized(lists, padded);
        }
        sized(std::slice::from_mut(&mut self.lifted), padded);
        vertex_pass(plan.avx2, self);
        // `Scene::shadow_lift`: none on a sphere.
        for v in 0..self.at.len() {
            if self.sphere[v] {
                self.lifted[v] = 0.0;
                for a in 0..3 {
                    self.lift[a][v] = 0.0;
                }
            }
        }
    }

    /// Each vertex's light stream, and its light samples' terms and
    /// shadow rays, in lanes (`Integrator::direct` for area lights).
    fn light(&mut self, plan: &ArrayPlan, streams: &mut [Rng]) {
        let s = &plan.s;
        let padded = self.dir[0].len();
        let slots = plan.groups().map(|(_, n)| n as usize).sum();
        self.term.resize_with(slots, Default::default);
        self.has_ray.resize_with(slots, Vec::new);
        self.shadow.resize_with(slots, Default::default);
        // Each slot's lists are written whole by its light pass.
        for j in 0..slots {
            sized(&mut self.term[j], padded);
            sized(std::slice::from_mut(&mut self.has_ray[j]), padded);
            sized(&mut self.shadow[j], padded);
        }
        self.light_stream.clear();
        for &i in &self.at {
            let k = self.live[i as usize] as usize;
            // `Integrator::light_stream`: split at every vertex that is
            // not specular (none here is), used or not.
            let light_stream = streams[k].split();
            self.light_stream
                .push(s.counts(self.depth[k] + 1).then_some(light_stream));
        }
        // An area light's two numbers per vertex, in `draws`.
        zeros(&mut self.draws, padded);
        let mut slot = 0;
        for (source, n) in plan.groups() {
            for _ in 0..n {
                if let Source::Area(_) | Source::Ambient { .. } = source {
                    for (i, stream) in self.light_stream.iter_mut().enumerate() {
                        if let Some(stream) = stream {
                            (self.draws[0][i], self.draws[1][i]) = stream.next_2d();
                        }
                    }
                }
                light_pass(plan, self, source, slot);
                slot += 1;
            }
        }
    }

    /// Each vertex's direct light, as the tape sums it: each light's
    /// samples (zero where blocked or without a ray) averaged, the means
    /// summed, times the path's throughput.
    fn sum(&mut self, plan: &ArrayPlan) {
        let mut ray = 0;
        for (v, &i) in self.at.iter().enumerate() {
            if self.light_stream[v].is_none() {
                continue;
            }
            let k = self.live[i as usize] as usize;
            let mut sum = Vec3::ZERO;
            let mut slot = 0;
            for (_, n) in plan.groups() {
                let mut group = Vec3::ZERO;
                for _ in 0..n {
                    let term = if self.has_ray[slot][v] != 0.0 {
                        ray += 1;
                        if self.blocked[ray - 1] {
                            Vec3::ZERO
                        } else {
                            lane(&self.term[slot], v)
                        }
                    } else {
                        Vec3::ZERO
                    };
                    group += term;
                    slot += 1;
                }
                sum += group / n as f32;
            }
            self.total[k] += self.beta[k] * sum;
        }
    }

    /// Each vertex's path leaves along a BSDF sample (after Russian
    /// roulette from the second vertex on), as [`Integrator::leave`]
    /// takes it: the draws path by path, the direction and ray in lanes;
    /// the paths that go on are the next bounce's live ones.
    fn leave(&mut self, plan: &ArrayPlan, streams: &mut [Rng]) {
        let s = &plan.s;
        let padded = self.dir[0].len();
        zeros(&mut self.draws, padded);
        self.going.clear();
        self.going.resize(padded, 0.0);
        for (v, &i) in self.at.iter().enumerate() {
            let k = self.live[i as usize] as usize;
            let rng = &mut streams[k];
            if self.depth[k] >= 1 {
                if let Some(p) = s.russian_roulette {
                    if rng.next_f32() >= p {
                        continue;
                    }
                    self.beta[k] /= p;
                }
            }
            // `material::sample`'s two numbers (a Lambertian surface).
            (self.draws[0][v], self.draws[1][v]) = rng.next_2d();
            self.going[v] = 1.0;
        }
        sized(&mut self.next, padded);
        bsdf_pass(plan.avx2, self);
        self.next_live.clear();
        for (v, &i) in self.at.iter().enumerate() {
            if self.going[v] == 0.0 {
                continue;
            }
            let k = self.live[i as usize] as usize;
            self.beta[k] *= self.albedo[v];
            if self.beta[k] == Vec3::ZERO || !self.beta[k].is_finite() {
                continue;
            }
            let ng = lane(&self.ng, v);
            self.prev[k] = Previous {
                bsdf_pdf: self.draws[2][v],
                from: lane(&self.p, v),
                facing: Facing {
                    geometric: ng,
                    smooth: (self.lifted[v] != 0.0).then(|| lane(&self.ns, v)),
                },
            };
            self.ray[k] = Ray {
                origin: Vec3::new(self.next[0][v], self.next[1][v], self.next[2][v]),
                dir: Vec3::new(self.next[3][v], self.next[4][v], self.next[5][v]),
                t_min: 0.0,
                t_max: f32::INFINITY,
            };
            self.depth[k] += 1;
            self.next_live.push(k as u32);
        }
        // With the paths that went on alone, in the order of the paths
        // (both lists are): the order the paths' states trace them in.
        let mut alone = self.alone.iter().filter(|a| a.goes).map(|a| a.path);
        if let Some(first) = alone.next() {
            self.live.clear();
            let mut lanes = self.next_live.iter().copied().peekable();
            for k in std::iter::once(first).chain(alone) {
                while let Some(l) = lanes.next_if(|&l| l < k) {
                    self.live.push(l);
                }
                self.live.push(k);
            }
            self.live.extend(lanes);
            return;
        }
        std::mem::swap(&mut self.live, &mut self.next_live);
    }
}

/// [`crate::geom::sampling::cosine_hemisphere`] lane by lane, its bits.
#[inline(always)]
fn cosine_hemisphere8(u: F8, v: F8) -> [F8; 3] {
    let r = u.sqrt();
    let (sin, cos) = v.sin_cos_turns();
    [
        r * cos,
        r * sin,
        (F8::splat(1.0) - u).max(F8::splat(0.0)).sqrt(),
    ]
}

/// The BSDF pass behind its proof of AVX2.
fn bsdf_pass(_avx2: Avx2, wave: &mut ArrayWave) {
    // SAFETY: `Avx2` exists only where the CPU runs AVX2
    // (`Avx2::detect`), the pass's one requirement.
    unsafe { bsdf_avx2(wave) }
}

/// A cosine-weighted direction from each vertex whose path goes on
/// (`material::sample` for a Lambertian surface, `Integrator::leave`), and
/// its ray (`Ray::spawn`), eight vertices at a time; `going` keeps the
/// paths whose direction leaves the facet's front, `draws[2]` takes the
/// direction's density.
///
/// # Safety
/// The CPU must run AVX2.
#[target_feature(enable = "avx2")]
unsafe fn bsdf_avx2(wave: &mut ArrayWave) {
    let zero = F8::splat(0.0);
    let frac_1_pi = F8::splat(std::f32::consts::FRAC_1_PI);
    for i in (0..wave.dir[0].len()).step_by(L) {
        let local =
            cosine_hemisphere8(F8::load(&wave.draws[0][i..]), F8::load(&wave.draws[1][i..]));
        let (s, t, n) = (v3(&wave.s, i), v3(&wave.t, i), v3(&wave.ns, i));
        let wi = each3!(|k| s[k] * local[0] + t[k] * local[1] + n[k] * local[2]);
        let ng = v3(&wave.ng, i);
        let going = F8::load(&wave.going[i..]).gt(zero);
        // (As `leave` tests them: a NaN would go on.)
        let ok = going
            .and_not(local[2].le(zero))
            .and_not(dot(wi, ng).le(zero));
        F8::select(ok, F8::splat(1.0), zero).store(&mut wave.going[i..]);
        (local[2] * frac_1_pi).store(&mut wave.draws[2][i..]);
        let origin = spawn(v3(&wave.p, i), v3(&wave.error, i), ng, wi);
        for k in 0..3 {
            origin[k].store(&mut wave.next[k][i..]);
            wi[k].store(&mut wave.next[3 + k][i..]);
        }
    }
}

/// The surface pass behind its proof of AVX2.
fn surface_pass(_avx2: Avx2, wave: &mut ArrayWave) {
    // SAFETY: `Avx2` exists only where the CPU runs AVX2
    // (`Avx2::detect`), the pass's one requirement.
    unsafe { surface_avx2(wave) }
}

/// Each vertex's surface point (`Scene::surface_point` of a smoothly
/// shaded triangle, in its operations and order, as
/// `render::lanes::surface_points`), eight vertices at a time; `plain`
/// marks the lanes whose normals took the plain case (the others are the
/// scalar function's to answer).
///
/// # Safety
/// The CPU must run AVX2.
#[target_feature(enable = "avx2")]
unsafe fn surface_avx2(wave: &mut ArrayWave) {
    let margin_ulps = F8::splat(gamma(crate::scene::TEST_ULPS));
    let g9 = F8::splat(gamma(9));
    let (zero, one, two, three) = (
        F8::splat(0.0),
        F8::splat(1.0),
        F8::splat(2.0),
        F8::splat(3.0),
    );
    let (tiny, inf) = (F8::splat(f32::MIN_POSITIVE), F8::splat(f32::INFINITY));
    for i in (0..wave.dir[0].len()).step_by(L) {
        let w = v3(&wave.w, i);
        let c = each3!(|k| v3(&wave.corner[k], i));
        let nm = each3!(|k| v3(&wave.normal[k], i));
        // Vec3::max per coordinate, then the largest.
        let d = |x: usize, y: usize, a: usize| (c[x][a] - c[y][a]).abs();
        let size = each3!(|a| d(1, 0, a).max(d(2, 0, a)).max(d(2, 1, a)));
        let margin = margin_ulps * size[0].max(size[1]).max(size[2]);
        let on = each3!(|a| c[0][a] * w[0] + c[1][a] * w[1] + c[2][a] * w[2]);
        let inward = each3!(|a| (c[0][a] + c[1][a] + c[2][a]) / three - on[a]);
        let reach = dot(inward, inward).sqrt();
        let steps = reach.gt(two * margin);
        let step = two * margin / reach;
        let e1 = each3!(|a| c[1][a] - c[0][a]);
        let e2 = each3!(|a| c[2][a] - c[0][a]);
        let x = [
            e1[1] * e2[2] - e1[2] * e2[1],
            e1[2] * e2[0] - e1[0] * e2[2],
            e1[0] * e2[1] - e1[1] * e2[0],
        ];
        let squared = dot(x, x);
        let len = squared.sqrt();
        let ng = map3!(x, |v| v / len);
        let smooth = each3!(|a| nm[0][a] * w[0] + nm[1][a] * w[1] + nm[2][a] * w[2]);
        let recip = one / dot(smooth, smooth).sqrt();
        let unit = map3!(smooth, |v| v * recip);
        let outward = dot(unit, ng).lt(zero);
        let plain = squared
            .gt(tiny)
            .and(squared.lt(inf))
            .and(recip.lt(inf))
            .and(recip.gt(zero));
        F8::select(plain, one, zero).store(&mut wave.plain[i..]);
        for a in 0..3 {
            F8::select(steps, on[a] + inward[a] * step, on[a]).store(&mut wave.p[a][i..]);
            let e = (c[0][a] * w[0]).abs() + (c[1][a] * w[1]).abs() + (c[2][a] * w[2]).abs();
            (g9 * e + margin).store(&mut wave.error[a][i..]);
            ng[a].store(&mut wave.ng[a][i..]);
            F8::select(outward, -unit[a], unit[a]).store(&mut wave.ns[a][i..]);
        }
    }
}

/// The vertex pass behind its proof of AVX2.
fn vertex_pass(_avx2: Avx2, wave: &mut ArrayWave) {
    // SAFETY: `Avx2` exists only where the CPU runs AVX2
    // (`Avx2::detect`), the pass's one requirement.
    unsafe { vertex_avx2(wave) }
}

/// Facing (opaque surfaces are two-sided: the normals turned towards
/// `wo`; a diffuse surface keeps the smooth normal's side), the shading
/// frame (`Frame::new`) and the terminator lift (`Scene::shadow_lift`,
/// `terminator_lift`), eight vertices at a time.
///
/// # Safety
/// The CPU must run AVX2.
#[target_feature(enable = "avx2")]
unsafe fn vertex_avx2(wave: &mut ArrayWave) {
    let (zero, one) = (F8::splat(0.0), F8::splat(1.0));
    for i in (0..wave.dir[0].len()).step_by(L) {
        let wo = map3!(v3(&wave.dir, i), |x| -x);
        let (ng0, ns0) = (v3(&wave.ng, i), v3(&wave.ns, i));
        let back = dot(wo, ng0).lt(zero);
        let ng = map3!(ng0, |x| F8::select(back, -x, x));
        let ns = map3!(ns0, |x| F8::select(back, -x, x));
        let sign = one.copysign(ns[2]);
        let fa = -one / (sign + ns[2]);
        let fb = ns[0] * ns[1] * fa;
        let s = [one + sign * ns[0] * ns[0] * fa, sign * fb, -sign * ns[0]];
        let t = [fb, sign + ns[1] * ns[1] * fa, -ns[1]];
        let w = v3(&wave.w, i);
        let nk = each3!(|k| v3(&wave.normal[k], i));
        let interp = each3!(|a| nk[0][a] * w[0] + nk[1][a] * w[1] + nk[2][a] * w[2]);
        let flip = dot(interp, ng).lt(zero);
        let p = v3(&wave.p, i);
        let mut lift = [zero; 3];
        for k in 0..3 {
            let nn = map3!(nk[k], |x| F8::select(flip, -x, x));
            let c = v3(&wave.corner[k], i);
            let below = dot(each3!(|a| p[a] - c[a]), nn).min(zero);
            for a in 0..3 {
                lift[a] = lift[a] - nn[a] * (below * w[k]);
            }
        }
        F8::select(dot(lift, ng).gt(zero), one, zero).store(&mut wave.lifted[i..]);
        store3(ng, &mut wave.ng, i);
        store3(ns, &mut wave.ns, i);
        store3(s, &mut wave.s, i);
        store3(t, &mut wave.t, i);
        store3(lift, &mut wave.lift, i);
    }
}

/// The light pass behind its proof of AVX2.
fn light_pass(plan: &ArrayPlan, wave: &mut ArrayWave, source: Source, slot: usize) {
    // SAFETY: `plan.avx2` proves the CPU runs AVX2, the pass's one
    // requirement.
    unsafe { light_avx2(&plan.s, wave, source, slot) }
}

/// One sample of `source` (at `draws[0..2]` of the unit square for an
/// area light) from each vertex: its term (MIS-weighted for an area light) and
/// shadow ray (`sample_li`, `Integrator::unoccluded`), eight vertices at a
/// time.
///
/// # Safety
/// The CPU must run AVX2.
#[target_feature(enable = "avx2")]
unsafe fn light_avx2(s: &PathSettings, wave: &mut ArrayWave, source: Source, slot: usize) {
    let splat3 = |v: Vec3| [F8::splat(v.x), F8::splat(v.y), F8::splat(v.z)];
    let g1 = F8::splat(gamma(1));
    let (zero, one, inf) = (F8::splat(0.0), F8::splat(1.0), F8::splat(f32::INFINITY));
    let yes = zero.le(zero);
    let frac_1_pi = F8::splat(std::f32::consts::FRAC_1_PI);
    let end = F8::splat(crate::geom::ray::SHADOW_END);
    // MIS's weight counts the samples a group takes: `samples * pick`.
    let mis = matches!(source, Source::Area(_) | Source::Ambient { .. })
        && s.estimator == DirectEstimator::Mis;
    let samples = mis.then(|| F8::splat(s.light_samples.max(1) as f32 * 1.0));
    let count = wave.at.len();
    for i in (0..wave.dir[0].len()).step_by(L) {
        let p = v3(&wave.p, i);
        let (ng, ns) = (v3(&wave.ng, i), v3(&wave.ns, i));
        let lifted = F8::load(&wave.lifted[i..]).gt(zero);
        // The sample: direction, distance, radiance over density, the
        // density, and whether there is one.
        let (wi, distance, contribution, pdf, some) = match source {
            Source::Area(light) => {
                let (u, v) = (F8::load(&wave.draws[0][i..]), F8::load(&wave.draws[1][i..]));
                let (o, eu, ev) = (
                    splat3(light.origin),
                    splat3(light.edge_u),
                    splat3(light.edge_v),
                );
                // `point_at`, then `area_to_solid_angle` and
                // `from_area_point`.
                let to = each3!(|k| o[k] + eu[k] * u + ev[k] * v - p[k]);
                let d2 = dot(to, to);
                let distance = d2.sqrt();
                let cos_light = -dot(to, splat3(light.normal)) / distance;
                let pdf = d2 / (cos_light * F8::splat(light.area));
                let some = d2
                    .ne(zero)
                    .and(cos_light.gt(zero))
                    .and(pdf.gt(zero))
                    .and(pdf.lt(inf));
                let wi = map3!(to, |x| x / distance);
                let contribution = map3!(splat3(light.radiance), |x| x / pdf);
                (wi, distance, contribution, pdf, some)
            }
            Source::Point {
                position,
                intensity,
            } => {
                let to = each3!(|k| F8::splat(position[k]) - p[k]);
                let d2 = dot(to, to);
                let distance = d2.sqrt();
                let wi = map3!(to, |x| x / distance);
                let contribution = map3!(splat3(intensity), |x| x / d2);
                (wi, distance, contribution, inf, d2.ne(zero))
            }
            Source::Directional { to_light, radiance } => {
                (splat3(to_light), inf, splat3(radiance), inf, yes)
            }
            Source::Ambient { radiance } => {
                // `sample_li`: cosine-weighted around the geometric
                // normal, or, from a lifted point (which faces by its
                // smooth normal too), around either, picked by the first
                // number.
                let (u, v) = (F8::load(&wave.draws[0][i..]), F8::load(&wave.draws[1][i..]));
                let (half, two) = (F8::splat(0.5), F8::splat(2.0));
                let smooth = lifted.and(half.le(u));
                let u = F8::select(lifted, F8::select(smooth, two * u - one, two * u), u);
                let around = each3!(|k| F8::select(smooth, ns[k], ng[k]));
                let local = cosine_hemisphere8(u.min(F8::splat(1.0 - f32::EPSILON / 2.0)), v);
                // `Frame::new(around).to_world(local)`.
                let sign = one.copysign(around[2]);
                let fa = -one / (sign + around[2]);
                let fb = around[0] * around[1] * fa;
                let fs = [
                    one + sign * around[0] * around[0] * fa,
                    sign * fb,
                    -sign * around[0],
                ];
                let ft = [fb, sign + around[1] * around[1] * fa, -around[1]];
                let wi = each3!(|k| fs[k] * local[0] + ft[k] * local[1] + around[k] * local[2]);
                let some = yes.and_not(wi[1].le(zero)).and_not(local[2].le(zero));
                // `Facing::ambient_pdf`.
                let cosine = |n: [F8; 3]| dot(wi, n).max(zero) * frac_1_pi;
                let pdf = F8::select(lifted, half * (cosine(ng) + cosine(ns)), cosine(ng));
                let contribution = map3!(splat3(radiance), |x| x / pdf);
                (wi, inf, contribution, pdf, some)
            }
        };
        // `unoccluded`: in front of the shading normal, and of the facet
        // unless the point is lifted; the BSDF (Lambertian) not zero.
        let z = dot(wi, ns);
        let in_front = dot(wi, ng).gt(zero);
        let mut albedo = [zero; 3];
        for l in 0..L {
            let a = wave.albedo[(i + l).min(count - 1)];
            for k in 0..3 {
                albedo[k].0[l] = a[k];
            }
        }
        let f = map3!(albedo, |x| F8::select(z.gt(zero), x * frac_1_pi, zero));
        let black = f[0].ne(zero).or(f[1].ne(zero)).or(f[2].ne(zero));
        let ok = some.and(z.gt(zero)).and(in_front.or(lifted)).and(black);
        let weight = match samples {
            Some(n) => {
                // `power_heuristic(samples * pick * pdf, material::pdf)`.
                let a = n * pdf;
                let b = z.max(zero) * frac_1_pi;
                let (a2, b2) = (a * a, b * b);
                let sum = a2 + b2;
                let plain = sum.gt(zero).and(sum.lt(inf));
                let heuristic = F8::select(plain, a2 / sum, F8::select(a.ne(inf), zero, one));
                F8::select(in_front.and(pdf.lt(inf)), heuristic, one)
            }
            None => one,
        };
        let scale = z.abs() * weight / one;
        // The shadow ray, from the lifted point where there is one.
        let error = v3(&wave.error, i);
        let lift = v3(&wave.lift, i);
        let from = each3!(|k| F8::select(lifted, p[k] + lift[k], p[k]));
        // From a lifted point towards a point (not a direction), the ray
        // aims at the sample's point.
        let aimed = lifted.and(distance.lt(inf));
        let from_error = each3!(|k| F8::select(
            lifted,
            error[k] + (p[k].abs() + lift[k].abs()) * g1,
            error[k]
        ));
        let reach = each3!(|k| p[k] + wi[k] * distance - from[k]);
        let length = dot(reach, reach).sqrt();
        let dir = each3!(|k| F8::select(aimed, reach[k] / length, wi[k]));
        let far = F8::select(aimed, length, distance);
        let origin = spawn(from, from_error, ng, dir);
        let term = each3!(|k| f[k] * contribution[k] * scale);
        store3(term, &mut wave.term[slot], i);
        F8::select(ok, one, zero).store(&mut wave.has_ray[slot][i..]);
        let ray = &mut wave.shadow[slot];
        for k in 0..3 {
            origin[k].store(&mut ray[k][i..]);
            dir[k].store(&mut ray[3 + k][i..]);
        }
        zero.store(&mut ray[6][i..]);
        (far * end).store(&mut ray[7][i..]);
    }
}
