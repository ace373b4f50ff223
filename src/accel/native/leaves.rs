//! The leaf tests the kernels call, one per primitive kind: 4-wide
//! Möller–Trumbore blocks, watertight triangles and spheres. Each remembers
//! what it hit nearest; the query turns that into a [`Hit`](crate::geom::Hit).

use glam::Vec3;

use super::sphere;
#[cfg(target_arch = "x86_64")]
use super::traverse::packet::{Lanes, PacketRays, Width, MAX_LANES};
use super::traverse::Leaves;
#[cfg(target_arch = "x86_64")]
use super::traverse::PacketLeaves;
use super::triangle::{TriangleBlock4, TriangleTest, Watertight};
#[cfg(target_arch = "x86_64")]
use super::triangle::{EDGE_SLACK, PARALLEL_DETERMINANT, PREFILTER_HIGH, PREFILTER_LOW};
use super::SphereItem;
use crate::geom::Ray;

/// Möller–Trumbore blocks: remembers (block, lane, u, v) of the nearest hit.
///
/// Hits are ordered by distance, then by slot (`4 * block + lane`): of two
/// triangles at exactly the same distance (a ray through the edge they
/// share) the lower slot wins, whichever the walk meets first. So the
/// answer does not depend on the order leaves are visited in, and packets
/// ([`BlockPacket`]), which visit them in another order, give single rays'
/// answers bit for bit.
pub(super) struct BlockLeaves<'a> {
    pub(super) blocks: &'a [TriangleBlock4],
    pub(super) ray: &'a Ray,
    pub(super) best: Option<(u32, usize, f32, f32)>,
}

/// The slot of a remembered hit, `u32::MAX` for none: ties go to the lower.
#[inline(always)]
fn slot(best: Option<(u32, usize, f32, f32)>) -> u32 {
    best.map_or(u32::MAX, |(b, lane, ..)| 4 * b + lane as u32)
}

impl Leaves for BlockLeaves<'_> {
    #[inline(always)]
    fn nearest(&mut self, first: u32, count: u32, mut t_max: f32) -> Option<f32> {
        let mut found = None;
        for b in first..first + count {
            if let Some((lane, t, u, v)) =
                self.blocks[b as usize].nearest(self.ray, self.ray.t_min, t_max)
            {
                // At exactly `t_max`, only a lower slot than the hit so far.
                if t < t_max || 4 * b + (lane as u32) < slot(self.best) {
                    t_max = t;
                    found = Some(t);
                    self.best = Some((b, lane, u, v));
                }
            }
        }
        found
    }

    #[inline(always)]
    fn address(&self, first: u32) -> *const u8 {
        self.blocks.as_ptr().wrapping_add(first as usize).cast()
    }

    #[inline(always)]
    fn any(&mut self, first: u32, count: u32, t_max: f32) -> bool {
        (first..first + count).any(|b| {
            self.blocks[b as usize]
                .nearest(self.ray, self.ray.t_min, t_max)
                .is_some()
        })
    }
}

/// Watertight triangles: remembers (slot, u, v) of the nearest hit.
pub(super) struct WatertightLeaves<'a> {
    pub(super) corners: &'a [([Vec3; 3], u32)],
    pub(super) setup: <Watertight as TriangleTest>::Setup,
    pub(super) t_min: f32,
    pub(super) best: Option<(u32, f32, f32)>,
}

impl Leaves for WatertightLeaves<'_> {
    #[inline(always)]
    fn nearest(&mut self, first: u32, count: u32, mut t_max: f32) -> Option<f32> {
        let mut found = None;
        for slot in first..first + count {
            let tri = &self.corners[slot as usize].0;
            if let Some((t, u, v)) = Watertight::intersect(tri, &self.setup, self.t_min, t_max) {
                t_max = t;
                found = Some(t);
                self.best = Some((slot, u, v));
            }
        }
        found
    }

    #[inline(always)]
    fn address(&self, first: u32) -> *const u8 {
        self.corners.as_ptr().wrapping_add(first as usize).cast()
    }

    #[inline(always)]
    fn any(&mut self, first: u32, count: u32, t_max: f32) -> bool {
        (first..first + count).any(|slot| {
            Watertight::intersect(
                &self.corners[slot as usize].0,
                &self.setup,
                self.t_min,
                t_max,
            )
            .is_some()
        })
    }
}

/// Spheres: remembers the item of the nearest hit.
pub(super) struct SphereLeaves<'a> {
    pub(super) items: &'a [SphereItem],
    pub(super) ray: &'a Ray,
    pub(super) best: Option<u32>,
}

impl Leaves for SphereLeaves<'_> {
    #[inline(always)]
    fn nearest(&mut self, first: u32, count: u32, mut t_max: f32) -> Option<f32> {
        let mut found = None;
        for i in first..first + count {
            let s = &self.items[i as usize];
            if let Some(t) =
                sphere::intersect_sphere(s.center, s.radius, self.ray, self.ray.t_min, t_max)
            {
                t_max = t;
                found = Some(t);
                self.best = Some(i);
            }
        }
        found
    }

    #[inline(always)]
    fn address(&self, first: u32) -> *const u8 {
        self.items.as_ptr().wrapping_add(first as usize).cast()
    }

    #[inline(always)]
    fn any(&mut self, first: u32, count: u32, t_max: f32) -> bool {
        (first..first + count).any(|i| {
            let s = &self.items[i as usize];
            sphere::intersect_sphere(s.center, s.radius, self.ray, self.ray.t_min, t_max).is_some()
        })
    }
}

/// Per ray, triangle `i` of `block`: the rays (lanes in `live`) it hits
/// within `(t_min, t_max]` and their `t, u, v`. The operations of
/// [`TriangleBlock4::nearest`] for that triangle, in the same order, lane
/// by lane, so each ray gets the bits its single-ray test computes; none
/// when the test rejects every live lane before the division.
///
/// # Safety
/// Only from `W`'s `#[target_feature]` code.
///
/// `BEHIND` adds the prefilter's test of the distance's sign
/// (`triangle::behind`): shadow rays leave a surface and meet their own
/// triangle at `t <= 0`, where it skips the division (maxplanck's light
/// packets 1.11x); camera rays never start on a surface, and for them it
/// was pure arithmetic (camera packets 0.97x), so closest-hit packets go
/// without it. Either way the same lanes hit.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn lanes_hit<W: Width, const BEHIND: bool>(
    block: &TriangleBlock4,
    i: usize,
    r: &Lanes<W>,
    t_max: W::V,
    live: u32,
) -> (u32, W::V, W::V, W::V) {
    // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
    // enabled (a detected token chose this code) and the tree was checked by `Tree::new`,
    // so every node reference read from it is in range.
    unsafe {
        let at = |k: usize, axis: usize| W::splat(block.corner(k, axis, i));
        let (v0x, v0y, v0z) = (at(0, 0), at(0, 1), at(0, 2));
        let (e1x, e1y, e1z) = (at(1, 0), at(1, 1), at(1, 2));
        let (e2x, e2y, e2z) = (at(2, 0), at(2, 1), at(2, 2));
        let [dx, dy, dz] = r.dir;
        let (mul, sub, add) = (
            |a, b| W::mul(a, b),
            |a, b| W::sub(a, b),
            |a, b| W::add(a, b),
        );
        let px = sub(mul(dy, e2z), mul(e2y, dz));
        let py = sub(mul(dz, e2x), mul(e2z, dx));
        let pz = sub(mul(dx, e2y), mul(e2x, dy));
        let det = add(add(mul(e1x, px), mul(e1y, py)), mul(e1z, pz));
        let abs = W::abs(det);
        // The determinant's sign bit alone.
        let sign = W::xor(det, abs);
        let sx = sub(r.origin[0], v0x);
        let sy = sub(r.origin[1], v0y);
        let sz = sub(r.origin[2], v0z);
        let qx = sub(mul(sy, e1z), mul(e1y, sz));
        let qy = sub(mul(sz, e1x), mul(e1z, sx));
        let qz = sub(mul(sx, e1y), mul(e1x, sy));
        let u_det = add(add(mul(sx, px), mul(sy, py)), mul(sz, pz));
        let v_det = add(add(mul(dx, qx), mul(dy, qy)), mul(dz, qz));
        let t_det = add(add(mul(e2x, qx), mul(e2y, qy)), mul(e2z, qz));
        let (u_abs, v_abs) = (W::xor(u_det, sign), W::xor(v_det, sign));
        let low = mul(abs, W::splat(-PREFILTER_LOW));
        let inside = live
            & W::ge(abs, W::splat(PARALLEL_DETERMINANT))
            & W::ge(u_abs, low)
            & W::ge(v_abs, low)
            & W::le(add(u_abs, v_abs), mul(abs, W::splat(PREFILTER_HIGH)))
            & if BEHIND {
                W::gt(W::xor(t_det, sign), r.behind)
            } else {
                u32::MAX
            };
        let zero = W::splat(0.0);
        if inside == 0 {
            return (0, zero, zero, zero);
        }
        let inv = W::div(W::splat(1.0), det);
        let (u, v) = (mul(u_det, inv), mul(v_det, inv));
        let t = mul(t_det, inv);
        let valid = inside
            & W::ge(u, W::splat(-EDGE_SLACK))
            & W::ge(v, W::splat(-EDGE_SLACK))
            & W::le(add(u, v), W::splat(1.0 + EDGE_SLACK))
            & W::gt(t, r.t_min)
            & W::le(t, t_max);
        (valid, t, u, v)
    }
}

/// Möller–Trumbore blocks for a packet: each triangle against all its rays
/// at once ([`lanes_hit`]); remembers per lane the nearest hit's block and
/// lane (`4 * block + lane`, kept as a float's bits so that a lane blend
/// carries it with `u` and `v`), `u` and `v`.
#[cfg(target_arch = "x86_64")]
pub(super) struct BlockPacket<'a, W: Width> {
    pub(super) blocks: &'a [TriangleBlock4],
    pub(super) rays: &'a Lanes<W>,
    pub(super) best: [f32; MAX_LANES],
    pub(super) u: [f32; MAX_LANES],
    pub(super) v: [f32; MAX_LANES],
}

#[cfg(target_arch = "x86_64")]
impl<'a, W: Width> BlockPacket<'a, W> {
    pub(super) fn new(blocks: &'a [TriangleBlock4], rays: &'a PacketRays<W>) -> Self {
        BlockPacket {
            blocks,
            rays: &rays.lanes,
            best: [f32::from_bits(u32::MAX); MAX_LANES],
            u: [0.0; MAX_LANES],
            v: [0.0; MAX_LANES],
        }
    }

    /// Lane `i`'s hit so far, as [`BlockLeaves::best`] holds it.
    pub(super) fn get(&self, i: usize) -> Option<(u32, usize, f32, f32)> {
        let id = self.best[i].to_bits();
        (id != u32::MAX).then(|| (id / 4, (id % 4) as usize, self.u[i], self.v[i]))
    }

    /// Lane `i`'s hit as a single-ray leaf test left it.
    pub(super) fn set(&mut self, i: usize, hit: Option<(u32, usize, f32, f32)>) {
        if let Some((b, lane, u, v)) = hit {
            self.best[i] = f32::from_bits(4 * b + lane as u32);
            self.u[i] = u;
            self.v[i] = v;
        }
    }

    /// Lane `i`'s nearest hit: (primitive, u, v).
    pub(super) fn hit(&self, i: usize) -> Option<(u32, f32, f32)> {
        let id = self.best[i].to_bits();
        (id != u32::MAX).then(|| {
            let block = &self.blocks[(id / 4) as usize];
            (block.prim((id % 4) as usize), self.u[i], self.v[i])
        })
    }
}

#[cfg(target_arch = "x86_64")]
impl<W: Width> PacketLeaves<W> for BlockPacket<'_, W> {
    #[inline(always)]
    unsafe fn nearest(
        &mut self,
        first: u32,
        count: u32,
        mask: u32,
        t_max: &mut [f32; MAX_LANES],
    ) -> u32 {
        // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
        // enabled (a detected token chose this code) and the tree was checked by
        // `Tree::new`, so every node reference read from it is in range.
        unsafe {
            let mut t_lanes = W::load(t_max);
            let (mut best, mut u_lanes, mut v_lanes) =
                (W::load(&self.best), W::load(&self.u), W::load(&self.v));
            let mut found = 0;
            for b in first..first + count {
                let block = &self.blocks[b as usize];
                // Triangle by triangle, each taking the rays whose nearest it
                // is so far (`t <= t_max`, and at exactly `t_max` only from a
                // higher slot): what the single-ray block test and leaf loop
                // choose.
                for i in 0..4 {
                    if block.prim(i) == u32::MAX {
                        break;
                    }
                    let (mut hits, t, u, v) =
                        lanes_hit::<W, false>(block, i, self.rays, t_lanes, mask);
                    if hits == 0 {
                        continue;
                    }
                    let ties = hits & W::ge(t, t_lanes);
                    if ties != 0 {
                        let mut held = [0.0f32; MAX_LANES];
                        W::store(&mut held, best);
                        let id = 4 * b + i as u32;
                        for (lane, held) in held.iter().enumerate().take(W::N) {
                            if ties >> lane & 1 != 0 && id >= held.to_bits() {
                                hits &= !(1 << lane);
                            }
                        }
                        if hits == 0 {
                            continue;
                        }
                    }
                    found |= hits;
                    t_lanes = W::select(hits, t_lanes, t);
                    u_lanes = W::select(hits, u_lanes, u);
                    v_lanes = W::select(hits, v_lanes, v);
                    best = W::select(hits, best, W::splat(f32::from_bits(4 * b + i as u32)));
                }
            }
            W::store(&mut self.best, best);
            W::store(&mut self.u, u_lanes);
            W::store(&mut self.v, v_lanes);
            W::store(t_max, t_lanes);
            found
        }
    }

    #[inline(always)]
    unsafe fn any(&mut self, first: u32, count: u32, mask: u32, t_max: &[f32; MAX_LANES]) -> u32 {
        // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
        // enabled (a detected token chose this code) and the tree was checked by
        // `Tree::new`, so every node reference read from it is in range.
        unsafe {
            let t_lanes = W::load(t_max);
            let mut live = mask;
            for b in first..first + count {
                let block = &self.blocks[b as usize];
                for i in 0..4 {
                    if block.prim(i) == u32::MAX {
                        break;
                    }
                    let (hits, ..) = lanes_hit::<W, true>(block, i, self.rays, t_lanes, live);
                    live &= !hits;
                    if live == 0 {
                        return mask;
                    }
                }
            }
            mask & !live
        }
    }
}
