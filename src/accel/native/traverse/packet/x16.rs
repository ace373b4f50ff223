//! Sixteen rays in AVX-512 lanes: [`X16`]'s lane operations and the
//! transpose of sixteen rays into them.

use std::arch::x86_64::*;

use super::width::{fields8, Width, MAX_LANES};
use crate::geom::Ray;

/// Sixteen rays in AVX-512 lanes.
#[derive(Clone, Copy, Debug)]
pub struct X16;

/// One round of [`fields16`]: registers `k` and `k + step` (for each `k`
/// without `step`'s bit) give `k` their lanes picked by `even` and
/// `k + step` those picked by `odd`.
#[inline(always)]
unsafe fn shuffle_round(x: [__m512; 8], step: usize, even: __m512i, odd: __m512i) -> [__m512; 8] {
    // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
    // requires of every lane operation; memory is reached only through references to whole
    // lane arrays and rays.
    unsafe {
        let mut y = x;
        for k in 0..8 {
            if k & step == 0 {
                y[k] = _mm512_permutex2var_ps(x[k], even, x[k + step]);
                y[k + step] = _mm512_permutex2var_ps(x[k], odd, x[k + step]);
            }
        }
        y
    }
}

/// Sixteen rays' eight floats, transposed: eight loads of two rays each,
/// then three rounds of two-source shuffles, each exchanging one bit of
/// the ray index (which register) with one of the field index (which
/// lane), 24 shuffles where [`fields8`] twice takes 56.
#[inline(always)]
unsafe fn fields16(rays: &[Ray; 16]) -> [__m512; 8] {
    // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
    // requires of every lane operation; memory is reached only through references to whole
    // lane arrays and rays.
    unsafe {
        let base = rays.as_ptr().cast::<f32>();
        let mut z = [_mm512_setzero_ps(); 8];
        for (j, register) in z.iter_mut().enumerate() {
            *register = _mm512_loadu_ps(base.add(16 * j));
        }
        // Register j holds rays 2j and 2j + 1. Round one: four-float blocks,
        // fields 0-3 of rays (2j, 2j + 1, 2j + 8, 2j + 9) and fields 4-7.
        let mut a = [_mm512_setzero_ps(); 8];
        for j in 0..4 {
            a[j] = _mm512_shuffle_f32x4::<0x88>(z[j], z[j + 4]);
            a[j + 4] = _mm512_shuffle_f32x4::<0xDD>(z[j], z[j + 4]);
        }
        // Round two: pairs of fields; round three: single fields, rays in
        // order. An index picks from the first register (0-15) or the second
        // (16-31).
        let b = shuffle_round(
            a,
            2,
            _mm512_setr_epi32(0, 1, 4, 5, 16, 17, 20, 21, 8, 9, 12, 13, 24, 25, 28, 29),
            _mm512_setr_epi32(2, 3, 6, 7, 18, 19, 22, 23, 10, 11, 14, 15, 26, 27, 30, 31),
        );
        shuffle_round(
            b,
            1,
            _mm512_setr_epi32(0, 2, 16, 18, 4, 6, 20, 22, 8, 10, 24, 26, 12, 14, 28, 30),
            _mm512_setr_epi32(1, 3, 17, 19, 5, 7, 21, 23, 9, 11, 25, 27, 13, 15, 29, 31),
        )
    }
}

// SAFETY: every method is an AVX-512F intrinsic on `__m512` lanes (or an
// AVX2 one) or plain scalar code, so it needs what the `Width` contract
// leaves to its callers: AVX-512F and AVX2 enabled in the calling kernel.
unsafe impl Width for X16 {
    type V = __m512;
    const N: usize = 16;
    #[inline(always)]
    unsafe fn splat(x: f32) -> __m512 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { _mm512_set1_ps(x) }
    }
    #[inline(always)]
    unsafe fn add(a: __m512, b: __m512) -> __m512 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { _mm512_add_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn sub(a: __m512, b: __m512) -> __m512 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { _mm512_sub_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn mul(a: __m512, b: __m512) -> __m512 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { _mm512_mul_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn div(a: __m512, b: __m512) -> __m512 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { _mm512_div_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn fmsub(a: __m512, b: __m512, c: __m512) -> __m512 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { _mm512_fmsub_ps(a, b, c) }
    }
    #[inline(always)]
    unsafe fn min(a: __m512, b: __m512) -> __m512 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { _mm512_min_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn max(a: __m512, b: __m512) -> __m512 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { _mm512_max_ps(a, b) }
    }
    #[inline(always)]
    unsafe fn xor(a: __m512, b: __m512) -> __m512 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe {
            _mm512_castsi512_ps(_mm512_xor_si512(
                _mm512_castps_si512(a),
                _mm512_castps_si512(b),
            ))
        }
    }
    #[inline(always)]
    unsafe fn abs(a: __m512) -> __m512 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe {
            let sign = _mm512_set1_epi32(i32::MIN);
            _mm512_castsi512_ps(_mm512_andnot_si512(sign, _mm512_castps_si512(a)))
        }
    }
    #[inline(always)]
    unsafe fn copysign(m: __m512, s: __m512) -> __m512 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe {
            let sign = _mm512_set1_epi32(i32::MIN);
            _mm512_castsi512_ps(_mm512_or_si512(
                _mm512_andnot_si512(sign, _mm512_castps_si512(m)),
                _mm512_and_si512(sign, _mm512_castps_si512(s)),
            ))
        }
    }
    #[inline(always)]
    unsafe fn le(a: __m512, b: __m512) -> u32 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { u32::from(_mm512_cmp_ps_mask::<_CMP_LE_OQ>(a, b)) }
    }
    #[inline(always)]
    unsafe fn lt(a: __m512, b: __m512) -> u32 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { u32::from(_mm512_cmp_ps_mask::<_CMP_LT_OQ>(a, b)) }
    }
    #[inline(always)]
    unsafe fn gt(a: __m512, b: __m512) -> u32 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { u32::from(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(a, b)) }
    }
    #[inline(always)]
    unsafe fn ge(a: __m512, b: __m512) -> u32 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { u32::from(_mm512_cmp_ps_mask::<_CMP_GE_OQ>(a, b)) }
    }
    #[inline(always)]
    unsafe fn select(mask: u32, no: __m512, yes: __m512) -> __m512 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { _mm512_mask_blend_ps(mask as u16, no, yes) }
    }
    #[inline(always)]
    unsafe fn load(p: &[f32; MAX_LANES]) -> __m512 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { _mm512_loadu_ps(p.as_ptr()) }
    }
    #[inline(always)]
    unsafe fn store(p: &mut [f32; MAX_LANES], v: __m512) {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { _mm512_storeu_ps(p.as_mut_ptr(), v) }
    }
    #[cfg(test)]
    #[inline(always)]
    unsafe fn min_of(v: __m512, mask: u32) -> f32 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { _mm512_reduce_min_ps(X16::select(mask, _mm512_set1_ps(f32::INFINITY), v)) }
    }
    #[inline(always)]
    unsafe fn max_of(v: __m512, mask: u32) -> f32 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe { _mm512_reduce_max_ps(X16::select(mask, _mm512_set1_ps(f32::NEG_INFINITY), v)) }
    }
    /// Up to sixteen minima at once: four rounds, each halving the lanes
    /// left of every input while pairing inputs into one register, 30
    /// shuffles where sixteen reductions one by one take 64.
    #[inline(always)]
    unsafe fn min_each<const K: usize>(v: [__m512; K], mask: u32) -> [f32; K] {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe {
            const { assert!(K <= 16) };
            let inf = _mm512_set1_ps(f32::INFINITY);
            let mut x = [inf; 16];
            for k in 0..K {
                x[k] = X16::select(mask, inf, v[k]);
            }
            // Round one: register k holds inputs 2k and 2k + 1, eight lanes
            // each; round two: register m holds inputs 4m to 4m + 3, one
            // 128-bit block each.
            let mut c = [_mm512_setzero_ps(); 8];
            for k in 0..8 {
                let (a, b) = (x[2 * k], x[2 * k + 1]);
                c[k] = _mm512_min_ps(
                    _mm512_shuffle_f32x4::<0x44>(a, b),
                    _mm512_shuffle_f32x4::<0xEE>(a, b),
                );
            }
            let mut d = [_mm512_setzero_ps(); 4];
            for m in 0..4 {
                let (a, b) = (c[2 * m], c[2 * m + 1]);
                d[m] = _mm512_min_ps(
                    _mm512_shuffle_f32x4::<0x88>(a, b),
                    _mm512_shuffle_f32x4::<0xDD>(a, b),
                );
            }
            // Rounds three and four, within each block: block j ends up
            // holding inputs j, 4 + j, 8 + j and 12 + j, one lane each.
            let mut e = [_mm512_setzero_ps(); 2];
            for h in 0..2 {
                let (a, b) = (d[2 * h], d[2 * h + 1]);
                e[h] = _mm512_min_ps(
                    _mm512_shuffle_ps::<0x44>(a, b),
                    _mm512_shuffle_ps::<0xEE>(a, b),
                );
            }
            let f = _mm512_min_ps(
                _mm512_shuffle_ps::<0x88>(e[0], e[1]),
                _mm512_shuffle_ps::<0xDD>(e[0], e[1]),
            );
            let mut lanes = [0.0f32; 16];
            _mm512_storeu_ps(lanes.as_mut_ptr(), f);
            let mut each = [0.0f32; K];
            for k in 0..K {
                each[k] = lanes[4 * (k % 4) + k / 4];
            }
            each
        }
    }
    #[inline(always)]
    unsafe fn signs(v: __m512) -> u32 {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation. A float's sign bit is its bits' as an integer.
        unsafe {
            u32::from(_mm512_cmplt_epi32_mask(
                _mm512_castps_si512(v),
                _mm512_setzero_si512(),
            ))
        }
    }
    #[inline(always)]
    unsafe fn fields(rays: &[Ray]) -> [__m512; 8] {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe {
            if let Some(full) = rays.first_chunk::<16>() {
                return fields16(full);
            }
            let split = rays.len().min(8);
            let lo = fields8(&rays[..split]);
            // The second eight repeat the last ray when there are no more.
            let hi = fields8(if rays.len() > 8 {
                &rays[8..rays.len().min(16)]
            } else {
                &rays[split - 1..split]
            });
            let mut out = [_mm512_setzero_ps(); 8];
            for f in 0..8 {
                out[f] = _mm512_castpd_ps(_mm512_insertf64x4::<1>(
                    _mm512_castpd256_pd512(_mm256_castps_pd(lo[f])),
                    _mm256_castps_pd(hi[f]),
                ));
            }
            out
        }
    }
}

#[cfg(test)]
pub(super) mod tests {
    use super::*;

    fn avx512() -> bool {
        let yes = is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx2");
        if !yes {
            eprintln!("this CPU has no AVX-512: the sixteen-lane kernels are not reached here");
        }
        yes
    }

    /// Sixteen rays with distinct floats, field `f` of ray `i` being
    /// `i + f / 8` (the transpose tests of both sixteen-ray widths).
    pub(in crate::accel::native::traverse::packet) fn rays() -> Vec<Ray> {
        (0..16)
            .map(|i| {
                let x = |f: usize| i as f32 + f as f32 / 8.0;
                Ray {
                    origin: glam::Vec3::new(x(0), x(1), x(2)),
                    dir: glam::Vec3::new(x(3), x(4), x(5)),
                    t_min: x(6),
                    t_max: x(7),
                }
            })
            .collect()
    }

    #[target_feature(enable = "avx512f,avx2")]
    unsafe fn transposed(rays: &[Ray]) -> [[f32; MAX_LANES]; 8] {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe {
            X16::fields(rays).map(|v| {
                let mut a = [0.0; MAX_LANES];
                X16::store(&mut a, v);
                a
            })
        }
    }

    #[test]
    fn sixteen_rays_transpose_as_eight_and_eight() {
        if !avx512() {
            return;
        }
        let rays = rays();
        // SAFETY: the CPU has the features (checked above).
        let whole = unsafe { transposed(&rays) };
        for (f, lanes) in whole.iter().enumerate() {
            for (i, &x) in lanes.iter().enumerate() {
                assert_eq!(x, i as f32 + f as f32 / 8.0, "field {f} of ray {i}");
            }
        }
        // Fifteen rays take the other path, the last ray repeated.
        // SAFETY: as above.
        let short = unsafe { transposed(&rays[..15]) };
        for f in 0..8 {
            assert_eq!(short[f][..15], whole[f][..15]);
            assert_eq!(short[f][15], whole[f][14]);
        }
    }

    #[target_feature(enable = "avx512f,avx2")]
    unsafe fn minima(v: &[[f32; MAX_LANES]; 13], mask: u32) -> ([f32; 13], [f32; 13]) {
        // SAFETY: the caller runs with AVX-512F and AVX2 enabled, as the `Width` contract
        // requires of every lane operation; memory is reached only through references to
        // whole lane arrays and rays.
        unsafe {
            let vectors = v.map(|a| X16::load(&a));
            (
                X16::min_each(vectors, mask),
                vectors.map(|x| X16::min_of(x, mask)),
            )
        }
    }

    #[test]
    fn minima_at_once_are_the_minima_one_by_one() {
        if !avx512() {
            return;
        }
        // Each input has its minimum in another lane; the masks leave it
        // out in some cases.
        let v: [[f32; MAX_LANES]; 13] = std::array::from_fn(|k| {
            std::array::from_fn(|l| ((l + 3 * k) % 16) as f32 - 100.0 * k as f32)
        });
        for mask in [0xffff, 0x8001, 0x0ff0, 0x0004, 0xfffe] {
            // SAFETY: the CPU has the features (checked above).
            let (at_once, one_by_one) = unsafe { minima(&v, mask) };
            assert_eq!(at_once, one_by_one, "mask {mask:#06x}");
        }
    }
}
