//! Direct lighting at a vertex: one sample per delta light, and the chosen
//! estimator (light sampling, MIS or uniform hemisphere directions) for
//! everything else, into a [`Shadows`] sink.

use glam::Vec3;

use super::{power_heuristic, DirectEstimator, Integrator, PathSettings, Shadows, Vertex};
use crate::accel::Accel;
use crate::geom::sampling::{
    uniform_hemisphere, uniform_sphere, Frame, Rng, UNIFORM_HEMISPHERE_PDF,
};
use crate::geom::Ray;
use crate::render::light::{sample_environment, sample_li, LightSample};
use crate::render::material::{self, emitted};
use crate::scene::Light;

impl<A: Accel> Integrator<'_, A> {
    /// Direct lighting at a vertex into `sink`: one sample per delta
    /// light, and the chosen estimator for everything else, each light
    /// group's samples averaged.
    #[inline]
    pub(super) fn direct(
        &self,
        v: &Vertex,
        s: &PathSettings,
        rng: &mut Rng,
        sink: &mut impl Shadows,
    ) {
        for light in &self.lights.delta {
            self.light_sample(v, light, 1.0, None, rng, sink);
            sink.mean(1);
        }
        let n = s.light_samples.max(1);
        let weighting = (s.estimator == DirectEstimator::Mis).then_some(n as f32);
        match s.estimator {
            DirectEstimator::LightSampling | DirectEstimator::Mis => {
                for light in &self.lights.each {
                    for _ in 0..n {
                        self.light_sample(v, light, 1.0, weighting, rng, sink);
                    }
                    sink.mean(n);
                }
                if !self.lights.emitters.is_empty() {
                    for _ in 0..n {
                        let (i, pmf) = self.lights.pick_emitter(rng.next_f32());
                        let light = &self.lights.emitters[i];
                        self.light_sample(v, light, pmf, weighting, rng, sink);
                    }
                    sink.mean(n);
                }
                if let Some(env) = &self.lights.environment {
                    for _ in 0..n {
                        match sample_environment(env, rng) {
                            Some(ls) => self.unoccluded(v, &ls, 1.0, weighting, sink),
                            None => sink.term(Vec3::ZERO),
                        }
                    }
                    sink.mean(n);
                }
            }
            DirectEstimator::Hemisphere => {
                let groups = self.lights.groups() as u32;
                if groups == 0 {
                    return;
                }
                // Uniform over the geometric hemisphere: exactly the
                // directions the surface scatters into. Where the point
                // lifts onto the smooth surface, light sampling also takes
                // light in front of the shading normal from behind the
                // facet ([`Self::unoccluded`]): then the whole sphere, the
                // same directions kept and traced from the same point.
                let around = Frame::new(v.at.ng);
                let (from, pdf) = match &v.lifted {
                    Some(lifted) => (lifted, UNIFORM_HEMISPHERE_PDF * 0.5),
                    None => (&v.at, UNIFORM_HEMISPHERE_PDF),
                };
                let count = n * groups;
                for _ in 0..count {
                    let (a, b) = rng.next_2d();
                    let wi = match v.lifted {
                        Some(_) => uniform_sphere(a, b),
                        None => around.to_world(uniform_hemisphere(a, b)),
                    };
                    let wi_local = v.frame.to_local(wi);
                    if wi_local.z <= 0.0 || (wi.dot(v.at.ng) <= 0.0 && v.lifted.is_none()) {
                        continue;
                    }
                    let f = material::eval(v.m, v.wo, wi_local);
                    if f == Vec3::ZERO {
                        continue;
                    }
                    let ray = Ray::spawn(from, wi, f32::INFINITY);
                    let incoming = match self.accel.closest_hit(&ray, sink.counters()) {
                        Some(hit) => {
                            let material =
                                self.scene.materials[self.scene.material_of(hit.prim) as usize];
                            emitted(&material, -wi.dot(self.scene.geometric_normal(&ray, &hit)))
                        }
                        None => self.sky(wi),
                    };
                    sink.term(f * incoming * (wi_local.z.abs() / pdf));
                }
                sink.mean(count);
            }
        }
    }

    /// One light sample with its shadow ray: `f L |cos| / (pick p)`, times
    /// the power-heuristic weight against BSDF sampling when `weighting`
    /// gives the samples taken per group (the light's density is
    /// `samples * pick * p`).
    #[inline]
    fn light_sample(
        &self,
        v: &Vertex,
        light: &Light,
        pick: f32,
        weighting: Option<f32>,
        rng: &mut Rng,
        sink: &mut impl Shadows,
    ) {
        // The ambient light is sampled around the geometric normal: its
        // hemisphere is exactly the directions the surface scatters into.
        match sample_li(light, v.at.p, v.facing(), rng) {
            Some(ls) => self.unoccluded(v, &ls, pick, weighting, sink),
            None => sink.term(Vec3::ZERO),
        }
    }

    /// The term of light sample `ls` (picked with probability `pick`),
    /// counted if its shadow ray is clear; see [`Self::light_sample`].
    #[inline]
    fn unoccluded(
        &self,
        v: &Vertex,
        ls: &LightSample,
        pick: f32,
        weighting: Option<f32>,
        sink: &mut impl Shadows,
    ) {
        // Light counts only in front of the shading normal (the smooth
        // surface's terminator ends it, not the facet's), and in front of
        // the facet too unless the point lifts onto the smooth surface (a
        // coarse mesh's terminator): then light from behind the facet
        // reaches it, tested from the lifted point, since the facet does
        // not shadow what the smooth surface it stands for would see.
        let wi_local = v.frame.to_local(ls.wi);
        let in_front = ls.wi.dot(v.at.ng) > 0.0;
        if wi_local.z <= 0.0 || (!in_front && v.lifted.is_none()) {
            return sink.term(Vec3::ZERO);
        }
        let f = material::eval(v.m, v.wo, wi_local);
        if f == Vec3::ZERO {
            return sink.term(Vec3::ZERO);
        }
        let shadow = match &v.lifted {
            Some(from) if ls.distance.is_finite() => {
                let to = v.at.p + ls.wi * ls.distance - from.p;
                let length = to.length();
                Ray::shadow(from, to / length, length)
            }
            Some(from) => Ray::shadow(from, ls.wi, ls.distance),
            None => Ray::shadow(&v.at, ls.wi, ls.distance),
        };
        sink.unless_blocked(&shadow, || {
            // BSDF sampling never leaves behind the geometric normal, so
            // light sampling alone covers those directions.
            let weight = match weighting {
                Some(samples) if ls.pdf.is_finite() && in_front => {
                    power_heuristic(samples * pick * ls.pdf, material::pdf(v.m, v.wo, wi_local))
                }
                _ => 1.0,
            };
            f * ls.contribution * (wi_local.z.abs() * weight / pick)
        });
    }
}
