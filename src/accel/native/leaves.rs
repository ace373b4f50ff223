//! The leaf tests the kernels call, one per primitive kind: 4-wide
//! Möller–Trumbore blocks, watertight triangles and spheres. Each remembers
//! what it hit nearest; the query turns that into a [`Hit`](crate::geom::Hit).

use glam::Vec3;

use super::sphere;
use super::traverse::Leaves;
#[cfg(target_arch = "x86_64")]
use std::arch::x86_64::*;

#[cfg(target_arch = "x86_64")]
use super::traverse::packet::{lane_mask, PacketRays, LANES};
#[cfg(target_arch = "x86_64")]
use super::traverse::PacketLeaves;
#[cfg(target_arch = "x86_64")]
use super::triangle::eight::{self, Rays8};
use super::triangle::{TriangleBlock4, TriangleTest, Watertight};
use super::SphereItem;
use crate::geom::Ray;

/// Möller–Trumbore blocks: remembers (block, lane, u, v) of the nearest hit.
pub(super) struct BlockLeaves<'a> {
    pub(super) blocks: &'a [TriangleBlock4],
    pub(super) ray: &'a Ray,
    pub(super) best: Option<(u32, usize, f32, f32)>,
}

impl Leaves for BlockLeaves<'_> {
    #[inline(always)]
    fn nearest(&mut self, first: u32, count: u32, mut t_max: f32) -> Option<f32> {
        let mut found = None;
        for b in first..first + count {
            if let Some((lane, t, u, v)) =
                self.blocks[b as usize].nearest(self.ray, self.ray.t_min, t_max)
            {
                t_max = t;
                found = Some(t);
                self.best = Some((b, lane, u, v));
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

/// Möller–Trumbore blocks for a packet of eight rays: each triangle
/// against all of them at once ([`eight::hit`]); remembers per lane the
/// nearest hit's block and lane (`4 * block + lane`), `u` and `v`.
#[cfg(target_arch = "x86_64")]
pub(super) struct BlockPacket<'a> {
    pub(super) blocks: &'a [TriangleBlock4],
    pub(super) rays: &'a Rays8,
    pub(super) best: [u32; LANES],
    pub(super) u: [f32; LANES],
    pub(super) v: [f32; LANES],
}

#[cfg(target_arch = "x86_64")]
impl<'a> BlockPacket<'a> {
    pub(super) fn new(blocks: &'a [TriangleBlock4], rays: &'a PacketRays) -> BlockPacket<'a> {
        BlockPacket {
            blocks,
            rays: &rays.lanes,
            best: [u32::MAX; LANES],
            u: [0.0; LANES],
            v: [0.0; LANES],
        }
    }

    /// Lane `i`'s hit as a single-ray leaf test left it.
    pub(super) fn set(&mut self, i: usize, hit: Option<(u32, usize, f32, f32)>) {
        if let Some((b, lane, u, v)) = hit {
            self.best[i] = 4 * b + lane as u32;
            self.u[i] = u;
            self.v[i] = v;
        }
    }

    /// Lane `i`'s nearest hit: (primitive, u, v).
    pub(super) fn hit(&self, i: usize) -> Option<(u32, f32, f32)> {
        let id = self.best[i];
        (id != u32::MAX).then(|| {
            let block = &self.blocks[(id / 4) as usize];
            (block.prim((id % 4) as usize), self.u[i], self.v[i])
        })
    }
}

#[cfg(target_arch = "x86_64")]
impl PacketLeaves for BlockPacket<'_> {
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    #[inline]
    unsafe fn nearest(
        &mut self,
        first: u32,
        count: u32,
        mask: u32,
        t_max: &mut [f32; LANES],
    ) -> u32 {
        let live = lane_mask(mask);
        let mut t_lanes = _mm256_loadu_ps(t_max.as_ptr());
        let mut found = 0;
        for b in first..first + count {
            let block = &self.blocks[b as usize];
            // Triangle by triangle, each taking the rays whose nearest it
            // is so far (`t <= t_max`, the later one on a tie): what the
            // single-ray block test and leaf loop choose.
            for i in 0..4 {
                if block.prim(i) == u32::MAX {
                    break;
                }
                let (hits, t, u, v) = eight::hit(block, i, self.rays, t_lanes, live);
                if hits == 0 {
                    continue;
                }
                found |= hits;
                let take = lane_mask(hits);
                t_lanes = _mm256_blendv_ps(t_lanes, t, take);
                let id = 4 * b + i as u32;
                for lane in (0..LANES).filter(|l| hits & (1 << l) != 0) {
                    self.best[lane] = id;
                }
                let (mut us, mut vs) = ([0.0f32; LANES], [0.0f32; LANES]);
                _mm256_storeu_ps(us.as_mut_ptr(), u);
                _mm256_storeu_ps(vs.as_mut_ptr(), v);
                for lane in (0..LANES).filter(|l| hits & (1 << l) != 0) {
                    self.u[lane] = us[lane];
                    self.v[lane] = vs[lane];
                }
            }
        }
        _mm256_storeu_ps(t_max.as_mut_ptr(), t_lanes);
        found
    }

    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    #[inline]
    unsafe fn any(&mut self, first: u32, count: u32, mask: u32, t_max: &[f32; LANES]) -> u32 {
        let t_lanes = _mm256_loadu_ps(t_max.as_ptr());
        let mut live = mask;
        for b in first..first + count {
            let block = &self.blocks[b as usize];
            for i in 0..4 {
                if block.prim(i) == u32::MAX {
                    break;
                }
                let (hits, ..) = eight::hit(block, i, self.rays, t_lanes, lane_mask(live));
                live &= !hits;
                if live == 0 {
                    return mask;
                }
            }
        }
        mask & !live
    }
}
