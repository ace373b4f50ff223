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

#[cfg(target_arch = "x86_64")]
use super::node::COMPRESS;
use super::node::{is_leaf, leaf_count, leaf_first, ChildRef, Node8, WIDTH};
use super::tree::{Tree, MAX_DEPTH};
use super::BOX_FAR_SCALE;
use crate::simd::cpu::Avx2;

/// Stack entries: each level leaves at most seven children behind, and a
/// push writes eight.
const STACK: usize = (WIDTH - 1) * MAX_DEPTH + WIDTH + 1;

/// A kernel's traversal stack, 64-byte aligned. A local this aligned makes
/// the compiler realign the kernel's frame, which also gives its 32-byte
/// vector spills (the ray's broadcast constants, reloaded at every node)
/// 32-byte aligned slots. Without it the frame is only 16-byte aligned,
/// the spills land wherever the caller's stack leaves them, and where they
/// straddle cache lines every node pays split loads: single-ray traversal
/// ran 20-30% slower in one of every few stack placements (the
/// environment's size alone moved it; docs/design.md, Measuring).
#[repr(C, align(64))]
struct AlignedStack<T>([MaybeUninit<T>; STACK]);

impl<T: Copy> AlignedStack<T> {
    #[inline(always)]
    fn new() -> Self {
        AlignedStack([MaybeUninit::uninit(); STACK])
    }

    #[inline(always)]
    fn as_mut_ptr(&mut self) -> *mut T {
        self.0.as_mut_ptr().cast()
    }
}

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

/// What a leaf test answers for a packet's rays at once (lanes of
/// width `W`); implemented for triangle blocks.
#[cfg(target_arch = "x86_64")]
pub trait PacketLeaves<W: packet::Width> {
    /// For each ray (lane) in `mask`, the nearest hit among `count` items
    /// from `first` no farther than its `t_max`, which shrinks to it; the
    /// lanes hit. The implementation remembers what each lane hit.
    ///
    /// # Safety
    /// Only from `W`'s `#[target_feature]` code ([`packet::Width`]).
    unsafe fn nearest(
        &mut self,
        first: u32,
        count: u32,
        mask: u32,
        t_max: &mut [f32; packet::MAX_LANES],
    ) -> u32;
    /// The rays in `mask` that hit anything within their `t_max`.
    ///
    /// # Safety
    /// As [`PacketLeaves::nearest`].
    unsafe fn any(
        &mut self,
        first: u32,
        count: u32,
        mask: u32,
        t_max: &[f32; packet::MAX_LANES],
    ) -> u32;
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

    /// Whether the fast box test's constants are finite for this ray. By
    /// comparisons, not `Vec3A::is_finite`: glam does not inline that one,
    /// so a crate built without LTO paid a call per ray for it.
    #[inline(always)]
    fn fast_test_fits(&self) -> bool {
        let infinity = Vec3A::splat(f32::INFINITY);
        (self.fast[0].abs().cmplt(infinity) & self.fast[2].abs().cmplt(infinity)).all()
    }

    /// Whether the ray enters the box `[lo, hi]` within `t_max`, by the
    /// robust test (conservative: never false for a box it touches).
    #[inline(always)]
    pub fn enters(&self, [lo, hi]: [Vec3A; 2], t_max: f32) -> bool {
        if (self.origin.cmpge(lo) & self.origin.cmple(hi)).all() {
            return true;
        }
        let a = (lo - self.origin) * self.inv_dir;
        let b = (hi - self.origin) * self.inv_dir;
        let near = a.min(b).max_element().max(self.t_min);
        let far = (a.max(b).min_element() * BOX_FAR_SCALE).min(t_max);
        near <= far
    }

    /// Octant index of the child orders: bit set for a positive direction.
    #[inline(always)]
    pub(super) fn octant(&self) -> u32 {
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
pub(super) const FAST_FAR_SCALE: f32 = 1.0 + 1.0 / (1 << 20) as f32;
/// Absolute margins of the fast box test, relative to `|o / d|`.
const FAST_NEAR_MARGIN: f32 = 1.0 / (1 << 22) as f32;
const FAST_FAR_MARGIN: f32 = 1.0 / (1 << 21) as f32;

/// Which box test a traversal runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BoxTest {
    Robust,
    Fast,
}

/// The closest hit below `start` (the root, 0, or a child reference read
/// from one of the tree's nodes): shrinks `t_max` to its distance; true if
/// anything was hit. `cpu` picks the AVX2 kernel.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn closest<L: Leaves>(
    tree: &Tree,
    ray: &BoxRay,
    t_max: &mut f32,
    leaves: &mut L,
    cpu: Option<Avx2>,
    test: BoxTest,
    work: &mut Work,
    start: ChildRef,
) -> bool {
    walk::<false, L>(tree, ray, t_max, leaves, cpu, test, work, start)
}

/// Whether anything below `start` (as in [`closest`]) lies within
/// `t_max`.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub fn any<L: Leaves>(
    tree: &Tree,
    ray: &BoxRay,
    t_max: f32,
    leaves: &mut L,
    cpu: Option<Avx2>,
    test: BoxTest,
    work: &mut Work,
    start: ChildRef,
) -> bool {
    walk::<true, L>(tree, ray, &mut { t_max }, leaves, cpu, test, work, start)
}

/// [`closest`] or, with `ANY`, [`any`]: the checks that make the kernels'
/// unchecked reads sound, then the kernel the CPU and the box test pick.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
fn walk<const ANY: bool, L: Leaves>(
    tree: &Tree,
    ray: &BoxRay,
    t_max: &mut f32,
    leaves: &mut L,
    cpu: Option<Avx2>,
    test: BoxTest,
    work: &mut Work,
    start: ChildRef,
) -> bool {
    if tree.is_empty() || (start == 0 && !ray.enters(tree.bounds(), *t_max)) {
        return false;
    }
    // The kernels read nodes unchecked from `start` on: a reference this
    // tree does not hold would be a bug upstream, stopped here.
    assert!(
        tree.holds(start),
        "walk from {start}, not a reference of this tree"
    );
    #[cfg(target_arch = "x86_64")]
    if let Some(cpu) = cpu {
        // SAFETY: the token proves the CPU has the kernels' features, and
        // the tree holds `start` (asserted above).
        return unsafe {
            if test == BoxTest::Fast && ray.fast_test_fits() {
                avx2::walk::<false, ANY, L>(cpu, tree, ray, t_max, leaves, work, start)
            } else {
                avx2::walk::<true, ANY, L>(cpu, tree, ray, t_max, leaves, work, start)
            }
        };
    }
    let _ = (cpu, test);
    scalar::walk::<ANY, L>(tree, ray, t_max, leaves, work, start)
}

/// Which of `rays` (at most [`STREAM`], those in `active`) anything
/// blocks within their `t_max`, walked as one stream
/// ([`avx2::any_stream`]); `leaves(i)` gives ray `i`'s leaf test. The
/// same answers as [`any`] ray by ray.
#[cfg(target_arch = "x86_64")]
#[allow(clippy::too_many_arguments)]
pub fn any_stream<L: Leaves>(
    tree: &Tree,
    rays: &[BoxRay],
    t_max: &[f32],
    active: u64,
    leaves: &mut impl FnMut(usize) -> L,
    cpu: Avx2,
    test: BoxTest,
    work: &mut Work,
) -> u64 {
    assert!(rays.len() <= STREAM && t_max.len() == rays.len());
    if tree.is_empty() {
        return 0;
    }
    let (entering, fits) = stream_entry(tree, rays, t_max, active);
    // SAFETY: the token proves the CPU's features, the tree is not empty,
    // and `entering` holds only rays of `rays` (checked above).
    unsafe {
        if test == BoxTest::Fast && fits {
            avx2::any_stream::<false, L>(cpu, tree, rays, t_max, entering, leaves, work)
        } else {
            avx2::any_stream::<true, L>(cpu, tree, rays, t_max, entering, leaves, work)
        }
    }
}

/// The closest hits of `rays` (at most [`STREAM`], those in `active`)
/// walked as one stream ([`avx2::closest_stream`]); `leaves[i]` is ray
/// `i`'s leaf test and keeps its hit, `t_max[i]` shrinks to it. The same
/// answers as [`closest`] ray by ray. Returns the rays that hit.
#[cfg(target_arch = "x86_64")]
#[allow(clippy::too_many_arguments)]
pub fn closest_stream<L: Leaves>(
    tree: &Tree,
    rays: &[BoxRay],
    t_max: &mut [f32],
    active: u64,
    leaves: &mut [L],
    cpu: Avx2,
    test: BoxTest,
    work: &mut Work,
) -> u64 {
    assert!(rays.len() <= STREAM && t_max.len() == rays.len() && leaves.len() == rays.len());
    if tree.is_empty() {
        return 0;
    }
    let (entering, fits) = stream_entry(tree, rays, t_max, active);
    // SAFETY: the token proves the CPU's features, the tree is not empty,
    // and `entering` holds only rays of `rays`, whose `t_max` and `leaves`
    // are as long (checked above).
    unsafe {
        if test == BoxTest::Fast && fits {
            avx2::closest_stream::<false, L>(cpu, tree, rays, t_max, entering, leaves, work)
        } else {
            avx2::closest_stream::<true, L>(cpu, tree, rays, t_max, entering, leaves, work)
        }
    }
}

/// The rays of a stream (those in `active`) that enter the tree's root box
/// within their `t_max`, and whether all of them may take the fast box
/// test.
#[cfg(target_arch = "x86_64")]
#[inline(always)]
fn stream_entry(tree: &Tree, rays: &[BoxRay], t_max: &[f32], active: u64) -> (u64, bool) {
    let mut entering = 0u64;
    let mut fits = true;
    for (i, (ray, &t)) in rays.iter().zip(t_max).enumerate() {
        if active >> i & 1 != 0 && ray.enters(tree.bounds(), t) {
            entering |= 1 << i;
            fits &= ray.fast_test_fits();
        }
    }
    (entering, fits)
}

mod scalar;

#[cfg(target_arch = "x86_64")]
mod avx2;

#[cfg(target_arch = "x86_64")]
pub use avx2::STREAM;

#[cfg(target_arch = "x86_64")]
pub mod packet;

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
    fn the_box_tests_never_cull_a_box_the_ray_touches() {
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
                // The root box test before a traversal, too.
                assert!(
                    ray.enters([lo, hi], t_max),
                    "root test culled: o {o} d {d} box {lo}..{hi} t_max {t_max}"
                );
            }
        }
        // About a sixth of the boxes are touched; the test means nothing
        // if few were.
        assert!(touched > 50_000, "only {touched} boxes touched");
    }
}
