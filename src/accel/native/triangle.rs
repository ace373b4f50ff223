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

use crate::geom::Ray;

/// Per-ray data of the watertight test, computed once per ray.
#[derive(Clone, Copy, Debug)]
pub struct ShearedRay {
    pub origin: Vec3,
    /// The dominant axis, the two others, and the shear.
    kx: usize,
    ky: usize,
    kz: usize,
    shear: Vec3,
}

impl ShearedRay {
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
        ShearedRay {
            origin: ray.origin,
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
    /// What the test precomputes per ray.
    type Setup: Copy;
    fn setup(ray: &Ray) -> Self::Setup;
    /// Precomputes what the test keeps for a triangle with these corners.
    fn prepare(v0: Vec3, v1: Vec3, v2: Vec3) -> [Vec3; 3];
    /// `(t, u, v)` of a hit with `t` in `(t_min, t_max]` (Embree's
    /// convention: a hit at exactly `t_min` is behind the origin).
    fn intersect(
        tri: &[Vec3; 3],
        ray: &Self::Setup,
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
    type Setup = Ray;

    fn setup(ray: &Ray) -> Ray {
        *ray
    }

    /// Stores `v0, e1 = v1 - v0, e2 = v2 - v0`.
    fn prepare(v0: Vec3, v1: Vec3, v2: Vec3) -> [Vec3; 3] {
        [v0, v1 - v0, v2 - v0]
    }

    /// A division-free prefilter compares the unnormalized barycentrics
    /// with `|det|` (loosely enough never to reject a hit), so the division
    /// runs only near the triangle; the decision itself is the classic one
    /// on `u = U / det`, `v = V / det`. One lane of [`TriangleBlock4`] does
    /// the same operations in the same order.
    #[inline(always)]
    fn intersect(tri: &[Vec3; 3], ray: &Ray, t_min: f32, t_max: f32) -> Option<(f32, f32, f32)> {
        let [v0, e1, e2] = *tri;
        let d = ray.dir;
        let p = d.cross(e2);
        let det = e1.dot(p);
        let abs = det.abs();
        if !(abs >= PARALLEL_DETERMINANT) {
            return None;
        }
        let sign = det.to_bits() & SIGN;
        let s = ray.origin - v0;
        let q = s.cross(e1);
        let (u_det, v_det) = (s.dot(p), d.dot(q));
        let (u_abs, v_abs) = (flip(u_det, sign), flip(v_det, sign));
        let (low, high) = (-abs * PREFILTER_LOW, abs * PREFILTER_HIGH);
        let t_det = e2.dot(q);
        if !(u_abs >= low
            && v_abs >= low
            && u_abs + v_abs <= high
            && flip(t_det, sign) > behind(t_min))
        {
            return None;
        }
        let inv = 1.0 / det;
        let (u, v) = (u_det * inv, v_det * inv);
        if !(u >= -EDGE_SLACK && v >= -EDGE_SLACK && u + v <= 1.0 + EDGE_SLACK) {
            return None;
        }
        let t = t_det * inv;
        if !(t > t_min && t <= t_max) {
            return None;
        }
        Some((t, u, v))
    }
}

const SIGN: u32 = 1 << 31;
/// The prefilter's `u + v <= 1` is tested as `U + V <= |det| * slack`: the
/// classic test's `fl(U / det) + fl(V / det) <= 1` allows a few ulps more.
const PREFILTER_SLACK: f32 = 1.0 + 16.0 * f32::EPSILON;
pub(super) const PREFILTER_LOW: f32 = EDGE_SLACK * PREFILTER_SLACK;

/// The prefilter's bound on `t * |det|` (`t_det` with the determinant's
/// sign taken off): a hit at `t <= 0` can never pass `t > t_min` when
/// `t_min >= 0` (the computed `t` has the sign of `t_det * det`, or is a
/// zero), so such lanes skip the division. Rays leaving a surface meet
/// their own triangle there: on the bunny, 1.0 M of 1.1 M block tests past
/// the barycentric prefilter of a million bounce rays were rejected by `t`
/// alone. Any `t_min < 0` (which a traceable ray never has) keeps every
/// lane.
#[inline(always)]
pub(super) fn behind(t_min: f32) -> f32 {
    if t_min >= 0.0 {
        0.0
    } else {
        f32::NEG_INFINITY
    }
}
pub(super) const PREFILTER_HIGH: f32 = (1.0 + EDGE_SLACK) * PREFILTER_SLACK;

/// Möller-Trumbore accepts barycentrics this far outside the triangle: its
/// rounding differs between the two triangles of an edge, so a ray aimed
/// at the edge can miss both (a leak: the black pixel at a floor-wall
/// junction). A margin of a few ulps of 1 closes most such gaps at no
/// cost; the rare ray then hits both triangles and the nearer wins. The
/// watertight test needs none.
pub const EDGE_SLACK: f32 = 4e-6;

/// `x` with its sign flipped when `sign` has the sign bit: `x * sign(det)`
/// without a multiplication.
#[inline(always)]
fn flip(x: f32, sign: u32) -> f32 {
    f32::from_bits(x.to_bits() ^ sign)
}

pub struct Watertight;

impl TriangleTest for Watertight {
    const NAME: &'static str = "watertight";
    type Setup = ShearedRay;

    fn setup(ray: &Ray) -> ShearedRay {
        ShearedRay::new(ray)
    }

    /// Stores the corners.
    fn prepare(v0: Vec3, v1: Vec3, v2: Vec3) -> [Vec3; 3] {
        [v0, v1, v2]
    }

    #[inline(always)]
    fn intersect(
        tri: &[Vec3; 3],
        ray: &ShearedRay,
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
        if !(t > t_min && t <= t_max) {
            return None;
        }
        Some((t, e1 * inv, e2 * inv))
    }
}

/// Four Möller–Trumbore triangles in structure-of-arrays form (`v0`,
/// `e1`, `e2`, each as x, y, z lanes) with their primitive ids, tested
/// against one ray at once. Unused lanes hold a degenerate triangle that
/// the determinant test rejects.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(32))]
pub struct TriangleBlock4 {
    v: [[[f32; 4]; 3]; 3],
    prims: [u32; 4],
}

/// One lane's answer: distance and barycentrics.
pub type LaneHit = (usize, f32, f32, f32);

impl TriangleBlock4 {
    /// A block of four unused lanes.
    pub const EMPTY: TriangleBlock4 = TriangleBlock4 {
        v: [[[0.0f32; 4]; 3]; 3],
        prims: [u32::MAX; 4],
    };

    /// Packs up to four triangles given as `[v0, e1, e2]` with their ids.
    pub fn pack(tris: &[([Vec3; 3], u32)]) -> TriangleBlock4 {
        let mut block = TriangleBlock4::EMPTY;
        for (lane, (tri, prim)) in tris.iter().take(4).enumerate() {
            block.set_lane(lane, tri, *prim);
        }
        block
    }

    /// Puts triangle `[v0, e1, e2]` with id `prim` in lane `lane`.
    #[inline(always)]
    pub fn set_lane(&mut self, lane: usize, tri: &[Vec3; 3], prim: u32) {
        for (k, p) in tri.iter().enumerate() {
            self.v[k][0][lane] = p.x;
            self.v[k][1][lane] = p.y;
            self.v[k][2][lane] = p.z;
        }
        self.prims[lane] = prim;
    }

    /// Lane `i` as `[v0, e1, e2]`.
    pub fn lane(&self, i: usize) -> [Vec3; 3] {
        [0, 1, 2].map(|k| Vec3::new(self.v[k][0][i], self.v[k][1][i], self.v[k][2][i]))
    }

    /// Coordinate `axis` of lane `i`'s `v0` (`k` 0), `e1` (1) or `e2` (2).
    #[inline(always)]
    pub fn corner(&self, k: usize, axis: usize, i: usize) -> f32 {
        self.v[k][axis][i]
    }

    /// The primitive id of lane `i`.
    #[inline(always)]
    pub fn prim(&self, i: usize) -> u32 {
        self.prims[i]
    }

    /// The nearest hit in `(t_min, t_max]`: `(lane, t, u, v)`; on equal
    /// distances the lowest lane (ties go to the lowest slot, see
    /// [`BlockLeaves`](super::leaves::BlockLeaves)).
    #[inline(always)]
    pub fn nearest(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<LaneHit> {
        #[cfg(target_arch = "x86_64")]
        {
            self.nearest_sse(ray, t_min, t_max)
        }
        #[cfg(not(target_arch = "x86_64"))]
        {
            self.nearest_scalar(ray, t_min, t_max)
        }
    }

    /// The scalar twin of the SIMD test: every lane through
    /// [`MollerTrumbore::intersect`], then the same reduction.
    #[cfg_attr(target_arch = "x86_64", allow(dead_code))]
    fn nearest_scalar(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<LaneHit> {
        let mut best: Option<LaneHit> = None;
        for i in 0..4 {
            if let Some((t, u, v)) = MollerTrumbore::intersect(&self.lane(i), ray, t_min, t_max) {
                if best.is_none_or(|b| t < b.1) {
                    best = Some((i, t, u, v));
                }
            }
        }
        best
    }

    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    fn nearest_sse(&self, ray: &Ray, t_min: f32, t_max: f32) -> Option<LaneHit> {
        use std::arch::x86_64::*;
        // SAFETY: SSE and SSE2 are part of the x86_64 baseline; every load
        // reads four floats of this 32-byte aligned block.
        unsafe {
            let load = |k: usize, axis: usize| _mm_load_ps(self.v[k][axis].as_ptr());
            let (v0x, v0y, v0z) = (load(0, 0), load(0, 1), load(0, 2));
            let (e1x, e1y, e1z) = (load(1, 0), load(1, 1), load(1, 2));
            let (e2x, e2y, e2z) = (load(2, 0), load(2, 1), load(2, 2));
            let (dx, dy, dz) = (
                _mm_set1_ps(ray.dir.x),
                _mm_set1_ps(ray.dir.y),
                _mm_set1_ps(ray.dir.z),
            );
            let (mul, sub, add) = (
                |a, b| _mm_mul_ps(a, b),
                |a, b| _mm_sub_ps(a, b),
                |a, b| _mm_add_ps(a, b),
            );
            // p = dir x e2 (glam's operand order)
            let px = sub(mul(dy, e2z), mul(e2y, dz));
            let py = sub(mul(dz, e2x), mul(e2z, dx));
            let pz = sub(mul(dx, e2y), mul(e2x, dy));
            let det = add(add(mul(e1x, px), mul(e1y, py)), mul(e1z, pz));
            let sign_bit = _mm_set1_ps(-0.0);
            let abs = _mm_andnot_ps(sign_bit, det);
            let sign = _mm_and_ps(sign_bit, det);
            let sx = sub(_mm_set1_ps(ray.origin.x), v0x);
            let sy = sub(_mm_set1_ps(ray.origin.y), v0y);
            let sz = sub(_mm_set1_ps(ray.origin.z), v0z);
            // q = s x e1
            let qx = sub(mul(sy, e1z), mul(e1y, sz));
            let qy = sub(mul(sz, e1x), mul(e1z, sx));
            let qz = sub(mul(sx, e1y), mul(e1x, sy));
            let u_det = add(add(mul(sx, px), mul(sy, py)), mul(sz, pz));
            let v_det = add(add(mul(dx, qx), mul(dy, qy)), mul(dz, qz));
            let t_det = add(add(mul(e2x, qx), mul(e2y, qy)), mul(e2z, qz));
            let (u_abs, v_abs) = (_mm_xor_ps(u_det, sign), _mm_xor_ps(v_det, sign));
            let low = mul(abs, _mm_set1_ps(-PREFILTER_LOW));
            let inside = _mm_and_ps(
                _mm_and_ps(
                    _mm_and_ps(
                        _mm_cmpge_ps(abs, _mm_set1_ps(PARALLEL_DETERMINANT)),
                        _mm_cmpge_ps(u_abs, low),
                    ),
                    _mm_and_ps(
                        _mm_cmpge_ps(v_abs, low),
                        _mm_cmple_ps(add(u_abs, v_abs), mul(abs, _mm_set1_ps(PREFILTER_HIGH))),
                    ),
                ),
                _mm_cmpgt_ps(_mm_xor_ps(t_det, sign), _mm_set1_ps(behind(t_min))),
            );
            if _mm_movemask_ps(inside) == 0 {
                return None;
            }
            let inv = _mm_div_ps(_mm_set1_ps(1.0), det);
            let (u, v) = (mul(u_det, inv), mul(v_det, inv));
            let t = mul(t_det, inv);
            let valid = _mm_and_ps(
                _mm_and_ps(
                    inside,
                    _mm_and_ps(
                        _mm_and_ps(
                            _mm_cmpge_ps(u, _mm_set1_ps(-EDGE_SLACK)),
                            _mm_cmpge_ps(v, _mm_set1_ps(-EDGE_SLACK)),
                        ),
                        _mm_cmple_ps(add(u, v), _mm_set1_ps(1.0 + EDGE_SLACK)),
                    ),
                ),
                _mm_and_ps(
                    _mm_cmpgt_ps(t, _mm_set1_ps(t_min)),
                    _mm_cmple_ps(t, _mm_set1_ps(t_max)),
                ),
            );
            let mut mask = _mm_movemask_ps(valid) as u32;
            if mask == 0 {
                return None;
            }
            let mut ts = [0.0f32; 4];
            _mm_storeu_ps(ts.as_mut_ptr(), t);
            let mut best = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            while mask != 0 {
                let i = mask.trailing_zeros() as usize;
                if ts[i] < ts[best] {
                    best = i;
                }
                mask &= mask - 1;
            }
            let (mut us, mut vs) = ([0.0f32; 4], [0.0f32; 4]);
            _mm_storeu_ps(us.as_mut_ptr(), u);
            _mm_storeu_ps(vs.as_mut_ptr(), v);
            Some((best, ts[best], us[best], vs[best]))
        }
    }
}

/// Which triangle test the native backend runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum TriangleMode {
    #[default]
    MollerTrumbore,
    Watertight,
}

crate::choice!(TriangleMode { MollerTrumbore => "moller-trumbore", Watertight => "watertight" });

#[cfg(test)]
mod tests {
    use super::*;

    fn hit<T: TriangleTest>(v: [Vec3; 3], ray: Ray) -> Option<(f32, f32, f32)> {
        let tri = T::prepare(v[0], v[1], v[2]);
        T::intersect(&tri, &T::setup(&ray), ray.t_min, ray.t_max)
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
    fn four_wide_block_matches_the_scalar_test_bit_for_bit() {
        let mut state = 5u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32) / (1u64 << 24) as f32 * 2.0 - 1.0
        };
        let mut hits = 0;
        for _ in 0..20_000 {
            let count = 1 + (next().abs() * 3.99) as usize;
            let tris: Vec<([Vec3; 3], u32)> = (0..count as u32)
                .map(|i| {
                    let a = Vec3::new(next(), next(), next());
                    let tri = MollerTrumbore::prepare(
                        a,
                        a + Vec3::new(next(), next(), next()) * 0.5,
                        a + Vec3::new(next(), next(), next()) * 0.5,
                    );
                    (tri, i)
                })
                .collect();
            let block = TriangleBlock4::pack(&tris);
            // Aim near a random lane's centroid so that many rays hit.
            let [v0, e1, e2] = tris[(next().abs() * (count as f32 - 0.01)) as usize].0;
            let target = v0 + (e1 + e2) / 3.0 + Vec3::new(next(), next(), next()) * 0.1;
            let origin = Vec3::new(next(), next(), next()) * 2.0;
            let ray = Ray::new(origin, (target - origin).normalize());
            let simd = block.nearest(&ray, 0.0, f32::INFINITY);
            let scalar = block.nearest_scalar(&ray, 0.0, f32::INFINITY);
            assert_eq!(
                simd.map(|h| (h.0, h.1.to_bits(), h.2.to_bits(), h.3.to_bits())),
                scalar.map(|h| (h.0, h.1.to_bits(), h.2.to_bits(), h.3.to_bits()))
            );
            hits += simd.is_some() as usize;
        }
        assert!(
            hits > 1000,
            "only {hits} hits: the test rays miss too often to mean anything"
        );
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
