//! The native backend: the project's own BVH ([`bvh`]) over the scene's
//! triangles ([`triangle`]) and, in a second tree, its spheres ([`sphere`]).
//!
//! Triangles-only scenes pay nothing for spheres on the per-ray path beyond
//! one emptiness check. Triangle data are stored in leaf order, precomputed
//! for the chosen test, so a leaf's triangles are contiguous in memory.

pub mod bvh;
pub mod sphere;
pub mod triangle;

use std::time::Instant;

use glam::Vec3;

use self::bvh::{BuildMethod, Bvh, BvhNode};
use self::triangle::{MollerTrumbore, RayTriangleSetup, TriangleMode, TriangleTest, Watertight};
use super::{Accel, AccelStats, Hit, Ray, TraceCounters};
use crate::scene::{Bounds, Scene};

/// Build and traversal options of the native backend.
#[derive(Clone, Copy, Debug)]
pub struct NativeOptions {
    pub triangle: TriangleMode,
    pub method: BuildMethod,
    /// Largest number of primitives in a leaf.
    pub max_leaf: usize,
}

impl Default for NativeOptions {
    fn default() -> Self {
        NativeOptions {
            triangle: TriangleMode::MollerTrumbore,
            method: BuildMethod::Sah,
            max_leaf: 4,
        }
    }
}

/// Deepest tree the fixed traversal stack handles; deeper SAH trees (only
/// from pathological inputs) are rebuilt with median splits.
const MAX_DEPTH: usize = 96;

/// Conservative far-plane scale for the box test, 1 + 2γ(3) (Ize 2013,
/// "Robust BVH ray traversal", JCGT 2(2)), so that rounding in the slab test
/// never culls a box the watertight triangle test would hit.
const BOX_FAR_SCALE: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

pub struct NativeBvh {
    options: NativeOptions,
    triangles: Bvh,
    /// Per leaf slot: data of [`TriangleTest::prepare`].
    triangle_data: Vec<[Vec3; 3]>,
    spheres: Bvh,
    /// Per leaf slot: centre and radius.
    sphere_data: Vec<(Vec3, f32)>,
    triangle_count: u32,
    build_ms: f64,
}

/// A ray prepared for slab tests.
struct BoxRay {
    origin: Vec3,
    inv_dir: Vec3,
    dir_negative: [bool; 3],
}

impl BoxRay {
    fn new(ray: &Ray) -> Self {
        // Zero components get a huge finite reciprocal of the same sign, so
        // that a slab plane through the origin gives 0 * huge = 0, never
        // 0 * inf = NaN.
        let safe = |d: f32| {
            1.0 / if d.abs() < 1e-30 {
                1e-30f32.copysign(d)
            } else {
                d
            }
        };
        let inv_dir = Vec3::new(safe(ray.dir.x), safe(ray.dir.y), safe(ray.dir.z));
        BoxRay {
            origin: ray.origin,
            inv_dir,
            dir_negative: [inv_dir.x < 0.0, inv_dir.y < 0.0, inv_dir.z < 0.0],
        }
    }

    #[inline(always)]
    fn hits(&self, node: &BvhNode, t_min: f32, t_max: f32) -> bool {
        let t0 = (Vec3::from(node.min) - self.origin) * self.inv_dir;
        let t1 = (Vec3::from(node.max) - self.origin) * self.inv_dir;
        let near = t0.min(t1).max_element().max(t_min);
        let far = t0.max(t1).min_element() * BOX_FAR_SCALE;
        near <= far.min(t_max)
    }
}

/// Walks `nodes` front to back and calls `leaf_test(slot, t_max)` for every
/// primitive slot of every leaf the ray reaches; a `Some(t)` shrinks the
/// interval. With `any`, stops at the first hit. Returns whether anything
/// was hit.
#[inline(always)]
fn traverse(
    nodes: &[BvhNode],
    ray: &BoxRay,
    t_min: f32,
    t_max: &mut f32,
    any: bool,
    counters: &mut TraceCounters,
    mut leaf_test: impl FnMut(usize, f32) -> Option<f32>,
) -> bool {
    if nodes.is_empty() {
        return false;
    }
    let mut stack = [0u32; MAX_DEPTH];
    let mut top = 0usize;
    let mut index = 0usize;
    let mut hit = false;
    loop {
        let node = &nodes[index];
        counters.box_tests += 1;
        if ray.hits(node, t_min, *t_max) {
            if !node.is_leaf() {
                // Visit the child on the ray's side of the split first.
                let (near, far) = if ray.dir_negative[node.axis as usize] {
                    (node.offset as usize, index + 1)
                } else {
                    (index + 1, node.offset as usize)
                };
                stack[top] = far as u32;
                top += 1;
                index = near;
                continue;
            }
            let first = node.offset as usize;
            for slot in first..first + node.count as usize {
                counters.prim_tests += 1;
                if let Some(t) = leaf_test(slot, *t_max) {
                    *t_max = t;
                    hit = true;
                    if any {
                        return true;
                    }
                }
            }
        }
        if top == 0 {
            return hit;
        }
        top -= 1;
        index = stack[top] as usize;
    }
}

impl NativeBvh {
    pub fn build(scene: &Scene, options: &NativeOptions) -> NativeBvh {
        let start = Instant::now();
        let mesh = &scene.mesh;
        let tri_boxes: Vec<Bounds> = (0..mesh.len())
            .map(|i| {
                let mut b = Bounds::EMPTY;
                for p in mesh.corners(i) {
                    b.grow(p);
                }
                b
            })
            .collect();
        let triangles = build_bounded_depth(&tri_boxes, options);
        let prepare = match options.triangle {
            TriangleMode::MollerTrumbore => MollerTrumbore::prepare,
            TriangleMode::Watertight => Watertight::prepare,
        };
        let triangle_data = triangles
            .prim_order
            .iter()
            .map(|&i| {
                let [a, b, c] = mesh.corners(i as usize);
                prepare(a, b, c)
            })
            .collect();
        let sphere_boxes: Vec<Bounds> = scene
            .spheres
            .iter()
            .map(|s| Bounds {
                min: s.center - Vec3::splat(s.radius),
                max: s.center + Vec3::splat(s.radius),
            })
            .collect();
        let spheres = build_bounded_depth(&sphere_boxes, options);
        let sphere_data = spheres
            .prim_order
            .iter()
            .map(|&i| {
                let s = &scene.spheres[i as usize];
                (s.center, s.radius)
            })
            .collect();
        NativeBvh {
            options: *options,
            triangles,
            triangle_data,
            spheres,
            sphere_data,
            triangle_count: mesh.len() as u32,
            build_ms: start.elapsed().as_secs_f64() * 1e3,
        }
    }

    /// The triangle tree (for invariants and statistics).
    pub fn triangle_bvh(&self) -> &Bvh {
        &self.triangles
    }

    pub fn sphere_bvh(&self) -> &Bvh {
        &self.spheres
    }

    fn closest<T: TriangleTest>(&self, ray: &Ray, counters: &mut TraceCounters) -> Option<Hit> {
        let box_ray = BoxRay::new(ray);
        let setup = RayTriangleSetup::new(ray);
        let mut t_max = ray.t_max;
        let mut best: Option<(usize, f32, f32)> = None;
        traverse(
            &self.triangles.nodes,
            &box_ray,
            ray.t_min,
            &mut t_max,
            false,
            counters,
            |slot, t_max| {
                let (t, u, v) = T::intersect(&self.triangle_data[slot], &setup, ray.t_min, t_max)?;
                best = Some((slot, u, v));
                Some(t)
            },
        );
        let mut best_sphere = None;
        if !self.spheres.is_empty() {
            traverse(
                &self.spheres.nodes,
                &box_ray,
                ray.t_min,
                &mut t_max,
                false,
                counters,
                |slot, t_max| {
                    let (c, r) = self.sphere_data[slot];
                    let t = sphere::intersect_sphere(c, r, ray, ray.t_min, t_max)?;
                    best_sphere = Some(slot);
                    Some(t)
                },
            );
        }
        if let Some(slot) = best_sphere {
            let (c, _) = self.sphere_data[slot];
            let prim = self.triangle_count + self.spheres.prim_order[slot];
            return Some(Hit {
                t: t_max,
                prim,
                u: 0.0,
                v: 0.0,
                normal: (ray.at(t_max) - c).normalize_or_zero(),
            });
        }
        let (slot, u, v) = best?;
        let [a, b, c] = self.triangle_data[slot];
        let normal = match self.options.triangle {
            TriangleMode::MollerTrumbore => b.cross(c),
            TriangleMode::Watertight => (b - a).cross(c - a),
        }
        .normalize_or_zero();
        Some(Hit {
            t: t_max,
            prim: self.triangles.prim_order[slot],
            u,
            v,
            normal,
        })
    }

    fn any<T: TriangleTest>(&self, ray: &Ray, counters: &mut TraceCounters) -> bool {
        let box_ray = BoxRay::new(ray);
        let setup = RayTriangleSetup::new(ray);
        let mut t_max = ray.t_max;
        let tri = traverse(
            &self.triangles.nodes,
            &box_ray,
            ray.t_min,
            &mut t_max,
            true,
            counters,
            |slot, t_max| {
                T::intersect(&self.triangle_data[slot], &setup, ray.t_min, t_max).map(|h| h.0)
            },
        );
        tri || traverse(
            &self.spheres.nodes,
            &box_ray,
            ray.t_min,
            &mut t_max,
            true,
            counters,
            |slot, t_max| {
                let (c, r) = self.sphere_data[slot];
                sphere::intersect_sphere(c, r, ray, ray.t_min, t_max)
            },
        )
    }
}

fn build_bounded_depth(boxes: &[Bounds], options: &NativeOptions) -> Bvh {
    let bvh = Bvh::build(boxes, options.max_leaf, options.method);
    if bvh.depth() <= MAX_DEPTH {
        return bvh;
    }
    Bvh::build(boxes, options.max_leaf, BuildMethod::Median)
}

impl Accel for NativeBvh {
    fn closest_hit(&self, ray: &Ray, counters: &mut TraceCounters) -> Option<Hit> {
        counters.rays += 1;
        if !ray.is_traceable() {
            return None;
        }
        match self.options.triangle {
            TriangleMode::MollerTrumbore => self.closest::<MollerTrumbore>(ray, counters),
            TriangleMode::Watertight => self.closest::<Watertight>(ray, counters),
        }
    }

    fn occluded(&self, ray: &Ray, counters: &mut TraceCounters) -> bool {
        counters.rays += 1;
        if !ray.is_traceable() {
            return false;
        }
        match self.options.triangle {
            TriangleMode::MollerTrumbore => self.any::<MollerTrumbore>(ray, counters),
            TriangleMode::Watertight => self.any::<Watertight>(ray, counters),
        }
    }

    fn stats(&self) -> AccelStats {
        let (t, s) = (&self.triangles, &self.spheres);
        AccelStats {
            backend: "native".into(),
            primitives: t.prim_order.len() + s.prim_order.len(),
            build_ms: self.build_ms,
            memory_bytes: t.memory_bytes()
                + s.memory_bytes()
                + self.triangle_data.len() * std::mem::size_of::<[Vec3; 3]>()
                + self.sphere_data.len() * std::mem::size_of::<(Vec3, f32)>(),
            nodes: t.nodes.len() + s.nodes.len(),
            leaves: t.leaf_count() + s.leaf_count(),
            depth: t.depth().max(s.depth()),
            sah_cost: t.sah_cost(),
            details: format!(
                "{} triangles, {:?} build, max leaf {}",
                match self.options.triangle {
                    TriangleMode::MollerTrumbore => MollerTrumbore::NAME,
                    TriangleMode::Watertight => Watertight::NAME,
                },
                self.options.method,
                self.options.max_leaf
            ),
        }
    }
}
