//! Ray/triangle tests of the native backend.
//!
//! - [`MollerTrumbore`]: Möller and Trumbore 1997, "Fast, minimum storage
//!   ray/triangle intersection": two edge vectors, a determinant that is ~0
//!   for rays parallel to the plane, barycentrics checked against [0, 1] and
//!   u + v <= 1, then t against the ray's interval. Fast, but rays through a
//!   shared edge can slip between the two triangles.
//! - [`Watertight`]: Woop, Benthin and Wald 2013, "Watertight ray/triangle
//!   intersection" (JCGT 2(1)): translate, shear and scale into ray space,
//!   then edge functions whose signs are consistent across shared edges,
//!   recomputed in double precision when one is exactly zero. The accuracy
//!   reference.
//!
//! Both report `(t, u, v)` with `u`, `v` the weights of corners 1 and 2.

use glam::Vec3;

use crate::accel::Ray;

/// Per-ray data precomputed once for all triangle tests.
#[derive(Clone, Copy, Debug)]
pub struct RayTriangleSetup {
    pub origin: Vec3,
    pub dir: Vec3,
    /// Watertight: the dominant axis and the two others, and the shear.
    kx: usize,
    ky: usize,
    kz: usize,
    shear: Vec3,
}

impl RayTriangleSetup {
    pub fn new(ray: &Ray) -> Self {
        let d = ray.dir;
        let a = d.abs();
        let kz = if a.x >= a.y && a.x >= a.z {
            0
        } else if a.y >= a.z {
            1
        } else {
            2
        };
        let mut kx = (kz + 1) % 3;
        let mut ky = (kx + 1) % 3;
        // Keep the winding: swap when the dominant component is negative.
        if d[kz] < 0.0 {
            std::mem::swap(&mut kx, &mut ky);
        }
        let shear = Vec3::new(d[kx] / d[kz], d[ky] / d[kz], 1.0 / d[kz]);
        RayTriangleSetup {
            origin: ray.origin,
            dir: d,
            kx,
            ky,
            kz,
            shear,
        }
    }
}

/// A ray/triangle test over the triangle data it stores per primitive.
pub trait TriangleTest: Send + Sync + 'static {
    const NAME: &'static str;
    /// Precomputes what the test keeps for a triangle with these corners.
    fn prepare(v0: Vec3, v1: Vec3, v2: Vec3) -> [Vec3; 3];
    /// `(t, u, v)` of a hit with `t` in `[t_min, t_max]`.
    fn intersect(
        tri: &[Vec3; 3],
        ray: &RayTriangleSetup,
        t_min: f32,
        t_max: f32,
    ) -> Option<(f32, f32, f32)>;
}

/// Below this |det| (for unit-length directions: |cos| times twice the area)
/// the ray counts as parallel to the triangle.
pub const PARALLEL_DETERMINANT: f32 = 1e-20;

pub struct MollerTrumbore;

impl TriangleTest for MollerTrumbore {
    const NAME: &'static str = "moller-trumbore";

    /// Stores `v0, e1 = v1 - v0, e2 = v2 - v0`.
    fn prepare(v0: Vec3, v1: Vec3, v2: Vec3) -> [Vec3; 3] {
        [v0, v1 - v0, v2 - v0]
    }

    #[inline(always)]
    fn intersect(
        tri: &[Vec3; 3],
        ray: &RayTriangleSetup,
        t_min: f32,
        t_max: f32,
    ) -> Option<(f32, f32, f32)> {
        let [v0, e1, e2] = *tri;
        let p = ray.dir.cross(e2);
        let det = e1.dot(p);
        if det.abs() < PARALLEL_DETERMINANT {
            return None;
        }
        let inv = 1.0 / det;
        let s = ray.origin - v0;
        let u = s.dot(p) * inv;
        if !(0.0..=1.0).contains(&u) {
            return None;
        }
        let q = s.cross(e1);
        let v = ray.dir.dot(q) * inv;
        if v < 0.0 || u + v > 1.0 {
            return None;
        }
        let t = e2.dot(q) * inv;
        if t < t_min || t > t_max {
            return None;
        }
        Some((t, u, v))
    }
}

pub struct Watertight;

impl TriangleTest for Watertight {
    const NAME: &'static str = "watertight";

    /// Stores the corners.
    fn prepare(v0: Vec3, v1: Vec3, v2: Vec3) -> [Vec3; 3] {
        [v0, v1, v2]
    }

    #[inline(always)]
    fn intersect(
        tri: &[Vec3; 3],
        ray: &RayTriangleSetup,
        t_min: f32,
        t_max: f32,
    ) -> Option<(f32, f32, f32)> {
        let (kx, ky, kz) = (ray.kx, ray.ky, ray.kz);
        let s = ray.shear;
        let a = tri[0] - ray.origin;
        let b = tri[1] - ray.origin;
        let c = tri[2] - ray.origin;
        // Shear the corners so that the ray runs along +z from the origin.
        let (ax, ay) = (a[kx] - s.x * a[kz], a[ky] - s.y * a[kz]);
        let (bx, by) = (b[kx] - s.x * b[kz], b[ky] - s.y * b[kz]);
        let (cx, cy) = (c[kx] - s.x * c[kz], c[ky] - s.y * c[kz]);
        let mut e0 = cx * by - cy * bx; // weight of corner 0
        let mut e1 = ax * cy - ay * cx; // weight of corner 1
        let mut e2 = bx * ay - by * ax; // weight of corner 2
        if e0 == 0.0 || e1 == 0.0 || e2 == 0.0 {
            // Exactly on an edge in single precision: decide in double so
            // that both triangles sharing the edge agree (paper, §3.4).
            let d = |p: f32, q: f32, r: f32, w: f32| p as f64 * q as f64 - r as f64 * w as f64;
            e0 = d(cx, by, cy, bx) as f32;
            e1 = d(ax, cy, ay, cx) as f32;
            e2 = d(bx, ay, by, ax) as f32;
        }
        if (e0 < 0.0 || e1 < 0.0 || e2 < 0.0) && (e0 > 0.0 || e1 > 0.0 || e2 > 0.0) {
            return None;
        }
        let det = e0 + e1 + e2;
        if det == 0.0 {
            return None;
        }
        let (az, bz, cz) = (s.z * a[kz], s.z * b[kz], s.z * c[kz]);
        let t_scaled = e0 * az + e1 * bz + e2 * cz;
        let inv = 1.0 / det;
        let t = t_scaled * inv;
        if !(t >= t_min && t <= t_max) {
            return None;
        }
        Some((t, e1 * inv, e2 * inv))
    }
}

/// Which triangle test the native backend runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default, clap::ValueEnum)]
pub enum TriangleMode {
    #[default]
    MollerTrumbore,
    Watertight,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn hit<T: TriangleTest>(v: [Vec3; 3], ray: Ray) -> Option<(f32, f32, f32)> {
        let tri = T::prepare(v[0], v[1], v[2]);
        T::intersect(&tri, &RayTriangleSetup::new(&ray), ray.t_min, ray.t_max)
    }

    #[test]
    fn both_tests_agree_on_a_plain_hit() {
        let v = [
            Vec3::new(0.0, 0.0, 0.0),
            Vec3::new(1.0, 0.0, 0.0),
            Vec3::new(0.0, 1.0, 0.0),
        ];
        let ray = Ray::new(Vec3::new(0.25, 0.5, 2.0), Vec3::new(0.0, 0.0, -1.0));
        let a = hit::<MollerTrumbore>(v, ray).expect("Möller–Trumbore missed");
        let b = hit::<Watertight>(v, ray).expect("watertight missed");
        for (x, y) in [
            (a.0, 2.0),
            (a.1, 0.25),
            (a.2, 0.5),
            (b.0, 2.0),
            (b.1, 0.25),
            (b.2, 0.5),
        ] {
            assert!(
                (x - y).abs() < 1e-6,
                "got {x}, expected {y} (MT {a:?}, WT {b:?})"
            );
        }
    }

    #[test]
    fn parallel_and_behind_rays_miss() {
        let v = [Vec3::ZERO, Vec3::X, Vec3::Y];
        let parallel = Ray::new(Vec3::new(0.2, 0.2, 0.0), Vec3::X);
        let behind = Ray::new(Vec3::new(0.2, 0.2, 1.0), Vec3::Z);
        for r in [parallel, behind] {
            assert_eq!(hit::<MollerTrumbore>(v, r), None, "MT hit {r:?}");
            assert_eq!(hit::<Watertight>(v, r), None, "WT hit {r:?}");
        }
    }

    #[test]
    fn watertight_hits_exactly_one_side_of_a_shared_edge_at_least() {
        // Two triangles sharing the diagonal of the unit square; rays aimed
        // exactly at points of the diagonal must hit at least one of them.
        let a = [Vec3::ZERO, Vec3::X, Vec3::new(1.0, 1.0, 0.0)];
        let b = [Vec3::ZERO, Vec3::new(1.0, 1.0, 0.0), Vec3::Y];
        let mut leaks = 0;
        for i in 1..1000 {
            let s = i as f32 / 1000.0 * 0.999_37;
            let origin = Vec3::new(0.3, 0.7, 1.0);
            let ray = Ray::new(origin, Vec3::new(s, s, 0.0) - origin);
            if hit::<Watertight>(a, ray).is_none() && hit::<Watertight>(b, ray).is_none() {
                leaks += 1;
            }
        }
        assert_eq!(
            leaks, 0,
            "{leaks} of 999 rays through the shared edge leaked"
        );
    }
}
