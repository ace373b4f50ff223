//! One packet width's lane operations: [`X8`] (AVX2, eight rays) and
//! [`X16`] (AVX-512, sixteen), behind the [`Width`] trait the packet
//! kernels are generic over.

use std::arch::x86_64::*;

use crate::geom::Ray;

/// Most rays in a packet: the lane arrays' length for either width.
pub const MAX_LANES: usize = 16;

/// One packet width's operations on lanes of rays: [`X8`] (AVX2, eight
/// rays) and [`X16`] (AVX-512, sixteen). Each is the operation the
/// single-ray code uses, lane by lane (IEEE arithmetic, ordered quiet
/// comparisons), so every lane computes the single ray's bits. Masks hold
/// one bit per lane.
///
/// # Safety
/// The methods need the width's CPU features; they are reached only from
/// the width's `#[target_feature]` entry points, which a detected token
/// guards, and are always inlined into them.
pub unsafe trait Width: Copy {
    type V: Copy;
    /// Rays per packet.
    const N: usize;
    unsafe fn splat(x: f32) -> Self::V;
    unsafe fn add(a: Self::V, b: Self::V) -> Self::V;
    unsafe fn sub(a: Self::V, b: Self::V) -> Self::V;
    unsafe fn mul(a: Self::V, b: Self::V) -> Self::V;
    unsafe fn div(a: Self::V, b: Self::V) -> Self::V;
    /// `a * b - c`, rounded once.
    unsafe fn fmsub(a: Self::V, b: Self::V, c: Self::V) -> Self::V;
    /// `_mm*_min_ps` / `_mm*_max_ps`: the second operand where either is
    /// NaN.
    unsafe fn min(a: Self::V, b: Self::V) -> Self::V;
    unsafe fn max(a: Self::V, b: Self::V) -> Self::V;
    unsafe fn xor(a: Self::V, b: Self::V) -> Self::V;
    unsafe fn abs(a: Self::V) -> Self::V;
    /// `m`'s magnitude with `s`'s sign.
    unsafe fn copysign(m: Self::V, s: Self::V) -> Self::V;
    unsafe fn le(a: Self::V, b: Self::V) -> u32;
    unsafe fn lt(a: Self::V, b: Self::V) -> u32;
    unsafe fn gt(a: Self::V, b: Self::V) -> u32;
    unsafe fn ge(a: Self::V, b: Self::V) -> u32;
    /// `yes` in the lanes of `mask`, `no` elsewhere.
    unsafe fn select(mask: u32, no: Self::V, yes: Self::V) -> Self::V;
    /// The first `N` floats at `p`.
    unsafe fn load(p: &[f32; MAX_LANES]) -> Self::V;
    unsafe fn store(p: &mut [f32; MAX_LANES], v: Self::V);
    /// The smallest and the largest of the lanes in `mask` (which is not
    /// empty). The smallest one by one is only the tests' reference for
    /// [`Width::min_each`].
    #[cfg(test)]
    unsafe fn min_of(v: Self::V, mask: u32) -> f32;
    unsafe fn max_of(v: Self::V, mask: u32) -> f32;
    /// The smallest lane in `mask` (not empty) of each of `v`, all at
    /// once. Lane code builds arrays with loops,
    /// never `map` or `from_fn`, whose closures run in library code without
    /// the width's target features (docs/design.md, Packets).
    unsafe fn min_each<const K: usize>(v: [Self::V; K], mask: u32) -> [f32; K];
    /// The eight floats of each of up to `N` rays (`Ray` is eight floats,
    /// `repr(C)`), one vector per field; lanes past the rays repeat the
    /// last.
    unsafe fn fields(rays: &[Ray]) -> [Self::V; 8];
    /// The lanes whose sign bit is set (negative zero and NaNs included).
    unsafe fn signs(v: Self::V) -> u32;
}

/// Eight rays in AVX2 lanes.
#[derive(Clone, Copy, Debug)]
pub struct X8;

/// The lanes of `mask` as an AVX2 vector mask.
#[inline(always)]
unsafe fn lane_mask8(mask: u32) -> __m256 {
    // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of every
    // lane operation; memory is reached only through references to whole lane arrays and
    // rays.
    unsafe {
        let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
        _mm256_castsi256_ps(_mm256_cmpeq_epi32(
            _mm256_and_si256(_mm256_set1_epi32(mask as i32), bits),
            bits,
        ))
    }
}

/// Up to eight rays' eight floats, transposed.
#[inline(always)]
pub(super) unsafe fn fields8(rays: &[Ray]) -> [__m256; 8] {
    // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of every
    // lane operation; memory is reached only through references to whole lane arrays and
    // rays.
    unsafe {
        let last = rays.len().min(8) - 1;
        let row = |i: usize| _mm256_loadu_ps((&rays[i.min(last)] as *const Ray).cast::<f32>());
        let r = [
            row(0),
            row(1),
            row(2),
            row(3),
            row(4),
            row(5),
            row(6),
            row(7),
        ];
        let t0 = _mm256_unpacklo_ps(r[0], r[1]);
        let t1 = _mm256_unpackhi_ps(r[0], r[1]);
        let t2 = _mm256_unpacklo_ps(r[2], r[3]);
        let t3 = _mm256_unpackhi_ps(r[2], r[3]);
        let t4 = _mm256_unpacklo_ps(r[4], r[5]);
        let t5 = _mm256_unpackhi_ps(r[4], r[5]);
        let t6 = _mm256_unpacklo_ps(r[6], r[7]);
        let t7 = _mm256_unpackhi_ps(r[6], r[7]);
        let u0 = _mm256_shuffle_ps::<0x44>(t0, t2);
        let u1 = _mm256_shuffle_ps::<0xEE>(t0, t2);
        let u2 = _mm256_shuffle_ps::<0x44>(t1, t3);
        let u3 = _mm256_shuffle_ps::<0xEE>(t1, t3);
        let u4 = _mm256_shuffle_ps::<0x44>(t4, t6);
        let u5 = _mm256_shuffle_ps::<0xEE>(t4, t6);
        let u6 = _mm256_shuffle_ps::<0x44>(t5, t7);
        let u7 = _mm256_shuffle_ps::<0xEE>(t5, t7);
        [
            _mm256_permute2f128_ps::<0x20>(u0, u4),
            _mm256_permute2f128_ps::<0x20>(u1, u5),
            _mm256_permute2f128_ps::<0x20>(u2, u6),
            _mm256_permute2f128_ps::<0x20>(u3, u7),
            _mm256_permute2f128_ps::<0x31>(u0, u4),
            _mm256_permute2f128_ps::<0x31>(u1, u5),
            _mm256_permute2f128_ps::<0x31>(u2, u6),
            _mm256_permute2f128_ps::<0x31>(u3, u7),
        ]
    }
}

// SAFETY: every method is an AVX2 (or FMA) intrinsic on `__m256` lanes or
// plain scalar code, so it needs what the `Width` contract leaves to its
// callers: AVX2 and FMA enabled in the calling kernel.
unsafe impl Width for X8 {
    type V = __m256;
    const N: usize = 8;
    #[inline(always)]
    unsafe fn splat(x: f32) -> __m256 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_set1_ps(x) }
    }
    #[inline(always)]
    unsafe fn add(a: __m256, b: __m256) -> __m256 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_add_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn sub(a: __m256, b: __m256) -> __m256 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_sub_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn mul(a: __m256, b: __m256) -> __m256 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_mul_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn div(a: __m256, b: __m256) -> __m256 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_div_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn fmsub(a: __m256, b: __m256, c: __m256) -> __m256 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_fmsub_ps(a, b, c) }
    }
    #[inline(always)]
    unsafe fn min(a: __m256, b: __m256) -> __m256 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_min_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn max(a: __m256, b: __m256) -> __m256 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_max_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn xor(a: __m256, b: __m256) -> __m256 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_xor_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn abs(a: __m256) -> __m256 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_andnot_ps(_mm256_set1_ps(-0.0), a) }
    }
    #[inline(always)]
    unsafe fn copysign(m: __m256, s: __m256) -> __m256 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe {
            let sign = _mm256_set1_ps(-0.0);
            _mm256_or_ps(_mm256_andnot_ps(sign, m), _mm256_and_ps(sign, s))
        }
    }
    #[inline(always)]
    unsafe fn le(a: __m256, b: __m256) -> u32 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(a, b)) as u32 }
    }
    #[inline(always)]
    unsafe fn lt(a: __m256, b: __m256) -> u32 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(a, b)) as u32 }
    }
    #[inline(always)]
    unsafe fn gt(a: __m256, b: __m256) -> u32 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(a, b)) as u32 }
    }
    #[inline(always)]
    unsafe fn ge(a: __m256, b: __m256) -> u32 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(a, b)) as u32 }
    }
    #[inline(always)]
    unsafe fn select(mask: u32, no: __m256, yes: __m256) -> __m256 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_blendv_ps(no, yes, lane_mask8(mask)) }
    }
    #[inline(always)]
    unsafe fn load(p: &[f32; MAX_LANES]) -> __m256 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_loadu_ps(p.as_ptr()) }
    }
    #[inline(always)]
    unsafe fn store(p: &mut [f32; MAX_LANES], v: __m256) {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { _mm256_storeu_ps(p.as_mut_ptr(), v) }
    }
    #[cfg(test)]
    #[inline(always)]
    unsafe fn min_of(v: __m256, mask: u32) -> f32 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe {
            let m = X8::select(mask, _mm256_set1_ps(f32::INFINITY), v);
            let m = _mm256_min_ps(m, _mm256_permute2f128_ps::<1>(m, m));
            let m = _mm256_min_ps(m, _mm256_shuffle_ps::<0b0100_1110>(m, m));
            _mm256_cvtss_f32(_mm256_min_ps(m, _mm256_shuffle_ps::<0b1011_0001>(m, m)))
        }
    }
    #[inline(always)]
    unsafe fn max_of(v: __m256, mask: u32) -> f32 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe {
            let m = X8::select(mask, _mm256_set1_ps(f32::NEG_INFINITY), v);
            let m = _mm256_max_ps(m, _mm256_permute2f128_ps::<1>(m, m));
            let m = _mm256_max_ps(m, _mm256_shuffle_ps::<0b0100_1110>(m, m));
            _mm256_cvtss_f32(_mm256_max_ps(m, _mm256_shuffle_ps::<0b1011_0001>(m, m)))
        }
    }
    /// Up to sixteen minima at once: three rounds, each halving the lanes
    /// left of every input while pairing inputs into one register (42
    /// shuffles and minima where sixteen reductions one by one take 96),
    /// as [`X16::min_each`] does at sixteen lanes.
    #[inline(always)]
    unsafe fn min_each<const K: usize>(v: [__m256; K], mask: u32) -> [f32; K] {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe {
            const { assert!(K <= 16) };
            let inf = _mm256_set1_ps(f32::INFINITY);
            let lanes = lane_mask8(mask);
            let mut x = [inf; 16];
            for k in 0..K {
                x[k] = _mm256_blendv_ps(inf, v[k], lanes);
            }
            // Round one: register k holds inputs 2k and 2k + 1, one 128-bit
            // half each; round two: register m holds, per half, two lanes of
            // inputs 4m and 4m + 2 (low half) or 4m + 1 and 4m + 3 (high).
            let mut c = [_mm256_setzero_ps(); 8];
            for k in 0..8 {
                let (a, b) = (x[2 * k], x[2 * k + 1]);
                c[k] = _mm256_min_ps(
                    _mm256_permute2f128_ps::<0x20>(a, b),
                    _mm256_permute2f128_ps::<0x31>(a, b),
                );
            }
            let mut d = [_mm256_setzero_ps(); 4];
            for m in 0..4 {
                let (a, b) = (c[2 * m], c[2 * m + 1]);
                d[m] = _mm256_min_ps(
                    _mm256_shuffle_ps::<0x44>(a, b),
                    _mm256_shuffle_ps::<0xEE>(a, b),
                );
            }
            // Round three: lane j of register h is input 8h + 2 (j % 4) + j / 4.
            let mut e = [_mm256_setzero_ps(); 2];
            for h in 0..2 {
                let (a, b) = (d[2 * h], d[2 * h + 1]);
                e[h] = _mm256_min_ps(
                    _mm256_shuffle_ps::<0x88>(a, b),
                    _mm256_shuffle_ps::<0xDD>(a, b),
                );
            }
            let mut out = [0.0f32; 16];
            _mm256_storeu_ps(out.as_mut_ptr(), e[0]);
            _mm256_storeu_ps(out.as_mut_ptr().add(8), e[1]);
            let mut each = [0.0f32; K];
            for k in 0..K {
                let r = k % 8;
                each[k] = out[8 * (k / 8) + 4 * (r % 2) + r / 2];
            }
            each
        }
    }
    #[inline(always)]
    unsafe fn fields(rays: &[Ray]) -> [__m256; 8] {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe { fields8(rays) }
    }
    #[inline(always)]
    unsafe fn signs(v: __m256) -> u32 {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation.
        unsafe { _mm256_movemask_ps(v) as u32 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[target_feature(enable = "avx2")]
    unsafe fn minima8(v: &[[f32; MAX_LANES]; 13], mask: u32) -> ([f32; 13], [f32; 13]) {
        // SAFETY: the caller runs with AVX2 enabled, as the `Width` contract requires of
        // every lane operation; memory is reached only through references to whole lane
        // arrays and rays.
        unsafe {
            let vectors = v.map(|a| X8::load(&a));
            let mut one_by_one = [0.0; 13];
            for (k, x) in vectors.iter().enumerate() {
                one_by_one[k] = X8::min_of(*x, mask);
            }
            (X8::min_each(vectors, mask), one_by_one)
        }
    }

    #[test]
    fn eight_lane_minima_at_once_are_the_minima_one_by_one() {
        if !is_x86_feature_detected!("avx2") {
            eprintln!("this CPU has no AVX2: the eight-lane kernels are not reached here");
            return;
        }
        let v: [[f32; MAX_LANES]; 13] = std::array::from_fn(|k| {
            std::array::from_fn(|l| ((l + 3 * k) % 8) as f32 - 100.0 * k as f32)
        });
        for mask in [0xff, 0x81, 0x3c, 0x04, 0xfe] {
            // SAFETY: the CPU has the feature (checked above).
            let (at_once, one_by_one) = unsafe { minima8(&v, mask) };
            assert_eq!(at_once, one_by_one, "mask {mask:#04x}");
        }
    }
}
