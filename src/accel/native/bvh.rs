//! The BVH itself: a compact, depth-first node array built with a binned
//! surface-area heuristic (Wald 2007, "On fast construction of SAH-based
//! bounding volume hierarchies"), children built in parallel where the work
//! pays for it.
//!
//! The builder only sees boxes; which primitives sit in the leaves is the
//! caller's business (`prim_order` maps leaf slots to primitive indices).

use glam::Vec3;

use crate::scene::Bounds;

/// One node: 32 bytes, two per cache line. An inner node's left child is
/// the next node; `offset` is its right child. A leaf's primitives are the
/// slots `offset .. offset + count`.
#[derive(Clone, Copy, Debug, PartialEq)]
#[repr(C, align(32))]
pub struct BvhNode {
    pub min: [f32; 3],
    pub offset: u32,
    pub max: [f32; 3],
    /// Leaf: number of primitives (> 0). Inner: 0.
    pub count: u16,
    /// Inner: split axis, used to visit the nearer child first.
    pub axis: u16,
}

impl BvhNode {
    #[inline]
    pub fn is_leaf(&self) -> bool {
        self.count > 0
    }

    pub fn bounds(&self) -> Bounds {
        Bounds {
            min: Vec3::from(self.min),
            max: Vec3::from(self.max),
        }
    }
}

/// How the builder chooses splits.
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

/// Cost constants of the SAH, relative to one primitive test.
pub const TRAVERSAL_COST: f64 = 1.0;
pub const INTERSECTION_COST: f64 = 1.0;
/// Triangles tested together by one SIMD leaf test (see `triangle.rs`).
pub const LEAF_BLOCK: usize = 4;

/// Cost of a leaf of `n` primitives: leaves are tested in blocks of
/// [`LEAF_BLOCK`] at the price of one, so a leaf of up to four costs one
/// test and the builder fills leaves instead of splitting them further.
pub fn leaf_cost(n: usize) -> f64 {
    INTERSECTION_COST * n.div_ceil(LEAF_BLOCK) as f64
}
const BINS: usize = 16;
/// Below this many primitives children are built on the calling thread.
const PARALLEL_THRESHOLD: usize = 4096;

#[derive(Clone, Debug, Default)]
pub struct Bvh {
    pub nodes: Vec<BvhNode>,
    /// Leaf slot -> primitive index given to [`Bvh::build`].
    pub prim_order: Vec<u32>,
    pub max_leaf: usize,
}

#[derive(Clone, Copy)]
struct PrimRef {
    bounds: Bounds,
    centroid: Vec3,
    index: u32,
}

enum BuildNode {
    Leaf {
        bounds: Bounds,
        first: usize,
        count: usize,
    },
    Inner {
        bounds: Bounds,
        axis: usize,
        children: Box<[BuildNode; 2]>,
    },
}

fn area(b: &Bounds) -> f64 {
    if b.is_empty() {
        return 0.0;
    }
    let d = (b.max - b.min).as_dvec3();
    2.0 * (d.x * d.y + d.y * d.z + d.z * d.x)
}

impl Bvh {
    /// Builds over the given primitive boxes. Leaves hold at most
    /// `max_leaf` primitives (1..=255) unless boxes cannot be separated.
    pub fn build(boxes: &[Bounds], max_leaf: usize, method: BuildMethod) -> Bvh {
        let max_leaf = max_leaf.clamp(1, 255);
        let mut refs: Vec<PrimRef> = boxes
            .iter()
            .enumerate()
            .map(|(i, b)| PrimRef {
                bounds: *b,
                centroid: b.center(),
                index: i as u32,
            })
            .collect();
        if refs.is_empty() {
            return Bvh {
                nodes: Vec::new(),
                prim_order: Vec::new(),
                max_leaf,
            };
        }
        let root = build_node(&mut refs, 0, max_leaf, method);
        let mut nodes = Vec::with_capacity(2 * boxes.len() / max_leaf.max(1) + 1);
        flatten(&root, &mut nodes);
        Bvh {
            nodes,
            prim_order: refs.iter().map(|r| r.index).collect(),
            max_leaf,
        }
    }

    pub fn leaf_count(&self) -> usize {
        self.nodes.iter().filter(|n| n.is_leaf()).count()
    }

    /// Depth of the deepest leaf (the root alone has depth 1).
    pub fn depth(&self) -> usize {
        fn walk(nodes: &[BvhNode], i: usize) -> usize {
            let n = &nodes[i];
            if n.is_leaf() {
                1
            } else {
                1 + walk(nodes, i + 1).max(walk(nodes, n.offset as usize))
            }
        }
        if self.nodes.is_empty() {
            0
        } else {
            walk(&self.nodes, 0)
        }
    }

    /// SAH cost of the tree: expected cost of a random ray through the root
    /// (MacDonald and Booth 1990), with [`TRAVERSAL_COST`] per inner node
    /// and [`leaf_cost`] per leaf.
    pub fn sah_cost(&self) -> f64 {
        let Some(root) = self.nodes.first() else {
            return 0.0;
        };
        let root_area = area(&root.bounds());
        if root_area == 0.0 {
            return 0.0;
        }
        self.nodes
            .iter()
            .map(|n| {
                let a = area(&n.bounds()) / root_area;
                if n.is_leaf() {
                    a * leaf_cost(n.count as usize)
                } else {
                    a * TRAVERSAL_COST
                }
            })
            .sum()
    }

    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<BvhNode>() + self.prim_order.len() * 4
    }
}

fn bounds_of(refs: &[PrimRef]) -> (Bounds, Bounds) {
    let mut b = Bounds::EMPTY;
    let mut c = Bounds::EMPTY;
    for r in refs {
        b = b.union(r.bounds);
        c.grow(r.centroid);
    }
    (b, c)
}

fn build_node(
    refs: &mut [PrimRef],
    first: usize,
    max_leaf: usize,
    method: BuildMethod,
) -> BuildNode {
    let (bounds, centroids) = bounds_of(refs);
    let n = refs.len();
    let leaf = BuildNode::Leaf {
        bounds,
        first,
        count: n,
    };
    if n == 1 {
        return leaf;
    }
    let extent = centroids.extent();
    let axis = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    let split = match method {
        BuildMethod::Median => {
            if n <= max_leaf {
                return leaf;
            }
            let mid = n / 2;
            refs.select_nth_unstable_by(mid, |a, b| a.centroid[axis].total_cmp(&b.centroid[axis]));
            Some((axis, mid))
        }
        BuildMethod::Sah => sah_split(refs, &bounds, &centroids, max_leaf),
    };
    let (axis, mid) = match split {
        Some(s) => s,
        None if n <= max_leaf => return leaf,
        // Cannot separate the centroids but too many for one leaf: split the
        // list in half so that leaf sizes stay bounded.
        None => (axis, n / 2),
    };
    let (left, right) = refs.split_at_mut(mid);
    let (l, r) = if n >= PARALLEL_THRESHOLD {
        rayon::join(
            || build_node(left, first, max_leaf, method),
            || build_node(right, first + mid, max_leaf, method),
        )
    } else {
        (
            build_node(left, first, max_leaf, method),
            build_node(right, first + mid, max_leaf, method),
        )
    };
    BuildNode::Inner {
        bounds,
        axis,
        children: Box::new([l, r]),
    }
}

/// Best binned SAH split of `refs`, partitioned in place: `(axis, count of
/// the left side)`, or `None` when a leaf is cheaper (and allowed).
fn sah_split(
    refs: &mut [PrimRef],
    bounds: &Bounds,
    centroids: &Bounds,
    max_leaf: usize,
) -> Option<(usize, usize)> {
    let n = refs.len();
    let parent_area = area(bounds);
    let mut best: Option<(f64, usize, usize)> = None; // cost, axis, bin boundary
    for axis in 0..3 {
        let lo = centroids.min[axis];
        let span = centroids.max[axis] - lo;
        if span <= 0.0 {
            continue;
        }
        let scale = BINS as f32 / span;
        let mut counts = [0usize; BINS];
        let mut boxes = [Bounds::EMPTY; BINS];
        for r in refs.iter() {
            let b = (((r.centroid[axis] - lo) * scale) as usize).min(BINS - 1);
            counts[b] += 1;
            boxes[b] = boxes[b].union(r.bounds);
        }
        // Sweep from the right to get the right-side areas, then from the left.
        let mut right_area = [0.0f64; BINS];
        let mut right_count = [0usize; BINS];
        let (mut acc, mut cnt) = (Bounds::EMPTY, 0);
        for i in (1..BINS).rev() {
            acc = acc.union(boxes[i]);
            cnt += counts[i];
            right_area[i] = area(&acc);
            right_count[i] = cnt;
        }
        let (mut acc, mut cnt) = (Bounds::EMPTY, 0);
        for i in 0..BINS - 1 {
            acc = acc.union(boxes[i]);
            cnt += counts[i];
            if cnt == 0 || right_count[i + 1] == 0 {
                continue;
            }
            let cost = TRAVERSAL_COST
                + (area(&acc) * leaf_cost(cnt) + right_area[i + 1] * leaf_cost(right_count[i + 1]))
                    / parent_area;
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, i + 1));
            }
        }
    }
    let (cost, axis, boundary) = best?;
    if n <= max_leaf && cost >= leaf_cost(n) {
        return None;
    }
    let lo = centroids.min[axis];
    let scale = BINS as f32 / (centroids.max[axis] - lo);
    let bin_of = |r: &PrimRef| (((r.centroid[axis] - lo) * scale) as usize).min(BINS - 1);
    // In-place partition: left bins to the front.
    let mut i = 0;
    let mut j = n;
    while i < j {
        if bin_of(&refs[i]) < boundary {
            i += 1;
        } else {
            j -= 1;
            refs.swap(i, j);
        }
    }
    Some((axis, i))
}

fn flatten(node: &BuildNode, out: &mut Vec<BvhNode>) -> usize {
    let index = out.len();
    match node {
        BuildNode::Leaf {
            bounds,
            first,
            count,
        } => out.push(BvhNode {
            min: bounds.min.into(),
            offset: *first as u32,
            max: bounds.max.into(),
            count: *count as u16,
            axis: 0,
        }),
        BuildNode::Inner {
            bounds,
            axis,
            children,
        } => {
            out.push(BvhNode {
                min: bounds.min.into(),
                offset: 0,
                max: bounds.max.into(),
                count: 0,
                axis: *axis as u16,
            });
            flatten(&children[0], out);
            let right = flatten(&children[1], out);
            out[index].offset = right as u32;
        }
    }
    index
}

#[cfg(test)]
mod tests {
    use super::*;

    fn random_boxes(n: usize) -> Vec<Bounds> {
        let mut state = 12345u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32) / (1u64 << 24) as f32
        };
        (0..n)
            .map(|_| {
                let c = Vec3::new(next(), next(), next()) * 10.0;
                let h = Vec3::new(next(), next(), next()) * 0.1;
                Bounds {
                    min: c - h,
                    max: c + h,
                }
            })
            .collect()
    }

    #[test]
    fn identical_boxes_still_give_bounded_leaves() {
        let boxes = vec![
            Bounds {
                min: Vec3::ZERO,
                max: Vec3::ONE
            };
            100
        ];
        let bvh = Bvh::build(&boxes, 4, BuildMethod::Sah);
        let worst = bvh
            .nodes
            .iter()
            .filter(|n| n.is_leaf())
            .map(|n| n.count)
            .max()
            .unwrap();
        assert!(
            worst <= 4,
            "a leaf holds {worst} primitives with max_leaf 4"
        );
        let mut seen = bvh.prim_order.clone();
        seen.sort();
        assert_eq!(seen, (0..100).collect::<Vec<u32>>());
    }

    #[test]
    fn sah_beats_median_on_random_boxes() {
        let boxes = random_boxes(5000);
        let sah = Bvh::build(&boxes, 4, BuildMethod::Sah).sah_cost();
        let median = Bvh::build(&boxes, 4, BuildMethod::Median).sah_cost();
        assert!(
            sah < median,
            "SAH cost {sah:.2} is not below median-split cost {median:.2}"
        );
    }
}
