//! A packet's box tests: the interval test of all eight children against
//! the whole packet (a lower bound of every lane's near distance, an upper
//! bound of every far one), and the lane test, the single-ray slab test
//! lane by lane (see the notes of [`super`]).

use std::arch::x86_64::*;

use super::{Packet, PacketRays, Width, MAX_LANES};
use crate::accel::native::node::Node8;
use crate::accel::native::traverse::FAST_FAR_SCALE;
use crate::accel::native::BOX_FAR_SCALE;

/// The interval test's constants, broadcast over a node's eight children:
/// per axis the range of the reciprocals and the end of each offset's
/// range that gives the lowest near and the highest far distance (see the
/// module notes).
pub(super) struct Interval {
    near_r: [(__m256, __m256); 3],
    near_c: [__m256; 3],
    far_r: [(__m256, __m256); 3],
    far_c: [__m256; 3],
    t_min: __m256,
}

/// The lane test's constants of each axis: near `r`, near `c`, far `r`,
/// far `c` (robust form: reciprocal and origin; fast form: the fused
/// constants).
#[inline(always)]
fn constants<W: Width, const ROBUST: bool>(r: &PacketRays<W>) -> [&[W::V; 3]; 4] {
    if ROBUST {
        [&r.inv, &r.lanes.origin, &r.inv, &r.lanes.origin]
    } else {
        [&r.inv, &r.fast[0], &r.fast[1], &r.fast[2]]
    }
}

/// The interval test's constants of packet `p`.
#[inline(always)]
pub(super) unsafe fn interval<W: Width, const ROBUST: bool>(p: &Packet<W>) -> Interval {
    // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
    // enabled (a detected token chose this code) and the tree was checked by `Tree::new`,
    // so every node reference read from it is in range.
    unsafe {
        let r = p.rays;
        let [_, near_c, _, far_c] = constants::<W, ROBUST>(r);
        let (mask, lead) = (p.mask, p.mask.trailing_zeros());
        let splat = |x: f32| _mm256_set1_ps(x);
        let zero = splat(0.0);
        // The thirteen ends at once: maxima as minima of the negated lanes
        // (exact), then per axis the reciprocals' range and the offsets' ends.
        let neg = |v: W::V| W::xor(v, W::splat(-0.0));
        let wants_min = |axis: usize| ROBUST && r.negative[axis] >> lead & 1 != 0;
        let mut inputs = [r.lanes.t_min; 13];
        for axis in 0..3 {
            // Fast form `plane * r - c`: the largest `c` lowers the near
            // distance, the smallest raises the far one. Robust form
            // `(plane - o) * r`: which end of `o` does depends on the sign of
            // `r`, the packet's octant.
            let (nc, fc) = (near_c[axis], far_c[axis]);
            inputs[1 + 4 * axis] = r.inv[axis];
            inputs[2 + 4 * axis] = neg(r.inv[axis]);
            inputs[3 + 4 * axis] = if wants_min(axis) { nc } else { neg(nc) };
            inputs[4 + 4 * axis] = if wants_min(axis) { neg(fc) } else { fc };
        }
        let ends = W::min_each(inputs, mask);
        let mut ia = Interval {
            near_r: [(zero, zero); 3],
            near_c: [zero; 3],
            far_r: [(zero, zero); 3],
            far_c: [zero; 3],
            t_min: splat(ends[0]),
        };
        for axis in 0..3 {
            let [r_lo, r_hi, nc, fc] = [1, 2, 3, 4].map(|k| ends[k + 4 * axis]);
            let (r_hi, nc, fc) = if wants_min(axis) {
                (-r_hi, nc, -fc)
            } else {
                (-r_hi, -nc, fc)
            };
            ia.near_r[axis] = (splat(r_lo), splat(r_hi));
            // The fast form's far reciprocal is `r (1 + 2^-20)` lane by lane;
            // multiplying by a positive constant keeps the order, so its range
            // is the reciprocals' range times the same constant.
            ia.far_r[axis] = if ROBUST {
                (splat(r_lo), splat(r_hi))
            } else {
                (splat(r_lo * FAST_FAR_SCALE), splat(r_hi * FAST_FAR_SCALE))
            };
            ia.near_c[axis] = splat(nc);
            ia.far_c[axis] = splat(fc);
        }
        ia
    }
}

/// One plane's distance over the node's children, robust
/// `(plane - c) * r` or fast `plane * r - c`.
#[inline(always)]
unsafe fn distance<const ROBUST: bool>(plane: __m256, r: __m256, c: __m256) -> __m256 {
    // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
    // enabled (a detected token chose this code) and the tree was checked by `Tree::new`,
    // so every node reference read from it is in range.
    unsafe {
        if ROBUST {
            _mm256_mul_ps(_mm256_sub_ps(plane, c), r)
        } else {
            _mm256_fmsub_ps(plane, r, c)
        }
    }
}

/// One axis's end of the interval test over the node's children: the
/// lowest near distance (`FAR` false) or the highest far distance of the
/// packet's range of constants, at plane row `row`.
#[inline(always)]
unsafe fn interval_end<const ROBUST: bool, const FAR: bool>(
    node: &Node8,
    ia: &Interval,
    row: usize,
    axis: usize,
) -> __m256 {
    // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
    // enabled (a detected token chose this code) and the tree was checked by `Tree::new`,
    // so every node reference read from it is in range.
    unsafe {
        let p = _mm256_load_ps(node.planes[row].as_ptr());
        if FAR {
            let (lo, hi) = ia.far_r[axis];
            let c = ia.far_c[axis];
            _mm256_max_ps(distance::<ROBUST>(p, lo, c), distance::<ROBUST>(p, hi, c))
        } else {
            let (lo, hi) = ia.near_r[axis];
            let c = ia.near_c[axis];
            _mm256_min_ps(distance::<ROBUST>(p, lo, c), distance::<ROBUST>(p, hi, c))
        }
    }
}

/// The interval test of the node's eight children against the packet:
/// lower bounds of the entry distances and the children some ray may
/// enter within `t_max`.
#[inline(always)]
pub(super) unsafe fn interval_slab<const ROBUST: bool>(
    node: &Node8,
    ia: &Interval,
    rows: &[(usize, usize); 3],
    t_max: __m256,
) -> (__m256, u32) {
    // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
    // enabled (a detected token chose this code) and the tree was checked by `Tree::new`,
    // so every node reference read from it is in range.
    unsafe {
        // Calls of a function, not of closures: a closure is only hinted
        // inline, and the two this replaces were compiled out of line (six
        // calls a node; inlined, 0.97-1.05x, within the noise).
        let (n0, n1, n2) = (
            interval_end::<ROBUST, false>(node, ia, rows[0].0, 0),
            interval_end::<ROBUST, false>(node, ia, rows[1].0, 1),
            interval_end::<ROBUST, false>(node, ia, rows[2].0, 2),
        );
        let (f0, f1, f2) = (
            interval_end::<ROBUST, true>(node, ia, rows[0].1, 0),
            interval_end::<ROBUST, true>(node, ia, rows[1].1, 1),
            interval_end::<ROBUST, true>(node, ia, rows[2].1, 2),
        );
        let near = _mm256_max_ps(_mm256_max_ps(n0, n1), _mm256_max_ps(n2, ia.t_min));
        let far = _mm256_min_ps(_mm256_min_ps(f0, f1), f2);
        let far = if ROBUST {
            _mm256_mul_ps(far, _mm256_set1_ps(BOX_FAR_SCALE))
        } else {
            far
        };
        let far = _mm256_min_ps(far, t_max);
        let hit = _mm256_cmp_ps::<_CMP_LE_OQ>(near, far);
        (near, _mm256_movemask_ps(hit) as u32)
    }
}

/// The rays (lanes) that enter child `c` of `node` within their own
/// `t_max`: the single-ray slab test, lane by lane.
#[inline(always)]
pub(super) unsafe fn lane_slab<W: Width, const ROBUST: bool>(
    node: &Node8,
    c: usize,
    r: &PacketRays<W>,
    rows: &[(usize, usize); 3],
    t_max: W::V,
) -> u32 {
    // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
    // enabled (a detected token chose this code) and the tree was checked by `Tree::new`,
    // so every node reference read from it is in range.
    unsafe {
        let [near_r, near_c, far_r, far_c] = constants::<W, ROBUST>(r);
        // Functions, not closures: a closure the compiler leaves out of
        // line runs without the width's target features, and its
        // intrinsics become calls (it did for two-register packets).
        let mut near_t = [r.lanes.t_min; 3];
        let mut far_t = [r.lanes.t_min; 3];
        for a in 0..3 {
            let (near_row, far_row) = rows[a];
            near_t[a] = lane_distance::<W, ROBUST>(node.planes[near_row][c], near_r[a], near_c[a]);
            far_t[a] = lane_distance::<W, ROBUST>(node.planes[far_row][c], far_r[a], far_c[a]);
        }
        let near = W::max(
            W::max(near_t[0], near_t[1]),
            W::max(near_t[2], r.lanes.t_min),
        );
        let far = W::min(W::min(far_t[0], far_t[1]), far_t[2]);
        let far = if ROBUST {
            W::mul(far, W::splat(BOX_FAR_SCALE))
        } else {
            far
        };
        W::le(near, W::min(far, t_max))
    }
}

/// [`lane_slab`] for lanes of any octants: each axis's distances to both
/// planes, the nearer taken as entry and the farther as exit, lane by
/// lane. Distances are monotone in the plane (rounding is monotone, and
/// near and far reciprocals share the direction's sign), so the smaller
/// of the two is exactly the distance to the plane the ray's octant picks
/// as near, and the larger to its far plane: each lane gets the single-ray
/// test's values, bit for bit (the entry distances are returned with
/// the lanes that enter). `c` must be a used slot (an unused slot's
/// planes are inverted, which only the octant's rows reject).
#[inline(always)]
pub(super) unsafe fn lane_slab_mixed<W: Width, const ROBUST: bool>(
    node: &Node8,
    c: usize,
    r: &PacketRays<W>,
    t_max: W::V,
) -> (W::V, u32) {
    // SAFETY: the caller runs with the width's CPU features enabled.
    unsafe {
        let [near_r, near_c, far_r, far_c] = constants::<W, ROBUST>(r);
        let mut near = r.lanes.t_min;
        let mut far = W::splat(f32::INFINITY);
        for a in 0..3 {
            let (lo, hi) = (node.planes[2 * a][c], node.planes[2 * a + 1][c]);
            let to_lo = lane_distance::<W, ROBUST>(lo, near_r[a], near_c[a]);
            let to_hi = lane_distance::<W, ROBUST>(hi, near_r[a], near_c[a]);
            // The robust form's far constants are the near ones.
            let (from_lo, from_hi) = if ROBUST {
                (to_lo, to_hi)
            } else {
                (
                    lane_distance::<W, ROBUST>(lo, far_r[a], far_c[a]),
                    lane_distance::<W, ROBUST>(hi, far_r[a], far_c[a]),
                )
            };
            near = W::max(near, W::min(to_lo, to_hi));
            far = W::min(far, W::max(from_lo, from_hi));
        }
        let far = if ROBUST {
            W::mul(far, W::splat(BOX_FAR_SCALE))
        } else {
            far
        };
        (near, W::le(near, W::min(far, t_max)))
    }
}

/// One slab end's distance for every lane: `(plane - c) * r` (robust form,
/// `c` the origin, `r` the reciprocal) or `plane * r - c` rounded once
/// (fast form, `c` the origin times the reciprocal).
///
/// # Safety
/// As [`lane_slab`].
#[inline(always)]
unsafe fn lane_distance<W: Width, const ROBUST: bool>(plane: f32, r: W::V, c: W::V) -> W::V {
    // SAFETY: the caller runs with the width's CPU features enabled.
    unsafe {
        let p = W::splat(plane);
        if ROBUST {
            W::mul(W::sub(p, c), r)
        } else {
            W::fmsub(p, r, c)
        }
    }
}

/// Lanes outside `mask` set to `-inf`, so that no box test passes there.
#[inline(always)]
pub(super) unsafe fn masked_t_max<W: Width>(t_max: &[f32; MAX_LANES], mask: u32) -> W::V {
    // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
    // enabled (a detected token chose this code) and the tree was checked by `Tree::new`,
    // so every node reference read from it is in range.
    unsafe { W::select(mask, W::splat(f32::NEG_INFINITY), W::load(t_max)) }
}
