//! The traversal layout: the binary SAH tree collapsed into an N-wide BVH
//! (Dammertz et al. 2008, "Shallow bounding volume hierarchies for fast
//! SIMD ray tracing of incoherent rays"), whose child boxes are stored as
//! structure-of-arrays and tested at once.
//!
//! Widths and instruction sets:
//! - 8-wide, AVX (`std::arch`, `#[target_feature(enable = "avx")]`), built
//!   only when `is_x86_feature_detected!("avx")` says the CPU has it;
//! - 4-wide, SSE, on every x86_64 CPU (SSE2 is part of the x86_64 baseline);
//! - the same 4-wide tree with a scalar slab test on other architectures.
//!
//! Every SIMD slab test has a scalar twin with the same IEEE operations in
//! the same order; tests prove they give identical answers.

use super::bvh::Bvh;
use super::BOX_FAR_SCALE;

/// Marks an unused child slot.
const EMPTY: u32 = u32::MAX;
/// Set in `child` for a leaf: the low bits are the first primitive slot.
const LEAF: u32 = 1 << 31;

/// N children: boxes as SoA, then references.
#[derive(Clone, Copy, Debug)]
#[repr(C, align(64))]
pub struct WideNode<const N: usize> {
    pub lo_x: [f32; N],
    pub hi_x: [f32; N],
    pub lo_y: [f32; N],
    pub hi_y: [f32; N],
    pub lo_z: [f32; N],
    pub hi_z: [f32; N],
    /// Inner child: node index. Leaf: `LEAF | first slot`. Unused: `EMPTY`.
    pub child: [u32; N],
    /// Leaf: primitive count; inner: 0.
    pub count: [u32; N],
}

impl<const N: usize> WideNode<N> {
    fn empty() -> Self {
        WideNode {
            lo_x: [f32::INFINITY; N],
            hi_x: [f32::NEG_INFINITY; N],
            lo_y: [f32::INFINITY; N],
            hi_y: [f32::NEG_INFINITY; N],
            lo_z: [f32::INFINITY; N],
            hi_z: [f32::NEG_INFINITY; N],
            child: [EMPTY; N],
            count: [0; N],
        }
    }
}

/// A ray prepared for slab tests.
#[derive(Clone, Copy, Debug)]
pub struct BoxRay {
    pub origin: [f32; 3],
    pub inv_dir: [f32; 3],
}

impl BoxRay {
    pub fn new(origin: glam::Vec3, inv_dir: glam::Vec3) -> Self {
        BoxRay {
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

/// An N-wide tree. A `BvhWide<8>` exists only on CPUs with AVX: its only
/// constructor checks, which is what makes its AVX slab test sound.
#[derive(Clone, Debug)]
pub struct BvhWide<const N: usize> {
    pub nodes: Vec<WideNode<N>>,
    /// The root when the whole tree is a single leaf: `(first, count)`.
    pub root_leaf: Option<(u32, u32)>,
    /// Entries the traversal stack can hold at most: N - 1 deferred
    /// children per level, plus the root.
    pub max_stack: usize,
}

pub type Bvh4 = BvhWide<4>;
pub type Bvh8 = BvhWide<8>;

impl Bvh4 {
    pub fn from_binary(bvh: &Bvh) -> Bvh4 {
        BvhWide::collapse_from(bvh)
    }
}

impl Bvh8 {
    /// The 8-wide tree, or `None` when the CPU lacks AVX.
    pub fn from_binary(bvh: &Bvh) -> Option<Bvh8> {
        avx_available().then(|| BvhWide::collapse_from(bvh))
    }
}

/// Whether this CPU runs the 8-wide AVX traversal.
pub fn avx_available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        is_x86_feature_detected!("avx")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

impl<const N: usize> BvhWide<N> {
    /// Collapses a binary BVH: each wide node takes the two children of a
    /// binary node and keeps opening the child with the largest surface
    /// area until it has N.
    fn collapse_from(bvh: &Bvh) -> Self {
        let mut out = BvhWide {
            nodes: Vec::new(),
            root_leaf: None,
            max_stack: 1,
        };
        if bvh.nodes.is_empty() {
            return out;
        }
        if bvh.nodes[0].is_leaf() {
            out.root_leaf = Some((bvh.nodes[0].offset, bvh.nodes[0].count as u32));
            return out;
        }
        collapse(bvh, 0, &mut out.nodes);
        out.max_stack = (N - 1) * out.depth() + N;
        out
    }

    /// Number of node levels.
    fn depth(&self) -> usize {
        fn walk<const N: usize>(nodes: &[WideNode<N>], i: usize) -> usize {
            let n = &nodes[i];
            1 + (0..N)
                .filter(|&k| n.child[k] != EMPTY && !is_leaf(n.child[k]))
                .map(|k| walk(nodes, n.child[k] as usize))
                .max()
                .unwrap_or(0)
        }
        if self.nodes.is_empty() {
            0
        } else {
            walk(&self.nodes, 0)
        }
    }

    /// Replaces every leaf's first slot with `f(first, count)` (e.g. the
    /// index of the leaf's first triangle block).
    pub fn remap_leaves(&mut self, mut f: impl FnMut(u32, u32) -> u32) {
        if let Some((first, count)) = self.root_leaf {
            self.root_leaf = Some((f(first, count), count));
        }
        for node in &mut self.nodes {
            for i in 0..N {
                if is_leaf(node.child[i]) {
                    node.child[i] = LEAF | f(leaf_first(node.child[i]), node.count[i]);
                }
            }
        }
    }

    pub fn memory_bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<WideNode<N>>()
    }

    /// The children of `node` that the ray enters within `[t_min, t_max]`;
    /// returns how many were written to `out`.
    #[inline(always)]
    pub fn hit_children(
        &self,
        node: &WideNode<N>,
        ray: &BoxRay,
        t_min: f32,
        t_max: f32,
        out: &mut [ChildHit; N],
    ) -> usize {
        let mut near = [0.0f32; N];
        let mask = slab(node, ray, t_min, t_max, &mut near);
        let mut n = 0;
        for i in 0..N {
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

/// Writes the wide node for binary inner node `index`; returns its index.
fn collapse<const N: usize>(bvh: &Bvh, index: usize, out: &mut Vec<WideNode<N>>) -> u32 {
    let node = &bvh.nodes[index];
    let mut kids: Vec<usize> = vec![index + 1, node.offset as usize];
    while kids.len() < N {
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
    out.push(WideNode::empty());
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

/// The node's box arrays as one run of floats (a pointer to the whole
/// `repr(C)` node, whose first six fields are the `[f32; N]` arrays).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn node_floats<const N: usize>(node: &WideNode<N>) -> *const f32 {
    (node as *const WideNode<N>).cast::<f32>()
}

/// Slab test of the N boxes: hit mask, entry distances in `near`.
#[inline(always)]
fn slab<const N: usize>(
    node: &WideNode<N>,
    ray: &BoxRay,
    t_min: f32,
    t_max: f32,
    near: &mut [f32; N],
) -> u32 {
    #[cfg(target_arch = "x86_64")]
    {
        if N == 4 {
            // SAFETY: SSE/SSE2 are part of the x86_64 baseline.
            return unsafe { slab4_sse(node_floats(node), ray, t_min, t_max, near.as_mut_ptr()) };
        }
        if N == 8 {
            // SAFETY: a `WideNode<8>` lives only in a `Bvh8`, which is only
            // built after `avx_available()` returned true.
            return unsafe { slab8_avx(node_floats(node), ray, t_min, t_max, near.as_mut_ptr()) };
        }
    }
    slab_scalar(node, ray, t_min, t_max, near)
}

/// The SSE test of a 4-wide node. `boxes` points at the node's six
/// consecutive `[f32; 4]` arrays (`lo_x, hi_x, lo_y, hi_y, lo_z, hi_z`).
#[cfg(target_arch = "x86_64")]
#[inline(always)]
unsafe fn slab4_sse(
    boxes: *const f32,
    ray: &BoxRay,
    t_min: f32,
    t_max: f32,
    near_out: *mut f32,
) -> u32 {
    use std::arch::x86_64::*;
    let axis = |k: usize, o: f32, inv: f32| {
        let (o, inv) = (_mm_set1_ps(o), _mm_set1_ps(inv));
        let t0 = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(boxes.add(8 * k)), o), inv);
        let t1 = _mm_mul_ps(_mm_sub_ps(_mm_loadu_ps(boxes.add(8 * k + 4)), o), inv);
        (_mm_min_ps(t0, t1), _mm_max_ps(t0, t1))
    };
    let (nx, fx) = axis(0, ray.origin[0], ray.inv_dir[0]);
    let (ny, fy) = axis(1, ray.origin[1], ray.inv_dir[1]);
    let (nz, fz) = axis(2, ray.origin[2], ray.inv_dir[2]);
    let near = _mm_max_ps(_mm_max_ps(nx, ny), _mm_max_ps(nz, _mm_set1_ps(t_min)));
    let far = _mm_mul_ps(
        _mm_min_ps(_mm_min_ps(fx, fy), fz),
        _mm_set1_ps(BOX_FAR_SCALE),
    );
    let far = _mm_min_ps(far, _mm_set1_ps(t_max));
    _mm_storeu_ps(near_out, near);
    _mm_movemask_ps(_mm_cmple_ps(near, far)) as u32
}

/// The AVX test of an 8-wide node, laid out as in [`slab4_sse`] with
/// `[f32; 8]` arrays. Callers guarantee AVX is available.
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx")]
#[inline]
unsafe fn slab8_avx(
    boxes: *const f32,
    ray: &BoxRay,
    t_min: f32,
    t_max: f32,
    near_out: *mut f32,
) -> u32 {
    use std::arch::x86_64::*;
    let axis = |k: usize, o: f32, inv: f32| {
        let (o, inv) = (_mm256_set1_ps(o), _mm256_set1_ps(inv));
        let t0 = _mm256_mul_ps(_mm256_sub_ps(_mm256_loadu_ps(boxes.add(16 * k)), o), inv);
        let t1 = _mm256_mul_ps(
            _mm256_sub_ps(_mm256_loadu_ps(boxes.add(16 * k + 8)), o),
            inv,
        );
        (_mm256_min_ps(t0, t1), _mm256_max_ps(t0, t1))
    };
    let (nx, fx) = axis(0, ray.origin[0], ray.inv_dir[0]);
    let (ny, fy) = axis(1, ray.origin[1], ray.inv_dir[1]);
    let (nz, fz) = axis(2, ray.origin[2], ray.inv_dir[2]);
    let near = _mm256_max_ps(
        _mm256_max_ps(nx, ny),
        _mm256_max_ps(nz, _mm256_set1_ps(t_min)),
    );
    let far = _mm256_mul_ps(
        _mm256_min_ps(_mm256_min_ps(fx, fy), fz),
        _mm256_set1_ps(BOX_FAR_SCALE),
    );
    let far = _mm256_min_ps(far, _mm256_set1_ps(t_max));
    _mm256_storeu_ps(near_out, near);
    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32
}

/// The scalar twin of the SIMD slab tests.
#[inline(always)]
fn slab_scalar<const N: usize>(
    node: &WideNode<N>,
    ray: &BoxRay,
    t_min: f32,
    t_max: f32,
    near_out: &mut [f32; N],
) -> u32 {
    let mut mask = 0;
    // `_mm_min_ps(a, b)` returns b when a is NaN, as `if a < b { a } else { b }`.
    let min = |a: f32, b: f32| if a < b { a } else { b };
    let max = |a: f32, b: f32| if a > b { a } else { b };
    for i in 0..N {
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
        near_out[i] = near;
    }
    mask
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::accel::native::bvh::BuildMethod;
    use crate::scene::Bounds;
    use glam::Vec3;

    fn agree<const N: usize>(tree: &BvhWide<N>, next: &mut impl FnMut() -> f32) {
        for _ in 0..2000 {
            let dir = Vec3::new(next(), next(), if next() > 0.0 { 0.0 } else { next() });
            let safe = |d: f32| {
                1.0 / if d.abs() < 1e-30 {
                    1e-30f32.copysign(d)
                } else {
                    d
                }
            };
            let ray = BoxRay::new(
                Vec3::new(next(), next(), next()),
                Vec3::new(safe(dir.x), safe(dir.y), safe(dir.z)),
            );
            for node in &tree.nodes {
                let (mut a, mut b) = ([0.0f32; N], [0.0f32; N]);
                let ma = slab(node, &ray, 0.0, f32::INFINITY, &mut a);
                let mb = slab_scalar(node, &ray, 0.0, f32::INFINITY, &mut b);
                assert_eq!(ma, mb, "{N}-wide hit masks differ");
                for i in 0..N {
                    if ma & (1 << i) != 0 {
                        assert_eq!(
                            a[i].to_bits(),
                            b[i].to_bits(),
                            "{N}-wide entry distances differ"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn simd_and_scalar_slab_tests_agree() {
        let mut state = 99u64;
        let mut next = move || {
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
        let binary = Bvh::build(&boxes, 1, BuildMethod::Sah);
        agree(&Bvh4::from_binary(&binary), &mut next);
        match Bvh8::from_binary(&binary) {
            Some(wide) => agree(&wide, &mut next),
            None => eprintln!("no AVX on this CPU: the 8-wide test is not run"),
        }
    }
}
