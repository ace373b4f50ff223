//! A wave's paths with their state in lists, one per value (structure of
//! arrays), stepped by passes that work sixteen paths at a time: the design
//! `examples/soa_step.rs` measured at 2.9-3.05x the `PathState` step on
//! the same hits, the same rays to the bit (docs/experiments.md, stop
//! 51). The paths still going sit in slots, in the order of the paths,
//! their state in lists indexed by the slot (stop 59). Each bounce: the
//! extension rays' closest hits in one batch; what each path sees there
//! (emission, the sky), in the order and operations of
//! [`Integrator::arrive`]; the paths that go on from a vertex moved to
//! the front of the slots; the surface points and vertices (facing,
//! frame, the point lifted onto the smooth surface) in lanes; one light
//! stream split off each path; every light sample with its MIS-weighted
//! term and shadow ray in lanes; the shadow rays in one batch; each path's
//! direct light summed in lanes as [`super::ShadowTape::sum`] sums it;
//! Russian roulette, the BSDF's numbers, its direction and ray in lanes,
//! as [`Integrator::leave`] takes them. The generators step in lanes too
//! ([`Rng16`]). Every operation is the scalar code's, in its order, so the
//! image has the bits of the paths walked alone (tested).
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
use crate::geom::sampling::{self, Rng};
use crate::geom::{gamma, Hit, Ray};
use crate::render::light::Facing;
use crate::render::light::LightSet;
use crate::render::wave::{held, WaveTimes};
use crate::render::wide::{lane_pass, Vectors, F16, LANES};
use crate::scene::{AreaLight, Light, Material, NormalMode, Scene};
use crate::{each3, map3};

/// Lanes of a pass.
const L: usize = LANES;

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

impl<A: Accel> Integrator<'_, A> {
    /// The plan of a wave in arrays, if this integrator's scene and
    /// settings are ones it takes.
    pub fn array_plan(&self, avx2: Option<Avx2>) -> Option<ArrayPlan<'_>> {
        let sky = self.ambient != Vec3::ZERO || self.lights.environment.is_some();
        plan(self.scene, &self.lights, self.shading, avx2).map(|p| ArrayPlan { sky, ..p })
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
    Some(ArrayPlan {
        lanes,
        s,
        vectors: Vectors::widest(avx2),
        sky: true,
    })
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
///
/// The paths still going sit in slots, in the order of the paths: each
/// bounce, the ones that go on from their hits move to the front, their
/// order kept (a stable compaction, in place). A slot's state is in
/// lists indexed by the slot, so the passes read and write it sixteen
/// slots at a time, with no index between a vertex and its path.
#[derive(Default)]
pub struct ArrayWave {
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

/// Generators side by side: each one's state and increment
/// ([`Rng::parts`]).
#[derive(Default)]
struct Rngs {
    state: Vec<u64>,
    inc: Vec<u64>,
}

impl Rngs {
    #[inline(always)]
    fn get(&self, v: usize) -> Rng {
        Rng::from_parts(self.state[v], self.inc[v])
    }

    #[inline(always)]
    fn set(&mut self, v: usize, rng: &Rng) {
        (self.state[v], self.inc[v]) = rng.parts();
    }

    /// At least `n` generators each (see [`sized`]).
    fn sized(&mut self, n: usize) {
        if self.state.len() < n {
            self.state.resize(n, 0);
            self.inc.resize(n, 0);
        }
    }

    fn held_bytes(&self) -> usize {
        held(&self.state) + held(&self.inc)
    }
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

/// Gives `lists` at least `n` values each, for a pass that writes the
/// first `n`: what they held before stays until then, and they never
/// shrink (zeroing them took 25 ms of the 0.6 s of stepping in CBempty's
/// frame, and so did growing them back from bounce to bounce).
fn sized(lists: &mut [Vec<f32>], n: usize) {
    for l in lists {
        if l.len() < n {
            l.resize(n, 0.0);
        }
    }
}

/// Three coordinates of sixteen vertices from `lists` at vertex `i`.
#[inline(always)]
fn v3(lists: &Lists, i: usize) -> [F16; 3] {
    each3!(|a| F16::load(&lists[a][i..]))
}

#[inline(always)]
fn store3(v: [F16; 3], lists: &mut Lists, i: usize) {
    for (a, v) in v.into_iter().enumerate() {
        v.store(&mut lists[a][i..]);
    }
}

#[inline(always)]
fn dot(a: [F16; 3], b: [F16; 3]) -> F16 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

#[inline(always)]
fn splat3(v: Vec3) -> [F16; 3] {
    [F16::splat(v.x), F16::splat(v.y), F16::splat(v.z)]
}

#[inline(always)]
fn lane(lists: &Lists, i: usize) -> Vec3 {
    Vec3::new(lists[0][i], lists[1][i], lists[2][i])
}

#[inline(always)]
fn set_lane(lists: &mut Lists, i: usize, v: Vec3) {
    for a in 0..3 {
        lists[a][i] = v[a];
    }
}

/// `Ray::spawn`'s origin: the point moved past its error bound along the
/// normal, to the side `dir` leaves on, then one ulp further away.
#[inline(always)]
fn spawn(p: [F16; 3], error: [F16; 3], ng: [F16; 3], dir: [F16; 3]) -> [F16; 3] {
    let zero = F16::splat(0.0);
    let d = ng[0].abs() * error[0] + ng[1].abs() * error[1] + ng[2].abs() * error[2];
    let d = F16::select(dot(dir, ng).lt(zero), -d, d);
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

    /// What each ray's path sees at its hit, as [`Integrator::arrive`]
    /// counts it: the sky where it missed, emission where it hit a light.
    /// The paths that scatter there from a Lambertian vertex (below the
    /// last bounce) keep a slot, their vertices' hit data gathered into
    /// the lists and their surface points computed in lanes; the paths at
    /// a vertex of another material take the whole bounce alone
    /// ([`Self::alone`]) and keep a slot if they go on.
    fn arrive<A: Accel>(
        &mut self,
        integrator: &Integrator<A>,
        plan: &ArrayPlan,
        counters: &mut TraceCounters,
    ) {
        let (scene, s) = (integrator.scene, &plan.s);
        self.alone.clear();
        self.tape.clear();
        let most = self.rays.len().div_ceil(L) * L;
        sized(&mut self.albedo, most);
        sized(std::slice::from_mut(&mut self.lanes), most);
        sized(std::slice::from_mut(&mut self.lit), most);
        self.from.clear();
        self.ray_of.clear();
        // Which paths keep a slot, and what the others see.
        for j in 0..self.rays.len() {
            let v = self.traced[j] as usize;
            let (ray, k, depth) = (self.rays[j], self.path[v] as usize, self.depth[v]);
            let Some(hit) = self.hits[j] else {
                let seen = !(depth == 0 && s.background == Background::Black);
                if plan.sky && s.counts(depth) && seen {
                    let (beta, prev) = (lane(&self.beta, v), self.prev(v));
                    self.total[k] += beta * integrator.escaped(s, &prev, ray.dir);
                }
                continue;
            };
            let m = &scene.materials[scene.material_of(hit.prim) as usize];
            let in_lanes = matches!(m, Material::Lambertian { .. } | Material::Emission { .. });
            let to = self.from.len();
            if !in_lanes || plan.lanes.is_none() {
                if self.alone(integrator, s, v, ray, hit, to, counters) {
                    self.from.push(v as u32);
                    self.ray_of.push(j as u32);
                    self.lanes[to] = 0.0;
                    self.lit[to] = 0.0;
                }
                continue;
            }
            if s.counts(depth) && m.emission() != Vec3::ZERO {
                let sp = scene.surface_point(&ray, &hit);
                let (beta, prev) = (lane(&self.beta, v), self.prev(v));
                self.total[k] =
                    integrator.with_emission(self.total[k], beta, s, &prev, m, &hit, &sp, ray.dir);
            }
            // An emitter's vertex adds nothing more: its light samples
            // and BSDF give zero.
            let Material::Lambertian { albedo, .. } = *m else {
                continue;
            };
            if depth >= s.last_bounce() {
                continue;
            }
            self.from.push(v as u32);
            self.ray_of.push(j as u32);
            self.lanes[to] = 1.0;
            self.lit[to] = if s.counts(depth + 1) { 1.0 } else { 0.0 };
            for a in 0..3 {
                self.albedo[a][to] = albedo[a];
            }
        }
        let count = self.from.len();
        let padded = count.div_ceil(L) * L;
        self.compact();
        // The vertices' lists: hit data gathered, padded with the last;
        // every other value is written by the surface pass.
        for lists in [
            &mut self.albedo,
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
        sized(std::slice::from_mut(&mut self.lanes), padded);
        sized(std::slice::from_mut(&mut self.lit), padded);
        if self.sphere.len() < padded {
            self.sphere.resize(padded, false);
        }
        self.lanes[count..padded].fill(0.0);
        self.lit[count..padded].fill(0.0);
        (self.count, self.padded) = (count, padded);
        let (rays, hits) = (&self.rays[..], &self.hits[..]);
        let (ray_of, lanes) = (&self.ray_of[..], &self.lanes[..]);
        let sphere = &mut self.sphere[..];
        let albedo = self.albedo.each_mut().map(|l| &mut l[..]);
        let dir = self.dir.each_mut().map(|l| &mut l[..]);
        let w = self.w.each_mut().map(|l| &mut l[..]);
        let corner = self
            .corner
            .each_mut()
            .map(|c| c.each_mut().map(|l| &mut l[..]));
        let normal = self
            .normal
            .each_mut()
            .map(|c| c.each_mut().map(|l| &mut l[..]));
        for v in 0..count {
            if lanes[v] == 0.0 {
                // A path that went on alone: its lanes compute nothing
                // that is used.
                continue;
            }
            let j = ray_of[v] as usize;
            let (ray, hit) = (&rays[j], hits[j].expect("a vertex's hit"));
            // A sphere's point is the scalar function's (below), and it
            // has no lift: its lanes take zeros meanwhile.
            let p = hit.prim as usize;
            sphere[v] = p >= scene.mesh.len();
            let (corners, normals, bary) = if sphere[v] {
                ([Vec3::ZERO; 3], [Vec3::ZERO; 3], [0.0; 3])
            } else {
                (
                    scene.mesh.corners(p),
                    scene.corner_normals(p),
                    crate::scene::barycentric_weights(&hit),
                )
            };
            for a in 0..3 {
                dir[a][v] = ray.dir[a];
                w[a][v] = bary[a];
                for c in 0..3 {
                    corner[c][a][v] = corners[c][a];
                    normal[c][a][v] = normals[c][a];
                }
            }
        }
        // The padding repeats the last slot.
        for v in count..padded {
            sphere[v] = sphere[count - 1];
            for a in 0..3 {
                albedo[a][v] = albedo[a][count - 1];
                dir[a][v] = dir[a][count - 1];
                w[a][v] = w[a][count - 1];
                for c in 0..3 {
                    corner[c][a][v] = corner[c][a][count - 1];
                    normal[c][a][v] = normal[c][a][count - 1];
                }
            }
        }
        surface_pass(plan.vectors, self);
        // Spheres, and lanes whose normals left the plain case: the
        // scalar function.
        for v in 0..count {
            if self.lanes[v] == 0.0 || (self.plain[v] != 0.0 && !self.sphere[v]) {
                continue;
            }
            let j = self.ray_of[v] as usize;
            let hit = self.hits[j].expect("a vertex's hit");
            let sp = scene.surface_point(&self.rays[j], &hit);
            set_lane(&mut self.p, v, sp.position);
            set_lane(&mut self.error, v, sp.error);
            set_lane(&mut self.ng, v, sp.geometric_normal);
            set_lane(&mut self.ns, v, sp.shading_normal);
        }
    }

    /// Each kept slot takes its path's state from the slot it was in
    /// (`from`, rising, never below the slot it fills: so in place). Where
    /// its ray left is not moved: it is read at the slot it was in, when
    /// arriving, and the vertex's own lists replace it when leaving.
    fn compact(&mut self) {
        let from = &self.from[..];
        fn gather<T: Copy>(list: &mut [T], from: &[u32]) {
            for (to, &v) in from.iter().enumerate() {
                list[to] = list[v as usize];
            }
        }
        gather(&mut self.path, from);
        gather(&mut self.depth, from);
        for a in 0..3 {
            gather(&mut self.beta[a], from);
        }
        gather(&mut self.rng.state, from);
        gather(&mut self.rng.inc, from);
    }

    /// Slot `v`'s path, whose `ray`'s closest hit is `hit` at a vertex
    /// the lanes do not take, takes the bounce as the paths' states take
    /// it ([`Integrator::arrive_at`], `light_at`, `go_on`), its shadow
    /// rays on the tape: it arrives, records its direct light, and leaves
    /// at once (leaving draws from the path's stream after the light
    /// stream is split off, as alone); its direct light joins its total
    /// when the shadow rays are answered. Whether it goes on, in slot
    /// `to`.
    #[allow(clippy::too_many_arguments)]
    fn alone<A: Accel>(
        &mut self,
        integrator: &Integrator<A>,
        s: &PathSettings,
        v: usize,
        ray: Ray,
        hit: Hit,
        to: usize,
        counters: &mut TraceCounters,
    ) -> bool {
        let k = self.path[v] as usize;
        let mut walk = Walk {
            total: self.total[k],
            beta: lane(&self.beta, v),
            ray,
            prev: self.prev(v),
            depth: self.depth[v],
        };
        let mut rng = self.rng.get(v);
        let vertex = integrator.arrive(&mut walk, Some(hit), None, s);
        self.total[k] = walk.total;
        let Some(vertex) = vertex else {
            return false;
        };
        let (first_term, first_ray) = self.tape.ends();
        let mut deferred = Deferred {
            tape: &mut self.tape,
            counters,
        };
        let lit = integrator.light(walk.depth, &vertex, s, &mut rng, &mut deferred);
        let direct = lit.then(|| Span::since(first_term, first_ray, &self.tape));
        let beta = walk.beta;
        let goes = integrator.leave(&mut walk, &vertex, s, &mut rng);
        self.alone.push(Alone {
            path: k as u32,
            beta,
            direct,
            goes: goes.then_some((to as u32, walk, rng)),
        });
        goes
    }

    /// Each vertex's facing, shading frame and terminator lift, in lanes
    /// (the operations of `Integrator::arrive`, `Frame::new` and
    /// `Scene::shadow_lift`).
    fn vertices(&mut self, plan: &ArrayPlan) {
        let padded = self.padded;
        for lists in [&mut self.s, &mut self.t, &mut self.lift] {
            sized(lists, padded);
        }
        sized(std::slice::from_mut(&mut self.lifted), padded);
        vertex_pass(plan.vectors, self);
        // `Scene::shadow_lift`: none on a sphere.
        for v in 0..padded {
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
    fn light(&mut self, plan: &ArrayPlan) {
        let padded = self.padded;
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
        // `Integrator::light_stream`: split at every vertex that is not
        // specular (none here is), used or not. Every slot splits: a
        // path that went on alone gets its generator back when leaving.
        self.light_rng.sized(padded);
        split_pass(plan.vectors, self);
        // An area light's two numbers per vertex, in `draws`.
        sized(&mut self.draws, padded);
        let mut slot = 0;
        for (source, n) in plan.groups() {
            for _ in 0..n {
                if let Source::Area(_) | Source::Ambient { .. } = source {
                    light_draws_pass(plan.vectors, self);
                }
                light_pass(plan.vectors, &plan.s, self, source, slot);
                slot += 1;
            }
        }
    }

    /// The shadow rays of the vertices that take direct light, vertex by
    /// vertex and sample by sample, and where each came from; `open`
    /// cleared for their answers.
    fn shadow_gather(&mut self) {
        let padded = self.padded;
        self.shadow_rays.clear();
        self.shadow_at.clear();
        self.open.resize_with(self.term.len(), Vec::new);
        for open in &mut self.open {
            sized(std::slice::from_mut(open), padded);
            open[..padded].fill(0.0);
        }
        let lit = &self.lit[..self.count];
        for (v, _) in lit.iter().enumerate().filter(|(_, &l)| l != 0.0) {
            for (j, (has, r)) in self.has_ray.iter().zip(&self.shadow).enumerate() {
                if has[v] != 0.0 {
                    let ray = Ray::from_flat(&std::array::from_fn(|c| r[c][v]));
                    self.shadow_rays.push(ray);
                    self.shadow_at.push((j as u32, v as u32));
                }
            }
        }
    }

    /// Each vertex's direct light, as the tape sums it: each light's
    /// samples (zero where blocked or without a ray) averaged, the means
    /// summed, times the path's throughput (in lanes), added to its
    /// path's sum.
    fn sum(&mut self, plan: &ArrayPlan) {
        for (&(j, v), &blocked) in self.shadow_at.iter().zip(&self.blocked) {
            self.open[j as usize][v as usize] = if blocked { 0.0 } else { 1.0 };
        }
        sized(&mut self.direct, self.padded);
        sum_pass(plan.vectors, plan, self);
        let (lit, path) = (&self.lit[..self.count], &self.path[..]);
        for (v, _) in lit.iter().enumerate().filter(|(_, &l)| l != 0.0) {
            self.total[path[v] as usize] += lane(&self.direct, v);
        }
    }

    /// Each vertex's path leaves along a BSDF sample (after Russian
    /// roulette from the second vertex on), as [`Integrator::leave`]
    /// takes it, and the paths that went on alone take their state back:
    /// the slots that go on give the next bounce's rays.
    fn leave(&mut self, plan: &ArrayPlan) {
        let padded = self.padded;
        sized(&mut self.draws, padded);
        sized(std::slice::from_mut(&mut self.going), padded);
        sized(&mut self.next, padded);
        leave_pass(plan.vectors, &plan.s, self);
        // Where each path left, for the next vertex: this one's lists,
        // whole (a slot that does not go on is not read again, and the
        // passes write these lists whole before they read them).
        std::mem::swap(&mut self.prev_from, &mut self.p);
        std::mem::swap(&mut self.prev_ng, &mut self.ng);
        std::mem::swap(&mut self.prev_ns, &mut self.ns);
        std::mem::swap(&mut self.prev_smooth, &mut self.lifted);
        std::mem::swap(&mut self.prev_pdf, &mut self.draws[2]);
        // The paths that went on alone, in their slots.
        for a in &self.alone {
            let Some((v, walk, rng)) = &a.goes else {
                continue;
            };
            let v = *v as usize;
            set_lane(&mut self.beta, v, walk.beta);
            self.depth[v] = walk.depth;
            self.prev_pdf[v] = walk.prev.bsdf_pdf;
            set_lane(&mut self.prev_from, v, walk.prev.from);
            set_lane(&mut self.prev_ng, v, walk.prev.facing.geometric);
            let smooth = walk.prev.facing.smooth;
            self.prev_smooth[v] = if smooth.is_some() { 1.0 } else { 0.0 };
            set_lane(&mut self.prev_ns, v, smooth.unwrap_or(Vec3::ZERO));
            self.rng.set(v, rng);
            self.going[v] = 1.0;
        }
        let mut alone_rays = self.alone.iter().filter_map(|a| a.goes.as_ref());
        self.rays.clear();
        self.traced.clear();
        let (going, lanes, next) = (&self.going[..], &self.lanes[..], &self.next);
        for v in 0..self.count {
            if going[v] == 0.0 {
                continue;
            }
            self.traced.push(v as u32);
            if lanes[v] == 0.0 {
                let (_, walk, _) = alone_rays.next().expect("an alone path's ray");
                self.rays.push(walk.ray);
                continue;
            }
            self.rays.push(Ray {
                origin: Vec3::new(next[0][v], next[1][v], next[2][v]),
                dir: Vec3::new(next[3][v], next[4][v], next[5][v]),
                t_min: 0.0,
                t_max: f32::INFINITY,
            });
        }
    }
}

/// Sixteen generators side by side: [`Rng`] lane by lane, its bits.
#[derive(Clone, Copy)]
struct Rng16 {
    state: [u64; L],
    inc: [u64; L],
}

// Lane loops index their arrays, as `F16`'s do.
#[allow(clippy::needless_range_loop)]
impl Rng16 {
    #[inline(always)]
    fn load(r: &Rngs, i: usize) -> Rng16 {
        Rng16 {
            state: r.state[i..i + L].try_into().expect("sixteen states"),
            inc: r.inc[i..i + L].try_into().expect("sixteen increments"),
        }
    }

    #[inline(always)]
    fn store(&self, r: &mut Rngs, i: usize) {
        r.state[i..i + L].copy_from_slice(&self.state);
        r.inc[i..i + L].copy_from_slice(&self.inc);
    }

    /// `Rng::next_u32` in the lanes of `mask`; the others keep their
    /// state (their outputs are not used).
    #[inline(always)]
    fn next_u32(&mut self, mask: F16) -> [u32; L] {
        let mut out = [0; L];
        for l in 0..L {
            let old = self.state[l];
            let new = sampling::step(old, self.inc[l]);
            // All ones where the lane steps: a select without a branch.
            let keep = 0u64.wrapping_sub(u64::from(mask.0[l].to_bits() != 0));
            self.state[l] = (new & keep) | (old & !keep);
            out[l] = sampling::output(old);
        }
        out
    }

    /// `Rng::next_f32` in the lanes of `mask`.
    #[inline(always)]
    fn next_f32(&mut self, mask: F16) -> F16 {
        F16::unit(&self.next_u32(mask))
    }

    /// `Rng::split`, every lane.
    #[inline(always)]
    fn split(&mut self) -> Rng16 {
        let all = F16::splat(f32::from_bits(u32::MAX));
        let (hi, lo) = (self.next_u32(all), self.next_u32(all));
        let mut child = Rng16 {
            state: [0; L],
            inc: [0; L],
        };
        for l in 0..L {
            let key = (u64::from(hi[l]) << 32) | u64::from(lo[l]);
            child.state[l] = sampling::mix(key);
            child.inc[l] = sampling::split_inc(self.inc[l]);
        }
        child
    }
}

/// Each vertex's direct light times its throughput into `direct`, as
/// [`super::ShadowTape::sum`] sums it: each light's samples (zero where
/// blocked or without a ray) averaged, the means summed; sixteen vertices
/// at a time.
#[inline(always)]
fn sum_lanes(plan: &ArrayPlan, wave: &mut ArrayWave) {
    let zero = F16::splat(0.0);
    for i in (0..wave.padded).step_by(L) {
        let mut sum = [zero; 3];
        let mut slot = 0;
        for (_, n) in plan.groups() {
            let mut group = [zero; 3];
            for _ in 0..n {
                let open = F16::load(&wave.open[slot][i..]).gt(zero);
                let term = v3(&wave.term[slot], i);
                group = each3!(|k| group[k] + F16::select(open, term[k], zero));
                slot += 1;
            }
            let n = F16::splat(n as f32);
            sum = each3!(|k| sum[k] + group[k] / n);
        }
        let beta = v3(&wave.beta, i);
        store3(each3!(|k| beta[k] * sum[k]), &mut wave.direct, i);
    }
}

lane_pass!(sum_pass = sum_lanes(plan: &ArrayPlan, wave: &mut ArrayWave));

/// Each slot's light stream split off its generator (`Rng::split`),
/// sixteen slots at a time.
#[inline(always)]
fn split_lanes(wave: &mut ArrayWave) {
    for i in (0..wave.padded).step_by(L) {
        let mut rng = Rng16::load(&wave.rng, i);
        let light = rng.split();
        rng.store(&mut wave.rng, i);
        light.store(&mut wave.light_rng, i);
    }
}

lane_pass!(split_pass = split_lanes(wave: &mut ArrayWave));

/// Two numbers from each slot's light stream into `draws[0..2]`
/// (`Rng::next_2d`), sixteen slots at a time.
#[inline(always)]
fn light_draws_lanes(wave: &mut ArrayWave) {
    let all = F16::splat(f32::from_bits(u32::MAX));
    for i in (0..wave.padded).step_by(L) {
        let mut light = Rng16::load(&wave.light_rng, i);
        light.next_f32(all).store(&mut wave.draws[0][i..]);
        light.next_f32(all).store(&mut wave.draws[1][i..]);
        light.store(&mut wave.light_rng, i);
    }
}

lane_pass!(light_draws_pass = light_draws_lanes(wave: &mut ArrayWave));

/// Each vertex's path leaves (`Integrator::leave` at a Lambertian
/// vertex), sixteen slots at a time: Russian roulette from the second
/// vertex on, the BSDF's two numbers, a cosine-weighted direction
/// (`material::sample`) with its density in `draws[2]`, and its ray
/// (`Ray::spawn`) in `next`; the throughput times the albedo, and
/// `going` for the paths that go on with a throughput neither zero nor
/// infinite. The slots of paths that went on alone compute values that
/// are replaced.
#[inline(always)]
fn leave_lanes(s: &PathSettings, wave: &mut ArrayWave) {
    let (zero, one, inf) = (F16::splat(0.0), F16::splat(1.0), F16::splat(f32::INFINITY));
    let frac_1_pi = F16::splat(std::f32::consts::FRAC_1_PI);
    let (roulette, p) = match s.russian_roulette {
        Some(p) => (true, F16::splat(p)),
        None => (false, one),
    };
    for i in (0..wave.padded).step_by(L) {
        let lanes = F16::load(&wave.lanes[i..]).gt(zero);
        let depth: [u32; L] = wave.depth[i..i + L].try_into().expect("sixteen depths");
        // All ones where a lane takes Russian roulette.
        let rolled =
            F16(depth.map(|d| f32::from_bits(0u32.wrapping_sub(u32::from(roulette && d >= 1)))));
        let rolled = rolled.and(lanes);
        let mut rng = Rng16::load(&wave.rng, i);
        let u = rng.next_f32(rolled);
        let survives = u.lt(p);
        let going = lanes.and_not(rolled.and_not(survives));
        let mut beta = v3(&wave.beta, i);
        beta = map3!(beta, |x| F16::select(rolled.and(survives), x / p, x));
        // `material::sample`'s two numbers (a Lambertian surface).
        let (u0, u1) = (rng.next_f32(going), rng.next_f32(going));
        rng.store(&mut wave.rng, i);
        let local = cosine_hemisphere8(u0, u1);
        let (s, t, n) = (v3(&wave.s, i), v3(&wave.t, i), v3(&wave.ns, i));
        let wi = each3!(|k| s[k] * local[0] + t[k] * local[1] + n[k] * local[2]);
        let ng = v3(&wave.ng, i);
        // (As `leave` tests them: a NaN would go on.)
        let going = going
            .and_not(local[2].le(zero))
            .and_not(dot(wi, ng).le(zero));
        let beta = each3!(|k| beta[k] * F16::load(&wave.albedo[k][i..]));
        let black = beta[0].ne(zero).or(beta[1].ne(zero)).or(beta[2].ne(zero));
        let finite = beta[0]
            .abs()
            .lt(inf)
            .and(beta[1].abs().lt(inf))
            .and(beta[2].abs().lt(inf));
        let going = going.and(black).and(finite);
        F16::select(going, one, zero).store(&mut wave.going[i..]);
        store3(beta, &mut wave.beta, i);
        (local[2] * frac_1_pi).store(&mut wave.draws[2][i..]);
        let origin = spawn(v3(&wave.p, i), v3(&wave.error, i), ng, wi);
        for k in 0..3 {
            origin[k].store(&mut wave.next[k][i..]);
            wi[k].store(&mut wave.next[3 + k][i..]);
        }
        wave.depth[i..i + L].copy_from_slice(&depth.map(|d| d + 1));
    }
}

lane_pass!(leave_pass = leave_lanes(s: &PathSettings, wave: &mut ArrayWave));

/// [`crate::geom::sampling::cosine_hemisphere`] lane by lane, its bits.
#[inline(always)]
fn cosine_hemisphere8(u: F16, v: F16) -> [F16; 3] {
    let r = u.sqrt();
    let (sin, cos) = v.sin_cos_turns();
    [
        r * cos,
        r * sin,
        (F16::splat(1.0) - u).max(F16::splat(0.0)).sqrt(),
    ]
}

/// Each vertex's surface point (`Scene::surface_point` of a smoothly
/// shaded triangle, in its operations and order, as
/// `render::lanes::surface_points`), sixteen vertices at a time; `plain`
/// marks the lanes whose normals took the plain case (the others are the
/// scalar function's to answer).
#[inline(always)]
fn surface_lanes(wave: &mut ArrayWave) {
    let margin_ulps = F16::splat(gamma(crate::scene::TEST_ULPS));
    let g9 = F16::splat(gamma(9));
    let (zero, one, two, three) = (
        F16::splat(0.0),
        F16::splat(1.0),
        F16::splat(2.0),
        F16::splat(3.0),
    );
    let (tiny, inf) = (F16::splat(f32::MIN_POSITIVE), F16::splat(f32::INFINITY));
    for i in (0..wave.padded).step_by(L) {
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
        F16::select(plain, one, zero).store(&mut wave.plain[i..]);
        for a in 0..3 {
            F16::select(steps, on[a] + inward[a] * step, on[a]).store(&mut wave.p[a][i..]);
            let e = (c[0][a] * w[0]).abs() + (c[1][a] * w[1]).abs() + (c[2][a] * w[2]).abs();
            (g9 * e + margin).store(&mut wave.error[a][i..]);
            ng[a].store(&mut wave.ng[a][i..]);
            F16::select(outward, -unit[a], unit[a]).store(&mut wave.ns[a][i..]);
        }
    }
}

lane_pass!(surface_pass = surface_lanes(wave: &mut ArrayWave));

/// Facing (opaque surfaces are two-sided: the normals turned towards
/// `wo`; a diffuse surface keeps the smooth normal's side), the shading
/// frame (`Frame::new`) and the terminator lift (`Scene::shadow_lift`,
/// `terminator_lift`), sixteen vertices at a time.
#[inline(always)]
fn vertex_lanes(wave: &mut ArrayWave) {
    let (zero, one) = (F16::splat(0.0), F16::splat(1.0));
    for i in (0..wave.padded).step_by(L) {
        let wo = map3!(v3(&wave.dir, i), |x| -x);
        let (ng0, ns0) = (v3(&wave.ng, i), v3(&wave.ns, i));
        let back = dot(wo, ng0).lt(zero);
        let ng = map3!(ng0, |x| F16::select(back, -x, x));
        let ns = map3!(ns0, |x| F16::select(back, -x, x));
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
            let nn = map3!(nk[k], |x| F16::select(flip, -x, x));
            let c = v3(&wave.corner[k], i);
            let below = dot(each3!(|a| p[a] - c[a]), nn).min(zero);
            for a in 0..3 {
                lift[a] = lift[a] - nn[a] * (below * w[k]);
            }
        }
        F16::select(dot(lift, ng).gt(zero), one, zero).store(&mut wave.lifted[i..]);
        store3(ng, &mut wave.ng, i);
        store3(ns, &mut wave.ns, i);
        store3(s, &mut wave.s, i);
        store3(t, &mut wave.t, i);
        store3(lift, &mut wave.lift, i);
    }
}

lane_pass!(vertex_pass = vertex_lanes(wave: &mut ArrayWave));

/// One sample of `source` (at `draws[0..2]` of the unit square for an
/// area light) from each vertex: its term (MIS-weighted for an area light) and
/// shadow ray (`sample_li`, `Integrator::unoccluded`), sixteen vertices at a
/// time.
#[inline(always)]
fn light_lanes(s: &PathSettings, wave: &mut ArrayWave, source: Source, slot: usize) {
    let g1 = F16::splat(gamma(1));
    let (zero, one, inf) = (F16::splat(0.0), F16::splat(1.0), F16::splat(f32::INFINITY));
    let yes = zero.le(zero);
    let frac_1_pi = F16::splat(std::f32::consts::FRAC_1_PI);
    let end = F16::splat(crate::geom::ray::SHADOW_END);
    // MIS's weight counts the samples a group takes: `samples * pick`.
    let mis = matches!(source, Source::Area(_) | Source::Ambient { .. })
        && s.estimator == DirectEstimator::Mis;
    let samples = mis.then(|| F16::splat(s.light_samples.max(1) as f32 * 1.0));
    for i in (0..wave.padded).step_by(L) {
        let p = v3(&wave.p, i);
        let (ng, ns) = (v3(&wave.ng, i), v3(&wave.ns, i));
        let lifted = F16::load(&wave.lifted[i..]).gt(zero);
        // The sample: direction, distance, radiance over density, the
        // density, and whether there is one.
        let (wi, distance, contribution, pdf, some) = match source {
            Source::Area(light) => {
                let (u, v) = (
                    F16::load(&wave.draws[0][i..]),
                    F16::load(&wave.draws[1][i..]),
                );
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
                let pdf = d2 / (cos_light * F16::splat(light.area));
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
                let to = each3!(|k| F16::splat(position[k]) - p[k]);
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
                let (u, v) = (
                    F16::load(&wave.draws[0][i..]),
                    F16::load(&wave.draws[1][i..]),
                );
                let (half, two) = (F16::splat(0.5), F16::splat(2.0));
                let smooth = lifted.and(half.le(u));
                let u = F16::select(lifted, F16::select(smooth, two * u - one, two * u), u);
                let around = each3!(|k| F16::select(smooth, ns[k], ng[k]));
                let local = cosine_hemisphere8(u.min(F16::splat(1.0 - f32::EPSILON / 2.0)), v);
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
                let (cos_g, cos_s) = (
                    dot(wi, ng).max(zero) * frac_1_pi,
                    dot(wi, ns).max(zero) * frac_1_pi,
                );
                let pdf = F16::select(lifted, half * (cos_g + cos_s), cos_g);
                let contribution = map3!(splat3(radiance), |x| x / pdf);
                (wi, inf, contribution, pdf, some)
            }
        };
        // `unoccluded`: in front of the shading normal, and of the facet
        // unless the point is lifted; the BSDF (Lambertian) not zero.
        let z = dot(wi, ns);
        let in_front = dot(wi, ng).gt(zero);
        let f = map3!(v3(&wave.albedo, i), |x| F16::select(
            z.gt(zero),
            x * frac_1_pi,
            zero
        ));
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
                let heuristic = F16::select(plain, a2 / sum, F16::select(a.ne(inf), zero, one));
                F16::select(in_front.and(pdf.lt(inf)), heuristic, one)
            }
            None => one,
        };
        let scale = z.abs() * weight / one;
        // The shadow ray, from the lifted point where there is one.
        let error = v3(&wave.error, i);
        let lift = v3(&wave.lift, i);
        let from = each3!(|k| F16::select(lifted, p[k] + lift[k], p[k]));
        // From a lifted point towards a point (not a direction), the ray
        // aims at the sample's point.
        let aimed = lifted.and(distance.lt(inf));
        let from_error = each3!(|k| F16::select(
            lifted,
            error[k] + (p[k].abs() + lift[k].abs()) * g1,
            error[k]
        ));
        let reach = each3!(|k| p[k] + wi[k] * distance - from[k]);
        let length = dot(reach, reach).sqrt();
        let dir = each3!(|k| F16::select(aimed, reach[k] / length, wi[k]));
        let far = F16::select(aimed, length, distance);
        let origin = spawn(from, from_error, ng, dir);
        let term = each3!(|k| f[k] * contribution[k] * scale);
        store3(term, &mut wave.term[slot], i);
        F16::select(ok, one, zero).store(&mut wave.has_ray[slot][i..]);
        let ray = &mut wave.shadow[slot];
        for k in 0..3 {
            origin[k].store(&mut ray[k][i..]);
            dir[k].store(&mut ray[3 + k][i..]);
        }
        zero.store(&mut ray[6][i..]);
        (far * end).store(&mut ray[7][i..]);
    }
}

lane_pass!(
    light_pass = light_lanes(
        s: &PathSettings,
        wave: &mut ArrayWave,
        source: Source,
        slot: usize,
    )
);

#[cfg(test)]
mod tests {
    use super::*;

    /// Sixteen generators side by side give each generator's own numbers,
    /// bit for bit: lanes masked out keep their state, and a split gives
    /// each lane the child `Rng::split` gives.
    #[test]
    fn generators_in_lanes_give_the_numbers_of_each_alone() {
        let mut alone: Vec<Rng> = (0..L as u32)
            .map(|l| Rng::for_sample(7, l, 3 * l, 11 + l))
            .collect();
        let mut rngs = Rngs::default();
        rngs.sized(L);
        for (l, r) in alone.iter().enumerate() {
            rngs.set(l, r);
        }
        let mut lanes = Rng16::load(&rngs, 0);
        let (on, off) = (f32::from_bits(u32::MAX), 0.0);
        for round in 0..50 {
            // Every third lane, shifted each round, sits out.
            let mask = F16(std::array::from_fn(|l| {
                if (l + round) % 3 == 0 {
                    off
                } else {
                    on
                }
            }));
            let out = lanes.next_f32(mask);
            for (l, r) in alone.iter_mut().enumerate() {
                if mask.is(l) {
                    assert_eq!(out.0[l].to_bits(), r.next_f32().to_bits());
                }
            }
        }
        let children = lanes.split();
        let mut split = Rngs::default();
        split.sized(L);
        lanes.store(&mut rngs, 0);
        children.store(&mut split, 0);
        for (l, r) in alone.iter_mut().enumerate() {
            let child = r.split();
            assert_eq!(rngs.get(l).parts(), r.parts(), "lane {l}");
            assert_eq!(split.get(l).parts(), child.parts(), "lane {l}'s child");
        }
    }
}
