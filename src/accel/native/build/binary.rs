//! The binary SAH tree, materialized so that it can be optimized
//! ([`super::reinsert`]) before its levels are grouped into wide nodes.

use super::split::{apply_split, find_split, PARALLEL_BINNING};
use super::*;

/// No node (the root's parent).
pub(super) const NONE: u32 = u32::MAX;

/// A node of the binary tree: an inner node with two children, or a leaf
/// over a run of references.
#[derive(Clone, Copy)]
pub(super) struct BinaryNode {
    pub(super) bounds: Aabb,
    pub(super) parent: u32,
    /// Inner: the two children. Leaf: the first reference and unused.
    pub(super) kids: [u32; 2],
    /// Leaf: its references (at least one). Inner: 0.
    pub(super) count: u32,
}

impl BinaryNode {
    pub(super) fn is_leaf(&self) -> bool {
        self.count > 0
    }
}

/// Every node of one tree; nodes never leave it (an optimization moves
/// them), so each index stays a node of the tree.
pub(super) struct BinaryTree {
    pub(super) nodes: Vec<BinaryNode>,
    pub(super) root: u32,
}

impl BinaryTree {
    /// The tree over `refs` (which `root` covers; its split chosen),
    /// partitioning them in place: every leaf is a run of them.
    pub(super) fn grow(refs: &mut [PrimRef], root: Record, settings: &Settings) -> BinaryTree {
        // 2 l - 1 nodes for l leaves: one node per reference covers leaves
        // of two or more on average (the shared meshes' hold 3.6).
        let mut nodes = super::super::memory::reserve(refs.len());
        grow(refs, root, settings, &mut nodes);
        for i in 0..nodes.len() {
            if !nodes[i].is_leaf() {
                for k in nodes[i].kids {
                    nodes[k as usize].parent = i as u32;
                }
            }
        }
        BinaryTree { nodes, root: 0 }
    }

    pub(super) fn area(&self, n: u32) -> f32 {
        self.nodes[n as usize].bounds.half_area()
    }

    /// Unnormalized SAH cost: half areas times [`TRAVERSAL_COST`] per
    /// inner node and [`leaf_cost`] per leaf.
    pub(super) fn sah(&self) -> f64 {
        self.nodes
            .iter()
            .map(|n| {
                let cost = if n.is_leaf() {
                    leaf_cost(n.count as usize)
                } else {
                    TRAVERSAL_COST
                };
                n.bounds.half_area() as f64 * cost as f64
            })
            .sum()
    }
}

/// Appends the subtree of `rec` (its references are `refs`, exactly) in
/// depth-first order, `rec`'s node first. Ranges above
/// [`PARALLEL_THRESHOLD`] grow their two sides concurrently, each into a
/// list of its own appended in order, so the tree is the same on any
/// number of threads. Parents are left for the caller.
fn grow(refs: &mut [PrimRef], rec: Record, settings: &Settings, out: &mut Vec<BinaryNode>) {
    let me = out.len();
    out.push(BinaryNode {
        bounds: rec.geom,
        parent: NONE,
        kids: [rec.start as u32, 0],
        count: rec.len() as u32,
    });
    if rec.split.is_none() {
        return;
    }
    out[me].count = 0;
    let (mut l, mut r) = apply_split(refs, &rec);
    let (left, right) = refs.split_at_mut(l.len());
    let parallel = rayon::current_num_threads() > 1;
    (l.split, r.split) = if rec.len() >= PARALLEL_BINNING && parallel {
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
    if rec.len() >= PARALLEL_THRESHOLD && parallel {
        let side = |refs: &mut [PrimRef], rec: Record| {
            let mut nodes = Vec::new();
            grow(refs, rec, settings, &mut nodes);
            nodes
        };
        let (a, b) = rayon::join(|| side(left, l), || side(right, r));
        let mut firsts = [0; 2];
        for (first, part) in firsts.iter_mut().zip([a, b]) {
            let offset = out.len() as u32;
            *first = offset;
            out.extend(part.into_iter().map(|mut n| {
                if !n.is_leaf() {
                    n.kids = n.kids.map(|k| k + offset);
                }
                n
            }));
        }
        out[me].kids = firsts;
    } else {
        grow(left, l, settings, out);
        let second = out.len() as u32;
        grow(right, r, settings, out);
        out[me].kids = [me as u32 + 1, second];
    }
}
