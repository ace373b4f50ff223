//! The tree the traversal kernels walk, as a type that proves its shape.
//!
//! The AVX2 kernels index nodes without bounds checks and keep their stack
//! in a fixed array, which is sound only for a tree whose inner references
//! stay inside it and whose depth the stack can hold. [`Tree`] is that
//! proof: its one constructor, [`Tree::new`], checks every reference once
//! (the builder's trees pass in time linear in the nodes), and the kernels
//! take nothing else. A node list made by hand reaches them only through
//! the same check:
//!
//! ```
//! use hybrid::accel::native::node::{Node8, ChildRef};
//! use hybrid::accel::native::tree::{Tree, TreeError};
//! use hybrid::geom::Bounds;
//! use glam::Vec3;
//!
//! let unit = Bounds { min: Vec3::ZERO, max: Vec3::ONE };
//! // Node 0 names itself as its child: a cycle.
//! let cyclic = vec![Node8::new(&[(0 as ChildRef, unit)])];
//! assert!(matches!(Tree::new(cyclic), Err(TreeError::Upward { .. })));
//! ```
//!
//! and the kernels themselves are private to the backend:
//!
//! ```compile_fail
//! use hybrid::accel::native::traverse;
//! ```

use glam::Vec3A;

use super::node::{is_leaf, ChildRef, Node8, EMPTY, WIDTH};
use crate::geom::Bounds;

/// Deepest tree (in wide levels) the kernels' fixed stacks hold; deeper
/// SAH trees are rebuilt by median splits (see `NativeBvh::build`).
pub const MAX_DEPTH: usize = 64;

/// Nodes whose inner references all point forwards, inside the list, at
/// most [`MAX_DEPTH`] levels deep: the kernels' precondition.
#[derive(Clone, Debug, Default)]
pub struct Tree {
    nodes: Vec<Node8>,
    /// The root's box, the union of its children's: `[lo, hi]`.
    bounds: [Vec3A; 2],
}

/// Why a node list is not a [`Tree`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum TreeError {
    /// A child reference names a node at or before its parent (a cycle, or
    /// a node visited twice by the depth-first order).
    #[error("node {node} names node {child} as a child: children follow their parent")]
    Upward { node: usize, child: u32 },
    #[error("node {node} names node {child}, past the last of {len}")]
    OutOfRange { node: usize, child: u32, len: usize },
    #[error("node {node} lies {depth} levels deep; traversal holds at most {MAX_DEPTH}")]
    TooDeep { node: usize, depth: usize },
}

impl Tree {
    /// Checks `nodes` (node 0 the root): every inner child reference is
    /// greater than its parent's index and smaller than the node count,
    /// so the references form no cycle and stay in the list, and no path
    /// from the root passes more than [`MAX_DEPTH`] nodes. Leaves and
    /// unused slots are not node references and need no check: the leaf
    /// tests index their own arrays with checks.
    pub fn new(nodes: Vec<Node8>) -> Result<Tree, TreeError> {
        let mut depth = vec![0u8; nodes.len()];
        if let Some(root) = depth.first_mut() {
            *root = 1;
        }
        for (i, node) in nodes.iter().enumerate() {
            let level = depth[i] as usize;
            for slot in 0..WIDTH {
                let child = node.child[slot];
                if child == EMPTY || is_leaf(child) {
                    continue;
                }
                let c = child as usize;
                if c <= i {
                    return Err(TreeError::Upward { node: i, child });
                }
                if c >= nodes.len() {
                    return Err(TreeError::OutOfRange {
                        node: i,
                        child,
                        len: nodes.len(),
                    });
                }
                // Unreachable nodes (depth 0) pass on nothing.
                if level > 0 {
                    if level + 1 > MAX_DEPTH {
                        return Err(TreeError::TooDeep {
                            node: c,
                            depth: level + 1,
                        });
                    }
                    depth[c] = depth[c].max(level as u8 + 1);
                }
            }
        }
        let root = nodes.first().map_or(Bounds::EMPTY, |root| {
            root.children().fold(Bounds::EMPTY, |b, (_, c)| b.union(c))
        });
        let bounds = [Vec3A::from(root.min), Vec3A::from(root.max)];
        Ok(Tree { nodes, bounds })
    }

    /// The box around everything in the tree.
    #[inline(always)]
    pub fn bounds(&self) -> [Vec3A; 2] {
        self.bounds
    }

    pub fn nodes(&self) -> &[Node8] {
        &self.nodes
    }

    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// Whether a walk may start at `r` in this tree: a leaf or an empty
    /// slot (which the kernels never read as a node), or an inner
    /// reference inside the node list, whose subtree the check of
    /// [`Tree::new`] covered like the whole tree's.
    #[inline(always)]
    pub fn holds(&self, r: ChildRef) -> bool {
        is_leaf(r) || (r as usize) < self.nodes.len()
    }

    /// The node at `r`, which the tree's check proved is in range for
    /// every inner reference the kernels read from its nodes.
    ///
    /// # Safety
    /// `r` is an inner reference the tree [holds](Tree::holds): 0 of a
    /// non-empty tree, a walk's checked start, or an inner child reference
    /// read from one of this tree's nodes.
    #[inline(always)]
    pub(super) unsafe fn node_unchecked(&self, r: u32) -> &Node8 {
        // SAFETY: the caller's reference is in range (`Tree::new`).
        unsafe { self.nodes.get_unchecked(r as usize) }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::native::node::{leaf, ChildRef};
    use crate::geom::Bounds;
    use glam::Vec3;

    fn unit() -> Bounds {
        Bounds {
            min: Vec3::ZERO,
            max: Vec3::ONE,
        }
    }

    fn inner(children: &[ChildRef]) -> Node8 {
        let slots: Vec<(ChildRef, Bounds)> = children.iter().map(|&c| (c, unit())).collect();
        Node8::new(&slots)
    }

    #[test]
    fn a_forward_tree_of_leaves_is_accepted() {
        let nodes = vec![inner(&[1, 2]), inner(&[leaf(0, 1)]), inner(&[leaf(1, 2)])];
        assert_eq!(Tree::new(nodes).expect("a valid tree").nodes().len(), 3);
        assert!(Tree::new(Vec::new()).expect("the empty tree").is_empty());
    }

    /// A walk starts only at a reference the tree holds: its nodes and any
    /// leaf, never a node past its end.
    #[test]
    fn walks_start_only_where_the_tree_holds() {
        let nodes = vec![inner(&[1, 2]), inner(&[leaf(0, 1)]), inner(&[leaf(1, 2)])];
        let tree = Tree::new(nodes).expect("a valid tree");
        assert!((0..3).all(|r| tree.holds(r)));
        assert!(tree.holds(leaf(5, 1)) && tree.holds(EMPTY));
        assert!(!tree.holds(3) && !tree.holds(1 << 20));
        assert!(!Tree::default().holds(0));
    }

    #[test]
    fn hand_built_trees_that_could_mislead_the_kernels_are_rejected() {
        // A cycle through the root.
        assert_eq!(
            Tree::new(vec![inner(&[1]), inner(&[0])]).unwrap_err(),
            TreeError::Upward { node: 1, child: 0 }
        );
        // A reference past the end.
        assert_eq!(
            Tree::new(vec![inner(&[5])]).unwrap_err(),
            TreeError::OutOfRange {
                node: 0,
                child: 5,
                len: 1
            }
        );
        // A chain deeper than the stacks hold.
        let mut chain: Vec<Node8> = (1..=MAX_DEPTH as u32).map(|i| inner(&[i])).collect();
        chain.push(inner(&[leaf(0, 1)]));
        assert!(matches!(
            Tree::new(chain).unwrap_err(),
            TreeError::TooDeep { depth, .. } if depth == MAX_DEPTH + 1
        ));
        // One level less is fine.
        let mut chain: Vec<Node8> = (1..MAX_DEPTH as u32).map(|i| inner(&[i])).collect();
        chain.push(inner(&[leaf(0, 1)]));
        assert!(Tree::new(chain).is_ok());
    }
}
