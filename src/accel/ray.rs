//! Rays, and the rules every consumer of the accelerator shares: which rays
//! a backend traces at all, where a secondary ray starts, and where a shadow
//! ray stops. The renderer and the parity suite both build their rays here,
//! so parity always tests the rays that are rendered.

use glam::Vec3;

/// A ray `origin + t * dir` for `t` in `[t_min, t_max]`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub t_min: f32,
    pub t_max: f32,
}

/// Relative offset of the spawn rule: a secondary ray starts
/// `SPAWN_EPSILON * (1 + max |p_i|)` off the surface along the geometric
/// normal, on the side it leaves to, with `t_min = 0`. Scaling with the
/// magnitude of `p` keeps the offset above the rounding error of the hit
/// point (a few ulps of `|p|`) for scenes far from the origin.
pub const SPAWN_EPSILON: f32 = 1e-5;

/// The largest ray origin or direction component any backend traces:
/// Embree's documented valid range is ±1.844e18 and it aborts the process
/// beyond it, so every backend treats rays outside as misses (the loader
/// scales scenes far larger than this into range).
pub const COORDINATE_LIMIT: f32 = 1.8e18;

/// A shadow ray stops at this fraction of the distance to the light
/// sample, so the light's own surface does not shadow it.
pub const SHADOW_END: f32 = 1.0 - 1e-4;

impl Ray {
    pub fn new(origin: Vec3, dir: Vec3) -> Ray {
        Ray {
            origin,
            dir,
            t_min: 0.0,
            t_max: f32::INFINITY,
        }
    }

    /// The spawn rule: a ray leaving `p` (on a surface with unit geometric
    /// normal `ng`) in direction `dir`, reaching as far as `t_max`.
    #[inline]
    pub fn spawn(p: Vec3, ng: Vec3, dir: Vec3, t_max: f32) -> Ray {
        let eps = SPAWN_EPSILON * (1.0 + p.abs().max_element());
        let offset = if dir.dot(ng) >= 0.0 {
            ng * eps
        } else {
            -ng * eps
        };
        Ray {
            origin: p + offset,
            dir,
            t_min: 0.0,
            t_max,
        }
    }

    /// The shadow-ray rule: from `p` towards a light sample at `distance`
    /// along the unit direction `wi`, stopping just short of it.
    #[inline]
    pub fn shadow(p: Vec3, ng: Vec3, wi: Vec3, distance: f32) -> Ray {
        Ray::spawn(p, ng, wi, distance * SHADOW_END)
    }

    #[inline]
    pub fn at(&self, t: f32) -> Vec3 {
        self.origin + self.dir * t
    }

    /// Rays with NaN or infinite components, components beyond
    /// [`COORDINATE_LIMIT`], a zero direction or an empty interval are
    /// reported as misses by every backend, never traced.
    #[inline]
    pub fn is_traceable(&self) -> bool {
        // `max_element` skips NaN, hence the finiteness tests.
        self.origin.is_finite()
            && self.dir.is_finite()
            && self.origin.abs().max_element() <= COORDINATE_LIMIT
            && self.dir.abs().max_element() <= COORDINATE_LIMIT
            && self.dir != Vec3::ZERO
            && self.t_min >= 0.0
            && self.t_min <= self.t_max
            && !self.t_max.is_nan()
    }
}
