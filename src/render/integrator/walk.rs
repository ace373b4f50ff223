//! A path walked alone: what it has gathered so far ([`Walk`]), and the
//! reference loop that takes it from vertex to vertex, every ray traced as
//! it is needed. The wavefront takes the same steps in the same order
//! ([`crate::render::wavefront`]), so the two give the same bits.

use glam::Vec3;

use super::shadows::{DirectSum, Now};
use super::{Integrator, Previous};
use crate::accel::{Accel, TraceCounters};
use crate::geom::sampling::Rng;
use crate::geom::{Hit, Ray};
use crate::render::light::Facing;

/// A path as far as it has gone: what it has gathered, its throughput,
/// the ray it is on and where that ray left.
#[derive(Clone, Copy)]
pub(in crate::render) struct Walk {
    pub(in crate::render) total: Vec3,
    pub(in crate::render) beta: Vec3,
    pub(in crate::render) ray: Ray,
    pub(in crate::render) prev: Previous,
    pub(in crate::render) depth: u32,
}

impl Walk {
    /// A path starting along a camera ray: emission it finds is counted
    /// fully.
    pub(in crate::render) fn new(camera_ray: &Ray) -> Walk {
        Walk {
            total: Vec3::ZERO,
            beta: Vec3::ONE,
            ray: *camera_ray,
            prev: Previous {
                bsdf_pdf: 0.0,
                from: camera_ray.origin,
                facing: Facing::geometric(Vec3::Y),
            },
            depth: 0,
        }
    }
}

impl<A: Accel> Integrator<'_, A> {
    /// The rest of a path from `walk`, whose ray's closest hit is `hit`,
    /// every ray traced as it is needed.
    pub(super) fn walk_on(
        &self,
        mut walk: Walk,
        mut hit: Option<Hit>,
        s: &super::PathSettings,
        rng: &mut Rng,
        counters: &mut TraceCounters,
    ) -> Vec3 {
        while let Some(vertex) = self.arrive(&mut walk, hit, s) {
            let mut now = Now {
                accel: self.accel,
                counters: &mut *counters,
                sum: DirectSum::default(),
            };
            if self.light(walk.depth, &vertex, s, rng, &mut now) {
                walk.total += walk.beta * now.sum.sum;
            }
            if !self.leave(&mut walk, &vertex, s, rng) {
                break;
            }
            hit = self.accel.closest_hit(&walk.ray, counters);
        }
        walk.total
    }
}
