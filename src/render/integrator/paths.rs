//! A path as a value that can wait: paused at a vertex until its shadow
//! rays are answered, or moving along a ray until its closest hit is. The
//! renderer advances many such paths together, one batch query for all
//! their extension rays and one for all their shadow rays per bounce
//! (waves); each path still draws its own random numbers in its own order
//! and sums the same terms in the same order as [`Integrator::radiance_from`]
//! walking it alone, so the image does not depend on the grouping.

use glam::Vec3;

use super::shadows::{Deferred, DirectSum, Now, ShadowTape, Span};
use super::{Integrator, Previous, Shading, Vertex};
use crate::accel::{Accel, TraceCounters};
use crate::geom::sampling::Rng;
use crate::geom::{Hit, Ray};
use crate::render::light::Facing;
use crate::scene::SurfacePoint;

/// A path as far as it has gone: what it has gathered, its throughput,
/// the ray it is on and where that ray left.
#[derive(Clone, Copy)]
pub struct Walk {
    pub(super) total: Vec3,
    pub(super) beta: Vec3,
    pub(super) ray: Ray,
    pub(super) prev: Previous,
    pub(super) depth: u32,
}

impl Walk {
    /// A path starting along a camera ray: emission it finds is counted
    /// fully.
    pub(super) fn new(camera_ray: &Ray) -> Walk {
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

/// Where a path stands between batch queries. Unboxed on purpose: the
/// renderer keeps a wave's worth in one list it reuses, and a box would be
/// an allocation per path.
#[allow(clippy::large_enum_variant)]
pub enum PathState<'s> {
    /// Ended, with the radiance it carries.
    Done(Vec3),
    /// At a scattering vertex, waiting on its direct lighting's shadow
    /// rays.
    Paused(Paused<'s>),
    /// Leaving along [`PathState::ray`], waiting on its closest hit.
    Moving(Walk),
}

impl PathState<'_> {
    /// The ray a moving path waits on.
    pub fn ray(&self) -> Option<&Ray> {
        match self {
            PathState::Moving(walk) => Some(&walk.ray),
            _ => None,
        }
    }

    /// The radiance of an ended path.
    pub fn value(&self) -> Option<Vec3> {
        match self {
            PathState::Done(value) => Some(*value),
            _ => None,
        }
    }
}

/// A path paused at a scattering vertex.
pub struct Paused<'s> {
    walk: Walk,
    vertex: Vertex<'s>,
    /// Its direct lighting on the tape, if the vertex takes any.
    direct: Option<Span>,
}

impl<'a, A: Accel> Integrator<'a, A> {
    /// Starts the path along a camera ray whose closest hit is `first`
    /// (surface point `point`, if the caller has it) and pauses it at its
    /// first vertex ([`Self::arrive_at`]). Normal shading is done here.
    #[inline]
    pub fn begin(
        &self,
        camera_ray: &Ray,
        first: Option<Hit>,
        point: Option<&SurfacePoint>,
        rng: &mut Rng,
        counters: &mut TraceCounters,
        state: &mut PathState<'a>,
    ) {
        let Shading::Path(_) = self.shading else {
            *state = PathState::Done(self.radiance_from(camera_ray, first, rng, counters));
            return;
        };
        *state = PathState::Moving(Walk::new(camera_ray));
        self.arrive_at(state, first, point);
    }

    /// A moving path arrives at `hit`, its ray's closest hit: it counts
    /// what it sees there and pauses at the vertex, or it ends. Other
    /// states are left as they are. `point`: the hit's surface point, if
    /// the caller has it. The vertex's direct lighting is the next step
    /// ([`Self::light_at`]), a pass of its own over a wave's paths: two
    /// short loops keep more paths' work in flight than one long one
    /// (docs/experiments.md, stop 49).
    #[inline]
    pub fn arrive_at(
        &self,
        state: &mut PathState<'a>,
        hit: Option<Hit>,
        point: Option<&SurfacePoint>,
    ) {
        let (PathState::Moving(walk), Shading::Path(s)) = (&mut *state, self.shading) else {
            return;
        };
        let mut walk = *walk;
        let Some(vertex) = self.arrive(&mut walk, hit, point, &s) else {
            *state = PathState::Done(walk.total);
            return;
        };
        // Written in place: a paused path is a few hundred bytes, and
        // returning it by value copied it into the caller's list.
        *state = PathState::Paused(Paused {
            walk,
            vertex,
            direct: None,
        });
    }

    /// A path paused at a vertex records its direct lighting on `tape`
    /// (if the vertex takes any), to be answered by one batch query of
    /// the tape's shadow rays. Other states are left as they are.
    #[inline]
    pub fn light_at(
        &self,
        state: &mut PathState<'a>,
        rng: &mut Rng,
        tape: &mut ShadowTape,
        counters: &mut TraceCounters,
    ) {
        let (PathState::Paused(paused), Shading::Path(s)) = (&mut *state, self.shading) else {
            return;
        };
        let (first_term, first_ray) = tape.ends();
        let mut deferred = Deferred { tape, counters };
        let lit = self.light(paused.walk.depth, &paused.vertex, &s, rng, &mut deferred);
        paused.direct = lit.then(|| Span::since(first_term, first_ray, deferred.tape));
    }

    /// Goes on with a paused path, `blocked` answering the tape's shadow
    /// rays (`blocked[i]` for `tape.rays()[i]`): its direct lighting
    /// counts, and it leaves the vertex along a BSDF sample (moving) or
    /// ends. Other states are left as they are.
    #[inline]
    pub fn go_on(
        &self,
        state: &mut PathState<'a>,
        tape: &ShadowTape,
        blocked: &[bool],
        rng: &mut Rng,
    ) {
        let (PathState::Paused(paused), Shading::Path(s)) = (&*state, self.shading) else {
            return;
        };
        let mut walk = paused.walk;
        if let Some(span) = &paused.direct {
            walk.total += walk.beta * tape.sum(span, blocked);
        }
        *state = if self.leave(&mut walk, &paused.vertex, &s, rng) {
            PathState::Moving(walk)
        } else {
            PathState::Done(walk.total)
        };
    }

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
        while let Some(vertex) = self.arrive(&mut walk, hit, None, s) {
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
