//! Grouping the binary tree's levels into wide nodes.
//!
//! Each wide node stands for a piece of the binary tree: the binary node
//! at its top and, below it, up to seven more binary nodes dissolved into
//! it, so that the piece's bottom (at most eight subtrees) becomes its
//! children. Which ones to dissolve is the choice. Embree's rule, kept for
//! `--build sah-top-down`, expands the child of largest area until the node
//! has eight; the nodes near the bottom then get what is left of the
//! binary tree beneath them, often three or four children. The SAH of the
//! wide tree (a node test for each wide node a ray enters, a block test
//! per leaf block) can be minimized exactly instead, by dynamic
//! programming over the binary tree (Ylitie, Karras and Laine 2017,
//! "Efficient incoherent ray traversal on GPUs through compressed wide
//! BVHs", HPG; without their merging of leaves, which the builder has
//! already sized): the leaves are fixed, so the cost to minimize is the sum
//! of the wide nodes' areas.

use super::binary::BinaryTree;
use super::*;

/// How the wide nodes are formed.
pub(super) enum Grouping {
    /// Expand the child of largest area until the node has eight.
    LargestFirst,
    /// The least total area of wide nodes ([`Plan`]).
    Optimal(Plan),
}

/// The best grouping of every binary subtree, bottom up.
pub(super) struct Plan {
    /// `cost[n][i - 1]`: the least sum of wide nodes' areas under binary
    /// node `n` when its subtree takes at most `i` child slots of the wide
    /// node above (1: `n` itself is the child, a leaf or a wide node).
    cost: Vec<[f32; WIDTH]>,
    /// How `n`'s subtree fills `i` slots: 0 when `i - 1` slots do as well
    /// (or `i` is 1), else the slots its left child takes, the right child
    /// taking the rest.
    left: Vec<[u8; WIDTH]>,
}

impl Plan {
    pub(super) fn new(tree: &BinaryTree) -> Plan {
        let n = tree.nodes.len();
        let mut plan = Plan {
            cost: vec![[0.0; WIDTH]; n],
            left: vec![[0; WIDTH]; n],
        };
        // Children before parents: the reverse of a preorder.
        let mut preorder = Vec::with_capacity(n);
        let mut stack = vec![tree.root];
        while let Some(x) = stack.pop() {
            preorder.push(x);
            let node = &tree.nodes[x as usize];
            if !node.is_leaf() {
                stack.extend(node.kids);
            }
        }
        for &x in preorder.iter().rev() {
            let node = &tree.nodes[x as usize];
            if node.is_leaf() {
                // A leaf costs its blocks whatever the grouping.
                continue;
            }
            let [l, r] = node.kids.map(|k| plan.cost[k as usize]);
            // split[i]: the children's subtrees in `i` slots between them.
            let mut split = [(f32::INFINITY, 0u8); WIDTH + 1];
            for (i, s) in split.iter_mut().enumerate().skip(2) {
                for k in 1..i {
                    let c = l[k - 1] + r[i - k - 1];
                    if c < s.0 {
                        *s = (c, k as u8);
                    }
                }
            }
            let mut cost = [0.0; WIDTH];
            let mut left = [0; WIDTH];
            // In one slot, `x` is a wide node over its children's eight.
            cost[0] = node.bounds.half_area() + split[WIDTH].0;
            left[0] = split[WIDTH].1;
            for i in 2..=WIDTH {
                (cost[i - 1], left[i - 1]) = if split[i].0 < cost[i - 2] {
                    split[i]
                } else {
                    (cost[i - 2], 0)
                };
            }
            plan.cost[x as usize] = cost;
            plan.left[x as usize] = left;
        }
        plan
    }

    /// Appends the children that `n`'s subtree puts in at most `slots`
    /// slots, with their binary depths (`n` at `depth`).
    fn fill(
        &self,
        tree: &BinaryTree,
        n: u32,
        slots: usize,
        depth: usize,
        out: &mut Vec<(u32, usize)>,
    ) {
        let node = &tree.nodes[n as usize];
        if slots == 1 || node.is_leaf() {
            out.push((n, depth));
            return;
        }
        match self.left[n as usize][slots - 1] as usize {
            0 => self.fill(tree, n, slots - 1, depth, out),
            k => {
                self.fill(tree, node.kids[0], k, depth + 1, out);
                self.fill(tree, node.kids[1], slots - k, depth + 1, out);
            }
        }
    }
}

impl Grouping {
    /// The children of the wide node over inner node `n` (at binary depth
    /// `depth`), in the order of the binary tree, with their binary depths.
    fn children(&self, tree: &BinaryTree, n: u32, depth: usize) -> Vec<(u32, usize)> {
        let mut children = Vec::with_capacity(WIDTH);
        match self {
            Grouping::LargestFirst => {
                children.push((n, depth));
                while children.len() < WIDTH {
                    let Some(i) = (0..children.len())
                        .filter(|&i| !tree.nodes[children[i].0 as usize].is_leaf())
                        .max_by(|&a, &b| {
                            tree.area(children[a].0)
                                .total_cmp(&tree.area(children[b].0))
                        })
                    else {
                        break;
                    };
                    let (c, d) = children[i];
                    let [a, b] = tree.nodes[c as usize].kids;
                    children[i] = (a, d + 1);
                    children.insert(i + 1, (b, d + 1));
                }
            }
            Grouping::Optimal(plan) => {
                // The node takes the binary node's own box; its children
                // fill the eight slots as planned for its one slot above.
                let [l, r] = tree.nodes[n as usize].kids;
                let k = plan.left[n as usize][0] as usize;
                plan.fill(tree, l, k, depth + 1, &mut children);
                plan.fill(tree, r, WIDTH - k, depth + 1, &mut children);
            }
        }
        children
    }

    /// Forms the wide node over inner node `n` (its `depth`; `n` at binary
    /// depth `binary_depth`) and everything below, depth first.
    pub(super) fn collapse(
        &self,
        tree: &BinaryTree,
        n: u32,
        depth: usize,
        binary_depth: usize,
        out: &mut Vec<Node8>,
        stats: &mut Stats,
    ) -> ChildRef {
        stats.nodes += 1;
        stats.depth = stats.depth.max(depth);
        stats.wide_sah += tree.area(n) as f64;
        let children = self.children(tree, n, binary_depth);
        let me = out.len();
        out.push(Node8::UNUSED);
        let mut slots = [(EMPTY, Bounds::EMPTY); WIDTH];
        for (slot, &(c, d)) in slots.iter_mut().zip(&children) {
            let node = &tree.nodes[c as usize];
            let r = if node.is_leaf() {
                stats.leaves += 1;
                stats.binary_depth = stats.binary_depth.max(d);
                stats.wide_sah +=
                    node.bounds.half_area() as f64 * leaf_cost(node.count as usize) as f64;
                // Slots of `prim_order`; `NativeBvh` later points leaves at
                // their data.
                leaf(node.kids[0], node.count)
            } else {
                self.collapse(tree, c, depth + 1, d, out, stats)
            };
            *slot = (r, node.bounds.bounds());
        }
        out[me] = Node8::new(&slots[..children.len()]);
        me as ChildRef
    }
}
