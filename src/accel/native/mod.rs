//! The native backend: the project's own 8-wide BVH over the scene's
//! triangles and, in a second tree, its spheres.
//!
//! - [`build`]: binned SAH, building the 8-wide tree directly;
//! - [`node`]: the 256-byte node with per-octant child orders;
//! - [`tree`]: the node list the kernels may trust, checked once;
//! - `traverse`: the AVX2 and scalar kernels, private to the backend;
//! - [`triangle`], [`sphere`]: the primitive tests;
//! - [`cpu`]: the token that proves AVX2 was detected.
//!
//! Leaf data are stored in the order the tree visits them (depth first),
//! precomputed for the chosen triangle test: Möller–Trumbore in 4-wide
//! blocks carrying their primitive ids, or the watertight test's corners.

pub mod build;
pub mod cpu;
mod leaves;
mod memory;
pub mod node;
mod pack;
pub mod sphere;
mod traverse;
pub mod tree;
pub mod triangle;

use std::time::Instant;

use glam::{Vec3, Vec3A};
use rayon::prelude::*;

use self::build::{BuildMethod, BuiltTree, TreeShape};
use self::cpu::{Avx2, Avx512};
#[cfg(target_arch = "x86_64")]
use self::leaves::BlockPacket;
use self::leaves::{BlockLeaves, SphereLeaves, WatertightLeaves};
use self::node::{Node8, MAX_LEAF_FIRST};
#[cfg(target_arch = "x86_64")]
use self::traverse::packet::{self, Packet, PacketRays, Width, X16, X8};
use self::traverse::{BoxRay, BoxTest, Leaves, Work};
use self::tree::{Tree, MAX_DEPTH};
use self::triangle::{TriangleBlock4, TriangleMode, TriangleTest, Watertight};
use super::{Accel, AccelError, AccelStats, TraceCounters, TreeFacts};
use crate::choice::Choice;
use crate::geom::{Bounds, Hit, Ray};
use crate::scene::Scene;

/// Build and traversal options of the native backend.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct NativeOptions {
    pub triangle: TriangleMode,
    pub method: BuildMethod,
    /// Largest number of primitives in a leaf (1..=16); 0 picks it by the
    /// number of primitives ([`NativeOptions::leaf_cap`]).
    pub max_leaf: usize,
    /// Traverse with AVX2 when the CPU has it (else the scalar kernel).
    pub simd: bool,
    /// Rays per packet of the batch queries: 0 the widest the CPU runs
    /// (16 with AVX-512, else 8), or 8 (AVX2 lanes even with AVX-512).
    pub packet_lanes: usize,
}

impl NativeOptions {
    pub const DEFAULT: NativeOptions = NativeOptions {
        triangle: TriangleMode::MollerTrumbore,
        method: BuildMethod::Sah,
        max_leaf: 0,
        simd: true,
        packet_lanes: 0,
    };

    /// The largest leaf for a tree over `primitives`: `max_leaf`, or when
    /// that is 0, one block of four ([`build::LEAF_BLOCK`]), and two blocks
    /// from [`LARGE_TREE`] primitives on. A large tree's nodes no longer
    /// stay in cache, so a level of nodes saved costs more than a second
    /// block tested: on the report's 1.31 M-triangle mesh, leaves of up to
    /// eight traced 4-10% more rays per second on every ray kind (one
    /// thread; camera 1.21x -> 1.30x Embree, bounce 0.91x -> 1.00x) and
    /// lowered the SAH cost (26.94 -> 26.80); on the 28-51 k-triangle
    /// shared meshes they were 0-8% slower, so those keep four.
    pub fn leaf_cap(&self, primitives: usize) -> usize {
        match self.max_leaf {
            0 if primitives >= LARGE_TREE => 2 * build::LEAF_BLOCK,
            0 => build::LEAF_BLOCK,
            n => n,
        }
    }

    /// What the builder charges a binary split over `primitives`, in leaf
    /// block tests: [`build::SPLIT_COST`], or for a [`LARGE_TREE`] the
    /// binary SAH's whole node test ([`build::TRAVERSAL_COST`]). There a
    /// node visit often misses the cache and the fuller leaves pay (see
    /// [`Self::leaf_cap`]); with the quarter, leaves of five to eight
    /// nearly always split in two and the 1.31 M-triangle mesh traced
    /// 9-16% fewer incoherent, shadow and bounce rays per second.
    pub fn split_cost(&self, primitives: usize) -> f32 {
        if primitives >= LARGE_TREE {
            build::TRAVERSAL_COST
        } else {
            build::SPLIT_COST
        }
    }
}

/// Trees over at least this many primitives get leaves of up to two
/// blocks by default (see [`NativeOptions::leaf_cap`]).
pub const LARGE_TREE: usize = 1 << 19;

impl Default for NativeOptions {
    fn default() -> Self {
        NativeOptions::DEFAULT
    }
}

/// Rays of one octant that a group of `lanes` needs at least to be traced
/// as a packet: three quarters of its lanes; fewer go one at a time. With
/// four of eight, AVX2 packets of diffuse bounce rays ran at 0.85x single
/// rays (CBbunny and maxplanck); with six, 0.95-0.97x, camera rays alike
/// and light rays alike or faster (docs/experiments.md, stop 43).
pub const fn min_packet(lanes: usize) -> u32 {
    (lanes as u32 * 3).div_ceil(4)
}

/// A batch query asks for the rays of the group this many groups ahead
/// before tracing each group (CBbunny camera packets 1.01x, maxplanck
/// 1.03x, 8 and 6 alternating pairs).
pub const PREFETCH_GROUPS: usize = 2;

/// A child that fewer of a packet's rays enter is handed to the single-ray
/// kernel, one ray at a time (0, 2 and 4 measured alike; 2 keeps a lone
/// ray from dragging the packet's interval tests along).
pub const SINGLE_BELOW: u32 = 2;

/// Conservative far-plane scale for the box test, 1 + 2γ(3) (Ize 2013,
/// "Robust BVH ray traversal", JCGT 2(2)), so that rounding in the slab test
/// never culls a box the watertight triangle test would hit.
pub(crate) const BOX_FAR_SCALE: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

/// Triangle data in the layout of the chosen test, in leaf order.
enum TriangleStore {
    Blocks(Vec<TriangleBlock4>),
    /// Watertight: corners and primitive id per leaf slot.
    Corners(Vec<([Vec3; 3], u32)>),
}

/// A sphere in leaf order.
#[derive(Clone, Copy, Debug)]
struct SphereItem {
    center: Vec3,
    radius: f32,
    prim: u32,
}

pub struct NativeBvh {
    options: NativeOptions,
    cpu: Option<Avx2>,
    /// The batch queries' kernels.
    packets: PacketKernels,
    box_test: BoxTest,
    triangles: Tree,
    triangle_store: TriangleStore,
    spheres: Tree,
    sphere_items: Vec<SphereItem>,
    build_ms: f64,
    shape: TreeShape,
    /// The triangle tree's largest leaf ([`NativeOptions::leaf_cap`]).
    leaf_cap: usize,
}

/// Builds a tree over `boxes`; a SAH tree deeper than the kernels' stacks
/// allow (pathological input only) is rebuilt by median splits, whose depth
/// is logarithmic.
fn build_bounded(boxes: &[Bounds], options: &NativeOptions) -> BuiltTree {
    let max_leaf = options.leaf_cap(boxes.len());
    let split_cost = options.split_cost(boxes.len());
    let tree = build::build(boxes, max_leaf, split_cost, options.method);
    if tree.shape.depth <= MAX_DEPTH {
        return tree;
    }
    build::build(boxes, max_leaf, split_cost, BuildMethod::Median)
}

/// The built nodes as a [`Tree`]; the builder's trees always pass, so an
/// error here is a bug in it, reported rather than traversed.
fn checked(nodes: Vec<Node8>) -> Result<Tree, AccelError> {
    Tree::new(nodes).map_err(|e| AccelError::Internal(format!("native: malformed tree ({e})")))
}

fn bounds_of(points: &[Vec3]) -> Bounds {
    let mut b = Bounds::EMPTY;
    for p in points {
        b.grow(*p);
    }
    b
}

impl NativeBvh {
    pub fn build(scene: &Scene, options: &NativeOptions) -> Result<NativeBvh, AccelError> {
        let start = Instant::now();
        let mesh = &scene.mesh;
        let limit = MAX_LEAF_FIRST as usize;
        if mesh.len() > limit || scene.spheres.len() > limit {
            return Err(AccelError::TooLarge(format!(
                "native: {} triangles and {} spheres; the native BVH holds up to {limit} of each",
                mesh.len(),
                scene.spheres.len()
            )));
        }
        let tri_boxes: Vec<Bounds> = (0..mesh.len())
            .into_par_iter()
            .map(|i| bounds_of(&mesh.corners(i)))
            .collect();
        let sphere_boxes: Vec<Bounds> = scene
            .spheres
            .iter()
            .map(|s| Bounds {
                min: s.center - Vec3::splat(s.radius),
                max: s.center + Vec3::splat(s.radius),
            })
            .collect();
        let tri_tree = build_bounded(&tri_boxes, options);
        let sphere_tree = build_bounded(&sphere_boxes, options);

        let mut triangles = tri_tree.nodes;
        let prim_order = &tri_tree.prim_order;
        let triangle_store = match options.triangle {
            TriangleMode::MollerTrumbore => TriangleStore::Blocks(pack::pack(
                &mut triangles,
                4,
                TriangleBlock4::EMPTY,
                |first, count, blocks| {
                    let slots = &prim_order[first as usize..(first + count) as usize];
                    for (block, lanes) in blocks.iter_mut().zip(slots.chunks(4)) {
                        for (lane, &prim) in lanes.iter().enumerate() {
                            let [v0, v1, v2] = mesh.corners(prim as usize);
                            block.set_lane(
                                lane,
                                &triangle::MollerTrumbore::prepare(v0, v1, v2),
                                prim,
                            );
                        }
                    }
                },
            )),
            TriangleMode::Watertight => TriangleStore::Corners(pack::pack(
                &mut triangles,
                1,
                ([Vec3::ZERO; 3], 0),
                |first, count, out| {
                    for (item, slot) in out.iter_mut().zip(first..first + count) {
                        let prim = prim_order[slot as usize];
                        let [a, b, c] = mesh.corners(prim as usize);
                        *item = (Watertight::prepare(a, b, c), prim);
                    }
                },
            )),
        };
        let mut spheres = sphere_tree.nodes;
        let empty = SphereItem {
            center: Vec3::ZERO,
            radius: 0.0,
            prim: u32::MAX,
        };
        let sphere_items = pack::pack(&mut spheres, 1, empty, |first, count, out| {
            for (item, slot) in out.iter_mut().zip(first..first + count) {
                let i = sphere_tree.prim_order[slot as usize];
                let s = &scene.spheres[i as usize];
                *item = SphereItem {
                    center: s.center,
                    radius: s.radius,
                    prim: mesh.len() as u32 + i,
                };
            }
        });
        let (t, s) = (tri_tree.shape, sphere_tree.shape);
        Ok(NativeBvh {
            options: *options,
            leaf_cap: options.leaf_cap(mesh.len()),
            cpu: if options.simd { Avx2::detect() } else { None },
            packets: PacketKernels::detect(options),
            box_test: match options.triangle {
                TriangleMode::MollerTrumbore => BoxTest::Fast,
                TriangleMode::Watertight => BoxTest::Robust,
            },
            triangles: checked(triangles)?,
            triangle_store,
            spheres: checked(spheres)?,
            sphere_items,
            build_ms: start.elapsed().as_secs_f64() * 1e3,
            shape: TreeShape {
                nodes: t.nodes + s.nodes,
                leaves: t.leaves + s.leaves,
                depth: t.depth.max(s.depth),
                binary_depth: t.binary_depth.max(s.binary_depth),
                sah_cost: if mesh.is_empty() {
                    s.sah_cost
                } else {
                    t.sah_cost
                },
            },
        })
    }

    /// Whether the AVX2 kernels run (else the scalar ones).
    pub fn simd(&self) -> bool {
        self.cpu.is_some()
    }

    /// The triangle tree's nodes, for inspection (tests, statistics).
    pub fn triangle_nodes(&self) -> &[Node8] {
        self.triangles.nodes()
    }

    /// Primitive ids of the triangles of leaf `r` (a leaf reference of
    /// [`NativeBvh::triangle_nodes`]).
    pub fn leaf_triangles(&self, r: node::ChildRef) -> Vec<u32> {
        let (first, count) = (node::leaf_first(r) as usize, node::leaf_count(r) as usize);
        match &self.triangle_store {
            TriangleStore::Blocks(blocks) => blocks[first..first + count]
                .iter()
                .flat_map(|b| (0..4).map(|lane| b.prim(lane)))
                .filter(|&p| p != u32::MAX)
                .collect(),
            TriangleStore::Corners(c) => c[first..first + count].iter().map(|t| t.1).collect(),
        }
    }

    pub fn shape(&self) -> TreeShape {
        self.shape
    }

    /// The closest hit of a traceable `ray`, whose coordinates are
    /// `vectors` ([`Ray::traceable_vectors`], read once by the caller). Watertight
    /// triangles and spheres are tested out of line, so that the common
    /// case, Möller–Trumbore blocks alone, stays small.
    fn closest(
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
    fn closest_box(
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
    fn closest_watertight(
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
    fn closest_sphere(
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
    fn walk_closest<L: Leaves>(
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
    fn walk_any<L: Leaves>(
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
    fn any(&self, ray: &Ray, vectors: (Vec3A, Vec3A), counters: &mut TraceCounters) -> bool {
        let box_ray = BoxRay::new(vectors.0, vectors.1, ray.t_min);
        self.any_box(ray, &box_ray, counters)
    }

    /// [`Self::any`] of a ray already prepared for the box tests.
    #[inline(always)]
    fn any_box(&self, ray: &Ray, box_ray: &BoxRay, counters: &mut TraceCounters) -> bool {
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
    fn any_watertight(
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
    fn any_sphere(&self, ray: &Ray, box_ray: &BoxRay, work: &mut Work) -> bool {
        let mut leaves = SphereLeaves {
            items: &self.sphere_items,
            ray,
            best: None,
        };
        self.walk_any(&self.spheres, box_ray, ray.t_max, &mut leaves, work)
    }
}

/// A traceable ray prepared for the box tests, as [`NativeBvh::closest`]
/// prepares it.
fn box_ray_of(ray: &Ray) -> BoxRay {
    BoxRay::new(Vec3A::from(ray.origin), Vec3A::from(ray.dir), ray.t_min)
}

/// The lanes set in `mask`, lowest first.
fn lanes_of(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let i = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            i
        })
    })
}

/// Which packet kernels a tree's batch queries run.
#[derive(Clone, Copy, Debug)]
enum PacketKernels {
    /// Sixteen rays in AVX-512 lanes.
    #[cfg(target_arch = "x86_64")]
    Avx512(Avx512),
    /// Eight rays in AVX2 lanes.
    #[cfg(target_arch = "x86_64")]
    Avx2(Avx2),
    /// None: every ray alone.
    None,
}

impl PacketKernels {
    /// The widest kernels the CPU runs, unless `options` turn SIMD off.
    fn detect(options: &NativeOptions) -> PacketKernels {
        if !options.simd {
            return PacketKernels::None;
        }
        #[cfg(target_arch = "x86_64")]
        {
            if let Some(wide) = Avx512::detect().filter(|_| options.packet_lanes != 8) {
                return PacketKernels::Avx512(wide);
            }
            if let Some(cpu) = Avx2::detect() {
                return PacketKernels::Avx2(cpu);
            }
        }
        PacketKernels::None
    }
}

/// One batch query's per-ray work, for the generic group code: the
/// closest hit or occlusion.
#[cfg(target_arch = "x86_64")]
trait Query {
    type Answer: Copy;
    const MISS: Self::Answer;
    fn alone(bvh: &NativeBvh, ray: &Ray, counters: &mut TraceCounters) -> Self::Answer;
    /// Whether the rays of a batch that no packet takes are walked
    /// together ([`Query::rest`]) rather than one at a time.
    const STREAMS: bool;
    /// The rays of a batch that no packet takes (`which`: indices into
    /// `rays`, at most [`traverse::STREAM`]), when [`Query::STREAMS`]; by
    /// default one at a time.
    fn rest(
        bvh: &NativeBvh,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        which: &[u32],
        out: &mut [Self::Answer],
        counters: &mut TraceCounters,
    ) {
        let _ = blocks;
        for &i in which {
            out[i as usize] = Self::alone(bvh, &rays[i as usize], counters);
        }
    }
    /// # Safety
    /// From `W`'s `#[target_feature]` code, with a non-empty tree.
    unsafe fn packet<W: Width>(
        bvh: &NativeBvh,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        p: &Packet<W>,
        out: &mut [Self::Answer],
        work: &mut Work,
    );
}

#[cfg(target_arch = "x86_64")]
struct Closest;

#[cfg(target_arch = "x86_64")]
struct Occluded;

#[cfg(target_arch = "x86_64")]
impl Query for Closest {
    type Answer = Option<Hit>;
    const MISS: Option<Hit> = None;
    // Closest hits keep single rays' front-to-back order; a stream that
    // shares nodes loses it (not measured yet).
    const STREAMS: bool = false;
    fn alone(bvh: &NativeBvh, ray: &Ray, counters: &mut TraceCounters) -> Option<Hit> {
        let vectors = ray.traceable_vectors()?;
        bvh.closest(ray, vectors, counters)
    }

    /// Triangles together, then spheres (if any) ray by ray within each
    /// ray's triangle hit, as [`NativeBvh::closest`] does.
    #[inline(always)]
    unsafe fn packet<W: Width>(
        bvh: &NativeBvh,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        p: &Packet<W>,
        out: &mut [Option<Hit>],
        work: &mut Work,
    ) {
        let mut t_max = p.rays.t_max();
        let (tree, test, cpu) = (&bvh.triangles, bvh.box_test, bvh.cpu);
        // Ray `i` alone from `start`, its hit kept in the packet's leaves.
        let mut alone =
            |leaves: &mut BlockPacket<W>, i: usize, start, t: &mut f32, work: &mut Work| {
                // The lane's hit so far goes along: a tie at `t` is
                // decided by its slot.
                let mut one = BlockLeaves {
                    blocks,
                    ray: &rays[i],
                    best: leaves.get(i),
                };
                let box_ray = box_ray_of(&rays[i]);
                let hit = traverse::closest(tree, &box_ray, t, &mut one, cpu, test, work, start);
                leaves.set(i, one.best);
                hit
            };
        let mut leaves = BlockPacket::new(blocks, p.rays);
        // The rays that miss the root box meet no triangle, as alone.
        let rooted = Packet {
            rays: p.rays,
            mask: p.mask & p.rays.enters(tree.bounds(), W::load(&t_max)),
        };
        let (t, l) = (&mut t_max, &mut leaves);
        let found = if rooted.mask == 0 {
            0
        } else if test == BoxTest::Fast && rooted.fast_test_fits() {
            packet::closest::<W, false, _>(tree, &rooted, t, l, &mut alone, work, SINGLE_BELOW)
        } else {
            packet::closest::<W, true, _>(tree, &rooted, t, l, &mut alone, work, SINGLE_BELOW)
        };
        // Without spheres a miss is one store, and no lane's branch depends
        // on whether it hit.
        let all = if bvh.sphere_items.is_empty() {
            for i in lanes_of(p.mask & !found) {
                out[i] = None;
            }
            found
        } else {
            p.mask
        };
        for i in lanes_of(all) {
            let mut hit = leaves.hit(i).map(|(prim, u, v)| Hit {
                t: t_max[i],
                prim,
                u,
                v,
            });
            if !bvh.sphere_items.is_empty() {
                let box_ray = box_ray_of(&rays[i]);
                hit = bvh
                    .closest_sphere(&rays[i], &box_ray, &mut t_max[i], work)
                    .or(hit);
            }
            out[i] = hit;
        }
    }
}

#[cfg(target_arch = "x86_64")]
impl Query for Occluded {
    type Answer = bool;
    const MISS: bool = false;
    const STREAMS: bool = true;
    fn alone(bvh: &NativeBvh, ray: &Ray, counters: &mut TraceCounters) -> bool {
        ray.traceable_vectors()
            .is_some_and(|v| bvh.any(ray, v, counters))
    }

    /// As one stream ([`traverse::any_stream`]): incoherent occlusion rays
    /// share the nodes they enter (CBbunny's random shadow rays 1.3-1.4x
    /// single rays, AVX2; docs/experiments.md, stop 43).
    fn rest(
        bvh: &NativeBvh,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        which: &[u32],
        out: &mut [bool],
        counters: &mut TraceCounters,
    ) {
        let Some(cpu) = bvh.cpu else {
            for &i in which {
                out[i as usize] = Self::alone(bvh, &rays[i as usize], counters);
            }
            return;
        };
        let mut work = Work::default();
        let unused = BoxRay::new(Vec3A::ZERO, Vec3A::X, 0.0);
        let mut box_rays = [unused; traverse::STREAM];
        let mut t_max = [0.0f32; traverse::STREAM];
        let mut active = 0u64;
        for (k, &i) in which.iter().enumerate() {
            let ray = &rays[i as usize];
            if let Some((o, d)) = ray.traceable_vectors() {
                active |= 1 << k;
                box_rays[k] = BoxRay::new(o, d, ray.t_min);
            }
            t_max[k] = ray.t_max;
        }
        let n = which.len();
        let mut leaves = |k: usize| BlockLeaves {
            blocks,
            ray: &rays[which[k] as usize],
            best: None,
        };
        let (tree, test) = (&bvh.triangles, bvh.box_test);
        let blocked = traverse::any_stream(
            tree,
            &box_rays[..n],
            &t_max[..n],
            active,
            &mut leaves,
            cpu,
            test,
            &mut work,
        );
        for (k, &i) in which.iter().enumerate() {
            let ray = &rays[i as usize];
            out[i as usize] = blocked >> k & 1 != 0
                || (active >> k & 1 != 0
                    && !bvh.sphere_items.is_empty()
                    && bvh.any_sphere(ray, &box_rays[k], &mut work));
        }
        counters.box_tests += work.nodes * node::WIDTH as u64;
        counters.prim_tests += work.items;
    }

    /// Triangles together, then spheres ray by ray for those not blocked,
    /// as [`NativeBvh::any`] does.
    #[inline(always)]
    unsafe fn packet<W: Width>(
        bvh: &NativeBvh,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        p: &Packet<W>,
        out: &mut [bool],
        work: &mut Work,
    ) {
        let t_max = p.rays.t_max();
        let (tree, test, cpu) = (&bvh.triangles, bvh.box_test, bvh.cpu);
        let mut alone = |_: &mut BlockPacket<W>, i: usize, start, t: f32, work: &mut Work| {
            let mut one = BlockLeaves {
                blocks,
                ray: &rays[i],
                best: None,
            };
            let box_ray = box_ray_of(&rays[i]);
            traverse::any(tree, &box_ray, t, &mut one, cpu, test, work, start)
        };
        let mut leaves = BlockPacket::new(blocks, p.rays);
        // The rays that miss the root box meet no triangle, as alone.
        let rooted = Packet {
            rays: p.rays,
            mask: p.mask & p.rays.enters(tree.bounds(), W::load(&t_max)),
        };
        let l = &mut leaves;
        let blocked = if rooted.mask == 0 {
            0
        } else if test == BoxTest::Fast && rooted.fast_test_fits() {
            packet::any::<W, false, _>(tree, &rooted, &t_max, l, &mut alone, work, SINGLE_BELOW)
        } else {
            packet::any::<W, true, _>(tree, &rooted, &t_max, l, &mut alone, work, SINGLE_BELOW)
        };
        for i in lanes_of(p.mask) {
            out[i] = blocked & (1 << i) != 0
                || (!bvh.sphere_items.is_empty()
                    && bvh.any_sphere(&rays[i], &box_ray_of(&rays[i]), work));
        }
    }
}

impl NativeBvh {
    /// A group of up to `W::N` rays of a batch query: the traceable ones
    /// of one octant as a packet when there are [`min_packet`] of them,
    /// the others one at a time.
    ///
    /// # Safety
    /// From `W`'s `#[target_feature]` code; the triangle tree is not
    /// empty.
    #[cfg(target_arch = "x86_64")]
    #[inline(always)]
    unsafe fn group<W: Width, Q: Query>(
        &self,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        out: &mut [Q::Answer],
        counters: &mut TraceCounters,
    ) {
        let prepared = PacketRays::<W>::load(rays);
        let mut rest = prepared.traceable;
        let lanes = (1u32 << out.len()) - 1;
        for i in lanes_of(lanes & !rest) {
            out[i] = Q::MISS;
        }
        let mut work = Work::default();
        while rest != 0 {
            let group = prepared.same_octant(rest);
            rest &= !group;
            if group.count_ones() >= min_packet(W::N) {
                let p = Packet {
                    rays: &prepared,
                    mask: group,
                };
                Q::packet::<W>(self, blocks, rays, &p, out, &mut work);
            } else {
                for i in lanes_of(group) {
                    out[i] = Q::alone(self, &rays[i], counters);
                }
            }
        }
        counters.box_tests += work.nodes * node::WIDTH as u64;
        counters.prim_tests += work.items;
    }

    /// [`Self::group`] with eight rays in AVX2 lanes.
    ///
    /// # Safety
    /// The CPU has AVX2 (the caller holds the token); the triangle tree is
    /// not empty.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    unsafe fn group8<Q: Query>(
        &self,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        out: &mut [Q::Answer],
        counters: &mut TraceCounters,
    ) {
        self.group::<X8, Q>(blocks, rays, out, counters)
    }

    /// [`Self::group`] with sixteen rays in AVX-512 lanes.
    ///
    /// # Safety
    /// The CPU has AVX-512F and AVX2 (the caller holds the token); the
    /// triangle tree is not empty.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    unsafe fn group16<Q: Query>(
        &self,
        blocks: &[TriangleBlock4],
        rays: &[Ray],
        out: &mut [Q::Answer],
        counters: &mut TraceCounters,
    ) {
        self.group::<X16, Q>(blocks, rays, out, counters)
    }

    /// A batch query through the packet kernels this tree may run; `None`
    /// when it may not (no AVX2, watertight triangles, no triangles).
    #[cfg(target_arch = "x86_64")]
    fn batch<Q: Query>(
        &self,
        rays: &[Ray],
        out: &mut [Q::Answer],
        counters: &mut TraceCounters,
    ) -> Option<()> {
        let TriangleStore::Blocks(blocks) = &self.triangle_store else {
            return None;
        };
        if self.triangles.is_empty() {
            return None;
        }
        type Group<Q> = unsafe fn(
            &NativeBvh,
            &[TriangleBlock4],
            &[Ray],
            &mut [<Q as Query>::Answer],
            &mut TraceCounters,
        );
        let (group, lanes): (Group<Q>, usize) = match self.packets {
            PacketKernels::Avx512(_) => (Self::group16::<Q>, 16),
            PacketKernels::Avx2(_) => (Self::group8::<Q>, 8),
            PacketKernels::None => return None,
        };
        // Rays of groups that form no packet, traced together once there
        // are a stream's worth.
        let mut pending = [0u32; traverse::STREAM];
        let mut waiting = 0;
        for start in (0..rays.len()).step_by(lanes) {
            let end = rays.len().min(start + lanes);
            let group_rays = &rays[start..end];
            counters.rays += group_rays.len() as u64;
            // The rays of the group after next, half a cache line each:
            // their first loads otherwise wait for memory.
            let ahead = rays.as_ptr().wrapping_add(start + PREFETCH_GROUPS * lanes);
            for line in 0..lanes / 2 {
                let line = ahead.cast::<i8>().wrapping_add(64 * line);
                // SAFETY: SSE is in every x86_64 CPU, and a prefetch never
                // faults, whatever the address.
                unsafe {
                    std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(line)
                };
            }
            let packs = packet::packet_can_form(group_rays, min_packet(lanes));
            if !packs && !Q::STREAMS {
                // No packet can form: the rays go alone, as single-ray
                // queries do, outside the lanes' code (traced from inside
                // it, incoherent batches ran at 0.93x single rays).
                for (ray, answer) in group_rays.iter().zip(&mut out[start..end]) {
                    *answer = Q::alone(self, ray, counters);
                }
                continue;
            }
            if !packs {
                // Or they wait for a stream's worth, traced together.
                for i in start..end {
                    pending[waiting] = i as u32;
                    waiting += 1;
                    if waiting == traverse::STREAM {
                        Q::rest(self, blocks, rays, &pending, out, counters);
                        waiting = 0;
                    }
                }
                continue;
            }
            // SAFETY: the kernels were chosen by the token that proves
            // their CPU features; the triangle tree is not empty (checked
            // above).
            unsafe { group(self, blocks, group_rays, &mut out[start..end], counters) };
        }
        if waiting > 0 {
            Q::rest(self, blocks, rays, &pending[..waiting], out, counters);
        }
        Some(())
    }
}

impl Accel for NativeBvh {
    fn closest_hit(&self, ray: &Ray, counters: &mut TraceCounters) -> Option<Hit> {
        counters.rays += 1;
        let vectors = ray.traceable_vectors()?;
        self.closest(ray, vectors, counters)
    }

    fn occluded(&self, ray: &Ray, counters: &mut TraceCounters) -> bool {
        counters.rays += 1;
        let Some(vectors) = ray.traceable_vectors() else {
            return false;
        };
        self.any(ray, vectors, counters)
    }

    /// Packets of sixteen rays (AVX-512) or eight (AVX2); one at a time
    /// without them.
    fn closest_hits(&self, rays: &[Ray], out: &mut [Option<Hit>], counters: &mut TraceCounters) {
        debug_assert_eq!(rays.len(), out.len());
        #[cfg(target_arch = "x86_64")]
        if self.batch::<Closest>(rays, out, counters).is_some() {
            return;
        }
        for (ray, answer) in rays.iter().zip(out.iter_mut()) {
            *answer = self.closest_hit(ray, counters);
        }
    }

    /// As [`Self::closest_hits`].
    fn occluded_all(&self, rays: &[Ray], out: &mut [bool], counters: &mut TraceCounters) {
        debug_assert_eq!(rays.len(), out.len());
        #[cfg(target_arch = "x86_64")]
        if self.batch::<Occluded>(rays, out, counters).is_some() {
            return;
        }
        for (ray, answer) in rays.iter().zip(out.iter_mut()) {
            *answer = self.occluded(ray, counters);
        }
    }

    fn stats(&self) -> AccelStats {
        let store = match &self.triangle_store {
            TriangleStore::Blocks(b) => std::mem::size_of_val(b.as_slice()),
            TriangleStore::Corners(c) => std::mem::size_of_val(c.as_slice()),
        };
        AccelStats {
            backend: "native".into(),
            primitives: self.sphere_items.len()
                + match &self.triangle_store {
                    TriangleStore::Blocks(b) => b
                        .iter()
                        .map(|b| (0..4).filter(|&l| b.prim(l) != u32::MAX).count())
                        .sum(),
                    TriangleStore::Corners(c) => c.len(),
                },
            build_ms: self.build_ms,
            memory_bytes: std::mem::size_of_val(self.triangles.nodes())
                + std::mem::size_of_val(self.spheres.nodes())
                + store
                + std::mem::size_of_val(self.sphere_items.as_slice()),
            tree: Some(TreeFacts {
                nodes: self.shape.nodes,
                leaves: self.shape.leaves,
                depth: self.shape.depth,
                sah_cost: self.shape.sah_cost,
            }),
            batch_call: match self.packets {
                #[cfg(target_arch = "x86_64")]
                PacketKernels::Avx512(_) => {
                    "packets of 16 rays (AVX-512) where 12 share an octant; other closest hits alone, other occlusion rays in streams of 64"
                }
                #[cfg(target_arch = "x86_64")]
                PacketKernels::Avx2(_) => {
                    "packets of 8 rays (AVX2) where 6 share an octant; other closest hits alone, other occlusion rays in streams of 64"
                }
                PacketKernels::None => "single-ray loop (no AVX2)",
            },
            details: format!(
                "{} triangles, {} build, max leaf {}, 8-wide {} traversal",
                self.options.triangle.name(),
                self.options.method.name(),
                self.leaf_cap,
                if self.simd() { "AVX2" } else { "scalar" }
            ),
        }
    }
}

#[cfg(all(test, target_arch = "x86_64"))]
mod tests {
    use super::*;
    use crate::parity::rays::{occlusion_rays, shadow_rays};
    use crate::scene::builtin::CORNELL;
    use crate::scene::NormalMode;

    /// Occlusion streams answer as single rays do, ray for ray: full
    /// streams of random rays, short ones (walked alone from the root), the
    /// renderer's light rays, and rays that cannot be traced at all.
    #[test]
    fn occlusion_streams_answer_as_single_rays() {
        if Avx2::detect().is_none() {
            return;
        }
        let scene = CORNELL
            .load(NormalMode::Smooth)
            .expect("the default scene loads");
        let bvh = NativeBvh::build(&scene, &NativeOptions::DEFAULT).expect("native builds");
        let TriangleStore::Blocks(blocks) = &bvh.triangle_store else {
            panic!("the default options store triangle blocks");
        };
        let mut rays = occlusion_rays(&scene, 3_000, 7);
        rays.extend(shadow_rays(&scene, &bvh, 3_000, 8));
        rays[5].dir = Vec3::ZERO;
        rays[70].origin.y = f32::NAN;
        let mut alone = TraceCounters::default();
        let single: Vec<bool> = rays.iter().map(|r| bvh.occluded(r, &mut alone)).collect();
        assert!(single.iter().any(|&b| b) && single.iter().any(|&b| !b));
        for size in [traverse::STREAM, 37, 3] {
            let mut out = vec![false; rays.len()];
            let mut streams = TraceCounters::default();
            for start in (0..rays.len()).step_by(size) {
                let which: Vec<u32> = (start..rays.len().min(start + size))
                    .map(|i| i as u32)
                    .collect();
                Occluded::rest(&bvh, blocks, &rays, &which, &mut out, &mut streams);
            }
            assert_eq!(out, single, "streams of {size} rays");
            // Each ray meets the nodes and leaves of its single-ray walk,
            // in the same order, up to the same leaf: the same counts.
            assert_eq!(
                (streams.box_tests, streams.prim_tests),
                (alone.box_tests, alone.prim_tests),
                "streams of {size} rays: node and leaf tests"
            );
        }
    }
}
