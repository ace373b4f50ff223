//! The traversal layout: the binary SAH tree collapsed into a 4-wide BVH
//! (Dammertz et al. 2008, "Shallow bounding volume hierarchies for fast
//! SIMD ray tracing of incoherent rays"), whose four child boxes are stored
//! as structure-of-arrays and tested at once.
//!
//! The four-box slab test uses SSE through `std::arch` on x86_64 (SSE2 is
//! part of the x86_64 baseline, so every x86_64 CPU runs it and no runtime
//! detection is needed) and a scalar loop elsewhere; both compute the same
//! IEEE operations in the same order and give identical answers.

use super::bvh::Bvh;

/// Marks an unused child slot.
const EMPTY: u32 = u32::MAX;
/// Set in `child` for a leaf: the low bits are the first primitive slot.
const LEAF: u32 = 1 << 31;

/// Four children: boxes as SoA, then references. 128 bytes, two cache lines.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct Bvh4Node {
    pub lo_x: [f32; 4],
    pub hi_x: [f32; 4],
    pub lo_y: [f32; 4],
    pub hi_y: [f32; 4],
    pub lo_z: [f32; 4],
    pub hi_z: [f32; 4],
    /// Inner child: node index. Leaf: `LEAF | first slot`. Unused: `EMPTY`.
    pub child: [u32; 4],
    /// Leaf: primitive count; inner: 0.
    pub count: [u32; 4],
}

/// A ray prepared for four-box tests.
#[derive(Clone, Copy, Debug)]
pub struct BoxRay4 {
    pub origin: [f32; 3],
    pub inv_dir: [f32; 3],
}

/// Conservative far-plane scale, see [`super::BOX_FAR_SCALE`].
use super::BOX_FAR_SCALE;

impl BoxRay4 {
    pub fn new(origin: glam::Vec3, inv_dir: glam::Vec3) -> Self {
        BoxRay4 {
            origin: origin.to_array(),
            inv_dir: inv_dir.to_array(),
        }
    }
}

/// A child the ray enters: its reference, primitive count and entry distance.
#[derive(Clone, Copy, Debug, Default)]
pub struct ChildHit {
    pub child: u32,
    pub count: u32,
    pub t_near: f32,
}

#[derive(Clone, Debug, Default)]
pub struct Bvh4 {
    pub nodes: Vec<Bvh4Node>,
    /// The root when the whole tree is a single leaf: `(first, count)`.
    pub root_leaf: Option<(u32, u32)>,
}

impl Bvh4 {
    /// Collapses a binary BVH: each 4-wide node takes the two children of a
    /// binary node and keeps opening the child with the largest surface
    /// area until it has four.
    pub fn from_binary(bvh: &Bvh) -> Bvh4 {
        let mut out = Bvh4::default();
        if bvh.nodes.is_empty() {
            return out;
        }
        if bvh.nodes[0].is_leaf() {
            out.root_leaf = Some((bvh.nodes[0].offset, bvh.nodes[0].count as u32));
            return out;
        }
        collapse(bvh, 0, &mut out.nodes);
        out
    }

    /// Replaces every leaf's first slot with `f(first, count)` (e.g. the
    /// index of the leaf's first triangle block).
    pub fn remap_leaves(&mut self, mut f: impl FnMut(u32, u32) -> u32) {
        if let Some((first, count)) = self.root_leaf {
            self.root_leaf = Some((f(first, count), count));
        }
        for node in &mut self.nodes {
            for i in 0..4 {
                if is_leaf(node.child[i]) {
                    node.child[i] = LEAF | f(leaf_first(node.child[i]), node.count[i]);
                }
            }
        }
    }

    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Bvh4Node>()
    }

    /// The children of `node` that the ray enters within `[t_min, t_max]`.
    #[inline(always)]
    pub fn hit_children(
        node: &Bvh4Node,
        ray: &BoxRay4,
        t_min: f32,
        t_max: f32,
        out: &mut [ChildHit; 4],
    ) -> usize {
        let (mask, near) = slab4(node, ray, t_min, t_max);
        let mut n = 0;
        for i in 0..4 {
            if mask & (1 << i) != 0 && node.child[i] != EMPTY {
                out[n] = ChildHit {
                    child: node.child[i],
                    count: node.count[i],
                    t_near: near[i],
                };
                n += 1;
            }
        }
        n
    }
}

#[inline(always)]
pub fn is_leaf(child: u32) -> bool {
    child & LEAF != 0 && child != EMPTY
}

#[inline(always)]
pub fn leaf_first(child: u32) -> u32 {
    child & !LEAF
}

fn area(b: &crate::scene::Bounds) -> f32 {
    let d = b.extent();
    d.x * d.y + d.y * d.z + d.z * d.x
}

/// Writes the 4-wide node for binary inner node `index`; returns its index.
fn collapse(bvh: &Bvh, index: usize, out: &mut Vec<Bvh4Node>) -> u32 {
    let node = &bvh.nodes[index];
    let mut kids: Vec<usize> = vec![index + 1, node.offset as usize];
    while kids.len() < 4 {
        // Open the inner child with the largest box.
        let best = kids
            .iter()
            .enumerate()
            .filter(|(_, &k)| !bvh.nodes[k].is_leaf())
            .max_by(|a, b| {
                area(&bvh.nodes[*a.1].bounds()).total_cmp(&area(&bvh.nodes[*b.1].bounds()))
            })
            .map(|(i, _)| i);
        let Some(i) = best else { break };
        let k = kids.swap_remove(i);
        kids.push(k + 1);
        kids.push(bvh.nodes[k].offset as usize);
    }
    let me = out.len();
    out.push(Bvh4Node {
        lo_x: [f32::INFINITY; 4],
        hi_x: [f32::NEG_INFINITY; 4],
        lo_y: [f32::INFINITY; 4],
        hi_y: [f32::NEG_INFINITY; 4],
        lo_z: [f32::INFINITY; 4],
        hi_z: [f32::NEG_INFINITY; 4],
        child: [EMPTY; 4],
        count: [0; 4],
    });
    for (slot, &k) in kids.iter().enumerate() {
        let c = &bvh.nodes[k];
        let (child, count) = if c.is_leaf() {
            (LEAF | c.offset, c.count as u32)
        } else {
            (collapse(bvh, k, out), 0)
        };
        let n = &mut out[me];
        n.lo_x[slot] = c.min[0];
        n.lo_y[slot] = c.min[1];
        n.lo_z[slot] = c.min[2];
        n.hi_x[slot] = c.max[0];
        n.hi_y[slot] = c.max[1];
        n.hi_z[slot] = c.max[2];
        n.child[slot] = child;
        n.count[slot] = count;
    }
    me as u32
}

/// Slab test of the four boxes: hit mask and entry distances.
#[inline(always)]
fn slab4(node: &Bvh4Node, ray: &BoxRay4, t_min: f32, t_max: f32) -> (u32, [f32; 4]) {
    #[cfg(target_arch = "x86_64")]
    {
        // SAFETY: SSE and SSE2 are part of the x86_64 baseline; the loads
        // read 16-byte arrays of the 64-byte-aligned node.
        unsafe { slab4_sse(node, ray, t_min, t_max) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        slab4_scalar(node, ray, t_min, t_max)
    }
}

#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn slab4_sse(node: &Bvh4Node, ray: &BoxRay4, t_min: f32, t_max: f32) -> (u32, [f32; 4]) {
    use std::arch::x86_64::*;
    let axis = |lo: &[f32; 4], hi: &[f32; 4], o: f32, inv: f32| {
        let (o, inv) = (_mm_set1_ps(o), _mm_set1_ps(inv));
        let t0 = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(lo.as_ptr()), o), inv);
        let t1 = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(hi.as_ptr()), o), inv);
        (_mm_min_ps(t0, t1), _mm_max_ps(t0, t1))
    };
    let (nx, fx) = axis(&node.lo_x, &node.hi_x, ray.origin[0], ray.inv_dir[0]);
    let (ny, fy) = axis(&node.lo_y, &node.hi_y, ray.origin[1], ray.inv_dir[1]);
    let (nz, fz) = axis(&node.lo_z, &node.hi_z, ray.origin[2], ray.inv_dir[2]);
    let near = _mm_max_ps(_mm_max_ps(nx, ny), _mm_max_ps(nz, _mm_set1_ps(t_min)));
    let far = _mm_mul_ps(
        _mm_min_ps(_mm_min_ps(fx, fy), fz),
        _mm_set1_ps(BOX_FAR_SCALE),
    );
    let far = _mm_min_ps(far, _mm_set1_ps(t_max));
    let mask = _mm_movemask_ps(_mm_cmple_ps(near, far)) as u32;
    let mut out = [0.0f32; 4];
    _mm_storeu_ps(out.as_mut_ptr(), near);
    (mask, out)
}

#[cfg_attr(target_arch = "x86_64", allow(dead_code))]
#[inline(always)]
fn slab4_scalar(node: &Bvh4Node, ray: &BoxRay4, t_min: f32, t_max: f32) -> (u32, [f32; 4]) {
    let mut mask = 0;
    let mut out = [0.0f32; 4];
    // Same operation order as the SSE path; `_mm_min_ps(a, b)` returns b
    // when a is NaN, as `if a < b { a } else { b }` does.
    let min = |a: f32, b: f32| if a < b { a } else { b };
    let max = |a: f32, b: f32| if a > b { a } else { b };
    for i in 0..4 {
        let ax = |lo: f32, hi: f32, o: f32, inv: f32| {
            let (t0, t1) = ((lo - o) * inv, (hi - o) * inv);
            (min(t0, t1), max(t0, t1))
        };
        let (nx, fx) = ax(node.lo_x[i], node.hi_x[i], ray.origin[0], ray.inv_dir[0]);
        let (ny, fy) = ax(node.lo_y[i], node.hi_y[i], ray.origin[1], ray.inv_dir[1]);
        let (nz, fz) = ax(node.lo_z[i], node.hi_z[i], ray.origin[2], ray.inv_dir[2]);
        let near = max(max(nx, ny), max(nz, t_min));
        let far = min(min(min(fx, fy), fz) * BOX_FAR_SCALE, t_max);
        if near <= far {
            mask |= 1 << i;
        }
        out[i] = near;
    }
    (mask, out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::native::bvh::BuildMethod;
    use crate::scene::Bounds;
    use glam::Vec3;

    #[test]
    fn sse_and_scalar_slab_tests_agree() {
        let mut state = 99u64;
        let mut next = || {
            state = state
                .wrapping_mul(6364136223846793005)
                .wrapping_add(1442695040888963407);
            ((state >> 40) as f32) / (1u64 << 24) as f32 * 4.0 - 2.0
        };
        let boxes: Vec<Bounds> = (0..64)
            .map(|_| {
                let c = Vec3::new(next(), next(), next());
                Bounds {
                    min: c - 0.3,
                    max: c + 0.3,
                }
            })
            .collect();
        let wide = Bvh4::from_binary(&Bvh::build(&boxes, 1, BuildMethod::Sah));
        for _ in 0..2000 {
            let dir = Vec3::new(next(), next(), if next() > 0.0 { 0.0 } else { next() });
            let safe = |d: f32| {
                1.0 / if d.abs() < 1e-30 {
                    1e-30f32.copysign(d)
                } else {
                    d
                }
            };
            let ray = BoxRay4::new(
                Vec3::new(next(), next(), next()),
                Vec3::new(safe(dir.x), safe(dir.y), safe(dir.z)),
            );
            for node in &wide.nodes {
                let a = slab4(node, &ray, 0.0, f32::INFINITY);
                let b = slab4_scalar(node, &ray, 0.0, f32::INFINITY);
                assert_eq!(a.0, b.0, "hit masks differ");
                for i in 0..4 {
                    if a.0 & (1 << i) != 0 {
                        assert_eq!(a.1[i].to_bits(), b.1[i].to_bits(), "entry distances differ");
                    }
                }
            }
        }
    }
}
