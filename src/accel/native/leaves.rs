//! The leaf tests the kernels call, one per primitive kind: 4-wide
//! Möller–Trumbore blocks, watertight triangles and spheres. Each remembers
//! what it hit nearest; the query turns that into a [`Hit`](crate::geom::Hit).

use glam::Vec3;

use super::sphere;
use super::traverse::Leaves;
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
