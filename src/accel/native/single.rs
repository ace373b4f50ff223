//! One ray's walk: the closest hit and the any-hit query over the
//! triangle tree (Möller–Trumbore blocks inline, watertight corners out of
//! line) and the sphere tree.

use glam::{Vec3, Vec3A};

use super::leaves::{BlockLeaves, SphereLeaves, WatertightLeaves};
use super::traverse::{self, BoxRay, Leaves, Work};
use super::tree::Tree;
use super::triangle::{TriangleTest, Watertight};
use super::{node, NativeBvh, TriangleStore};
use crate::accel::TraceCounters;
use crate::geom::{Hit, Ray};

impl NativeBvh {
    /// The closest hit of a traceable `ray`, whose coordinates are
    /// `vectors` ([`Ray::traceable_vectors`], read once by the caller). Watertight
    /// triangles and spheres are tested out of line, so that the common
    /// case, Möller–Trumbore blocks alone, stays small.
    #[inline]
    pub(super) fn closest(
        &self,
        ray: &Ray,
        vectors: (Vec3A, Vec3A),
        counters: &mut TraceCounters,
    ) -> Option<Hit> {
        let box_ray = BoxRay::new(vectors.0, vectors.1, ray.t_min);
        self.closest_box(ray, &box_ray, counters)
    }

    /// [`Self::closest`] of a ray already prepared for the box tests.
    #[inline(always)]
    pub(super) fn closest_box(
        &self,
        ray: &Ray,
        box_ray: &BoxRay,
        counters: &mut TraceCounters,
    ) -> Option<Hit> {
        let box_ray = *box_ray;
        let mut t_max = ray.t_max;
        let mut work = Work::default();
        let mut hit = match &self.triangle_store {
            TriangleStore::Blocks(blocks) => {
                let mut leaves = BlockLeaves {
                    blocks,
                    ray,
                    best: None,
                };
                self.walk_closest(
                    &self.triangles,
                    &box_ray,
                    &mut t_max,
                    &mut leaves,
                    &mut work,
                );
                leaves.best.map(|(b, lane, u, v)| Hit {
                    t: t_max,
                    prim: blocks[b as usize].prim(lane),
                    u,
                    v,
                })
            }
            TriangleStore::Corners(corners) => {
                self.closest_watertight(corners, ray, &box_ray, &mut t_max, &mut work)
            }
        };
        if !self.sphere_items.is_empty() {
            hit = self
                .closest_sphere(ray, &box_ray, &mut t_max, &mut work)
                .or(hit);
        }
        counters.box_tests += work.nodes * node::WIDTH as u64;
        counters.prim_tests += work.items;
        hit
    }

    /// [`Self::closest`] over watertight triangles.
    #[inline(never)]
    pub(super) fn closest_watertight(
        &self,
        corners: &[([Vec3; 3], u32)],
        ray: &Ray,
        box_ray: &BoxRay,
        t_max: &mut f32,
        work: &mut Work,
    ) -> Option<Hit> {
        let mut leaves = WatertightLeaves {
            corners,
            setup: Watertight::setup(ray),
            t_min: ray.t_min,
            best: None,
        };
        self.walk_closest(&self.triangles, box_ray, t_max, &mut leaves, work);
        let (slot, u, v) = leaves.best?;
        Some(Hit {
            t: *t_max,
            prim: corners[slot as usize].1,
            u,
            v,
        })
    }

    /// A sphere nearer than `t_max`, if any.
    #[inline(never)]
    pub(super) fn closest_sphere(
        &self,
        ray: &Ray,
        box_ray: &BoxRay,
        t_max: &mut f32,
        work: &mut Work,
    ) -> Option<Hit> {
        let mut leaves = SphereLeaves {
            items: &self.sphere_items,
            ray,
            best: None,
        };
        self.walk_closest(&self.spheres, box_ray, t_max, &mut leaves, work);
        let s = &self.sphere_items[leaves.best? as usize];
        Some(Hit {
            t: *t_max,
            prim: s.prim,
            u: 0.0,
            v: 0.0,
        })
    }

    #[inline(always)]
    pub(super) fn walk_closest<L: Leaves>(
        &self,
        nodes: &Tree,
        ray: &BoxRay,
        t_max: &mut f32,
        leaves: &mut L,
        work: &mut Work,
    ) -> bool {
        traverse::closest(nodes, ray, t_max, leaves, self.cpu, self.box_test, work, 0)
    }

    #[inline(always)]
    pub(super) fn walk_any<L: Leaves>(
        &self,
        nodes: &Tree,
        ray: &BoxRay,
        t_max: f32,
        leaves: &mut L,
        work: &mut Work,
    ) -> bool {
        traverse::any(nodes, ray, t_max, leaves, self.cpu, self.box_test, work, 0)
    }

    /// Whether anything blocks a traceable `ray`, as [`Self::closest`].
    #[inline]
    pub(super) fn any(
        &self,
        ray: &Ray,
        vectors: (Vec3A, Vec3A),
        counters: &mut TraceCounters,
    ) -> bool {
        let box_ray = BoxRay::new(vectors.0, vectors.1, ray.t_min);
        self.any_box(ray, &box_ray, counters)
    }

    /// [`Self::any`] of a ray already prepared for the box tests.
    #[inline(always)]
    pub(super) fn any_box(
        &self,
        ray: &Ray,
        box_ray: &BoxRay,
        counters: &mut TraceCounters,
    ) -> bool {
        let box_ray = *box_ray;
        let mut work = Work::default();
        let hit = match &self.triangle_store {
            TriangleStore::Blocks(blocks) => {
                let mut leaves = BlockLeaves {
                    blocks,
                    ray,
                    best: None,
                };
                self.walk_any(&self.triangles, &box_ray, ray.t_max, &mut leaves, &mut work)
            }
            TriangleStore::Corners(corners) => {
                self.any_watertight(corners, ray, &box_ray, &mut work)
            }
        } || (!self.sphere_items.is_empty() && self.any_sphere(ray, &box_ray, &mut work));
        counters.box_tests += work.nodes * node::WIDTH as u64;
        counters.prim_tests += work.items;
        hit
    }

    /// [`Self::any`] over watertight triangles.
    #[inline(never)]
    pub(super) fn any_watertight(
        &self,
        corners: &[([Vec3; 3], u32)],
        ray: &Ray,
        box_ray: &BoxRay,
        work: &mut Work,
    ) -> bool {
        let mut leaves = WatertightLeaves {
            corners,
            setup: Watertight::setup(ray),
            t_min: ray.t_min,
            best: None,
        };
        self.walk_any(&self.triangles, box_ray, ray.t_max, &mut leaves, work)
    }

    /// [`Self::any`] over spheres.
    #[inline(never)]
    pub(super) fn any_sphere(&self, ray: &Ray, box_ray: &BoxRay, work: &mut Work) -> bool {
        let mut leaves = SphereLeaves {
            items: &self.sphere_items,
            ray,
            best: None,
        };
        self.walk_any(&self.spheres, box_ray, ray.t_max, &mut leaves, work)
    }
}
