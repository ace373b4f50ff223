//! The portable kernels: the robust box test lane by lane, children
//! visited in the same octant order as the AVX2 kernels.

use super::*;

/// Entries the scalar stack holds without allocating: enough for any
/// ray on the shared scenes (a 4-level tree leaves at most 28 behind).
const INLINE: usize = 64;

/// The traversal stack: the first [`INLINE`] entries in an array, any
/// beyond in a vector that only deep trees ever allocate. No
/// allocation per ray, and no large array to clear per ray either.
struct Stack<T: Copy> {
    inline: [T; INLINE],
    len: usize,
    spill: Vec<T>,
}

impl<T: Copy> Stack<T> {
    #[inline(always)]
    fn new(fill: T) -> Self {
        Stack {
            inline: [fill; INLINE],
            len: 0,
            spill: Vec::new(),
        }
    }

    #[inline(always)]
    fn push(&mut self, item: T) {
        if self.len < INLINE {
            self.inline[self.len] = item;
            self.len += 1;
        } else {
            self.spill.push(item);
        }
    }

    #[inline(always)]
    fn pop(&mut self) -> Option<T> {
        if let Some(item) = self.spill.pop() {
            return Some(item);
        }
        self.len = self.len.checked_sub(1)?;
        Some(self.inline[self.len])
    }
}

/// Entry distances and hit mask of the node's children.
#[inline(always)]
fn slab(node: &Node8, ray: &BoxRay, t_max: f32) -> ([f32; WIDTH], u32) {
    let (o, inv) = (ray.origin, ray.inv_dir);
    let p = &node.planes;
    let mut near = [0.0f32; WIDTH];
    let mut mask = 0;
    let (ax, ay, az) = (ray.rows(0), ray.rows(1), ray.rows(2));
    // `_mm256_max_ps(a, b)` returns b when either is NaN, as
    // `if a > b { a } else { b }` does.
    let max = |a: f32, b: f32| if a > b { a } else { b };
    let min = |a: f32, b: f32| if a < b { a } else { b };
    for i in 0..WIDTH {
        let nx = (p[ax.0][i] - o.x) * inv.x;
        let ny = (p[ay.0][i] - o.y) * inv.y;
        let nz = (p[az.0][i] - o.z) * inv.z;
        let fx = (p[ax.1][i] - o.x) * inv.x;
        let fy = (p[ay.1][i] - o.y) * inv.y;
        let fz = (p[az.1][i] - o.z) * inv.z;
        let t0 = max(max(nx, ny), max(nz, ray.t_min));
        let t1 = min(min(min(fx, fy), fz) * BOX_FAR_SCALE, t_max);
        near[i] = t0;
        if t0 <= t1 {
            mask |= 1 << i;
        }
    }
    (near, mask)
}

/// Visits the hit children of `node`: returns the nearest in octant
/// order and pushes the others, farthest first.
#[inline(always)]
fn push_children(
    node: &Node8,
    octant: u32,
    near: &[f32; WIDTH],
    mask: u32,
    stack: &mut Stack<(ChildRef, f32)>,
) -> ChildRef {
    let mut nearest = None;
    for place in 0..WIDTH {
        let c = node.ordered(octant, place);
        if mask & (1 << c) != 0 {
            if let Some(previous) = nearest.replace(c) {
                stack.push((node.child[previous], near[previous]));
            }
        }
    }
    node.child[nearest.expect("a child was hit")]
}

/// One ray's walk from `start`, as [`super::avx2::walk`]: the closest hit
/// (`ANY` false) or any hit within `t_max` (`ANY` true). Out of line: only
/// CPUs without AVX2 run it, and inlined it would crowd the callers' fast
/// path.
#[inline(never)]
pub fn walk<const ANY: bool, L: Leaves>(
    tree: &Tree,
    ray: &BoxRay,
    t_max: &mut f32,
    leaves: &mut L,
    work: &mut Work,
    start: ChildRef,
) -> bool {
    let octant = ray.octant();
    let mut stack = Stack::new((0, 0.0));
    let mut current = start;
    let mut hit = false;
    loop {
        if !is_leaf(current) {
            let node = &tree.nodes()[current as usize];
            work.nodes += 1;
            let (near, mask) = slab(node, ray, *t_max);
            if mask != 0 {
                current = if ANY {
                    // Slot order (decreasing size), the last hit slot
                    // first; no distances to keep.
                    let last = 31 - mask.leading_zeros() as usize;
                    for i in (0..last).filter(|i| mask & (1 << i) != 0) {
                        stack.push((node.child[i], 0.0));
                    }
                    node.child[last]
                } else {
                    push_children(node, octant, &near, mask, &mut stack)
                };
                continue;
            }
        } else {
            let count = leaf_count(current);
            work.items += count as u64;
            if ANY {
                if leaves.any(leaf_first(current), count, *t_max) {
                    return true;
                }
            } else if let Some(t) = leaves.nearest(leaf_first(current), count, *t_max) {
                *t_max = t;
                hit = true;
            }
        }
        loop {
            let Some((next, near)) = stack.pop() else {
                return hit;
            };
            if ANY || near <= *t_max {
                current = next;
                break;
            }
        }
    }
}
