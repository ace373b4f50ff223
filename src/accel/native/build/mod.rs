//! The builder of the 8-wide tree: binned SAH (Wald 2007, "On fast
//! construction of SAH-based bounding volume hierarchies") over primitive
//! boxes builds a binary tree top-down; moving subtrees to where they cost
//! least ([`reinsert`]) then repairs what the greedy top-down splits got
//! wrong, and the binary levels are grouped into wide nodes with the least
//! total area ([`group`]). The SAH cost is reported for both trees.
//!
//! References are partitioned in place in one array; subtrees above
//! [`PARALLEL_THRESHOLD`] primitives are built in parallel (rayon), each
//! into its own node list that the parent appends and relocates.

use glam::{Vec3A, Vec4};
use rayon::prelude::*;

use super::node::{leaf, ChildRef, Node8, EMPTY, WIDTH};
use crate::geom::Bounds;

/// How splits are chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BuildMethod {
    /// Binned SAH over all three axes, then subtrees moved to where they
    /// cost least and the levels grouped into wide nodes of least area.
    #[default]
    Sah,
    /// The binned SAH tree as the top-down splits leave it, grouped
    /// largest child first (the earlier builder): what the moves and
    /// the grouping are measured against.
    SahTopDown,
    /// Object median on the widest centroid axis: the baseline the SAH is
    /// measured against.
    Median,
}

crate::choice!(BuildMethod { Sah => "sah", SahTopDown => "sah-top-down", Median => "median" });

/// Cost of a binary inner node relative to one leaf block test, in the
/// SAH cost the tree reports (the classical binary measure).
pub const TRAVERSAL_COST: f32 = 1.0;
/// What the builder charges a binary split, relative to one leaf block
/// test. One 8-wide node test costs about one block test and stands for
/// the up to seven binary splits it collapses: weighted by area (the
/// chance a ray reaches each), they add up to about 3.6 times the area of
/// the node's own box with the halving children of a balanced tree, so a
/// split costs about a quarter of a node test. Charging a whole node test
/// per split (the binary SAH's cost) packed big triangles into one leaf to
/// save a split: the Cornell box's walls shared a leaf whose box is the
/// whole room, so almost every ray inside the room tested it. Measured
/// against 1 on one thread (docs/experiments.md): on CBbunny light rays
/// +38%, incoherent +17%, camera, shadow and bounce +7-9%; the isolated
/// meshes within noise. Large trees keep 1
/// (`NativeOptions::split_cost`).
pub const SPLIT_COST: f32 = 0.25;
/// Triangles tested together by one SIMD leaf test (see `triangle.rs`):
/// leaves cost one test per started block, so the builder fills leaves
/// rather than splitting them further unless the split's boxes are much
/// smaller.
pub const LEAF_BLOCK: usize = 4;
/// Bins per axis.
const BINS: usize = 16;
/// Below this many primitives a subtree is built on the calling thread.
const PARALLEL_THRESHOLD: usize = 1024;

/// Cost of a leaf of `n` primitives, in block tests.
pub fn leaf_cost(n: usize) -> f32 {
    n.div_ceil(LEAF_BLOCK) as f32
}

/// Shape of the built tree.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct TreeShape {
    /// Wide nodes and leaves.
    pub nodes: usize,
    pub leaves: usize,
    /// Levels of wide nodes (a tree of one node has depth 1).
    pub depth: usize,
    /// Deepest chain of binary splits.
    pub binary_depth: usize,
    /// SAH cost of the binary tree (MacDonald and Booth 1990): expected
    /// cost of a random ray through the root, [`TRAVERSAL_COST`] per inner
    /// node and [`leaf_cost`] per leaf.
    pub sah_cost: f64,
    /// The same of the wide tree: one node test (about one block test)
    /// per wide node and [`leaf_cost`] per leaf.
    pub wide_sah_cost: f64,
}

/// A built tree: nodes in depth-first order (root first), leaves pointing
/// at runs of `prim_order` (leaf slot -> primitive index).
pub struct BuiltTree {
    pub nodes: Vec<Node8>,
    pub prim_order: Vec<u32>,
    pub shape: TreeShape,
}

/// An axis-aligned box in SIMD registers.
#[derive(Clone, Copy, Debug)]
struct Aabb {
    lo: Vec3A,
    hi: Vec3A,
}

impl Aabb {
    const EMPTY: Aabb = Aabb {
        lo: Vec3A::splat(f32::INFINITY),
        hi: Vec3A::splat(f32::NEG_INFINITY),
    };

    #[inline(always)]
    fn grow(&mut self, o: &Aabb) {
        self.lo = self.lo.min(o.lo);
        self.hi = self.hi.max(o.hi);
    }

    #[inline(always)]
    fn grow_point(&mut self, p: Vec3A) {
        self.lo = self.lo.min(p);
        self.hi = self.hi.max(p);
    }

    /// Half the surface area (the SAH only uses ratios).
    #[inline(always)]
    fn half_area(&self) -> f32 {
        let d = (self.hi - self.lo).max(Vec3A::ZERO);
        d.x * d.y + d.y * d.z + d.z * d.x
    }

    /// Twice the centre: centroids are binned in this space.
    #[inline(always)]
    fn centroid2(&self) -> Vec3A {
        self.lo + self.hi
    }

    fn bounds(&self) -> Bounds {
        Bounds {
            min: self.lo.into(),
            max: self.hi.into(),
        }
    }
}

/// A primitive's box with its index carried in the fourth lanes, as exact
/// small integers (the low 24 bits in `lo.w`, the rest in `hi.w`): 32
/// bytes, so every pass over the references moves a third less memory (as
/// Embree's references do). The fourth lanes never hold denormals, so the
/// box arithmetic on them costs nothing, and only [`PrimRef::index`] reads
/// them.
#[derive(Clone, Copy)]
struct PrimRef {
    lo: Vec4,
    hi: Vec4,
}

impl PrimRef {
    fn new(b: &Bounds, index: u32) -> PrimRef {
        PrimRef {
            lo: b.min.extend((index & 0xFF_FFFF) as f32),
            hi: b.max.extend((index >> 24) as f32),
        }
    }

    #[inline(always)]
    fn aabb(&self) -> Aabb {
        Aabb {
            lo: Vec3A::from_vec4(self.lo),
            hi: Vec3A::from_vec4(self.hi),
        }
    }

    fn index(&self) -> u32 {
        self.lo.w as u32 | (self.hi.w as u32) << 24
    }
}

/// How a range is split.
#[derive(Clone, Copy, Debug)]
enum Split {
    /// Primitives whose bin on `axis` (as [`bin_of`] computes it with this
    /// `lo` and `scale`) is below `boundary` go left.
    Binned {
        axis: usize,
        boundary: usize,
        lo: f32,
        scale: f32,
        /// Geometry bounds of the two sides, from the bins.
        left: Aabb,
        right: Aabb,
    },
    /// Object median along `axis`.
    Median { axis: usize },
    /// A range of at most [`LEAF_BLOCK`] primitives: bit `i` of `left`
    /// set sends the range's `i`-th reference left.
    Subset { left: u8 },
    /// Centroids cannot be separated: the first half goes left.
    Half,
}

/// A range of references with its bounds and, unless it becomes a leaf,
/// the split it will take.
#[derive(Clone, Copy)]
struct Record {
    start: usize,
    end: usize,
    geom: Aabb,
    cent: Aabb,
    split: Option<Split>,
}

impl Record {
    fn len(&self) -> usize {
        self.end - self.start
    }
}

/// The wide tree's counts, gathered while it is formed.
#[derive(Clone, Copy, Default)]
struct Stats {
    nodes: usize,
    leaves: usize,
    depth: usize,
    binary_depth: usize,
    /// Unnormalized SAH cost of the wide tree (half areas).
    wide_sah: f64,
}

#[derive(Clone, Copy)]
struct Settings {
    max_leaf: usize,
    /// What a binary split costs, in leaf block tests.
    split_cost: f32,
    method: BuildMethod,
}

/// Builds the tree over `boxes`. Leaves hold at most `max_leaf`
/// primitives (1..=16) unless their centroids cannot be separated; a
/// split is charged `split_cost` block tests ([`SPLIT_COST`] or
/// [`TRAVERSAL_COST`]).
pub fn build(boxes: &[Bounds], max_leaf: usize, split_cost: f32, method: BuildMethod) -> BuiltTree {
    let optimized = method == BuildMethod::Sah;
    build_with(boxes, max_leaf, split_cost, method, optimized, optimized)
}

/// [`build`], the subtree moves and the grouping chosen apart (for tests).
fn build_with(
    boxes: &[Bounds],
    max_leaf: usize,
    split_cost: f32,
    method: BuildMethod,
    moves: bool,
    optimal_grouping: bool,
) -> BuiltTree {
    let settings = Settings {
        max_leaf: max_leaf.clamp(1, 16),
        split_cost: split_cost.clamp(0.0, TRAVERSAL_COST),
        method,
    };
    let mut refs: Vec<PrimRef> = super::memory::reserve(boxes.len());
    refs.extend(
        boxes
            .iter()
            .enumerate()
            .map(|(i, b)| PrimRef::new(b, i as u32)),
    );
    if refs.is_empty() {
        return BuiltTree {
            nodes: Vec::new(),
            prim_order: Vec::new(),
            shape: TreeShape::default(),
        };
    }
    let (geom, cent) = bounds_of(&refs);
    let mut root = Record {
        start: 0,
        end: refs.len(),
        geom,
        cent,
        split: None,
    };
    root.split = find_split(&refs, &root, &settings);
    let mut tree = BinaryTree::grow(&mut refs, root, &settings);
    if moves {
        reinsert::optimize(&mut tree);
    }
    let grouping = if optimal_grouping {
        Grouping::Optimal(Plan::new(&tree))
    } else {
        Grouping::LargestFirst
    };
    let mut nodes = super::memory::reserve(refs.len() / 4 + 1);
    let mut stats = Stats::default();
    let root = &tree.nodes[tree.root as usize];
    if root.is_leaf() {
        // A single leaf still gets a root node, so traversal always starts
        // at node 0.
        nodes.push(Node8::new(&[(
            leaf(root.kids[0], root.count),
            geom.bounds(),
        )]));
        stats = Stats {
            nodes: 1,
            leaves: 1,
            depth: 1,
            binary_depth: 0,
            wide_sah: geom.half_area() as f64 * (1.0 + leaf_cost(root.count as usize) as f64),
        };
    } else {
        grouping.collapse(&tree, tree.root, 1, 0, &mut nodes, &mut stats);
    }
    let root_area = geom.half_area() as f64;
    let per_root = |cost: f64| {
        if root_area > 0.0 {
            cost / root_area
        } else {
            0.0
        }
    };
    BuiltTree {
        nodes,
        prim_order: refs.iter().map(PrimRef::index).collect(),
        shape: TreeShape {
            nodes: stats.nodes,
            leaves: stats.leaves,
            depth: stats.depth,
            binary_depth: stats.binary_depth,
            sah_cost: per_root(tree.sah()),
            wide_sah_cost: per_root(stats.wide_sah),
        },
    }
}

fn bounds_of(refs: &[PrimRef]) -> (Aabb, Aabb) {
    let mut geom = Aabb::EMPTY;
    let mut cent = Aabb::EMPTY;
    for r in refs {
        let b = r.aabb();
        geom.grow(&b);
        cent.grow_point(b.centroid2());
    }
    (geom, cent)
}

fn centroid_bounds(refs: &[PrimRef]) -> Aabb {
    let mut cent = Aabb::EMPTY;
    for r in refs {
        cent.grow_point(r.aabb().centroid2());
    }
    cent
}

mod binary;
mod group;
mod reinsert;
mod split;

use self::binary::BinaryTree;
use self::group::{Grouping, Plan};
use self::split::find_split;

#[cfg(test)]
mod tests;
