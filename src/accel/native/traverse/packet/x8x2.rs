//! Sixteen rays in two AVX2 registers per value ([`X8x2`]): the sixteen-ray
//! packet for CPUs without AVX-512. Every operation is [`X8`]'s, applied to
//! each half; a mask's low eight bits are the first half's lanes.
//!
//! The bet: a packet's per-node work that does not grow with its rays
//! (fetching the node, the interval test of its children, ordering and
//! pushing them) is shared by sixteen rays instead of eight, as the
//! AVX-512 packets share it.

use std::arch::x86_64::*;

use super::width::{fields8, Width, MAX_LANES, X8};
use crate::geom::Ray;

/// Sixteen rays in two AVX2 registers per value.
#[derive(Clone, Copy, Debug)]
pub struct X8x2;

/// The mask's halves: the first eight lanes, the second eight.
#[inline(always)]
fn halves(mask: u32) -> (u32, u32) {
    (mask & 0xff, mask >> 8)
}

macro_rules! both {
    ($op:ident($($a:ident),*)) => {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width`
        // contract requires; each half is one of X8's operations.
        unsafe { [X8::$op($($a[0]),*), X8::$op($($a[1]),*)] }
    };
}

macro_rules! compare {
    ($op:ident($a:ident, $b:ident)) => {
        // SAFETY: as in `both`.
        unsafe { X8::$op($a[0], $b[0]) | X8::$op($a[1], $b[1]) << 8 }
    };
}

// SAFETY: every method is X8's on each half, so it needs what X8 needs
// (AVX2 and FMA), which the `Width` contract leaves to the caller.
unsafe impl Width for X8x2 {
    type V = [__m256; 2];
    const N: usize = 16;
    #[inline(always)]
    unsafe fn splat(x: f32) -> [__m256; 2] {
        // SAFETY: as in `both`.
        let v = unsafe { X8::splat(x) };
        [v, v]
    }
    #[inline(always)]
    unsafe fn add(a: [__m256; 2], b: [__m256; 2]) -> [__m256; 2] {
        both!(add(a, b))
    }
    #[inline(always)]
    unsafe fn sub(a: [__m256; 2], b: [__m256; 2]) -> [__m256; 2] {
        both!(sub(a, b))
    }
    #[inline(always)]
    unsafe fn mul(a: [__m256; 2], b: [__m256; 2]) -> [__m256; 2] {
        both!(mul(a, b))
    }
    #[inline(always)]
    unsafe fn div(a: [__m256; 2], b: [__m256; 2]) -> [__m256; 2] {
        both!(div(a, b))
    }
    #[inline(always)]
    unsafe fn fmsub(a: [__m256; 2], b: [__m256; 2], c: [__m256; 2]) -> [__m256; 2] {
        both!(fmsub(a, b, c))
    }
    #[inline(always)]
    unsafe fn min(a: [__m256; 2], b: [__m256; 2]) -> [__m256; 2] {
        both!(min(a, b))
    }
    #[inline(always)]
    unsafe fn max(a: [__m256; 2], b: [__m256; 2]) -> [__m256; 2] {
        both!(max(a, b))
    }
    #[inline(always)]
    unsafe fn xor(a: [__m256; 2], b: [__m256; 2]) -> [__m256; 2] {
        both!(xor(a, b))
    }
    #[inline(always)]
    unsafe fn abs(a: [__m256; 2]) -> [__m256; 2] {
        both!(abs(a))
    }
    #[inline(always)]
    unsafe fn copysign(m: [__m256; 2], s: [__m256; 2]) -> [__m256; 2] {
        both!(copysign(m, s))
    }
    #[inline(always)]
    unsafe fn le(a: [__m256; 2], b: [__m256; 2]) -> u32 {
        compare!(le(a, b))
    }
    #[inline(always)]
    unsafe fn lt(a: [__m256; 2], b: [__m256; 2]) -> u32 {
        compare!(lt(a, b))
    }
    #[inline(always)]
    unsafe fn gt(a: [__m256; 2], b: [__m256; 2]) -> u32 {
        compare!(gt(a, b))
    }
    #[inline(always)]
    unsafe fn ge(a: [__m256; 2], b: [__m256; 2]) -> u32 {
        compare!(ge(a, b))
    }
    #[inline(always)]
    unsafe fn select(mask: u32, no: [__m256; 2], yes: [__m256; 2]) -> [__m256; 2] {
        let (lo, hi) = halves(mask);
        // SAFETY: as in `both`.
        unsafe { [X8::select(lo, no[0], yes[0]), X8::select(hi, no[1], yes[1])] }
    }
    #[inline(always)]
    unsafe fn load(p: &[f32; MAX_LANES]) -> [__m256; 2] {
        // SAFETY: as in `both`; the array holds sixteen floats, the two
        // loads read eight each from its start and its middle.
        unsafe {
            [
                _mm256_loadu_ps(p.as_ptr()),
                _mm256_loadu_ps(p.as_ptr().add(8)),
            ]
        }
    }
    #[inline(always)]
    unsafe fn store(p: &mut [f32; MAX_LANES], v: [__m256; 2]) {
        // SAFETY: as in `load`.
        unsafe {
            _mm256_storeu_ps(p.as_mut_ptr(), v[0]);
            _mm256_storeu_ps(p.as_mut_ptr().add(8), v[1]);
        }
    }
    #[cfg(test)]
    #[inline(always)]
    unsafe fn min_of(v: [__m256; 2], mask: u32) -> f32 {
        let (lo, hi) = halves(mask);
        // SAFETY: as in `both`; an empty half gives +inf.
        unsafe { X8::min_of(v[0], lo).min(X8::min_of(v[1], hi)) }
    }
    #[inline(always)]
    unsafe fn max_of(v: [__m256; 2], mask: u32) -> f32 {
        let (lo, hi) = halves(mask);
        // SAFETY: as in `both`; an empty half gives -inf.
        unsafe { X8::max_of(v[0], lo).max(X8::max_of(v[1], hi)) }
    }
    /// The two halves folded lane by lane (lanes outside the mask +inf),
    /// then [`X8::min_each`] of the eight lanes left.
    #[inline(always)]
    unsafe fn min_each<const K: usize>(v: [[__m256; 2]; K], mask: u32) -> [f32; K] {
        let (lo, hi) = halves(mask);
        // SAFETY: as in `both`.
        unsafe {
            let inf = _mm256_set1_ps(f32::INFINITY);
            let mut folded = [inf; K];
            for k in 0..K {
                folded[k] =
                    _mm256_min_ps(X8::select(lo, inf, v[k][0]), X8::select(hi, inf, v[k][1]));
            }
            X8::min_each(folded, 0xff)
        }
    }
    #[inline(always)]
    unsafe fn signs(v: [__m256; 2]) -> u32 {
        // SAFETY: as in `both`.
        unsafe { X8::signs(v[0]) | X8::signs(v[1]) << 8 }
    }
    #[inline(always)]
    unsafe fn fields(rays: &[Ray]) -> [[__m256; 2]; 8] {
        let n = rays.len().min(16);
        // Lanes past the rays repeat the last: the second half of a short
        // packet is the last ray eight times.
        let second = if n > 8 { &rays[8..n] } else { &rays[n - 1..n] };
        // SAFETY: as in `both`.
        let (a, b) = unsafe { (fields8(&rays[..n.min(8)]), fields8(second)) };
        let mut out = [[a[0], b[0]]; 8];
        for f in 0..8 {
            out[f] = [a[f], b[f]];
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[target_feature(enable = "avx2,fma")]
    unsafe fn minima(v: &[[f32; MAX_LANES]; 13], mask: u32) -> ([f32; 13], [f32; 13]) {
        // SAFETY: the caller checked that the CPU has AVX2 and FMA.
        unsafe {
            let mut vectors = [X8x2::splat(0.0); 13];
            let mut one_by_one = [0.0; 13];
            for k in 0..13 {
                vectors[k] = X8x2::load(&v[k]);
                one_by_one[k] = X8x2::min_of(vectors[k], mask);
            }
            (X8x2::min_each(vectors, mask), one_by_one)
        }
    }

    #[target_feature(enable = "avx2,fma")]
    unsafe fn transposed(rays: &[Ray]) -> [[f32; MAX_LANES]; 8] {
        // SAFETY: as in `minima`.
        unsafe {
            let fields = X8x2::fields(rays);
            let mut out = [[0.0; MAX_LANES]; 8];
            for f in 0..8 {
                X8x2::store(&mut out[f], fields[f]);
            }
            out
        }
    }

    /// Minima over both halves at once equal the minima one by one, for
    /// masks with lanes in one half, the other, or both; and sixteen rays
    /// (or fewer, the last repeated) transpose lane for lane.
    #[test]
    fn two_register_lanes_reduce_and_transpose_as_sixteen() {
        if !(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma")) {
            eprintln!("this CPU has no AVX2: the two-register kernels are not reached here");
            return;
        }
        let v: [[f32; MAX_LANES]; 13] = std::array::from_fn(|k| {
            std::array::from_fn(|l| ((l + 5 * k) % 16) as f32 - 100.0 * k as f32)
        });
        for mask in [0xffff, 0x00ff, 0xff00, 0x8001, 0x0100, 0x0004, 0x7ffe] {
            // SAFETY: the CPU has the features (checked above).
            let (at_once, one_by_one) = unsafe { minima(&v, mask) };
            assert_eq!(at_once, one_by_one, "mask {mask:#06x}");
        }
        let rays = super::super::x16::tests::rays();
        for n in [16, 11, 8, 3] {
            // SAFETY: as above.
            let lanes = unsafe { transposed(&rays[..n]) };
            for (f, lane) in lanes.iter().enumerate() {
                for (i, &x) in lane.iter().enumerate() {
                    let ray = i.min(n - 1) as f32;
                    assert_eq!(x, ray + f as f32 / 8.0, "{n} rays: field {f} of lane {i}");
                }
            }
        }
    }
}
