//! Rays and hits, and the rules every consumer of the accelerator shares:
//! which rays a backend traces at all, where a secondary ray starts, and
//! where a shadow ray stops. The renderer and the parity suite both build
//! their rays here, so parity always tests the rays that are rendered.

use glam::{Vec3, Vec3A};

/// A ray `origin + t * dir` for `t` in `[t_min, t_max]`. Laid out as a
/// [`FlatRay`] (eight floats), which packet traversal loads as rows and
/// transposes into lanes.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C)]
pub struct Ray {
    pub origin: Vec3,
    pub dir: Vec3,
    pub t_min: f32,
    pub t_max: f32,
}

/// A ray as eight floats: origin xyz, direction xyz, `t_min`, `t_max`
/// (the layout of exported ray files, `docs/rays.md`, and of the plain-C
/// Embree driver).
pub type FlatRay = [f32; 8];

const _: () = assert!(std::mem::size_of::<Ray>() == std::mem::size_of::<FlatRay>());

/// The closest hit along a ray: what every backend reports, and all it
/// reports. The shading data (position, normals, material) are derived
/// from these once, above the backends
/// (`Scene::surface_point`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    pub t: f32,
    /// Global primitive id: triangles first, then spheres.
    pub prim: u32,
    /// Barycentric weights of the triangle's corners 1 and 2 (corner 0 has
    /// `1 - u - v`); zero for spheres.
    pub u: f32,
    pub v: f32,
}

/// A point that secondary rays leave: its position, a bound on the
/// rounding error of each coordinate (so the true surface point lies in
/// `p ± error`), and the unit geometric normal there (either side).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SpawnPoint {
    pub p: Vec3,
    pub error: Vec3,
    pub ng: Vec3,
}

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

    /// The spawn rule (pbrt-v4's offset ray origin): a ray leaving `from`
    /// in direction `dir`, reaching as far as `t_max`. The origin moves
    /// along the normal, to the side `dir` leaves to, just past the box of
    /// the point's rounding error, and is then rounded one more ulp away:
    /// it can never lie behind the surface it leaves, at any scale, and
    /// sits as close to it as the arithmetic allows (so rays leaving a
    /// floor at a wall's foot do not start under the wall).
    #[inline]
    pub fn spawn(from: &SpawnPoint, dir: Vec3, t_max: f32) -> Ray {
        let d = from.ng.abs().dot(from.error);
        let mut offset = from.ng * d;
        if dir.dot(from.ng) < 0.0 {
            offset = -offset;
        }
        let moved = from.p + offset;
        let away = |x: f32, o: f32| {
            if o > 0.0 {
                x.next_up()
            } else if o < 0.0 {
                x.next_down()
            } else {
                x
            }
        };
        Ray {
            origin: Vec3::new(
                away(moved.x, offset.x),
                away(moved.y, offset.y),
                away(moved.z, offset.z),
            ),
            dir,
            t_min: 0.0,
            t_max,
        }
    }

    /// The shadow-ray rule: from `from` towards a light sample at
    /// `distance` along the unit direction `wi`, stopping just short of it.
    #[inline]
    pub fn shadow(from: &SpawnPoint, wi: Vec3, distance: f32) -> Ray {
        Ray::spawn(from, wi, distance * SHADOW_END)
    }

    pub fn flat(&self) -> FlatRay {
        let (o, d) = (self.origin, self.dir);
        [o.x, o.y, o.z, d.x, d.y, d.z, self.t_min, self.t_max]
    }

    pub fn from_flat(f: &FlatRay) -> Ray {
        Ray {
            origin: Vec3::new(f[0], f[1], f[2]),
            dir: Vec3::new(f[3], f[4], f[5]),
            t_min: f[6],
            t_max: f[7],
        }
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
        self.traceable_vectors().is_some()
    }

    /// The origin and the direction as vectors if the ray is traceable
    /// ([`Ray::is_traceable`]), read one coordinate at a time. A ray is
    /// usually written just before it is traced, a field or a coordinate
    /// per store, and a 16-byte load that spans two stores cannot take its
    /// data from them: it waits until they reach the cache, tens of cycles
    /// on the path from one bounce to the next. The compiler merges
    /// adjacent loads into such wide ones, so the reads are volatile.
    ///
    /// Every ray pays for the check, so the coordinates take three vector
    /// comparisons: `<=` is false for NaN, so the one against the limit
    /// also rejects NaN and infinities; `t_min <= t_max` rejects a NaN at
    /// either end.
    #[inline(always)]
    pub fn traceable_vectors(&self) -> Option<(Vec3A, Vec3A)> {
        // SAFETY: each pointer comes from a reference to an initialised f32.
        let f = |x: &f32| unsafe { std::ptr::read_volatile(x) };
        let v = |v: &Vec3| Vec3A::new(f(&v.x), f(&v.y), f(&v.z));
        let (origin, dir) = (v(&self.origin), v(&self.dir));
        let limit = Vec3A::splat(COORDINATE_LIMIT);
        let traceable = (origin.abs().cmple(limit) & dir.abs().cmple(limit)).all()
            & dir.abs().cmpgt(Vec3A::ZERO).any()
            & (self.t_min >= 0.0)
            & (self.t_min <= self.t_max);
        traceable.then_some((origin, dir))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn traceable_vectors_are_the_coordinates() {
        let r = Ray::spawn(
            &SpawnPoint {
                p: Vec3::new(1.5, -2.25, 3.0),
                error: Vec3::splat(1e-6),
                ng: Vec3::Z,
            },
            Vec3::new(0.6, 0.0, 0.8),
            7.0,
        );
        assert_eq!(
            r.traceable_vectors(),
            Some((Vec3A::from(r.origin), Vec3A::from(r.dir)))
        );
    }

    #[test]
    fn traceable_rejects_each_bad_field_alone() {
        let good = Ray::new(Vec3::new(1.0, -2.0, 3.0), Vec3::new(0.0, 0.0, -1.0));
        assert!(good.is_traceable());
        let with = |f: &dyn Fn(&mut Ray)| {
            let mut r = good;
            f(&mut r);
            r.is_traceable()
        };
        let far = COORDINATE_LIMIT * 1.5;
        for (what, bad) in [
            ("NaN", f32::NAN),
            ("infinity", f32::INFINITY),
            ("-infinity", f32::NEG_INFINITY),
            ("beyond the limit", far),
            ("beyond minus the limit", -far),
        ] {
            for axis in 0..3 {
                assert!(!with(&|r| r.origin[axis] = bad), "origin {axis} {what}");
                assert!(!with(&|r| r.dir[axis] = bad), "dir {axis} {what}");
            }
        }
        assert!(!with(&|r| r.dir = Vec3::ZERO), "zero direction");
        assert!(!with(&|r| r.dir = -Vec3::ZERO), "negative zero direction");
        assert!(
            with(&|r| r.dir = Vec3::new(0.0, 1e-30, 0.0)),
            "tiny direction"
        );
        assert!(
            with(&|r| r.origin = Vec3::splat(-COORDINATE_LIMIT)),
            "at the limit"
        );
        assert!(!with(&|r| r.t_min = -1e-9), "negative t_min");
        assert!(!with(&|r| r.t_min = f32::NAN), "NaN t_min");
        assert!(!with(&|r| r.t_max = f32::NAN), "NaN t_max");
        assert!(
            !with(&|r| (r.t_min, r.t_max) = (2.0, 1.0)),
            "empty interval"
        );
        assert!(with(&|r| (r.t_min, r.t_max) = (1.0, 1.0)), "one point");
        assert!(with(&|r| r.t_max = f32::INFINITY), "infinite t_max");
    }
}
