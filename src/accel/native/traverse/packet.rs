//! Packet traversal: up to sixteen rays of one octant walk the tree together
//! (Wald et al. 2001, "Interactive Rendering with Coherent Ray Tracing";
//! the hybrid packet/single scheme of Benthin et al. 2012, "Combining
//! Single and Packet-Ray Tracing for Arbitrary Ray Distributions on the
//! Intel MIC Architecture").
//!
//! Per node, one 8-wide interval test of all children against the whole
//! packet (Wald et al. 2007, "Ray Tracing Deformable Scenes Using Dynamic
//! Bounding Volume Hierarchies", interval arithmetic over the packet's
//! origins and reciprocal directions) culls the children no ray of the
//! packet can enter. Each child that passes is then tested against the
//! packet's rays, one lane per ray (eight with AVX2, [`X8`]; sixteen with
//! AVX-512, [`X16`]), giving the rays that enter it; children are pushed
//! with those lanes in the octant's front-to-back order. A leaf tests each
//! triangle against the packet's rays at once. A child entered by fewer
//! than `single_below` rays is handed to the single-ray kernel, one ray at
//! a time, from that child down.
//!
//! The same answers as single rays, by construction:
//! - the lane test is the single-ray slab test lane by lane: the same
//!   constants ([`BoxRay`]), the same operations in the same order;
//! - the interval test is the same formula evaluated at the ends of each
//!   constant's range over the packet. Correctly rounded subtraction,
//!   multiplication and fused multiply-add are monotone in each operand,
//!   so over a box of operands their extremes lie at its corners, and the
//!   interval's near distance is at most every lane's computed near
//!   distance, its far distance at least every lane's far distance: it
//!   never culls a child that a ray of the packet would enter;
//! - leaves run the single-ray triangle test's operations lane by lane,
//!   each ray with its own `t_max`.
//!
//! So each ray's hit is the nearest of the primitives its single-ray test
//! accepts. Between triangles at exactly the same distance the lower slot
//! wins in both (`leaves::BlockLeaves`), so the visiting order cannot pick
//! another; and each lane first takes the single-ray walk's root box test
//! ([`PacketRays::enters`]).

use std::arch::x86_64::*;

use super::*;
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
}

/// Eight rays in AVX2 lanes.
#[derive(Clone, Copy, Debug)]
pub struct X8;

/// Sixteen rays in AVX-512 lanes.
#[derive(Clone, Copy, Debug)]
pub struct X16;

/// The lanes of `mask` as an AVX2 vector mask.
#[inline(always)]
unsafe fn lane_mask8(mask: u32) -> __m256 {
    let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    _mm256_castsi256_ps(_mm256_cmpeq_epi32(
        _mm256_and_si256(_mm256_set1_epi32(mask as i32), bits),
        bits,
    ))
}

/// Up to eight rays' eight floats, transposed.
#[inline(always)]
unsafe fn fields8(rays: &[Ray]) -> [__m256; 8] {
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

/// One round of [`fields16`]: registers `k` and `k + step` (for each `k`
/// without `step`'s bit) give `k` their lanes picked by `even` and
/// `k + step` those picked by `odd`.
#[inline(always)]
unsafe fn shuffle_round(x: [__m512; 8], step: usize, even: __m512i, odd: __m512i) -> [__m512; 8] {
    let mut y = x;
    for k in 0..8 {
        if k & step == 0 {
            y[k] = _mm512_permutex2var_ps(x[k], even, x[k + step]);
            y[k + step] = _mm512_permutex2var_ps(x[k], odd, x[k + step]);
        }
    }
    y
}

/// Sixteen rays' eight floats, transposed: eight loads of two rays each,
/// then three rounds of two-source shuffles, each exchanging one bit of
/// the ray index (which register) with one of the field index (which
/// lane), 24 shuffles where [`fields8`] twice takes 56.
#[inline(always)]
unsafe fn fields16(rays: &[Ray; 16]) -> [__m512; 8] {
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

unsafe impl Width for X8 {
    type V = __m256;
    const N: usize = 8;
    #[inline(always)]
    unsafe fn splat(x: f32) -> __m256 {
        _mm256_set1_ps(x)
    }
    #[inline(always)]
    unsafe fn add(a: __m256, b: __m256) -> __m256 {
        _mm256_add_ps(a, b)
    }
    #[inline(always)]
    unsafe fn sub(a: __m256, b: __m256) -> __m256 {
        _mm256_sub_ps(a, b)
    }
    #[inline(always)]
    unsafe fn mul(a: __m256, b: __m256) -> __m256 {
        _mm256_mul_ps(a, b)
    }
    #[inline(always)]
    unsafe fn div(a: __m256, b: __m256) -> __m256 {
        _mm256_div_ps(a, b)
    }
    #[inline(always)]
    unsafe fn fmsub(a: __m256, b: __m256, c: __m256) -> __m256 {
        _mm256_fmsub_ps(a, b, c)
    }
    #[inline(always)]
    unsafe fn min(a: __m256, b: __m256) -> __m256 {
        _mm256_min_ps(a, b)
    }
    #[inline(always)]
    unsafe fn max(a: __m256, b: __m256) -> __m256 {
        _mm256_max_ps(a, b)
    }
    #[inline(always)]
    unsafe fn xor(a: __m256, b: __m256) -> __m256 {
        _mm256_xor_ps(a, b)
    }
    #[inline(always)]
    unsafe fn abs(a: __m256) -> __m256 {
        _mm256_andnot_ps(_mm256_set1_ps(-0.0), a)
    }
    #[inline(always)]
    unsafe fn copysign(m: __m256, s: __m256) -> __m256 {
        let sign = _mm256_set1_ps(-0.0);
        _mm256_or_ps(_mm256_andnot_ps(sign, m), _mm256_and_ps(sign, s))
    }
    #[inline(always)]
    unsafe fn le(a: __m256, b: __m256) -> u32 {
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(a, b)) as u32
    }
    #[inline(always)]
    unsafe fn lt(a: __m256, b: __m256) -> u32 {
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LT_OQ>(a, b)) as u32
    }
    #[inline(always)]
    unsafe fn gt(a: __m256, b: __m256) -> u32 {
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GT_OQ>(a, b)) as u32
    }
    #[inline(always)]
    unsafe fn ge(a: __m256, b: __m256) -> u32 {
        _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_GE_OQ>(a, b)) as u32
    }
    #[inline(always)]
    unsafe fn select(mask: u32, no: __m256, yes: __m256) -> __m256 {
        _mm256_blendv_ps(no, yes, lane_mask8(mask))
    }
    #[inline(always)]
    unsafe fn load(p: &[f32; MAX_LANES]) -> __m256 {
        _mm256_loadu_ps(p.as_ptr())
    }
    #[inline(always)]
    unsafe fn store(p: &mut [f32; MAX_LANES], v: __m256) {
        _mm256_storeu_ps(p.as_mut_ptr(), v)
    }
    #[cfg(test)]
    #[inline(always)]
    unsafe fn min_of(v: __m256, mask: u32) -> f32 {
        let m = X8::select(mask, _mm256_set1_ps(f32::INFINITY), v);
        let m = _mm256_min_ps(m, _mm256_permute2f128_ps::<1>(m, m));
        let m = _mm256_min_ps(m, _mm256_shuffle_ps::<0b0100_1110>(m, m));
        _mm256_cvtss_f32(_mm256_min_ps(m, _mm256_shuffle_ps::<0b1011_0001>(m, m)))
    }
    #[inline(always)]
    unsafe fn max_of(v: __m256, mask: u32) -> f32 {
        let m = X8::select(mask, _mm256_set1_ps(f32::NEG_INFINITY), v);
        let m = _mm256_max_ps(m, _mm256_permute2f128_ps::<1>(m, m));
        let m = _mm256_max_ps(m, _mm256_shuffle_ps::<0b0100_1110>(m, m));
        _mm256_cvtss_f32(_mm256_max_ps(m, _mm256_shuffle_ps::<0b1011_0001>(m, m)))
    }
    /// Up to sixteen minima at once: three rounds, each halving the lanes
    /// left of every input while pairing inputs into one register (42
    /// shuffles and minima where sixteen reductions one by one take 96),
    /// as [`X16::min_each`] does at sixteen lanes.
    #[inline(always)]
    unsafe fn min_each<const K: usize>(v: [__m256; K], mask: u32) -> [f32; K] {
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
    #[inline(always)]
    unsafe fn fields(rays: &[Ray]) -> [__m256; 8] {
        fields8(rays)
    }
}

unsafe impl Width for X16 {
    type V = __m512;
    const N: usize = 16;
    #[inline(always)]
    unsafe fn splat(x: f32) -> __m512 {
        _mm512_set1_ps(x)
    }
    #[inline(always)]
    unsafe fn add(a: __m512, b: __m512) -> __m512 {
        _mm512_add_ps(a, b)
    }
    #[inline(always)]
    unsafe fn sub(a: __m512, b: __m512) -> __m512 {
        _mm512_sub_ps(a, b)
    }
    #[inline(always)]
    unsafe fn mul(a: __m512, b: __m512) -> __m512 {
        _mm512_mul_ps(a, b)
    }
    #[inline(always)]
    unsafe fn div(a: __m512, b: __m512) -> __m512 {
        _mm512_div_ps(a, b)
    }
    #[inline(always)]
    unsafe fn fmsub(a: __m512, b: __m512, c: __m512) -> __m512 {
        _mm512_fmsub_ps(a, b, c)
    }
    #[inline(always)]
    unsafe fn min(a: __m512, b: __m512) -> __m512 {
        _mm512_min_ps(a, b)
    }
    #[inline(always)]
    unsafe fn max(a: __m512, b: __m512) -> __m512 {
        _mm512_max_ps(a, b)
    }
    #[inline(always)]
    unsafe fn xor(a: __m512, b: __m512) -> __m512 {
        _mm512_castsi512_ps(_mm512_xor_si512(
            _mm512_castps_si512(a),
            _mm512_castps_si512(b),
        ))
    }
    #[inline(always)]
    unsafe fn abs(a: __m512) -> __m512 {
        let sign = _mm512_set1_epi32(i32::MIN);
        _mm512_castsi512_ps(_mm512_andnot_si512(sign, _mm512_castps_si512(a)))
    }
    #[inline(always)]
    unsafe fn copysign(m: __m512, s: __m512) -> __m512 {
        let sign = _mm512_set1_epi32(i32::MIN);
        _mm512_castsi512_ps(_mm512_or_si512(
            _mm512_andnot_si512(sign, _mm512_castps_si512(m)),
            _mm512_and_si512(sign, _mm512_castps_si512(s)),
        ))
    }
    #[inline(always)]
    unsafe fn le(a: __m512, b: __m512) -> u32 {
        u32::from(_mm512_cmp_ps_mask::<_CMP_LE_OQ>(a, b))
    }
    #[inline(always)]
    unsafe fn lt(a: __m512, b: __m512) -> u32 {
        u32::from(_mm512_cmp_ps_mask::<_CMP_LT_OQ>(a, b))
    }
    #[inline(always)]
    unsafe fn gt(a: __m512, b: __m512) -> u32 {
        u32::from(_mm512_cmp_ps_mask::<_CMP_GT_OQ>(a, b))
    }
    #[inline(always)]
    unsafe fn ge(a: __m512, b: __m512) -> u32 {
        u32::from(_mm512_cmp_ps_mask::<_CMP_GE_OQ>(a, b))
    }
    #[inline(always)]
    unsafe fn select(mask: u32, no: __m512, yes: __m512) -> __m512 {
        _mm512_mask_blend_ps(mask as u16, no, yes)
    }
    #[inline(always)]
    unsafe fn load(p: &[f32; MAX_LANES]) -> __m512 {
        _mm512_loadu_ps(p.as_ptr())
    }
    #[inline(always)]
    unsafe fn store(p: &mut [f32; MAX_LANES], v: __m512) {
        _mm512_storeu_ps(p.as_mut_ptr(), v)
    }
    #[cfg(test)]
    #[inline(always)]
    unsafe fn min_of(v: __m512, mask: u32) -> f32 {
        _mm512_reduce_min_ps(X16::select(mask, _mm512_set1_ps(f32::INFINITY), v))
    }
    #[inline(always)]
    unsafe fn max_of(v: __m512, mask: u32) -> f32 {
        _mm512_reduce_max_ps(X16::select(mask, _mm512_set1_ps(f32::NEG_INFINITY), v))
    }
    /// Up to sixteen minima at once: four rounds, each halving the lanes
    /// left of every input while pairing inputs into one register, 30
    /// shuffles where sixteen reductions one by one take 64.
    #[inline(always)]
    unsafe fn min_each<const K: usize>(v: [__m512; K], mask: u32) -> [f32; K] {
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
    #[inline(always)]
    unsafe fn fields(rays: &[Ray]) -> [__m512; 8] {
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

/// A packet's rays as the leaf test takes them: origins, directions and
/// `t_min`, one lane per ray.
pub struct Lanes<W: Width> {
    pub origin: [W::V; 3],
    pub dir: [W::V; 3],
    pub t_min: W::V,
    /// Per lane the triangle prefilter's bound on `t * |det|`
    /// (`triangle::behind` of its `t_min`).
    pub behind: W::V,
}

/// Up to `W::N` rays as lanes, with what the kernels need, computed all
/// lanes at a time by the operations [`BoxRay::new`] and
/// [`Ray::traceable_vectors`] use per ray (so each lane holds the bits the
/// single-ray kernel computes). Lanes past the rays given repeat the last.
pub struct PacketRays<W: Width> {
    pub lanes: Lanes<W>,
    inv: [W::V; 3],
    /// The fast test's constants per axis: near `c`, far `r`, far `c`.
    fast: [[W::V; 3]; 3],
    t_max: W::V,
    /// Lanes whose ray is traceable.
    pub traceable: u32,
    /// Lanes whose fast-test constants are finite.
    fits: u32,
    /// Per axis, the lanes whose direction is negative.
    negative: [u32; 3],
}

/// The lanes of `group` whose octant (per axis, the lanes in `negative`
/// point down it) is that of its lowest lane.
#[inline(always)]
fn same_octant(negative: [u32; 3], group: u32) -> u32 {
    let lead = group.trailing_zeros();
    let mut same = group;
    for n in negative {
        same &= if n >> lead & 1 != 0 { n } else { !n };
    }
    same
}

/// Whether `min` of `rays` share an octant, read from the
/// directions' sign bits (the octants the packet code sorts traceable rays
/// by) in plain scalar code, so that a group where no packet can form
/// costs a few instructions a ray and never the lanes' set-up.
#[inline(always)]
pub fn packet_can_form(rays: &[Ray], min: u32) -> bool {
    debug_assert!(rays.len() <= MAX_LANES && (1..=MAX_LANES as u32).contains(&min));
    // One byte per octant counts its rays (at most sixteen, so no byte
    // carries into the next); adding 128 - min to every byte sets the
    // top bit of those that reached `min`.
    let mut counts = 0u64;
    for ray in rays {
        let sign = |x: f32| (x.to_bits() >> 31) as u64;
        let octant = sign(ray.dir.x) | sign(ray.dir.y) << 1 | sign(ray.dir.z) << 2;
        counts += 1 << (8 * octant);
    }
    let threshold = (128 - u64::from(min)) * 0x0101_0101_0101_0101;
    (counts + threshold) & 0x8080_8080_8080_8080 != 0
}

impl<W: Width> PacketRays<W> {
    /// The first `W::N` of `rays` (at least one) as lanes. Callers ask
    /// [`packet_can_form`] first: without a packet the set-up (three
    /// divisions, the box test's constants) is paid for nothing.
    ///
    /// # Safety
    /// Only from `W`'s `#[target_feature]` code ([`Width`]).
    #[inline(always)]
    pub unsafe fn load(rays: &[Ray]) -> PacketRays<W> {
        let [ox, oy, oz, dx, dy, dz, t_min, t_max] = W::fields(rays);
        let (origin, dir) = ([ox, oy, oz], [dx, dy, dz]);
        let lanes = (1u32 << rays.len().min(W::N)) - 1;
        // Ray::traceable_vectors, lane by lane.
        let limit = W::splat(crate::geom::ray::COORDINATE_LIMIT);
        let zero = W::splat(0.0);
        let mut traceable = W::le(t_min, t_max) & W::ge(t_min, zero);
        let mut moves = 0;
        for a in 0..3 {
            traceable &= W::le(W::abs(origin[a]), limit) & W::le(W::abs(dir[a]), limit);
            moves |= W::gt(W::abs(dir[a]), zero);
        }
        // BoxRay::new, lane by lane.
        let tiny = W::splat(1e-20);
        let one = W::splat(1.0);
        let infinity = W::splat(f32::INFINITY);
        let mut inv = [zero; 3];
        let mut fast = [[zero; 3]; 3];
        let mut negative = [0u32; 3];
        let mut fits = u32::MAX;
        for a in 0..3 {
            let d = dir[a];
            let safe = W::select(W::lt(W::abs(d), tiny), d, W::copysign(tiny, d));
            inv[a] = W::div(one, safe);
            let sign = W::mul(origin[a], safe);
            let near_k = W::add(one, W::copysign(W::splat(FAST_NEAR_MARGIN), sign));
            let far_k = W::sub(
                W::splat(FAST_FAR_SCALE),
                W::copysign(W::splat(FAST_FAR_MARGIN), sign),
            );
            fast[0][a] = W::mul(W::mul(origin[a], near_k), inv[a]);
            fast[1][a] = W::mul(inv[a], W::splat(FAST_FAR_SCALE));
            fast[2][a] = W::mul(W::mul(origin[a], far_k), inv[a]);
            fits &= W::lt(W::abs(fast[0][a]), infinity) & W::lt(W::abs(fast[2][a]), infinity);
            negative[a] = W::lt(safe, zero);
        }
        PacketRays {
            lanes: Lanes {
                origin,
                dir,
                t_min,
                behind: W::select(
                    W::ge(t_min, W::splat(0.0)),
                    W::splat(f32::NEG_INFINITY),
                    W::splat(0.0),
                ),
            },
            inv,
            fast,
            t_max,
            traceable: traceable & moves & lanes,
            fits,
            negative,
        }
    }

    /// The lanes of `group` whose directions lie in the octant of its
    /// lowest lane.
    pub fn same_octant(&self, group: u32) -> u32 {
        same_octant(self.negative, group)
    }

    /// The lanes whose ray enters the box `[lo, hi]` within their `t_max`:
    /// [`BoxRay::enters`], the single-ray walk's test of the root, lane by
    /// lane with the same operations (its minima and maxima are exact, so
    /// their order does not matter). A hit the triangle test's edge slack
    /// places just outside the root box is then missed by a packet's lane
    /// exactly as by the ray alone.
    ///
    /// # Safety
    /// As [`PacketRays::load`].
    #[inline(always)]
    pub unsafe fn enters(&self, [lo, hi]: [Vec3A; 2], t_max: W::V) -> u32 {
        let o = &self.lanes.origin;
        let mut inside = u32::MAX;
        let mut near = self.lanes.t_min;
        let mut far = W::splat(f32::INFINITY);
        for k in 0..3 {
            let (l, h) = (W::splat(lo[k]), W::splat(hi[k]));
            inside &= W::ge(o[k], l) & W::le(o[k], h);
            let a = W::mul(W::sub(l, o[k]), self.inv[k]);
            let b = W::mul(W::sub(h, o[k]), self.inv[k]);
            near = W::max(near, W::min(a, b));
            far = W::min(far, W::max(a, b));
        }
        let far = W::min(W::mul(far, W::splat(BOX_FAR_SCALE)), t_max);
        inside | W::le(near, far)
    }

    /// Each lane's `t_max`.
    ///
    /// # Safety
    /// As [`PacketRays::load`].
    #[inline(always)]
    pub unsafe fn t_max(&self) -> [f32; MAX_LANES] {
        let mut a = [0.0f32; MAX_LANES];
        W::store(&mut a, self.t_max);
        a
    }
}

/// A packet: the lanes in `mask` of `rays`, which share one octant.
pub struct Packet<'r, W: Width> {
    pub rays: &'r PacketRays<W>,
    pub mask: u32,
}

impl<W: Width> Packet<'_, W> {
    /// Whether every ray of the packet may take the fast box test.
    pub fn fast_test_fits(&self) -> bool {
        self.rays.fits & self.mask == self.mask
    }

    /// Rows of `Node8::planes` holding each axis's near and far planes.
    fn rows(&self) -> [(usize, usize); 3] {
        let lead = self.mask.trailing_zeros();
        [0, 1, 2].map(|a| {
            let near = 2 * a + (self.rays.negative[a] >> lead & 1) as usize;
            (near, near ^ 1)
        })
    }

    /// Index of the octant's child order (bit set for a positive axis).
    fn octant(&self) -> u32 {
        let lead = self.mask.trailing_zeros();
        (0..3).fold(0, |o, a| o | ((!self.rays.negative[a] >> lead & 1) << a))
    }
}

/// The interval test's constants, broadcast over a node's eight children:
/// per axis the range of the reciprocals and the end of each offset's
/// range that gives the lowest near and the highest far distance (see the
/// module notes).
struct Interval {
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
unsafe fn interval<W: Width, const ROBUST: bool>(p: &Packet<W>) -> Interval {
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

/// One plane's distance over the node's children, robust
/// `(plane - c) * r` or fast `plane * r - c`.
#[inline(always)]
unsafe fn distance<const ROBUST: bool>(plane: __m256, r: __m256, c: __m256) -> __m256 {
    if ROBUST {
        _mm256_mul_ps(_mm256_sub_ps(plane, c), r)
    } else {
        _mm256_fmsub_ps(plane, r, c)
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

/// The interval test of the node's eight children against the packet:
/// lower bounds of the entry distances and the children some ray may
/// enter within `t_max`.
#[inline(always)]
unsafe fn interval_slab<const ROBUST: bool>(
    node: &Node8,
    ia: &Interval,
    rows: &[(usize, usize); 3],
    t_max: __m256,
) -> (__m256, u32) {
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

/// The rays (lanes) that enter child `c` of `node` within their own
/// `t_max`: the single-ray slab test, lane by lane.
#[inline(always)]
unsafe fn lane_slab<W: Width, const ROBUST: bool>(
    node: &Node8,
    c: usize,
    r: &PacketRays<W>,
    rows: &[(usize, usize); 3],
    t_max: W::V,
) -> u32 {
    let [near_r, near_c, far_r, far_c] = constants::<W, ROBUST>(r);
    let plane = |row: usize| W::splat(node.planes[row][c]);
    let distance = |p: W::V, r: W::V, c: W::V| {
        if ROBUST {
            W::mul(W::sub(p, c), r)
        } else {
            W::fmsub(p, r, c)
        }
    };
    let near_t = |a: usize| distance(plane(rows[a].0), near_r[a], near_c[a]);
    let far_t = |a: usize| distance(plane(rows[a].1), far_r[a], far_c[a]);
    let near = W::max(
        W::max(near_t(0), near_t(1)),
        W::max(near_t(2), r.lanes.t_min),
    );
    let far = W::min(W::min(far_t(0), far_t(1)), far_t(2));
    let far = if ROBUST {
        W::mul(far, W::splat(BOX_FAR_SCALE))
    } else {
        far
    };
    W::le(near, W::min(far, t_max))
}

/// Lanes outside `mask` set to `-inf`, so that no box test passes there.
#[inline(always)]
unsafe fn masked_t_max<W: Width>(t_max: &[f32; MAX_LANES], mask: u32) -> W::V {
    W::select(mask, W::splat(f32::NEG_INFINITY), W::load(t_max))
}

/// Iterates the set bits of `mask`, lowest first.
#[inline(always)]
fn bits(mut mask: u32) -> impl Iterator<Item = usize> {
    std::iter::from_fn(move || {
        (mask != 0).then(|| {
            let i = mask.trailing_zeros() as usize;
            mask &= mask - 1;
            i
        })
    })
}

/// Closest hits of the packet's rays: shrinks each lane's `t_max` to its
/// hit; returns the lanes that hit. `leaves` tests the packet's leaves;
/// `single(leaves, i, start, t_max, work)` traces ray `i` alone from
/// `start` (the single-ray kernel with ray `i`'s leaf test, leaving its
/// hit where `leaves` keeps lane `i`'s).
///
/// # Safety
/// Only from `W`'s `#[target_feature]` code ([`Width`]), which also has
/// AVX2 and FMA; `tree` is not empty.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub unsafe fn closest<W: Width, const ROBUST: bool, P: PacketLeaves<W>>(
    tree: &Tree,
    packet: &Packet<W>,
    t_max: &mut [f32; MAX_LANES],
    leaves: &mut P,
    single: &mut impl FnMut(&mut P, usize, ChildRef, &mut f32, &mut Work) -> bool,
    work: &mut Work,
    single_below: u32,
) -> u32 {
    let ia = interval::<W, ROBUST>(packet);
    let lanes = packet.rays;
    let rows = packet.rows();
    let shift = _mm_cvtsi32_si128(3 * packet.octant() as i32);
    let mut refs = AlignedStack::<ChildRef>::new();
    let mut masks = AlignedStack::<u32>::new();
    let mut dists = AlignedStack::<f32>::new();
    let (refs, masks, dists) = (refs.as_mut_ptr(), masks.as_mut_ptr(), dists.as_mut_ptr());
    let mut top = 0usize;
    let mut t_lanes = masked_t_max::<W>(t_max, packet.mask);
    let mut far = W::max_of(t_lanes, packet.mask);
    let mut current: ChildRef = 0;
    let mut mask = packet.mask;
    let mut hits = 0u32;
    loop {
        if !is_leaf(current) {
            // SAFETY: the root, or an inner reference read from a node.
            let node = tree.node_unchecked(current);
            work.nodes += 1;
            let (near, passed) = interval_slab::<ROBUST>(node, &ia, &rows, _mm256_set1_ps(far));
            if passed != 0 {
                // The passed children in the octant's order, farthest
                // first: place `p` holds child `order[p] >> shift & 7`.
                let order = _mm256_and_si256(
                    _mm256_srl_epi32(_mm256_load_si256(node.order.as_ptr().cast()), shift),
                    _mm256_set1_epi32(7),
                );
                let hit_v = _mm256_castsi256_ps(_mm256_cmpgt_epi32(
                    _mm256_and_si256(
                        _mm256_set1_epi32(passed as i32),
                        _mm256_sllv_epi32(_mm256_set1_epi32(1), order),
                    ),
                    _mm256_setzero_si256(),
                ));
                let sorted = _mm256_movemask_ps(hit_v) as u32;
                let mut places = [0u32; WIDTH];
                _mm256_storeu_si256(places.as_mut_ptr().cast(), order);
                let mut near_of = [0f32; WIDTH];
                _mm256_storeu_ps(near_of.as_mut_ptr(), near);
                for place in bits(sorted) {
                    let c = places[place] as usize;
                    let entering = lane_slab::<W, ROBUST>(node, c, lanes, &rows, t_lanes) & mask;
                    if entering == 0 {
                        continue;
                    }
                    let child = node.child[c];
                    if entering.count_ones() < single_below {
                        for i in bits(entering) {
                            if single(leaves, i, child, &mut t_max[i], work) {
                                hits |= 1 << i;
                            }
                        }
                        t_lanes = masked_t_max::<W>(t_max, packet.mask);
                        far = W::max_of(t_lanes, packet.mask);
                        continue;
                    }
                    // SAFETY: each level leaves at most eight entries, the
                    // depth is bounded by MAX_DEPTH, and STACK holds that.
                    *refs.add(top) = child;
                    *masks.add(top) = entering;
                    *dists.add(top) = near_of[c];
                    top += 1;
                }
            }
        } else {
            let (first, count) = (leaf_first(current), leaf_count(current));
            work.items += u64::from(count * mask.count_ones());
            hits |= leaves.nearest(first, count, mask, t_max);
            t_lanes = masked_t_max::<W>(t_max, packet.mask);
            far = W::max_of(t_lanes, packet.mask);
        }
        loop {
            if top == 0 {
                return hits;
            }
            top -= 1;
            // SAFETY: entries below `top` were written above.
            if *dists.add(top) <= far {
                current = *refs.add(top);
                mask = *masks.add(top);
                break;
            }
        }
    }
}

/// Whether anything blocks each of the packet's rays within its `t_max`:
/// the blocked lanes. Like single-ray any hit, children are taken in slot
/// order (smallest box last, so first off the stack) and a ray leaves the
/// packet at its first hit.
///
/// # Safety
/// As [`closest`].
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub unsafe fn any<W: Width, const ROBUST: bool, P: PacketLeaves<W>>(
    tree: &Tree,
    packet: &Packet<W>,
    t_max: &[f32; MAX_LANES],
    leaves: &mut P,
    single: &mut impl FnMut(&mut P, usize, ChildRef, f32, &mut Work) -> bool,
    work: &mut Work,
    single_below: u32,
) -> u32 {
    let ia = interval::<W, ROBUST>(packet);
    let lanes = packet.rays;
    let rows = packet.rows();
    let mut refs = AlignedStack::<ChildRef>::new();
    let mut masks = AlignedStack::<u32>::new();
    let (refs, masks) = (refs.as_mut_ptr(), masks.as_mut_ptr());
    let mut top = 0usize;
    let mut live = packet.mask;
    let mut t_lanes = masked_t_max::<W>(t_max, live);
    let mut far = W::max_of(t_lanes, live);
    let mut current: ChildRef = 0;
    let mut mask = live;
    loop {
        if !is_leaf(current) {
            // SAFETY: the root, or an inner reference read from a node.
            let node = tree.node_unchecked(current);
            work.nodes += 1;
            let (_, passed) = interval_slab::<ROBUST>(node, &ia, &rows, _mm256_set1_ps(far));
            for c in bits(passed) {
                let entering = lane_slab::<W, ROBUST>(node, c, lanes, &rows, t_lanes) & mask;
                if entering == 0 {
                    continue;
                }
                let child = node.child[c];
                if entering.count_ones() < single_below {
                    for i in bits(entering) {
                        if single(leaves, i, child, t_max[i], work) {
                            live &= !(1 << i);
                        }
                    }
                    if live == 0 {
                        return packet.mask;
                    }
                    mask &= live;
                    t_lanes = masked_t_max::<W>(t_max, live);
                    far = W::max_of(t_lanes, live);
                    continue;
                }
                // SAFETY: as in `closest`.
                *refs.add(top) = child;
                *masks.add(top) = entering;
                top += 1;
            }
        } else {
            let (first, count) = (leaf_first(current), leaf_count(current));
            work.items += u64::from(count * mask.count_ones());
            live &= !leaves.any(first, count, mask, t_max);
            if live == 0 {
                return packet.mask;
            }
            t_lanes = masked_t_max::<W>(t_max, live);
            far = W::max_of(t_lanes, live);
        }
        loop {
            if top == 0 {
                return packet.mask & !live;
            }
            top -= 1;
            // SAFETY: entries below `top` were written above.
            let m = *masks.add(top) & live;
            if m != 0 {
                current = *refs.add(top);
                mask = m;
                break;
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn avx512() -> bool {
        let yes = is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx2");
        if !yes {
            eprintln!("this CPU has no AVX-512: the sixteen-lane kernels are not reached here");
        }
        yes
    }

    /// Sixteen rays with distinct floats, field `f` of ray `i` being
    /// `i + f / 8`.
    fn rays() -> Vec<Ray> {
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
        X16::fields(rays).map(|v| {
            let mut a = [0.0; MAX_LANES];
            X16::store(&mut a, v);
            a
        })
    }

    /// The byte counters agree with counting each octant's rays, for
    /// every threshold and group size, signed zeros included.
    #[test]
    fn packets_form_where_an_octant_holds_enough_rays() {
        let mut state = 0x9e37_79b9_u32;
        let mut next = || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            state
        };
        let component = |bits: u32| match bits % 3 {
            0 => 0.5,
            1 => -0.5,
            _ => -0.0,
        };
        for _ in 0..2000 {
            let n = 1 + next() as usize % MAX_LANES;
            let rays: Vec<Ray> = (0..n)
                .map(|_| {
                    let (x, y, z) = (next(), next(), next());
                    Ray::new(
                        glam::Vec3::ZERO,
                        glam::Vec3::new(component(x), component(y), component(z)),
                    )
                })
                .collect();
            let mut counts = [0u32; 8];
            for r in &rays {
                let o = (0..3).fold(0, |o, a| o | (r.dir[a].is_sign_negative() as usize) << a);
                counts[o] += 1;
            }
            for min in 1..=MAX_LANES as u32 {
                let expected = counts.iter().any(|&c| c >= min);
                assert_eq!(
                    packet_can_form(&rays, min),
                    expected,
                    "{counts:?}, min {min}"
                );
            }
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
        let vectors = v.map(|a| X16::load(&a));
        (
            X16::min_each(vectors, mask),
            vectors.map(|x| X16::min_of(x, mask)),
        )
    }

    #[target_feature(enable = "avx2")]
    unsafe fn minima8(v: &[[f32; MAX_LANES]; 13], mask: u32) -> ([f32; 13], [f32; 13]) {
        let vectors = v.map(|a| X8::load(&a));
        let mut one_by_one = [0.0; 13];
        for (k, x) in vectors.iter().enumerate() {
            one_by_one[k] = X8::min_of(*x, mask);
        }
        (X8::min_each(vectors, mask), one_by_one)
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
