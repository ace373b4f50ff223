//! The native backend: the project's own 8-wide BVH over the scene's
//! triangles and, in a second tree, its spheres.
//!
//! - [`build`]: binned SAH, building the 8-wide tree directly;
//! - [`node`]: the 256-byte node with per-octant child orders;
//! - [`tree`]: the node list the kernels may trust, checked once;
//! - `traverse`: the AVX2 and scalar kernels, private to the backend;
//! - [`triangle`], [`sphere`]: the primitive tests;
//! - the tokens that prove AVX2 or AVX-512 was detected are
//!   [`crate::simd::cpu`]'s.
//!
//! Leaf data are stored in the order the tree visits them (depth first),
//! precomputed for the chosen triangle test: Möller–Trumbore in 4-wide
//! blocks carrying their primitive ids, or the watertight test's corners.

mod batch;
pub mod build;
mod leaves;
mod memory;
pub mod node;
mod pack;
mod single;
pub mod sphere;
mod traverse;
pub mod tree;
pub mod triangle;

use std::time::Instant;

use glam::Vec3;
use rayon::prelude::*;

use self::batch::PacketKernels;
use self::build::{BuildMethod, BuiltTree, TreeShape};
use self::node::{Node8, MAX_LEAF_FIRST};
use self::traverse::BoxTest;
use self::tree::{Tree, MAX_DEPTH};
use self::triangle::{TriangleBlock4, TriangleMode, TriangleTest, Watertight};
use super::{Accel, AccelError, AccelStats, Coherence, TraceCounters, TreeFacts};
use crate::choice::Choice;
use crate::geom::{Bounds, Hit, Ray};
use crate::scene::Scene;
use crate::simd::cpu::Avx2;

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
    /// Rays per packet of the batch queries: 8 (AVX2 lanes even with
    /// AVX-512), or any other value for sixteen (AVX-512 lanes, or two
    /// AVX2 registers per value where the CPU has no AVX-512).
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
/// and light rays alike or faster (docs/experiments.md).
pub const fn min_packet(lanes: usize) -> u32 {
    (lanes as u32 * 3).div_ceil(4)
}

/// A group of an occlusion batch whose rays all run to infinity forms no
/// packet when their origins spread, across the rays, over more than the
/// tree's extent over this ([`batch::Plan`]). On maxplanck's directional
/// light (AVX2, Zen 4), the shadow rays of a 160x120 frame's camera hits
/// in wave order went 0.64x single rays as packets, 1.09x refused, and
/// the light rays of a 1150x870 frame's hits kept their packets (2.15x
/// single rays; 1/32 refused some of them: 1.96x); 1/8 measured as 1/16.
pub const SCATTERED_FRACTION: f32 = 16.0;

/// A batch query asks for the rays of the group this many groups ahead
/// before tracing each group (CBbunny camera packets 1.01x, maxplanck
/// 1.03x, 8 and 6 alternating pairs).
pub const PREFETCH_GROUPS: usize = 2;

/// A triangle tree of at most this many nodes (a root and one level below
/// it), in a scene without spheres, has a batch's rays of different
/// octants traced as one packet ([`traverse::packet::walk`]'s mixed
/// octants), as Embree's packets take any rays: every ray from points side
/// by side meets the same few nodes, and a packet tests them once for all
/// its rays. A deeper tree's incoherent rays part ways below the root,
/// where a packet still tests each node for all its lanes and streams win.
/// Exported waves, AVX2, packets against the streams they replace,
/// Mrays/s: CBempty (1 node) bounce 22.4 -> 35.2, shadow 43 -> 77;
/// CBbunny (1972 nodes) bounce 13.7 -> 10.9; maxplanck 7.9 -> 4.2;
/// sky/bunny 7.9 -> 4.2 and shadow 10.8 -> 8.7. With spheres the frames
/// lost, though the triangles' exported rays gained (CBspheres 29.3 ->
/// 31.9 and 81 -> 123): extension batches 0.44 -> 0.50 s on CBspheres,
/// 0.51 -> 0.63 s on the default scene (docs/experiments.md).
pub const MIXED_PACKET_NODES: usize = 1 + node::WIDTH;

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
    /// Batch queries trace a group's rays of different octants as one
    /// packet ([`MIXED_PACKET_NODES`]).
    mixed_packets: bool,
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
        let costed = if mesh.is_empty() { s } else { t };
        Ok(NativeBvh {
            options: *options,
            leaf_cap: options.leaf_cap(mesh.len()),
            cpu: if options.simd { Avx2::detect() } else { None },
            packets: PacketKernels::detect(options),
            box_test: match options.triangle {
                TriangleMode::MollerTrumbore => BoxTest::Fast,
                TriangleMode::Watertight => BoxTest::Robust,
            },
            mixed_packets: triangles.len() <= MIXED_PACKET_NODES && sphere_items.is_empty(),
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
                // The costs of the triangles' tree, or of the spheres'
                // where there are no triangles.
                sah_cost: costed.sah_cost,
                wide_sah_cost: costed.wide_sah_cost,
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
    /// without them. The packets find their own coherence (an octant's
    /// rays), so the hint is not needed.
    fn closest_hits(
        &self,
        rays: &[Ray],
        coherence: Coherence,
        out: &mut [Option<Hit>],
        counters: &mut TraceCounters,
    ) {
        debug_assert_eq!(rays.len(), out.len());
        // Incoherent rays that form no packet go as streams (a wave's
        // bounce rays 1.17-1.51x, random rays 0.94-1.23x single rays);
        // coherent ones alone (streams of the camera rays that form no
        // packet cost maxplanck's frame 0.8%; docs/experiments.md).
        #[cfg(target_arch = "x86_64")]
        let plan = batch::Plan {
            streams: coherence == Coherence::Incoherent,
            scattered: f32::INFINITY,
        };
        #[cfg(target_arch = "x86_64")]
        if self
            .batch::<batch::Closest>(rays, out, counters, plan)
            .is_some()
        {
            return;
        }
        for (ray, answer) in rays.iter().zip(out.iter_mut()) {
            *answer = self.closest_hit(ray, counters);
        }
    }

    /// As [`Self::closest_hits`], every group that forms no packet as
    /// streams; parallel rays to infinity from scattered points form none
    /// ([`SCATTERED_FRACTION`]).
    fn occluded_all(&self, rays: &[Ray], out: &mut [bool], counters: &mut TraceCounters) {
        debug_assert_eq!(rays.len(), out.len());
        #[cfg(target_arch = "x86_64")]
        let plan = batch::Plan {
            streams: true,
            scattered: {
                let [lo, hi] = self.triangles.bounds();
                (hi - lo).max_element() / SCATTERED_FRACTION
            },
        };
        #[cfg(target_arch = "x86_64")]
        if self
            .batch::<batch::Occluded>(rays, out, counters, plan)
            .is_some()
        {
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
                wide_sah_cost: self.shape.wide_sah_cost,
            }),
            batch_call: self.packets.describe(),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::brute::BruteForce;
    use crate::scene::builder::SceneBuilder;
    use crate::scene::generate::{icosphere, quad_ball};
    use crate::scene::{Material, NormalMode};
    use glam::Vec3;

    /// The scalar kernels (no SIMD, the twin every CPU runs) and the
    /// checked `Tree` they read, on a scene small enough for Miri
    /// (`cargo +nightly miri test --lib native::tests`): every ray's
    /// closest hit and occlusion agree with brute force.
    #[test]
    fn the_scalar_walks_agree_with_brute_force() {
        let mut b = SceneBuilder::new("two balls");
        let grey = b.material(Material::lambertian(Vec3::splat(0.5)));
        let (p, t) = icosphere(1);
        b.mesh(&p, &t, grey);
        let (p, t) = quad_ball(2);
        let moved: Vec<Vec3> = p
            .iter()
            .map(|&v| v * 0.5 + Vec3::new(1.6, 0.2, 0.0))
            .collect();
        b.mesh(&moved, &t, grey);
        b.camera(Vec3::new(0.5, 0.0, 5.0), Vec3::ZERO, 40.0, 40.0);
        let scene = b.finish(NormalMode::Smooth);
        let options = NativeOptions {
            simd: false,
            max_leaf: 2,
            ..NativeOptions::DEFAULT
        };
        let bvh = NativeBvh::build(&scene, &options).expect("builds");
        let brute = BruteForce::build(&scene);
        let mut counters = TraceCounters::default();
        let (mut hits, mut rays) = (0, 0);
        for i in 0..12 {
            for j in 0..12 {
                let target = Vec3::new(-1.5 + 0.3 * i as f32, -1.5 + 0.25 * j as f32, 0.0);
                let origin = Vec3::new(0.5, 0.3, 5.0);
                let ray = Ray::new(origin, (target - origin).normalize());
                let (native, reference) = (
                    bvh.closest_hit(&ray, &mut counters),
                    brute.closest_hit(&ray, &mut counters),
                );
                // Where a ray meets an edge, either triangle is its hit.
                assert_eq!(native.is_some(), reference.is_some(), "ray {i} {j}");
                if let (Some(n), Some(r)) = (native, reference) {
                    assert!(
                        (n.t - r.t).abs() <= 1e-5 * r.t,
                        "ray {i} {j}: t {} vs {}",
                        n.t,
                        r.t
                    );
                    hits += 1;
                }
                let shadow = Ray { t_max: 4.0, ..ray };
                assert_eq!(
                    bvh.occluded(&shadow, &mut counters),
                    brute.occluded(&shadow, &mut counters),
                    "shadow ray {i} {j}"
                );
                rays += 1;
            }
        }
        assert!(
            hits > rays / 4 && hits < rays,
            "{hits} of {rays} rays hit: the view misses the case"
        );
    }
}
