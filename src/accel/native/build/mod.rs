//! The builder of the 8-wide tree: binned SAH (Wald 2007, "On fast
//! construction of SAH-based bounding volume hierarchies") over primitive
//! boxes, forming wide nodes directly the way Embree's wide builders do:
//! a node starts with one child holding all its primitives and keeps
//! splitting the child with the largest surface area until it has eight
//! or none can be split. Every split is a binary SAH split, so the tree is
//! the binary SAH tree with its levels grouped; its SAH cost is reported
//! as the binary tree's.
//!
//! References are partitioned in place in one array; subtrees above
//! [`PARALLEL_THRESHOLD`] primitives are built in parallel (rayon), each
//! into its own node list that the parent appends and relocates.

use glam::{Vec3A, Vec4};
use rayon::prelude::*;

use super::node::{is_leaf, leaf, ChildRef, Node8, EMPTY, WIDTH};
use crate::geom::Bounds;

/// How splits are chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BuildMethod {
    /// Binned SAH over all three axes.
    #[default]
    Sah,
    /// Object median on the widest centroid axis: the baseline the SAH is
    /// measured against.
    Median,
}

crate::choice!(BuildMethod { Sah => "sah", Median => "median" });

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
    binary_depth: usize,
}

impl Record {
    fn len(&self) -> usize {
        self.end - self.start
    }
}

/// Tree statistics summed over subtrees.
#[derive(Clone, Copy, Default)]
struct Stats {
    nodes: usize,
    leaves: usize,
    depth: usize,
    binary_depth: usize,
    /// Unnormalized SAH cost (half areas).
    sah: f64,
}

impl Stats {
    fn add_child(&mut self, o: &Stats) {
        self.nodes += o.nodes;
        self.leaves += o.leaves;
        self.depth = self.depth.max(o.depth);
        self.binary_depth = self.binary_depth.max(o.binary_depth);
        self.sah += o.sah;
    }
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
        binary_depth: 0,
    };
    root.split = find_split(&refs, &root, &settings);
    let mut nodes = super::memory::reserve(refs.len() / 4 + 1);
    let (r, stats) = if root.split.is_some() {
        subtree(&mut refs, 0, root, 1, &settings, &mut nodes)
    } else {
        // A single leaf still gets a root node, so traversal always starts
        // at node 0.
        let (r, mut stats) = make_leaf(&root);
        nodes.push(Node8::new(&[(r, geom.bounds())]));
        stats.nodes = 1;
        stats.depth = 1;
        (0, stats)
    };
    debug_assert_eq!(r, 0, "the root is node 0");
    let root_area = geom.half_area() as f64;
    BuiltTree {
        nodes,
        prim_order: refs.iter().map(PrimRef::index).collect(),
        shape: TreeShape {
            nodes: stats.nodes,
            leaves: stats.leaves,
            depth: stats.depth,
            binary_depth: stats.binary_depth,
            sah_cost: if root_area > 0.0 {
                stats.sah / root_area
            } else {
                0.0
            },
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

fn make_leaf(rec: &Record) -> (ChildRef, Stats) {
    let n = rec.len();
    let stats = Stats {
        leaves: 1,
        binary_depth: rec.binary_depth,
        sah: rec.geom.half_area() as f64 * leaf_cost(n) as f64,
        ..Stats::default()
    };
    // Slots of `prim_order`; `NativeBvh` later points leaves at their data.
    (leaf(rec.start as u32, n as u32), stats)
}

/// Builds the wide node for `rec` (which has a split) and everything
/// below it, appending nodes to `out`; `refs` is the whole array.
fn subtree(
    refs: &mut [PrimRef],
    base: usize,
    rec: Record,
    depth: usize,
    settings: &Settings,
    out: &mut Vec<Node8>,
) -> (ChildRef, Stats) {
    // refs[..] covers rec's range offset by `base`.
    let local = |r: &Record| (r.start - base)..(r.end - base);
    let mut stats = Stats {
        nodes: 1,
        depth,
        ..Stats::default()
    };
    let (children, count) = if rec.len() >= HALVES_ABOVE {
        // Too large to split serially: one split, then each side forms
        // half the node on its own (concurrently). A fixed size rule, so
        // the tree does not depend on the thread count; the binary splits
        // are the same as largest-first would make, only grouped
        // differently at these top levels.
        stats.sah += rec.geom.half_area() as f64 * TRAVERSAL_COST as f64;
        let (mut l, mut r) = apply_split(&mut refs[local(&rec)], &rec);
        let (left, right) = refs.split_at_mut(l.end - base);
        (l.split, r.split) = rayon::join(
            || find_split(left, &l, settings),
            || find_split(right, &r, settings),
        );
        let ((lc, ln, ls), (rc, rn, rs)) = rayon::join(
            || form(left, l.start, l, WIDTH / 2, settings),
            || form(right, r.start, r, WIDTH / 2, settings),
        );
        stats.sah += ls + rs;
        let mut children = lc;
        children[ln..ln + rn].copy_from_slice(&rc[..rn]);
        (children, ln + rn)
    } else {
        let (children, count, sah) = form(refs, base, rec, WIDTH, settings);
        stats.sah += sah;
        (children, count)
    };
    let children = &children[..count];
    let me = out.len();
    out.push(Node8::UNUSED);
    let mut slots = [(EMPTY, Bounds::EMPTY); WIDTH];
    if rec.len() >= PARALLEL_THRESHOLD && rayon::current_num_threads() > 1 {
        // Disjoint slices of the references, one per child, in order.
        let mut parts = Vec::with_capacity(children.len());
        let mut rest = &mut refs[..];
        let mut offset = base;
        for c in children {
            let (head, tail) = rest.split_at_mut(c.end - offset);
            parts.push((head, offset, *c));
            rest = tail;
            offset = c.end;
        }
        let built: Vec<(ChildRef, Stats, Vec<Node8>)> = parts
            .into_par_iter()
            .map(|(part, part_base, c)| {
                let mut nodes = Vec::new();
                let (r, s) = child(part, part_base, c, depth + 1, settings, &mut nodes);
                (r, s, nodes)
            })
            .collect();
        for (slot, ((r, s, nodes), c)) in built.into_iter().zip(children).enumerate() {
            let offset = out.len() as u32;
            let relocate = |r: ChildRef| {
                if r == EMPTY || is_leaf(r) {
                    r
                } else {
                    r + offset
                }
            };
            out.extend(nodes.into_iter().map(|mut n| {
                n.child = n.child.map(relocate);
                n
            }));
            slots[slot] = (relocate(r), c.geom.bounds());
            stats.add_child(&s);
        }
    } else {
        for (slot, c) in children.iter().enumerate() {
            let (r, s) = child(&mut refs[local(c)], c.start, *c, depth + 1, settings, out);
            slots[slot] = (r, c.geom.bounds());
            stats.add_child(&s);
        }
    }
    out[me] = Node8::new(&slots[..count]);
    (me as ChildRef, stats)
}

/// Ranges at least this large form their node in two concurrent halves.
const HALVES_ABOVE: usize = 65_536;

/// Splits `rec` (its references are `refs`, which start at `base`) into
/// at most `max` children, always splitting the child with the largest
/// surface area next (Embree's rule for wide nodes). Returns the children
/// in the order of their ranges, their count, and the SAH cost of the
/// binary splits made (unnormalized).
fn form(
    refs: &mut [PrimRef],
    base: usize,
    rec: Record,
    max: usize,
    settings: &Settings,
) -> ([Record; WIDTH], usize, f64) {
    let local = |r: &Record| (r.start - base)..(r.end - base);
    let mut sah = 0.0;
    let mut children = [rec; WIDTH];
    let mut count = 1;
    while count < max {
        let Some(i) = (0..count)
            .filter(|&i| children[i].split.is_some())
            .max_by(|&a, &b| {
                children[a]
                    .geom
                    .half_area()
                    .total_cmp(&children[b].geom.half_area())
            })
        else {
            break;
        };
        let c = children[i];
        sah += c.geom.half_area() as f64 * TRAVERSAL_COST as f64;
        let (mut l, mut r) = apply_split(&mut refs[local(&c)], &c);
        let (left, right) = (&refs[local(&l)], &refs[local(&r)]);
        (l.split, r.split) = if c.len() >= PARALLEL_BINNING && rayon::current_num_threads() > 1 {
            rayon::join(
                || find_split(left, &l, settings),
                || find_split(right, &r, settings),
            )
        } else {
            (
                find_split(left, &l, settings),
                find_split(right, &r, settings),
            )
        };
        children.copy_within(i + 1..count, i + 2);
        children[i] = l;
        children[i + 1] = r;
        count += 1;
    }
    (children, count, sah)
}

/// A child of a node: a leaf, or the subtree under it.
fn child(
    refs: &mut [PrimRef],
    base: usize,
    rec: Record,
    depth: usize,
    settings: &Settings,
    out: &mut Vec<Node8>,
) -> (ChildRef, Stats) {
    match rec.split {
        None => make_leaf(&rec),
        Some(_) => subtree(refs, base, rec, depth, settings, out),
    }
}

mod split;

use self::split::{apply_split, find_split, PARALLEL_BINNING};

#[cfg(test)]
mod tests;
