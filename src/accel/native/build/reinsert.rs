//! Optimizing the binary tree after the build by moving subtrees
//! (insertion-based optimization: Bittner, Hapala and Havran 2013, "Fast
//! insertion-based optimization of bounding volume hierarchies", CGF 32(1);
//! the whole-subtree moves of Meister and Bittner 2018, "Parallel
//! reinsertion for bounding volume hierarchy optimization", CGF 37(2)).
//!
//! A top-down build decides the root's split before it knows what lies
//! below, and big primitives among small ones mislead it: in a Cornell box
//! the walls' centroids fall among the model's, so walls end up deep inside
//! the model's subtrees and rays walk several boxes the size of the room to
//! reach them. Taking a subtree out and putting it back where it adds the
//! least area puts such walls next to the root. Each move is the cheapest
//! of all places including the one it left, so the SAH cost never rises.

use std::cmp::Ordering;
use std::collections::BinaryHeap;

use super::binary::{BinaryTree, NONE};
use super::Aabb;

/// Share of the nodes moved per pass, those with the largest boxes first.
const MOVED_PER_PASS: f32 = 0.02;
/// Passes at most. The gains come in the first few: on the shared scenes
/// the cost settled within five.
const MAX_PASSES: usize = 16;
/// A pass that lowers the SAH cost by at most this share is the last.
const MIN_GAIN: f64 = 1e-3;

/// Moves subtrees of `tree` until the SAH cost settles.
pub(super) fn optimize(tree: &mut BinaryTree) {
    if tree.nodes.len() < 5 {
        return;
    }
    let moves = ((tree.nodes.len() as f32 * MOVED_PER_PASS) as usize).max(1);
    let mut cost = tree.sah();
    let mut order: Vec<u32> = (0..tree.nodes.len() as u32).collect();
    for _ in 0..MAX_PASSES {
        // Largest boxes first; ties by index, so the tree is the same on
        // every run.
        let largest_first =
            |&a: &u32, &b: &u32| tree.area(b).total_cmp(&tree.area(a)).then(a.cmp(&b));
        if moves < order.len() {
            order.select_nth_unstable_by(moves, largest_first);
        }
        order[..moves].sort_unstable_by(largest_first);
        for &n in &order[..moves] {
            tree.move_subtree(n);
        }
        let after = tree.sah();
        let gained = cost - after;
        cost = after;
        if gained <= cost * MIN_GAIN {
            break;
        }
    }
}

/// A place to try in the search for the cheapest one: the least cost any
/// node under it can have, what inserting there adds to its ancestors,
/// and the node.
struct Candidate {
    bound: f32,
    induced: f32,
    node: u32,
}

impl PartialEq for Candidate {
    fn eq(&self, other: &Self) -> bool {
        self.cmp(other) == Ordering::Equal
    }
}

impl Eq for Candidate {}

impl PartialOrd for Candidate {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

impl Ord for Candidate {
    /// The heap pops the smallest bound first.
    fn cmp(&self, other: &Self) -> Ordering {
        other.bound.total_cmp(&self.bound)
    }
}

fn union(a: &Aabb, b: &Aabb) -> Aabb {
    let mut u = *a;
    u.grow(b);
    u
}

impl BinaryTree {
    /// Moves the subtree under `n`, with its parent, to the place where it
    /// adds the least area; the root and its children stay.
    fn move_subtree(&mut self, n: u32) {
        let parent = self.nodes[n as usize].parent;
        if parent == NONE {
            return;
        }
        let grandparent = self.nodes[parent as usize].parent;
        if grandparent == NONE {
            return;
        }
        let [a, b] = self.nodes[parent as usize].kids;
        let sibling = if a == n { b } else { a };
        self.replace_child(grandparent, parent, sibling);
        self.refit(grandparent);
        let bounds = self.nodes[n as usize].bounds;
        let place = self.cheapest_place(&bounds);
        let above = self.nodes[place as usize].parent;
        self.replace_child(above, place, parent);
        self.nodes[parent as usize].kids = [place, n];
        self.nodes[place as usize].parent = parent;
        self.nodes[n as usize].parent = parent;
        self.refit(parent);
    }

    /// Puts `new` where `old` was under `parent` (or at the root).
    fn replace_child(&mut self, parent: u32, old: u32, new: u32) {
        if parent == NONE {
            self.root = new;
        } else {
            let kids = &mut self.nodes[parent as usize].kids;
            let slot = usize::from(kids[0] != old);
            debug_assert_eq!(kids[slot], old);
            kids[slot] = new;
        }
        self.nodes[new as usize].parent = parent;
    }

    /// Recomputes the boxes from inner node `n` up to the root.
    fn refit(&mut self, mut n: u32) {
        while n != NONE {
            let [a, b] = self.nodes[n as usize].kids;
            self.nodes[n as usize].bounds = union(
                &self.nodes[a as usize].bounds,
                &self.nodes[b as usize].bounds,
            );
            n = self.nodes[n as usize].parent;
        }
    }

    /// The node beside which a subtree with box `b` costs least: a new
    /// parent over both adds the area of their union, and every ancestor
    /// grows by its union with `b`. Branch and bound (Bittner et al.
    /// 2013): below a node, the cost is at least what its ancestors and
    /// itself already add plus `b`'s own area.
    fn cheapest_place(&self, b: &Aabb) -> u32 {
        let own = b.half_area();
        let mut heap = BinaryHeap::new();
        heap.push(Candidate {
            bound: own,
            induced: 0.0,
            node: self.root,
        });
        let (mut best, mut best_cost) = (self.root, f32::INFINITY);
        while let Some(c) = heap.pop() {
            if c.bound >= best_cost {
                break;
            }
            let node = &self.nodes[c.node as usize];
            let joined = union(&node.bounds, b).half_area();
            if c.induced + joined < best_cost {
                best_cost = c.induced + joined;
                best = c.node;
            }
            if !node.is_leaf() {
                let induced = c.induced + joined - node.bounds.half_area();
                if induced + own < best_cost {
                    for kid in node.kids {
                        heap.push(Candidate {
                            bound: induced + own,
                            induced,
                            node: kid,
                        });
                    }
                }
            }
        }
        best
    }
}
