//! The integrators, generic over the accelerator (static dispatch per ray):
//! normal shading, and a path tracer whose direct lighting uses either
//! uniform hemisphere sampling or light sampling.
//!
//! Bounce bookkeeping: light that reached the camera after `k` scatterings
//! is "bounce k" (k = 0: emitted light seen directly; k = 1: direct
//! lighting). `-m M` keeps bounces up to M, `-o 0` only bounce M, and
//! `--only direct|indirect` bounces 0..=1 or 2..=M. Every setting draws the
//! same random numbers for the same path prefix, so the per-bounce images
//! sum to the accumulated one.
//!
//! Emission is counted where it is found by a camera ray or after a
//! specular bounce; everywhere else the direct-lighting estimator at the
//! previous vertex has counted it already (next-event estimation).

use glam::Vec3;

use super::light::{ambient_radiance, escaped_radiance, sample_li};
use super::material::{self, emitted, is_specular};
use super::sampling::{uniform_hemisphere, Frame, Rng, UNIFORM_HEMISPHERE_PDF};
use crate::accel::ray::SpawnPoint;
use crate::accel::{Accel, Ray, TraceCounters};
use crate::scene::{Light, Material, Scene};

/// How direct lighting is estimated at a diffuse or glossy vertex.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum DirectEstimator {
    /// Uniform directions over the hemisphere, traced to whatever emits.
    Hemisphere,
    /// Points sampled on the lights, tested with shadow rays.
    #[default]
    LightSampling,
}

/// Which bounces an image shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BounceView {
    #[default]
    All,
    /// Emitted light seen directly and direct lighting (bounces 0 and 1).
    Direct,
    /// Light that scattered at least twice.
    Indirect,
}

crate::choice!(BounceView { All => "all", Direct => "direct", Indirect => "indirect" });

#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PathSettings {
    pub estimator: DirectEstimator,
    /// Samples per area (and ambient) light, or hemisphere samples.
    pub light_samples: u32,
    pub max_bounces: u32,
    /// False: only bounce `max_bounces` is shown (`-o 0`).
    pub accumulate: bool,
    pub view: BounceView,
    /// Russian roulette continuation probability, from the second vertex on.
    pub russian_roulette: Option<f32>,
}

impl Default for PathSettings {
    fn default() -> Self {
        PathSettings {
            estimator: DirectEstimator::LightSampling,
            light_samples: 1,
            max_bounces: 1,
            accumulate: true,
            view: BounceView::All,
            russian_roulette: None,
        }
    }
}

impl PathSettings {
    #[inline]
    fn counts(&self, bounce: u32) -> bool {
        let in_range = if self.accumulate {
            bounce <= self.max_bounces
        } else {
            bounce == self.max_bounces
        };
        in_range
            && match self.view {
                BounceView::All => true,
                BounceView::Direct => bounce <= 1,
                BounceView::Indirect => bounce >= 2,
            }
    }
}

/// What the renderer computes per camera ray.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Shading {
    /// Colour = shading normal * 0.5 + 0.5 at the first hit.
    Normals,
    Path(PathSettings),
}

pub struct Integrator<'a, A: Accel> {
    scene: &'a Scene,
    accel: &'a A,
    shading: Shading,
    /// Lights sampled with `light_samples` samples (area, ambient) and with
    /// one sample (delta lights).
    sampled_lights: Vec<Light>,
    delta_lights: Vec<Light>,
    /// Radiance escaped rays see from above (sum of the ambient lights).
    ambient: Vec3,
}

impl<'a, A: Accel> Integrator<'a, A> {
    pub fn new(scene: &'a Scene, accel: &'a A, shading: Shading) -> Self {
        let (delta_lights, sampled_lights) = scene.lights.iter().partition(|l| l.is_delta());
        Integrator {
            scene,
            accel,
            shading,
            sampled_lights,
            delta_lights,
            ambient: ambient_radiance(&scene.lights),
        }
    }

    /// Radiance (or normal colour) along a camera ray.
    pub fn radiance(&self, ray: &Ray, rng: &mut Rng, counters: &mut TraceCounters) -> Vec3 {
        match self.shading {
            Shading::Normals => match self.accel.closest_hit(ray, counters) {
                Some(hit) => {
                    // Shown facing the camera, as the shading sees it.
                    let sp = self
                        .scene
                        .surface_point(&ray, &hit);
                    let n = if ray.dir.dot(sp.geometric_normal) > 0.0 {
                        -sp.shading_normal
                    } else {
                        sp.shading_normal
                    };
                    n * 0.5 + Vec3::splat(0.5)
                }
                None => Vec3::ZERO,
            },
            Shading::Path(settings) => self.path(ray, &settings, rng, counters),
        }
    }

    fn path(
        &self,
        camera_ray: &Ray,
        s: &PathSettings,
        rng: &mut Rng,
        counters: &mut TraceCounters,
    ) -> Vec3 {
        let mut total = Vec3::ZERO;
        let mut beta = Vec3::ONE;
        let mut ray = *camera_ray;
        let mut specular = true;
        let mut depth = 0u32;
        loop {
            let Some(hit) = self.accel.closest_hit(&ray, counters) else {
                if specular && s.counts(depth) {
                    total += beta * escaped_radiance(self.ambient, ray.dir);
                }
                break;
            };
            let sp = self.scene.surface_point(&ray, &hit);
            let m = &self.scene.materials[sp.material as usize];
            let wo = -ray.dir;
            if specular && s.counts(depth) {
                total += beta * emitted(m, wo.dot(sp.geometric_normal));
            }
            if depth >= s.max_bounces {
                break;
            }
            // Opaque surfaces are two-sided: face the normals towards wo.
            // Dielectrics keep the outward normal to know inside from out.
            let dielectric = matches!(m, Material::Glass { .. } | Material::Refraction { .. });
            let (ng, ns) = if !dielectric && wo.dot(sp.geometric_normal) < 0.0 {
                (-sp.geometric_normal, -sp.shading_normal)
            } else {
                (sp.geometric_normal, sp.shading_normal)
            };
            let frame = Frame::new(ns);
            let wo_local = frame.to_local(wo);
            let at = SpawnPoint { ng, ..sp.spawn_point() };
            if !is_specular(m) {
                let direct = self.direct(&at, &frame, wo_local, m, s, rng, counters);
                if s.counts(depth + 1) {
                    total += beta * direct;
                }
            }
            if depth >= 1 {
                if let Some(p) = s.russian_roulette {
                    if rng.next_f32() >= p {
                        break;
                    }
                    beta /= p;
                }
            }
            let Some(bs) = material::sample(m, wo_local, rng) else {
                break;
            };
            beta *= bs.weight;
            if beta == Vec3::ZERO || !beta.is_finite() {
                break;
            }
            let wi = frame.to_world(bs.wi);
            specular = bs.specular;
            ray = Ray::spawn(&at, wi, f32::INFINITY);
            depth += 1;
        }
        total
    }

    /// Direct lighting at a vertex: one sample per delta light, and the
    /// chosen estimator for everything else.
    #[allow(clippy::too_many_arguments)]
    fn direct(
        &self,
        at: &SpawnPoint,
        frame: &Frame,
        wo: Vec3,
        m: &Material,
        s: &PathSettings,
        rng: &mut Rng,
        counters: &mut TraceCounters,
    ) -> Vec3 {
        let mut sum = Vec3::ZERO;
        for light in &self.delta_lights {
            sum += self.light_sample(light, at, frame, wo, m, rng, counters);
        }
        let n = s.light_samples.max(1);
        match s.estimator {
            DirectEstimator::LightSampling => {
                for light in &self.sampled_lights {
                    let mut acc = Vec3::ZERO;
                    for _ in 0..n {
                        acc += self.light_sample(light, at, frame, wo, m, rng, counters);
                    }
                    sum += acc / n as f32;
                }
            }
            DirectEstimator::Hemisphere => {
                if self.sampled_lights.is_empty() {
                    return sum;
                }
                let count = n * self.sampled_lights.len() as u32;
                let mut acc = Vec3::ZERO;
                for _ in 0..count {
                    let (u, v) = rng.next_2d();
                    let wi_local = uniform_hemisphere(u, v);
                    let wi = frame.to_world(wi_local);
                    if wi.dot(at.ng) <= 0.0 {
                        continue;
                    }
                    let f = material::eval(m, wo, wi_local);
                    if f == Vec3::ZERO {
                        continue;
                    }
                    let ray = Ray::spawn(at, wi, f32::INFINITY);
                    let incoming = match self.accel.closest_hit(&ray, counters) {
                        Some(hit) => {
                            let material =
                                self.scene.materials[self.scene.material_of(hit.prim) as usize];
                            emitted(&material, -wi.dot(hit.normal))
                        }
                        None => escaped_radiance(self.ambient, wi),
                    };
                    acc += f * incoming * (wi_local.z / UNIFORM_HEMISPHERE_PDF);
                }
                sum += acc / count as f32;
            }
        }
        sum
    }

    /// One light sample with its shadow ray.
    #[allow(clippy::too_many_arguments)]
    fn light_sample(
        &self,
        light: &Light,
        at: &SpawnPoint,
        frame: &Frame,
        wo: Vec3,
        m: &Material,
        rng: &mut Rng,
        counters: &mut TraceCounters,
    ) -> Vec3 {
        let Some(ls) = sample_li(light, at.p, frame.n, rng) else {
            return Vec3::ZERO;
        };
        let wi_local = frame.to_local(ls.wi);
        if wi_local.z <= 0.0 || ls.wi.dot(at.ng) <= 0.0 {
            return Vec3::ZERO;
        }
        let f = material::eval(m, wo, wi_local);
        if f == Vec3::ZERO {
            return Vec3::ZERO;
        }
        let shadow = Ray::shadow(at, ls.wi, ls.distance);
        if self.accel.occluded(&shadow, counters) {
            return Vec3::ZERO;
        }
        f * ls.contribution * wi_local.z
    }
}
