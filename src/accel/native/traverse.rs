//! Walking the 8-wide tree: closest hit and any hit, each as an AVX2
//! kernel (reached only with an [`Avx2`] token) and a portable scalar
//! twin over the same nodes.
//!
//! Per ray, once: the reciprocal direction, the octant (which picks each
//! axis's near and far plane, so the slab test needs no min/max per axis),
//! and the octant's child order. Per node: one 8-wide slab test; one hit
//! child is descended into directly. With several, closest hit permutes
//! them into the octant's front-to-back order, descends into the nearest
//! and pushes the others in one store (a compress shuffle from
//! [`COMPRESS`]) with their entry distances; its pops skip entries farther
//! than the hit found so far. Any hit needs no order to be correct and pays
//! for none: it descends into the smallest hit child (slots are sorted by
//! size) and pushes the rest as they are, keeps no distances, and stops at
//! the first hit. While a leaf is tested, the next stack entry is
//! prefetched (nodes span four cache lines).
//!
//! Box tests, both conservative (they never cull a box the exact test
//! would enter):
//! - robust: `(plane - o) * (1 / d)` with the far distance scaled by
//!   `1 + 2γ(3)` (Ize 2013, "Robust BVH ray traversal", JCGT 2(2));
//! - fast: one fused multiply-add per plane, `plane * r - c` with
//!   `r = fl(1 / d)` and per-ray constants that scale `o` before the
//!   multiplication by `r`, so that each is one multiplication after the
//!   division (a ray's first box test waits on them). Near planes subtract
//!   `c = fl(fl(o k) r)`, `k = 1 + 2^-22` where `o r` is positive and
//!   `1 - 2^-22` where it is negative: whatever the two roundings, `c`
//!   exceeds `o r` by at least `2u |o r|` (`u = 2^-24`), so near distances
//!   are only lowered. Far planes use `r (1 + 2^-20)` and the same form
//!   with `k = 1 + 2^-20 ∓ 2^-21`, which stays more than `5u |o r|` below
//!   `o r (1 + 2^-20)`. The fused result's own rounding is relative, and
//!   the far planes' `16u` of slack covers it where Ize's form needs about
//!   `6u`. Rays whose constants overflow take the robust form. A test
//!   checks the fast test against the slab test in f64 on boxes that just
//!   touch random rays.

use std::mem::MaybeUninit;

use glam::Vec3A;

use super::cpu::Avx2;
#[cfg(target_arch = "x86_64")]
use super::node::COMPRESS;
use super::node::{is_leaf, leaf_count, leaf_first, ChildRef, Node8, WIDTH};
use super::tree::{Tree, MAX_DEPTH};
use super::BOX_FAR_SCALE;

/// Stack entries: each level leaves at most seven children behind, and a
/// push writes eight.
const STACK: usize = (WIDTH - 1) * MAX_DEPTH + WIDTH + 1;

/// What a leaf test answers; implemented per primitive kind (triangle
/// blocks, watertight triangles, spheres).
pub trait Leaves {
    /// The nearest hit among `count` items from `first` no farther than
    /// `t_max`: its distance. The implementation remembers what it hit.
    fn nearest(&mut self, first: u32, count: u32, t_max: f32) -> Option<f32>;
    /// Whether any of the items is hit within `t_max`.
    fn any(&mut self, first: u32, count: u32, t_max: f32) -> bool;
    /// Where item `first` lives, for prefetching.
    fn address(&self, first: u32) -> *const u8;
}

/// A ray prepared for the slab tests.
#[derive(Clone, Copy, Debug)]
pub struct BoxRay {
    origin: Vec3A,
    inv_dir: Vec3A,
    /// The fast test's constants per axis: near `c`, far `r` and far `c`
    /// (see the module notes).
    fast: [Vec3A; 3],
    t_min: f32,
    /// `dir < 0` per axis: bit 0 x, bit 1 y, bit 2 z.
    negative: u32,
}

impl BoxRay {
    pub fn new(origin: Vec3A, dir: Vec3A, t_min: f32) -> BoxRay {
        // Tiny direction components become 1e-20 of the same sign, so a
        // slab through the origin gives 0 * huge = 0, never 0 * inf, and
        // `o / d` stays finite for any coordinate below 1e18. A ray
        // parallel to a slab is still never culled while inside it. One
        // vector division, the same per lane as three scalar ones.
        let tiny = Vec3A::splat(1e-20);
        let safe = Vec3A::select(dir.abs().cmplt(tiny), tiny.copysign(dir), dir);
        let inv = Vec3A::ONE / safe;
        // The fast constants scale `o` by factors picked by the sign of
        // `o r` (a product's sign is exact, even when it underflows), so
        // they take one multiplication each after the division: a ray's
        // first box test waits on this.
        let sign = origin * safe;
        let near_k = Vec3A::ONE + Vec3A::splat(FAST_NEAR_MARGIN).copysign(sign);
        let far_k = Vec3A::splat(FAST_FAR_SCALE) - Vec3A::splat(FAST_FAR_MARGIN).copysign(sign);
        BoxRay {
            origin,
            inv_dir: inv,
            fast: [
                origin * near_k * inv,
                inv * FAST_FAR_SCALE,
                origin * far_k * inv,
            ],
            t_min,
            // From `safe`, not `inv` (the same signs): the rows of the
            // planes a node test loads do not wait for the division.
            negative: safe.cmplt(Vec3A::ZERO).bitmask(),
        }
    }

    /// Whether the fast box test's constants are finite for this ray.
    #[inline(always)]
    fn fast_test_fits(&self) -> bool {
        self.fast[0].is_finite() & self.fast[2].is_finite()
    }

    /// Octant index of the child orders: bit set for a positive direction.
    #[inline(always)]
    fn octant(&self) -> u32 {
        !self.negative & 7
    }

    /// Rows of `Node8::planes` holding the near and far planes of `axis`.
    #[inline(always)]
    fn rows(&self, axis: usize) -> (usize, usize) {
        let near = 2 * axis + ((self.negative >> axis) & 1) as usize;
        (near, near ^ 1)
    }
}

/// Work counted during one traversal.
#[derive(Clone, Copy, Debug, Default)]
pub struct Work {
    pub nodes: u64,
    pub items: u64,
}

/// Relative slack of the fast box test's far planes (see the module notes).
const FAST_FAR_SCALE: f32 = 1.0 + 1.0 / (1 << 20) as f32;
/// Absolute margins of the fast box test, relative to `|o / d|`.
const FAST_NEAR_MARGIN: f32 = 1.0 / (1 << 22) as f32;
const FAST_FAR_MARGIN: f32 = 1.0 / (1 << 21) as f32;

/// Which box test a traversal runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoxTest {
    Robust,
    Fast,
}

/// The closest hit: shrinks `t_max` to its distance; true if anything was
/// hit. `cpu` picks the AVX2 kernel.
#[inline(always)]
pub fn closest<L: Leaves>(
    tree: &Tree,
    ray: &BoxRay,
    t_max: &mut f32,
    leaves: &mut L,
    cpu: Option<Avx2>,
    test: BoxTest,
    work: &mut Work,
) -> bool {
    if tree.is_empty() {
        return false;
    }
    #[cfg(target_arch = "x86_64")]
    if let Some(cpu) = cpu {
        // SAFETY: the token proves the CPU has the kernels' features.
        return unsafe {
            if test == BoxTest::Fast && ray.fast_test_fits() {
                avx2::closest::<false, L>(cpu, tree, ray, t_max, leaves, work)
            } else {
                avx2::closest::<true, L>(cpu, tree, ray, t_max, leaves, work)
            }
        };
    }
    let _ = (cpu, test);
    scalar::closest(tree, ray, t_max, leaves, work)
}

/// Whether anything lies within `t_max`.
#[inline(always)]
pub fn any<L: Leaves>(
    tree: &Tree,
    ray: &BoxRay,
    t_max: f32,
    leaves: &mut L,
    cpu: Option<Avx2>,
    test: BoxTest,
    work: &mut Work,
) -> bool {
    if tree.is_empty() {
        return false;
    }
    #[cfg(target_arch = "x86_64")]
    if let Some(cpu) = cpu {
        // SAFETY: the token proves the CPU has the kernels' features.
        return unsafe {
            if test == BoxTest::Fast && ray.fast_test_fits() {
                avx2::any::<false, L>(cpu, tree, ray, t_max, leaves, work)
            } else {
                avx2::any::<true, L>(cpu, tree, ray, t_max, leaves, work)
            }
        };
    }
    let _ = (cpu, test);
    scalar::any(tree, ray, t_max, leaves, work)
}

/// The portable kernels: the robust box test lane by lane, children
/// visited in the same octant order as the AVX2 kernels.
mod scalar {
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

    /// Out of line: only CPUs without AVX2 run it, and inlined it would
    /// crowd the callers' fast path.
    #[inline(never)]
    pub fn closest<L: Leaves>(
        tree: &Tree,
        ray: &BoxRay,
        t_max: &mut f32,
        leaves: &mut L,
        work: &mut Work,
    ) -> bool {
        let octant = ray.octant();
        let mut stack = Stack::new((0, 0.0));
        let mut current: ChildRef = 0;
        let mut hit = false;
        loop {
            if !is_leaf(current) {
                let node = &tree.nodes()[current as usize];
                work.nodes += 1;
                let (near, mask) = slab(node, ray, *t_max);
                if mask != 0 {
                    current = push_children(node, octant, &near, mask, &mut stack);
                    continue;
                }
            } else {
                let count = leaf_count(current);
                work.items += count as u64;
                if let Some(t) = leaves.nearest(leaf_first(current), count, *t_max) {
                    *t_max = t;
                    hit = true;
                }
            }
            loop {
                let Some((next, near)) = stack.pop() else {
                    return hit;
                };
                if near <= *t_max {
                    current = next;
                    break;
                }
            }
        }
    }

    /// Out of line, as [`closest`].
    #[inline(never)]
    pub fn any<L: Leaves>(
        tree: &Tree,
        ray: &BoxRay,
        t_max: f32,
        leaves: &mut L,
        work: &mut Work,
    ) -> bool {
        let mut stack = Stack::new(0);
        let mut current: ChildRef = 0;
        loop {
            if !is_leaf(current) {
                let node = &tree.nodes()[current as usize];
                work.nodes += 1;
                let (_, mask) = slab(node, ray, t_max);
                if mask != 0 {
                    // Slot order (decreasing size), the last hit slot first.
                    let last = 31 - mask.leading_zeros() as usize;
                    for i in (0..last).filter(|i| mask & (1 << i) != 0) {
                        stack.push(node.child[i]);
                    }
                    current = node.child[last];
                    continue;
                }
            } else {
                let count = leaf_count(current);
                work.items += count as u64;
                if leaves.any(leaf_first(current), count, t_max) {
                    return true;
                }
            }
            match stack.pop() {
                Some(next) => current = next,
                None => return false,
            }
        }
    }
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use std::arch::x86_64::*;

    use super::*;

    /// The per-ray constants of the 8-wide slab test. Robust form: near
    /// and far planes `(plane - a) * near_r`, `(plane - a) * far_r` with
    /// `a` the origin; fast form: `plane * near_r - near_c` and
    /// `plane * far_r - far_c`.
    struct Lanes {
        near_r: [__m256; 3],
        near_c: [__m256; 3],
        far_r: [__m256; 3],
        far_c: [__m256; 3],
        t_min: __m256,
        rows: [(usize, usize); 3],
        octant: u32,
        /// Shift that selects the octant's 3-bit field of `Node8::order`.
        shift: __m128i,
    }

    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    #[inline]
    fn lanes<const ROBUST: bool>(ray: &BoxRay) -> Lanes {
        let splat = |v: Vec3A| v.to_array().map(|x| _mm256_set1_ps(x));
        let (near_c, far_r, far_c) = if ROBUST {
            (ray.origin, ray.inv_dir, ray.origin)
        } else {
            (ray.fast[0], ray.fast[1], ray.fast[2])
        };
        Lanes {
            near_r: splat(ray.inv_dir),
            near_c: splat(near_c),
            far_r: splat(far_r),
            far_c: splat(far_c),
            t_min: _mm256_set1_ps(ray.t_min),
            rows: [ray.rows(0), ray.rows(1), ray.rows(2)],
            octant: ray.octant(),
            shift: _mm_cvtsi32_si128(3 * ray.octant() as i32),
        }
    }

    /// The 8-wide slab test: entry distances and the hit lanes.
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    #[inline]
    unsafe fn slab<const ROBUST: bool>(node: &Node8, l: &Lanes, t_max: __m256) -> (__m256, __m256) {
        let plane = |row: usize| _mm256_load_ps(node.planes[row].as_ptr());
        let near_t = |axis: usize| {
            let p = plane(l.rows[axis].0);
            if ROBUST {
                _mm256_mul_ps(_mm256_sub_ps(p, l.near_c[axis]), l.near_r[axis])
            } else {
                _mm256_fmsub_ps(p, l.near_r[axis], l.near_c[axis])
            }
        };
        let far_t = |axis: usize| {
            let p = plane(l.rows[axis].1);
            if ROBUST {
                _mm256_mul_ps(_mm256_sub_ps(p, l.far_c[axis]), l.far_r[axis])
            } else {
                _mm256_fmsub_ps(p, l.far_r[axis], l.far_c[axis])
            }
        };
        let near = _mm256_max_ps(
            _mm256_max_ps(near_t(0), near_t(1)),
            _mm256_max_ps(near_t(2), l.t_min),
        );
        let far = _mm256_min_ps(_mm256_min_ps(far_t(0), far_t(1)), far_t(2));
        let far = if ROBUST {
            _mm256_mul_ps(far, _mm256_set1_ps(BOX_FAR_SCALE))
        } else {
            far
        };
        let far = _mm256_min_ps(far, t_max);
        (near, _mm256_cmp_ps::<_CMP_LE_OQ>(near, far))
    }

    /// Asks for the four cache lines of `r`'s node or first leaf item
    /// (prefetches never fault, whatever the address).
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    #[inline]
    fn prefetch<L: Leaves>(tree: &Tree, leaves: &L, r: ChildRef) {
        let p = if is_leaf(r) {
            leaves.address(leaf_first(r))
        } else {
            tree.nodes().as_ptr().wrapping_add(r as usize).cast::<u8>()
        };
        for line in 0..4 {
            _mm_prefetch::<_MM_HINT_T0>(p.wrapping_add(64 * line).cast());
        }
    }

    /// Closest-hit's push: hit children in the octant's order; the nearest
    /// is returned, the others and their entry distances written to the
    /// stack at `*top`, which advances past them.
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    #[inline]
    unsafe fn push(
        node: &Node8,
        l: &Lanes,
        near: __m256,
        hit: __m256,
        refs: *mut ChildRef,
        dists: *mut f32,
        top: &mut usize,
    ) -> ChildRef {
        let order = _mm256_srl_epi32(_mm256_load_si256(node.order.as_ptr().cast()), l.shift);
        let sorted = _mm256_movemask_ps(_mm256_permutevar8x32_ps(hit, order)) as usize;
        let children =
            _mm256_permutevar8x32_epi32(_mm256_load_si256(node.child.as_ptr().cast()), order);
        let nearest = 31 - (sorted as u32).leading_zeros();
        let pack = _mm256_loadu_si256(COMPRESS[sorted].as_ptr().cast());
        _mm256_storeu_si256(
            refs.add(*top).cast(),
            _mm256_permutevar8x32_epi32(children, pack),
        );
        let d = _mm256_permutevar8x32_ps(near, order);
        _mm256_storeu_ps(dists.add(*top), _mm256_permutevar8x32_ps(d, pack));
        *top += sorted.count_ones() as usize - 1;
        node.child[node.ordered(l.octant, nearest as usize)]
    }

    /// Any-hit's push: no order to compute, the hit children in slot
    /// order (decreasing size); returns the last, the smallest, and writes
    /// the others to the stack at `*top`.
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    #[inline]
    unsafe fn push_any(node: &Node8, mask: u32, refs: *mut ChildRef, top: &mut usize) -> ChildRef {
        let pack = _mm256_loadu_si256(COMPRESS[mask as usize].as_ptr().cast());
        let children = _mm256_load_si256(node.child.as_ptr().cast());
        _mm256_storeu_si256(
            refs.add(*top).cast(),
            _mm256_permutevar8x32_epi32(children, pack),
        );
        *top += mask.count_ones() as usize - 1;
        node.child[31 - mask.leading_zeros() as usize]
    }

    /// # Safety
    /// Needs the token's CPU features (AVX2, FMA, bit counting) and a
    /// non-empty `tree`; its type proves the rest (references in range,
    /// depth at most [`MAX_DEPTH`], so the stack holds every push).
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    pub unsafe fn closest<const ROBUST: bool, L: Leaves>(
        _cpu: Avx2,
        tree: &Tree,
        ray: &BoxRay,
        t_max: &mut f32,
        leaves: &mut L,
        work: &mut Work,
    ) -> bool {
        let l = lanes::<ROBUST>(ray);
        let mut refs = [MaybeUninit::<ChildRef>::uninit(); STACK];
        let mut dists = [MaybeUninit::<f32>::uninit(); STACK];
        let (refs, dists) = (
            refs.as_mut_ptr().cast::<ChildRef>(),
            dists.as_mut_ptr().cast::<f32>(),
        );
        let mut top = 0usize;
        let mut far = _mm256_set1_ps(*t_max);
        let mut current: ChildRef = 0;
        let mut hit = false;
        loop {
            if !is_leaf(current) {
                // SAFETY: `current` is the root of a non-empty tree or an
                // inner reference read from one of its nodes.
                let node = tree.node_unchecked(current);
                work.nodes += 1;
                let (near, hits) = slab::<ROBUST>(node, &l, far);
                let mask = _mm256_movemask_ps(hits) as u32;
                if mask != 0 {
                    current = if mask & (mask - 1) == 0 {
                        node.child[mask.trailing_zeros() as usize]
                    } else {
                        // SAFETY: `top` stays below STACK - WIDTH: every
                        // level leaves at most seven entries and the depth
                        // is bounded by MAX_DEPTH.
                        push(node, &l, near, hits, refs, dists, &mut top)
                    };
                    continue;
                }
            } else {
                if top > 0 {
                    // The next entry is fetched while the leaf is tested.
                    // SAFETY: entries below `top` were written by `push`.
                    prefetch(tree, leaves, *refs.add(top - 1));
                }
                let count = leaf_count(current);
                work.items += count as u64;
                if let Some(t) = leaves.nearest(leaf_first(current), count, *t_max) {
                    *t_max = t;
                    far = _mm256_set1_ps(t);
                    hit = true;
                }
            }
            loop {
                if top == 0 {
                    return hit;
                }
                top -= 1;
                // SAFETY: entries below `top` were written by `push`.
                if *dists.add(top) <= *t_max {
                    current = *refs.add(top);
                    break;
                }
            }
        }
    }

    /// # Safety
    /// As [`closest`].
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    pub unsafe fn any<const ROBUST: bool, L: Leaves>(
        _cpu: Avx2,
        tree: &Tree,
        ray: &BoxRay,
        t_max: f32,
        leaves: &mut L,
        work: &mut Work,
    ) -> bool {
        let l = lanes::<ROBUST>(ray);
        let mut refs = [MaybeUninit::<ChildRef>::uninit(); STACK];
        let refs = refs.as_mut_ptr().cast::<ChildRef>();
        let mut top = 0usize;
        let far = _mm256_set1_ps(t_max);
        let mut current: ChildRef = 0;
        loop {
            if !is_leaf(current) {
                // SAFETY: as in `closest`.
                let node = tree.node_unchecked(current);
                work.nodes += 1;
                let (_, hits) = slab::<ROBUST>(node, &l, far);
                let mask = _mm256_movemask_ps(hits) as u32;
                if mask != 0 {
                    current = if mask & (mask - 1) == 0 {
                        node.child[mask.trailing_zeros() as usize]
                    } else {
                        push_any(node, mask, refs, &mut top)
                    };
                    continue;
                }
            } else {
                if top > 0 {
                    // The next entry is fetched while the leaf is tested.
                    // SAFETY: entries below `top` were written by `push`.
                    prefetch(tree, leaves, *refs.add(top - 1));
                }
                let count = leaf_count(current);
                work.items += count as u64;
                if leaves.any(leaf_first(current), count, t_max) {
                    return true;
                }
            }
            if top == 0 {
                return false;
            }
            top -= 1;
            // SAFETY: entries below `top` were written by `push`.
            current = *refs.add(top);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::sampling::Rng;
    use glam::{DVec3, Vec3};

    /// The fast test of one box as the AVX2 kernel computes it: one fused
    /// multiply-add per plane, near planes by the octant.
    fn fast_enters(ray: &BoxRay, lo: Vec3A, hi: Vec3A, t_max: f32) -> bool {
        let [near_c, far_r, far_c] = ray.fast;
        let r = ray.inv_dir;
        let (mut near, mut far) = (ray.t_min, t_max);
        for a in 0..3 {
            let (n, f) = if r[a] < 0.0 {
                (hi[a], lo[a])
            } else {
                (lo[a], hi[a])
            };
            near = near.max(n.mul_add(r[a], -near_c[a]));
            far = far.min(f.mul_add(far_r[a], -far_c[a]));
        }
        near <= far
    }

    /// The slab test in f64 on the f32 inputs, with the true `1 / d`.
    fn exact_enters(o: Vec3A, d: Vec3A, lo: Vec3A, hi: Vec3A, t_max: f32) -> bool {
        let (o, d) = (DVec3::from(Vec3::from(o)), DVec3::from(Vec3::from(d)));
        let (lo, hi) = (DVec3::from(Vec3::from(lo)), DVec3::from(Vec3::from(hi)));
        let (a, b) = ((lo - o) / d, (hi - o) / d);
        let near = a.min(b).max_element().max(0.0);
        let far = a.max(b).min_element().min(f64::from(t_max));
        near <= far
    }

    #[test]
    fn the_fast_box_test_never_culls_a_box_the_ray_touches() {
        let mut rng = Rng::new(11, 4);
        let mut touched = 0;
        for i in 0..400_000 {
            let scale = 10f32.powi(i % 10 - 3);
            let mut f = |s: f32| (2.0 * rng.next_f32() - 1.0) * s;
            let o = Vec3A::new(f(scale), f(scale), f(scale));
            // Some directions nearly parallel to an axis or a plane.
            let mut d = Vec3A::new(f(1.0), f(1.0), f(1.0));
            if i % 3 == 0 {
                d[i as usize % 3] *= 1e-6;
            }
            if d.cmpeq(Vec3A::ZERO).any() {
                continue;
            }
            let t_max = if i % 2 == 0 {
                f32::INFINITY
            } else {
                3.0 * scale
            };
            // A box with a corner on the ray (rounded to f32), so that
            // many of them are only just touched, or just missed.
            let t = f64::from(rng.next_f32() * 2.0 * scale);
            let on = (DVec3::from(Vec3::from(o)) + DVec3::from(Vec3::from(d)) * t).as_vec3();
            let (mut lo, mut hi) = (Vec3A::from(on), Vec3A::from(on));
            for a in 0..3 {
                let e = match rng.next_u32() % 3 {
                    0 => 0.0,
                    1 => scale * 1e-7 * rng.next_f32(),
                    _ => scale * rng.next_f32(),
                };
                if rng.next_u32().is_multiple_of(2) {
                    lo[a] -= e;
                } else {
                    hi[a] += e;
                }
            }
            let ray = BoxRay::new(o, d, 0.0);
            assert!(ray.fast_test_fits());
            if exact_enters(o, d, lo, hi, t_max) {
                touched += 1;
                assert!(
                    fast_enters(&ray, lo, hi, t_max),
                    "culled: o {o} d {d} box {lo}..{hi} t_max {t_max}"
                );
            }
        }
        // About a sixth of the boxes are touched; the test means nothing
        // if few were.
        assert!(touched > 50_000, "only {touched} boxes touched");
    }
}
