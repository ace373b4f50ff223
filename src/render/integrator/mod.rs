//! The integrators, generic over the accelerator (static dispatch per ray):
//! normal shading, and a path tracer whose direct lighting uses either
//! uniform hemisphere sampling or light sampling.
//!
//! Bounce bookkeeping: light that reached the camera after `k` scatterings
//! is "bounce k" (k = 0: emitted light seen directly; k = 1: direct
//! lighting). `-m M` keeps bounces up to M, `-o 0` only bounce M, and
//! `--only direct|indirect` bounces 0..=1 or 2..=M. A path stops as soon as
//! nothing it could still add is shown (past the last bounce shown), and
//! direct lighting is skipped at vertices whose bounce is not shown; each
//! vertex's direct lighting draws from a stream of its own, keyed by one
//! number of the path's stream, so skipping it leaves the path's random
//! numbers as they were. Every setting thus draws the same random numbers
//! for the same path prefix, and the per-bounce images sum to the
//! accumulated one.
//!
//! Emission found by a BSDF-sampled ray is weighted against light sampling
//! by the power heuristic under multiple importance sampling (the default,
//! Veach 1997); with pure light sampling it is counted only where no light
//! sampling happened (camera rays, after specular bounces), and with
//! hemisphere sampling direct light is whatever the hemisphere rays hit.
//!
//! Which directions an opaque surface scatters into is decided by its
//! geometric normal (facing `wo`); see [`super::material`].

use glam::Vec3;

mod direct;
mod settings;
mod shadows;
mod walk;

pub use self::settings::{Background, BounceView, DirectEstimator, PathSettings, Shading};
pub(in crate::render) use self::shadows::{Deferred, ShadowTape, Shadows, Span};
pub(in crate::render) use self::walk::Walk;

use super::light::{ambient_radiance, escaped_radiance, pdf_li, Facing, LightRef, LightSet};
use super::material::{self, emitted};
use crate::accel::{Accel, TraceCounters};
use crate::geom::ray::SpawnPoint;
use crate::geom::sampling::{Frame, Rng};
use crate::geom::{gamma, Hit, Ray};
use crate::scene::{Material, Scene, SurfacePoint};

pub struct Integrator<'a, A: Accel> {
    pub(in crate::render) scene: &'a Scene,
    accel: &'a A,
    pub(in crate::render) shading: Shading,
    pub(in crate::render) lights: LightSet,
    /// Radiance escaped rays see from above (sum of the ambient lights);
    /// the environment map adds to it.
    pub(in crate::render) ambient: Vec3,
}

/// What the next vertex needs to weigh emission it finds against light
/// sampling at the vertex a BSDF-sampled ray left.
#[derive(Clone, Copy)]
pub(in crate::render) struct Previous {
    /// The ray's density under BSDF sampling; 0 after a specular event
    /// (emission then counts fully).
    pub(in crate::render) bsdf_pdf: f32,
    /// Where the ray left, and which way that point faces (the ambient
    /// light is sampled around its normals).
    pub(in crate::render) from: Vec3,
    pub(in crate::render) facing: Facing,
}

/// The power heuristic weight of a strategy with density `a` (samples
/// counted in) against one with density `b`.
#[inline]
fn power_heuristic(a: f32, b: f32) -> f32 {
    let (a2, b2) = (a * a, b * b);
    if a2 + b2 > 0.0 && (a2 + b2).is_finite() {
        a2 / (a2 + b2)
    } else if a.is_infinite() {
        1.0
    } else {
        0.0
    }
}

impl<'a, A: Accel> Integrator<'a, A> {
    pub fn new(scene: &'a Scene, accel: &'a A, shading: Shading) -> Self {
        Integrator {
            scene,
            accel,
            shading,
            lights: LightSet::new(scene),
            ambient: ambient_radiance(&scene.lights),
        }
    }

    /// The backend the integrator traces with.
    pub fn accel(&self) -> &'a A {
        self.accel
    }

    /// The scene it renders.
    pub fn scene(&self) -> &'a Scene {
        self.scene
    }

    /// Radiance (or normal colour) along a camera ray whose closest hit
    /// `first` was traced already (by the caller, alone or in a packet
    /// with its neighbours').
    pub fn radiance_from(
        &self,
        ray: &Ray,
        first: Option<Hit>,
        rng: &mut Rng,
        counters: &mut TraceCounters,
    ) -> Vec3 {
        match self.shading {
            Shading::Normals => match first {
                Some(hit) => {
                    // Shown facing the camera, as the shading sees it.
                    let sp = self.scene.surface_point(ray, &hit);
                    let n = if ray.dir.dot(sp.geometric_normal) > 0.0 {
                        -sp.shading_normal
                    } else {
                        sp.shading_normal
                    };
                    n * 0.5 + Vec3::splat(0.5)
                }
                None => Vec3::ZERO,
            },
            Shading::Path(settings) => self.path(ray, first, &settings, rng, counters),
        }
    }

    /// The light-sampling density of reaching what a BSDF-sampled ray from
    /// `prev` found: the emitting primitive `prim` at `q` (normal
    /// `q_normal`). Counts the `-l` samples each strategy takes.
    fn light_pdf(
        &self,
        s: &PathSettings,
        prev: &Previous,
        prim: u32,
        q: Vec3,
        q_normal: Vec3,
        dir: Vec3,
    ) -> f32 {
        let n = s.light_samples.max(1) as f32;
        match self.lights.light_of(prim) {
            Some(LightRef::Each(i)) => {
                n * pdf_li(
                    &self.lights.each[i],
                    prev.from,
                    prev.facing,
                    q,
                    q_normal,
                    dir,
                )
            }
            Some(LightRef::Emitter(i)) => {
                n * self.lights.emitter_pmf(i)
                    * pdf_li(
                        &self.lights.emitters[i],
                        prev.from,
                        prev.facing,
                        q,
                        q_normal,
                        dir,
                    )
            }
            None => 0.0,
        }
    }

    /// What escaped rays see in direction `dir`: the ambient light above
    /// the horizon and the environment map.
    fn sky(&self, dir: Vec3) -> Vec3 {
        let env = self.lights.environment.as_ref();
        escaped_radiance(self.ambient, dir) + env.map_or(Vec3::ZERO, |e| e.radiance(dir))
    }

    /// The light a path counts when its ray from `prev` escapes along
    /// `dir`: all of it after the camera or a specular event; under MIS,
    /// each infinite light weighted against its own light-sampling density
    /// (the ambient light and the map are sampled separately); otherwise
    /// nothing, light sampling has counted it.
    pub(in crate::render) fn escaped(&self, s: &PathSettings, prev: &Previous, dir: Vec3) -> Vec3 {
        if prev.bsdf_pdf == 0.0 {
            return self.sky(dir);
        }
        if s.estimator != DirectEstimator::Mis {
            return Vec3::ZERO;
        }
        let n = s.light_samples.max(1) as f32;
        let mut le = Vec3::ZERO;
        let ambient = escaped_radiance(self.ambient, dir);
        if ambient != Vec3::ZERO {
            if let Some(light) = self.lights.ambient() {
                let pdf = n * pdf_li(light, prev.from, prev.facing, Vec3::ZERO, Vec3::ZERO, dir);
                le += ambient * power_heuristic(prev.bsdf_pdf, pdf);
            }
        }
        if let Some(env) = &self.lights.environment {
            let (radiance, pdf) = env.radiance_and_pdf(dir);
            if radiance != Vec3::ZERO {
                le += radiance * power_heuristic(prev.bsdf_pdf, n * pdf);
            }
        }
        le
    }

    /// `total` with the emission a path of throughput `beta` sees at
    /// `hit` (surface point `sp`, material `m`) along `dir` from `prev`:
    /// all of it after the camera or a specular event; under MIS, weighted
    /// against light sampling; otherwise none, light sampling has counted
    /// it.
    #[allow(clippy::too_many_arguments)]
    #[inline]
    pub(in crate::render) fn with_emission(
        &self,
        total: Vec3,
        beta: Vec3,
        s: &PathSettings,
        prev: &Previous,
        m: &Material,
        hit: &Hit,
        sp: &SurfacePoint,
        dir: Vec3,
    ) -> Vec3 {
        let le = emitted(m, (-dir).dot(sp.geometric_normal));
        if le == Vec3::ZERO {
            total
        } else if prev.bsdf_pdf == 0.0 {
            total + beta * le
        } else if s.estimator == DirectEstimator::Mis {
            let light = self.light_pdf(s, prev, hit.prim, sp.position, sp.geometric_normal, dir);
            total + beta * le * power_heuristic(prev.bsdf_pdf, light)
        } else {
            total
        }
    }

    /// The path along a camera ray whose closest hit is `first`.
    fn path(
        &self,
        camera_ray: &Ray,
        first: Option<Hit>,
        s: &PathSettings,
        rng: &mut Rng,
        counters: &mut TraceCounters,
    ) -> Vec3 {
        self.walk_on(Walk::new(camera_ray), first, s, rng, counters)
    }

    /// The path's ray arrives at `hit`: counts what it sees there (the
    /// sky if it missed, emission if it hit a light), and gives the
    /// vertex it scatters from, unless the path ends here.
    #[inline(always)]
    pub(in crate::render) fn arrive(
        &self,
        walk: &mut Walk,
        hit: Option<Hit>,
        s: &PathSettings,
    ) -> Option<Vertex<'a>> {
        let (ray, depth, prev) = (&walk.ray, walk.depth, &walk.prev);
        let Some(hit) = hit else {
            if s.counts(depth) && !(depth == 0 && s.background == Background::Black) {
                walk.total += walk.beta * self.escaped(s, prev, ray.dir);
            }
            return None;
        };
        let sp = self.scene.surface_point(ray, &hit);
        let m = &self.scene.materials[sp.material as usize];
        let wo = -ray.dir;
        if s.counts(depth) {
            walk.total = self.with_emission(walk.total, walk.beta, s, prev, m, &hit, &sp, ray.dir);
        }
        if depth >= s.last_bounce() {
            return None;
        }
        // Opaque surfaces are two-sided: face the normals towards wo.
        // Dielectrics keep the outward normal to know inside from out.
        let lobe = material::lobe(m);
        let dielectric = lobe.transmits();
        let back = !dielectric && wo.dot(sp.geometric_normal) < 0.0;
        let (ng, ns) = if back {
            (-sp.geometric_normal, -sp.shading_normal)
        } else {
            (sp.geometric_normal, sp.shading_normal)
        };
        // A smooth normal can tilt away from a view that the geometric
        // normal faces: turn it to the view where the material is defined
        // about the view (see `material::Lobe::turns_to_view`).
        let ns = if !dielectric && lobe.turns_to_view() && wo.dot(ns) < 0.0 {
            -ns
        } else {
            ns
        };
        let frame = Frame::new(ns);
        let at = SpawnPoint {
            ng,
            ..sp.spawn_point()
        };
        // Shadow rays leave from the point lifted onto the smooth
        // surface (the shadow-terminator fix), where there is one.
        let lift = if lobe.is_specular() {
            Vec3::ZERO
        } else {
            self.scene.shadow_lift(&hit, sp.position, ng)
        };
        let lifted = (lift.dot(ng) > 0.0).then(|| SpawnPoint {
            p: at.p + lift,
            error: at.error + (at.p.abs() + lift.abs()) * gamma(1),
            ng,
        });
        Some(Vertex {
            at,
            lifted,
            frame,
            wo: frame.to_local(wo),
            m,
            dielectric,
        })
    }

    /// Direct lighting at `vertex`, reached after `depth` bounces, into
    /// `sink`, if the vertex takes any (it is not specular, and its bounce
    /// is shown). The light stream is
    /// split off the path's at every vertex that is not specular, used or
    /// not, so the path's own random numbers do not depend on it.
    #[inline(always)]
    pub(in crate::render) fn light(
        &self,
        depth: u32,
        vertex: &Vertex,
        s: &PathSettings,
        rng: &mut Rng,
        sink: &mut impl Shadows,
    ) -> bool {
        if material::lobe(vertex.m).is_specular() {
            return false;
        }
        let mut light_rng = rng.split();
        if !s.counts(depth + 1) {
            return false;
        }
        self.direct(vertex, s, &mut light_rng, sink);
        true
    }

    /// The path leaves `vertex` along a BSDF sample (after Russian
    /// roulette from the second vertex on); false if it ends there.
    #[inline(always)]
    pub(in crate::render) fn leave(
        &self,
        walk: &mut Walk,
        vertex: &Vertex,
        s: &PathSettings,
        rng: &mut Rng,
    ) -> bool {
        if walk.depth >= 1 {
            if let Some(p) = s.russian_roulette {
                if rng.next_f32() >= p {
                    return false;
                }
                walk.beta /= p;
            }
        }
        let Some(bs) = material::sample(vertex.m, vertex.wo, rng) else {
            return false;
        };
        let wi = vertex.frame.to_world(bs.wi);
        // The geometric normal decides on which side an opaque surface
        // scatters.
        if !vertex.dielectric && wi.dot(vertex.at.ng) <= 0.0 {
            return false;
        }
        walk.beta *= bs.weight;
        if walk.beta == Vec3::ZERO || !walk.beta.is_finite() {
            return false;
        }
        walk.prev = Previous {
            bsdf_pdf: if bs.specular { 0.0 } else { bs.pdf },
            from: vertex.at.p,
            facing: vertex.facing(),
        };
        walk.ray = Ray::spawn(&vertex.at, wi, f32::INFINITY);
        walk.depth += 1;
        true
    }
}

impl Vertex<'_> {
    /// Which way the vertex faces for light sampling: its shading normal
    /// counts where shadow rays leave from the lifted point.
    fn facing(&self) -> Facing {
        Facing {
            geometric: self.at.ng,
            smooth: self.lifted.map(|_| self.frame.n),
        }
    }
}

/// A scattering vertex as direct lighting and BSDF sampling see it: where
/// rays leave, the shading frame, the outgoing direction in it, and the
/// material.
pub(in crate::render) struct Vertex<'s> {
    at: SpawnPoint,
    /// Where shadow rays leave, if not from `at` (see
    /// [`crate::scene::terminator_lift`]).
    lifted: Option<SpawnPoint>,
    frame: Frame,
    wo: Vec3,
    m: &'s Material,
    /// Glass: keeps its outward normal and scatters to either side.
    dielectric: bool,
}
