//! The 8-wide tree the native backend traverses: 256-byte nodes (four cache
//! lines) holding eight child boxes as structure of arrays, eight child
//! references and, per child, its place in a front-to-back order for each
//! of the eight ray octants (Fuetterling et al. 2017, "Accelerated single
//! ray tracing for wide vector units", HPG; the layout of tinybvh's
//! BVH8_CPU). A ray picks its octant's order once and pushes its hit
//! children in that order without sorting them.

use glam::Vec3;

use crate::geom::Bounds;

/// Children per node.
pub const WIDTH: usize = 8;

/// A child reference: an inner node's index, or a leaf (`LEAF` set) with
/// its first item (triangle block or sphere) and item count.
pub type ChildRef = u32;
const LEAF: u32 = 1 << 31;
const COUNT_SHIFT: u32 = 27;
/// Largest number of items (triangle blocks, spheres) one leaf holds.
pub const MAX_LEAF_ITEMS: u32 = 16;
/// Largest first item a leaf can name.
pub const MAX_LEAF_FIRST: u32 = (1 << COUNT_SHIFT) - 1;
/// An unused child slot (its box is empty, so no ray ever enters it).
pub const EMPTY: ChildRef = u32::MAX;

#[inline(always)]
pub fn is_leaf(r: ChildRef) -> bool {
    r & LEAF != 0
}

/// A leaf of `count` (1..=[`MAX_LEAF_ITEMS`]) items from `first`.
pub fn leaf(first: u32, count: u32) -> ChildRef {
    debug_assert!((1..=MAX_LEAF_ITEMS).contains(&count) && first <= MAX_LEAF_FIRST);
    LEAF | ((count - 1) << COUNT_SHIFT) | first
}

#[inline(always)]
pub fn leaf_first(r: ChildRef) -> u32 {
    r & MAX_LEAF_FIRST
}

#[inline(always)]
pub fn leaf_count(r: ChildRef) -> u32 {
    ((r & !LEAF) >> COUNT_SHIFT) + 1
}

/// One node of the tree. Planes come in the order `lo_x, hi_x, lo_y, hi_y,
/// lo_z, hi_z`, so a ray finds its near plane of axis `a` at
/// `2 a + (dir_a < 0)` and the far plane next to it.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Node8 {
    pub(super) planes: [[f32; WIDTH]; 6],
    pub(super) child: [ChildRef; WIDTH],
    /// `order[i] >> (3 * octant) & 7` is the child at place `i` of the
    /// octant's order, place 0 farthest and the last used place nearest.
    pub(super) order: [u32; WIDTH],
}

impl Node8 {
    /// A node with no children: a placeholder while a node's children are
    /// being built.
    pub const UNUSED: Node8 = Node8 {
        planes: [
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
            [f32::INFINITY; WIDTH],
            [f32::NEG_INFINITY; WIDTH],
        ],
        child: [EMPTY; WIDTH],
        order: [0; WIDTH],
    };

    /// A node over up to eight children with their boxes.
    pub fn new(children: &[(ChildRef, Bounds)]) -> Node8 {
        debug_assert!(!children.is_empty() && children.len() <= WIDTH);
        // Slots by decreasing surface area: any-hit traversal enters the
        // highest hit slot first, i.e. the smallest box, which is the
        // cheapest to resolve and, being tight around its triangles, the
        // likeliest to hold an occluder (measured against largest-first and
        // the split order: faster on every shared mesh, see docs/design.md).
        let area = |b: &Bounds| {
            let d = b.extent();
            d.x * d.y + d.y * d.z + d.z * d.x
        };
        let used = children.len();
        let mut areas = [f32::NEG_INFINITY; WIDTH];
        for (a, (_, b)) in areas.iter_mut().zip(children) {
            *a = area(b);
        }
        let mut node = Node8::UNUSED;
        let mut centres = [Vec3::ZERO; WIDTH];
        for (i, &c) in descending(&areas)[..used].iter().enumerate() {
            let (r, b) = children[c];
            node.child[i] = r;
            for axis in 0..3 {
                node.planes[2 * axis][i] = b.min[axis];
                node.planes[2 * axis + 1][i] = b.max[axis];
            }
            centres[i] = b.center();
        }
        // The octants with a negative x direction; each opposite octant's
        // order is the same one reversed (unused slots, which no ray
        // enters, may sit anywhere in it).
        for octant in (0..8u32).step_by(2) {
            // Distance of each child's centre along the octant's diagonal:
            // a ray of that octant meets larger keys later, so they come
            // first (farthest).
            let sign = Vec3::new(
                -1.0,
                if octant & 2 != 0 { 1.0 } else { -1.0 },
                if octant & 4 != 0 { 1.0 } else { -1.0 },
            );
            // Farthest (largest key) first; unused slots last.
            let mut keys = [f32::NEG_INFINITY; WIDTH];
            for (key, centre) in keys.iter_mut().zip(&centres[..used]) {
                *key = centre.dot(sign);
            }
            let places = descending(&keys);
            let opposite = octant ^ 7;
            for (place, &child) in places.iter().enumerate() {
                node.order[place] |= (child as u32) << (3 * octant);
                node.order[WIDTH - 1 - place] |= (child as u32) << (3 * opposite);
            }
        }
        node
    }

    /// The used slots, one bit each.
    #[inline(always)]
    pub fn used(&self) -> u32 {
        (0..WIDTH).fold(0, |m, i| m | u32::from(self.child[i] != EMPTY) << i)
    }

    /// Child slot `i`: its reference and box (`None` when unused).
    pub fn child(&self, i: usize) -> Option<(ChildRef, Bounds)> {
        (self.child[i] != EMPTY).then(|| {
            let p = &self.planes;
            (
                self.child[i],
                Bounds {
                    min: Vec3::new(p[0][i], p[2][i], p[4][i]),
                    max: Vec3::new(p[1][i], p[3][i], p[5][i]),
                },
            )
        })
    }

    /// The children in use.
    pub fn children(&self) -> impl Iterator<Item = (ChildRef, Bounds)> + '_ {
        (0..WIDTH).filter_map(|i| self.child(i))
    }

    /// The child slot at `place` of `octant`'s order.
    #[inline(always)]
    pub fn ordered(&self, octant: u32, place: usize) -> usize {
        ((self.order[place] >> (3 * octant)) & 7) as usize
    }

    /// Points every leaf at `f(first, count)` (e.g. its first triangle
    /// block).
    pub(super) fn remap_leaves(&mut self, mut f: impl FnMut(u32, u32) -> ChildRef) {
        for r in &mut self.child {
            if *r != EMPTY && is_leaf(*r) {
                *r = f(leaf_first(*r), leaf_count(*r));
            }
        }
    }
}

/// The slots in decreasing order of `keys` (`f32::total_cmp`, so any
/// key, NaN too, has one place), equal keys in slot order as a stable sort
/// gives: a slot's place is the number of keys that go before it, counted
/// without branches (a sort of eight mispredicts).
fn descending(keys: &[f32; WIDTH]) -> [usize; WIDTH] {
    let mut order = [0; WIDTH];
    for i in 0..WIDTH {
        let mut place = 0;
        for j in 0..WIDTH {
            place += keys[j].total_cmp(&keys[i]).then(i.cmp(&j)).is_gt() as usize;
        }
        order[place] = i;
    }
    order
}

/// For every 8-bit mask, the lanes whose bit is set, in increasing order,
/// then the others: the shuffle that packs the set lanes to the front.
pub const COMPRESS: [[u32; WIDTH]; 256] = {
    let mut table = [[0u32; WIDTH]; 256];
    let mut mask = 0;
    while mask < 256 {
        let mut out = 0;
        let mut lane = 0;
        while lane < WIDTH {
            if mask & (1 << lane) != 0 {
                table[mask][out] = lane as u32;
                out += 1;
            }
            lane += 1;
        }
        lane = 0;
        while lane < WIDTH {
            if mask & (1 << lane) == 0 {
                table[mask][out] = lane as u32;
                out += 1;
            }
            lane += 1;
        }
        mask += 1;
    }
    table
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn leaf_references_round_trip() {
        for (first, count) in [(0, 1), (12345, 4), (MAX_LEAF_FIRST, MAX_LEAF_ITEMS)] {
            let r = leaf(first, count);
            assert!(is_leaf(r));
            assert_eq!((leaf_first(r), leaf_count(r)), (first, count));
        }
        assert!(!is_leaf(7));
    }

    #[test]
    fn octant_orders_put_the_nearest_child_last() {
        let boxes: Vec<(ChildRef, Bounds)> = (0..3)
            .map(|i| {
                let c = Vec3::new(i as f32, 0.0, 0.0);
                (
                    i,
                    Bounds {
                        min: c - 0.1,
                        max: c + 0.1,
                    },
                )
            })
            .collect();
        let node = Node8::new(&boxes);
        // The used children in the octant's order, farthest first.
        let refs = |octant: u32| -> Vec<ChildRef> {
            (0..WIDTH)
                .map(|p| node.child[node.ordered(octant, p)])
                .filter(|&r| r != EMPTY)
                .collect()
        };
        // Octants with +x: child 0 (smallest x) is met first, so last.
        for octant in [0b001, 0b011, 0b101, 0b111] {
            assert_eq!(refs(octant), vec![2, 1, 0], "octant {octant:03b}");
            assert_eq!(refs(octant ^ 1), vec![0, 1, 2], "octant {:03b}", octant ^ 1);
        }
    }

    #[test]
    fn descending_is_a_stable_sort_of_any_keys() {
        let mut state = 7u64;
        let mut next = || {
            state = crate::geom::sampling::mix(state);
            state
        };
        for _ in 0..2000 {
            // Few distinct values, so ties are common; NaN and infinities too.
            let pool = [
                0.0,
                -0.0,
                1.0,
                2.5,
                -3.0,
                f32::NAN,
                f32::INFINITY,
                f32::NEG_INFINITY,
            ];
            let keys: [f32; WIDTH] = std::array::from_fn(|_| pool[(next() % 8) as usize]);
            let mut expected: Vec<usize> = (0..WIDTH).collect();
            expected.sort_by(|&a, &b| keys[b].total_cmp(&keys[a]));
            assert_eq!(descending(&keys).to_vec(), expected, "keys {keys:?}");
        }
    }

    #[test]
    fn compress_packs_set_lanes_first() {
        assert_eq!(COMPRESS[0b1010_0110][..4], [1, 2, 5, 7]);
        assert_eq!(COMPRESS[0xff], [0, 1, 2, 3, 4, 5, 6, 7]);
    }
}
