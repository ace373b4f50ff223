//! The native backend: the project's own BVH ([`bvh`]) over the scene's
//! triangles ([`triangle`]) and, in a second tree, its spheres ([`sphere`]),
//! traversed as 8-wide (AVX) or 4-wide (SSE) trees ([`wide`]).
//!
//! Triangles-only scenes pay nothing for spheres on the per-ray path beyond
//! one emptiness check. Triangle data are stored in leaf order, precomputed
//! for the chosen test, so a leaf's triangles are contiguous in memory.

pub mod bvh;
pub mod sphere;
pub mod triangle;
pub mod wide;

use std::time::Instant;

use glam::Vec3;

use self::bvh::{BuildMethod, Bvh};
use self::triangle::{MollerTrumbore, TriangleBlock4, TriangleMode, TriangleTest, Watertight};
use self::wide::{BoxRay, Bvh4, Bvh8, BvhWide, ChildHit};
use super::{Accel, AccelStats, Hit, Ray, TraceCounters};
use crate::scene::{Bounds, Scene};

/// Build and traversal options of the native backend.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NativeOptions {
    pub triangle: TriangleMode,
    pub method: BuildMethod,
    /// Largest number of primitives in a leaf.
    pub max_leaf: usize,
    /// Traverse 8-wide with AVX when the CPU has it (else 4-wide SSE).
    pub wide8: bool,
}

impl NativeOptions {
    pub const DEFAULT: NativeOptions = NativeOptions {
        triangle: TriangleMode::MollerTrumbore,
        method: BuildMethod::Sah,
        max_leaf: 4,
        wide8: true,
    };
}

impl Default for NativeOptions {
    fn default() -> Self {
        NativeOptions::DEFAULT
    }
}

/// Deepest binary tree accepted; deeper SAH trees (only from pathological
/// inputs) are rebuilt with median splits, which keeps traversal stacks
/// small.
const MAX_DEPTH: usize = 96;

/// Conservative far-plane scale for the box test, 1 + 2γ(3) (Ize 2013,
/// "Robust BVH ray traversal", JCGT 2(2)), so that rounding in the slab test
/// never culls a box the watertight triangle test would hit.
pub(crate) const BOX_FAR_SCALE: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// The traversal trees of one width: triangles and spheres.
enum Trees {
    Four(Bvh4, Bvh4),
    /// Exists only on CPUs with AVX ([`Bvh8::from_binary`] checks).
    Eight(Bvh8, Bvh8),
}

pub struct NativeBvh {
    options: NativeOptions,
    /// The binary SAH trees keep only their leaf order (slot -> primitive)
    /// once the wide trees are made; their shape is kept in `shape`.
    triangles: Bvh,
    spheres: Bvh,
    trees: Trees,
    triangle_store: TriangleStore,
    /// Per leaf slot: centre and radius.
    sphere_data: Vec<(Vec3, f32)>,
    triangle_count: u32,
    build_ms: f64,
    shape: TreeShape,
}

/// Node count, leaves, depth and SAH cost of the binary trees as built.
#[derive(Clone, Copy, Debug)]
struct TreeShape {
    nodes: usize,
    leaves: usize,
    depth: usize,
    sah_cost: f64,
}

/// Reciprocal direction with zero components replaced by a huge finite
/// value of the same sign, so that a slab plane through the origin gives
/// 0 * huge = 0, never 0 * inf = NaN.
fn safe_inverse(dir: Vec3) -> Vec3 {
    let safe = |d: f32| {
        1.0 / if d.abs() < 1e-30 {
            1e-30f32.copysign(d)
        } else {
            d
        }
    };
    Vec3::new(safe(dir.x), safe(dir.y), safe(dir.z))
}

/// Traversal stack entries kept on the machine stack; deeper trees (rare)
/// use a heap stack of their exact bound.
const SMALL_STACK: usize = 128;

/// Walks the wide tree front to back and calls `leaf_test(first, count,
/// t_max)` for every leaf the ray reaches; it returns the nearest hit in
/// the leaf, which shrinks the interval. With `any`, stops at the first hit.
/// Returns whether anything was hit.
#[inline(always)]
fn traverse<const N: usize>(
    tree: &BvhWide<N>,
    ray: &BoxRay,
    t_min: f32,
    t_max: &mut f32,
    any: bool,
    counters: &mut TraceCounters,
    mut leaf_test: impl FnMut(u32, u32, f32) -> Option<f32>,
) -> bool {
    let mut hit = false;
    if let Some((first, count)) = tree.root_leaf {
        counters.prim_tests += count as u64;
        if let Some(t) = leaf_test(first, count, *t_max) {
            *t_max = t;
            hit = true;
        }
        return hit;
    }
    if tree.nodes.is_empty() {
        return false;
    }
    let mut small = [ChildHit::default(); SMALL_STACK];
    let mut large = Vec::new();
    let stack: &mut [ChildHit] = if tree.max_stack <= SMALL_STACK {
        &mut small
    } else {
        large.resize(tree.max_stack, ChildHit::default());
        &mut large
    };
    let mut top = 1usize; // stack[0] is the root (inner node 0)
    let mut children = [ChildHit::default(); N];
    while top > 0 {
        top -= 1;
        let entry = stack[top];
        if entry.t_near > *t_max {
            continue;
        }
        if wide::is_leaf(entry.child) {
            counters.prim_tests += entry.count as u64;
            if let Some(t) = leaf_test(wide::leaf_first(entry.child), entry.count, *t_max) {
                *t_max = t;
                hit = true;
                if any {
                    return true;
                }
            }
            continue;
        }
        let node = &tree.nodes[entry.child as usize];
        counters.box_tests += N as u64;
        let n = tree.hit_children(node, ray, t_min, *t_max, &mut children);
        // Push farthest first so the nearest child is visited next
        // (insertion sort over at most N entries).
        for (i, &c) in children[..n].iter().enumerate() {
            let mut j = top + i;
            while j > top && stack[j - 1].t_near < c.t_near {
                stack[j] = stack[j - 1];
                j -= 1;
            }
            stack[j] = c;
        }
        top += n;
    }
    hit
}

/// Triangle data in the layout of the chosen test.
enum TriangleStore {
    /// Möller–Trumbore: leaves point at runs of 4-wide SoA blocks; a
    /// block's lanes are consecutive leaf slots starting at `first_slot`.
    Blocks {
        blocks: Vec<TriangleBlock4>,
        first_slot: Vec<u32>,
    },
    /// Watertight: the corners per leaf slot, tested one at a time.
    Corners(Vec<[Vec3; 3]>),
}

/// The blocks of a leaf that starts at block `first` and holds `count`
/// triangles: (block index, block, lanes in use).
#[inline(always)]
fn leaf_blocks(
    blocks: &[TriangleBlock4],
    first: u32,
    count: u32,
) -> impl Iterator<Item = (usize, &TriangleBlock4, usize)> {
    let first = first as usize;
    blocks[first..first + count.div_ceil(4) as usize]
        .iter()
        .enumerate()
        .map(move |(k, block)| (first + k, block, (count as usize - 4 * k).min(4)))
}

/// Packs every leaf's triangles into 4-wide blocks and points the leaves
/// of `tree` at their first block.
fn pack_blocks<const N: usize>(
    tree: &mut BvhWide<N>,
    corners: impl Fn(u32) -> [Vec3; 3],
) -> TriangleStore {
    let (mut blocks, mut first_slot) = (Vec::new(), Vec::new());
    tree.remap_leaves(|first, count| {
        let block = blocks.len() as u32;
        for start in (first..first + count).step_by(4) {
            let lanes: Vec<[Vec3; 3]> = (start..(start + 4).min(first + count))
                .map(|slot| {
                    let [a, b, c] = corners(slot);
                    MollerTrumbore::prepare(a, b, c)
                })
                .collect();
            blocks.push(TriangleBlock4::pack(&lanes));
            first_slot.push(start);
        }
        block
    });
    TriangleStore::Blocks { blocks, first_slot }
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
        let sphere_boxes: Vec<Bounds> = scene
            .spheres
            .iter()
            .map(|s| Bounds {
                min: s.center - Vec3::splat(s.radius),
                max: s.center + Vec3::splat(s.radius),
            })
            .collect();
        let mut triangles = build_bounded_depth(&tri_boxes, options);
        let mut spheres = build_bounded_depth(&sphere_boxes, options);
        let shape = TreeShape {
            nodes: triangles.nodes.len() + spheres.nodes.len(),
            leaves: triangles.leaf_count() + spheres.leaf_count(),
            depth: triangles.depth().max(spheres.depth()),
            sah_cost: triangles.sah_cost(),
        };
        let wide8 = if options.wide8 {
            Bvh8::from_binary(&triangles)
        } else {
            None
        };
        let mut trees = match wide8 {
            Some(t) => Trees::Eight(
                t,
                Bvh8::from_binary(&spheres).expect("AVX was just detected"),
            ),
            None => Trees::Four(Bvh4::from_binary(&triangles), Bvh4::from_binary(&spheres)),
        };
        let corners = |slot: u32| mesh.corners(triangles.prim_order[slot as usize] as usize);
        let triangle_store = match options.triangle {
            TriangleMode::MollerTrumbore => match &mut trees {
                Trees::Four(t, _) => pack_blocks(t, corners),
                Trees::Eight(t, _) => pack_blocks(t, corners),
            },
            TriangleMode::Watertight => TriangleStore::Corners(
                (0..triangles.prim_order.len() as u32)
                    .map(|slot| {
                        let [a, b, c] = corners(slot);
                        Watertight::prepare(a, b, c)
                    })
                    .collect(),
            ),
        };
        triangles.nodes = Vec::new();
        spheres.nodes = Vec::new();
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
            spheres,
            trees,
            triangle_store,
            sphere_data,
            triangle_count: mesh.len() as u32,
            build_ms: start.elapsed().as_secs_f64() * 1e3,
            shape,
        }
    }

    /// Width of the traversal trees (8 with AVX, else 4).
    pub fn width(&self) -> usize {
        match self.trees {
            Trees::Four(..) => 4,
            Trees::Eight(..) => 8,
        }
    }

    /// Nearest triangle hit: (leaf slot, u, v, unit normal), shrinking
    /// `t_max` to its distance.
    #[inline(always)]
    fn closest_triangle<const N: usize>(
        &self,
        tree: &BvhWide<N>,
        ray: &Ray,
        box_ray: &BoxRay,
        t_max: &mut f32,
        counters: &mut TraceCounters,
    ) -> Option<(u32, f32, f32, Vec3)> {
        let t_min = ray.t_min;
        let mut best = None;
        match &self.triangle_store {
            TriangleStore::Blocks { blocks, first_slot } => {
                traverse(
                    tree,
                    box_ray,
                    t_min,
                    t_max,
                    false,
                    counters,
                    |first, count, mut t_max| {
                        let mut found = None;
                        for (index, block, lanes) in leaf_blocks(blocks, first, count) {
                            if let Some((lane, t, u, v)) = block.intersect(lanes, ray, t_min, t_max)
                            {
                                t_max = t;
                                found = Some(t);
                                let [_, e1, e2] = block.lane(lane);
                                best = Some((first_slot[index] + lane as u32, u, v, e1.cross(e2)));
                            }
                        }
                        found
                    },
                );
            }
            TriangleStore::Corners(corners) => {
                let setup = Watertight::setup(ray);
                traverse(
                    tree,
                    box_ray,
                    t_min,
                    t_max,
                    false,
                    counters,
                    |first, count, mut t_max| {
                        let mut found = None;
                        for slot in first..first + count {
                            let tri = &corners[slot as usize];
                            if let Some((t, u, v)) =
                                Watertight::intersect(tri, &setup, t_min, t_max)
                            {
                                t_max = t;
                                found = Some(t);
                                best = Some((slot, u, v, (tri[1] - tri[0]).cross(tri[2] - tri[0])));
                            }
                        }
                        found
                    },
                );
            }
        }
        best.map(|(slot, u, v, n)| (slot, u, v, n.normalize_or_zero()))
    }

    #[inline(always)]
    fn any_triangle<const N: usize>(
        &self,
        tree: &BvhWide<N>,
        ray: &Ray,
        box_ray: &BoxRay,
        counters: &mut TraceCounters,
    ) -> bool {
        let (t_min, mut t_max) = (ray.t_min, ray.t_max);
        match &self.triangle_store {
            TriangleStore::Blocks { blocks, .. } => traverse(
                tree,
                box_ray,
                t_min,
                &mut t_max,
                true,
                counters,
                |first, count, t_max| {
                    leaf_blocks(blocks, first, count)
                        .find_map(|(_, block, lanes)| block.intersect(lanes, ray, t_min, t_max))
                        .map(|h| h.1)
                },
            ),
            TriangleStore::Corners(corners) => {
                let setup = Watertight::setup(ray);
                traverse(
                    tree,
                    box_ray,
                    t_min,
                    &mut t_max,
                    true,
                    counters,
                    |first, count, t_max| {
                        (first..first + count)
                            .find_map(|slot| {
                                Watertight::intersect(&corners[slot as usize], &setup, t_min, t_max)
                            })
                            .map(|h| h.0)
                    },
                )
            }
        }
    }

    /// Nearest sphere hit in `[t_min, t_max]`: its leaf slot.
    #[inline(always)]
    fn sphere_hit<const N: usize>(
        &self,
        tree: &BvhWide<N>,
        ray: &Ray,
        box_ray: &BoxRay,
        t_max: &mut f32,
        any: bool,
        counters: &mut TraceCounters,
    ) -> Option<u32> {
        if self.spheres.prim_order.is_empty() {
            return None;
        }
        let mut best = None;
        traverse(
            tree,
            box_ray,
            ray.t_min,
            t_max,
            any,
            counters,
            |first, count, mut t_max| {
                let mut found = None;
                for slot in first..first + count {
                    let (c, r) = self.sphere_data[slot as usize];
                    if let Some(t) = sphere::intersect_sphere(c, r, ray, ray.t_min, t_max) {
                        t_max = t;
                        found = Some(t);
                        best = Some(slot);
                    }
                }
                found
            },
        );
        best
    }

    /// Closest hit through the trees of one width.
    #[inline(always)]
    fn closest<const N: usize>(
        &self,
        triangles: &BvhWide<N>,
        spheres: &BvhWide<N>,
        ray: &Ray,
        counters: &mut TraceCounters,
    ) -> Option<Hit> {
        let box_ray = BoxRay::new(ray.origin, safe_inverse(ray.dir));
        let mut t_max = ray.t_max;
        let triangle = self.closest_triangle(triangles, ray, &box_ray, &mut t_max, counters);
        if let Some(slot) = self.sphere_hit(spheres, ray, &box_ray, &mut t_max, false, counters) {
            let (c, _) = self.sphere_data[slot as usize];
            let prim = self.triangle_count + self.spheres.prim_order[slot as usize];
            return Some(Hit {
                t: t_max,
                prim,
                u: 0.0,
                v: 0.0,
                normal: (ray.at(t_max) - c).normalize_or_zero(),
            });
        }
        let (slot, u, v, normal) = triangle?;
        Some(Hit {
            t: t_max,
            prim: self.triangles.prim_order[slot as usize],
            u,
            v,
            normal,
        })
    }

    /// Occlusion through the trees of one width.
    #[inline(always)]
    fn any<const N: usize>(
        &self,
        triangles: &BvhWide<N>,
        spheres: &BvhWide<N>,
        ray: &Ray,
        counters: &mut TraceCounters,
    ) -> bool {
        let box_ray = BoxRay::new(ray.origin, safe_inverse(ray.dir));
        self.any_triangle(triangles, ray, &box_ray, counters)
            || self
                .sphere_hit(
                    spheres,
                    ray,
                    &box_ray,
                    &mut ray.t_max.clone(),
                    true,
                    counters,
                )
                .is_some()
    }

    /// The 8-wide path compiled with AVX, so the AVX slab test inlines into
    /// the traversal loop.
    ///
    /// # Safety
    /// The CPU must support AVX (true whenever `Trees::Eight` exists).
    #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx"))]
    unsafe fn closest_avx(
        &self,
        triangles: &Bvh8,
        spheres: &Bvh8,
        ray: &Ray,
        counters: &mut TraceCounters,
    ) -> Option<Hit> {
        self.closest(triangles, spheres, ray, counters)
    }

    /// # Safety
    /// As [`NativeBvh::closest_avx`].
    #[cfg_attr(target_arch = "x86_64", target_feature(enable = "avx"))]
    unsafe fn any_avx(
        &self,
        triangles: &Bvh8,
        spheres: &Bvh8,
        ray: &Ray,
        counters: &mut TraceCounters,
    ) -> bool {
        self.any(triangles, spheres, ray, counters)
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
        match &self.trees {
            Trees::Four(t, s) => self.closest(t, s, ray, counters),
            // SAFETY: `Trees::Eight` is only built after AVX was detected.
            Trees::Eight(t, s) => unsafe { self.closest_avx(t, s, ray, counters) },
        }
    }

    fn occluded(&self, ray: &Ray, counters: &mut TraceCounters) -> bool {
        counters.rays += 1;
        if !ray.is_traceable() {
            return false;
        }
        match &self.trees {
            Trees::Four(t, s) => self.any(t, s, ray, counters),
            // SAFETY: as in `closest_hit`.
            Trees::Eight(t, s) => unsafe { self.any_avx(t, s, ray, counters) },
        }
    }

    fn stats(&self) -> AccelStats {
        let (t, s) = (&self.triangles, &self.spheres);
        let wide_bytes = match &self.trees {
            Trees::Four(a, b) => a.memory_bytes() + b.memory_bytes(),
            Trees::Eight(a, b) => a.memory_bytes() + b.memory_bytes(),
        };
        AccelStats {
            backend: "native".into(),
            primitives: t.prim_order.len() + s.prim_order.len(),
            build_ms: self.build_ms,
            memory_bytes: t.memory_bytes()
                + s.memory_bytes()
                + wide_bytes
                + match &self.triangle_store {
                    TriangleStore::Blocks { blocks, first_slot } => {
                        blocks.len() * std::mem::size_of::<TriangleBlock4>() + first_slot.len() * 4
                    }
                    TriangleStore::Corners(c) => c.len() * std::mem::size_of::<[Vec3; 3]>(),
                }
                + self.sphere_data.len() * std::mem::size_of::<(Vec3, f32)>(),
            nodes: self.shape.nodes,
            leaves: self.shape.leaves,
            depth: self.shape.depth,
            sah_cost: self.shape.sah_cost,
            details: format!(
                "{} triangles, {:?} build, max leaf {}, {}-wide traversal",
                match self.options.triangle {
                    TriangleMode::MollerTrumbore => MollerTrumbore::NAME,
                    TriangleMode::Watertight => Watertight::NAME,
                },
                self.options.method,
                self.options.max_leaf,
                self.width()
            ),
        }
    }
}
