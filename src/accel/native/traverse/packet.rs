//! Packet traversal: up to eight rays of one octant walk the tree together
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
//! packet's rays, eight lanes at once, giving the rays that enter it;
//! children are pushed with those lanes in the octant's front-to-back
//! order. A leaf is tested by each of its rays alone, with the single-ray
//! leaf test. A child entered by fewer than `single_below` rays is handed
//! to the single-ray kernel, one ray at a time, from that child down.
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
//! - leaves run the single-ray leaf test with the ray's own `t_max`.
//!
//! So each ray's hit is the nearest of the primitives its single-ray test
//! accepts; only between primitives at exactly the same distance may the
//! visiting order pick another (the single-ray kernels differ from each
//! other there too).

use std::arch::x86_64::*;

use super::*;
use crate::accel::native::triangle::eight::Rays8;
use crate::geom::Ray;

/// Rays in a packet.
pub const LANES: usize = 8;

/// Up to eight rays as lanes, with what the kernels need, computed eight
/// lanes at a time by the operations [`BoxRay::new`] and
/// [`Ray::traceable_vectors`] use per ray (so each lane holds the bits the
/// single-ray kernel computes). Lanes past the rays given repeat the last.
pub struct PacketRays {
    /// Origins, directions and `t_min`, as the leaf test takes them.
    pub lanes: Rays8,
    inv: [__m256; 3],
    /// The fast test's constants per axis: near `c`, far `r`, far `c`.
    fast: [[__m256; 3]; 3],
    t_max: __m256,
    /// Lanes whose ray is traceable.
    pub traceable: u32,
    /// Lanes whose fast-test constants are finite.
    fits: u32,
    /// Per axis, the lanes whose direction is negative.
    negative: [u32; 3],
}

impl PacketRays {
    /// The first eight of `rays` (at least one).
    ///
    /// # Safety
    /// Needs AVX2 (the caller's token).
    #[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
    pub unsafe fn load(rays: &[Ray]) -> PacketRays {
        let last = rays.len().min(LANES) - 1;
        // A `Ray` is eight floats (`repr(C)`): one row per ray, transposed
        // into one vector per field.
        let row = |i: usize| _mm256_loadu_ps((&rays[i.min(last)] as *const Ray).cast::<f32>());
        let [ox, oy, oz, dx, dy, dz, t_min, t_max] = transpose([
            row(0),
            row(1),
            row(2),
            row(3),
            row(4),
            row(5),
            row(6),
            row(7),
        ]);
        let (origin, dir) = ([ox, oy, oz], [dx, dy, dz]);
        let sign_bit = _mm256_set1_ps(-0.0);
        let abs = |v| _mm256_andnot_ps(sign_bit, v);
        let copysign =
            |m, s| _mm256_or_ps(_mm256_andnot_ps(sign_bit, m), _mm256_and_ps(sign_bit, s));
        let (le, lt) = (
            |a, b| _mm256_cmp_ps::<_CMP_LE_OQ>(a, b),
            |a, b| _mm256_cmp_ps::<_CMP_LT_OQ>(a, b),
        );
        // Ray::traceable_vectors, lane by lane.
        let limit = _mm256_set1_ps(crate::geom::ray::COORDINATE_LIMIT);
        let zero = _mm256_setzero_ps();
        let mut inside = _mm256_and_ps(le(t_min, t_max), _mm256_cmp_ps::<_CMP_GE_OQ>(t_min, zero));
        let mut moves = zero;
        for a in 0..3 {
            inside = _mm256_and_ps(
                inside,
                _mm256_and_ps(le(abs(origin[a]), limit), le(abs(dir[a]), limit)),
            );
            moves = _mm256_or_ps(moves, _mm256_cmp_ps::<_CMP_GT_OQ>(abs(dir[a]), zero));
        }
        let traceable = _mm256_movemask_ps(_mm256_and_ps(inside, moves)) as u32;
        // BoxRay::new, lane by lane.
        let tiny = _mm256_set1_ps(1e-20);
        let one = _mm256_set1_ps(1.0);
        let infinity = _mm256_set1_ps(f32::INFINITY);
        let mut inv = [zero; 3];
        let mut fast = [[zero; 3]; 3];
        let mut negative = [0u32; 3];
        let mut finite = _mm256_castsi256_ps(_mm256_set1_epi32(-1));
        for a in 0..3 {
            let d = dir[a];
            let safe = _mm256_blendv_ps(d, copysign(tiny, d), lt(abs(d), tiny));
            inv[a] = _mm256_div_ps(one, safe);
            let sign = _mm256_mul_ps(origin[a], safe);
            let near_k = _mm256_add_ps(one, copysign(_mm256_set1_ps(FAST_NEAR_MARGIN), sign));
            let far_k = _mm256_sub_ps(
                _mm256_set1_ps(FAST_FAR_SCALE),
                copysign(_mm256_set1_ps(FAST_FAR_MARGIN), sign),
            );
            fast[0][a] = _mm256_mul_ps(_mm256_mul_ps(origin[a], near_k), inv[a]);
            fast[1][a] = _mm256_mul_ps(inv[a], _mm256_set1_ps(FAST_FAR_SCALE));
            fast[2][a] = _mm256_mul_ps(_mm256_mul_ps(origin[a], far_k), inv[a]);
            finite = _mm256_and_ps(
                finite,
                _mm256_and_ps(lt(abs(fast[0][a]), infinity), lt(abs(fast[2][a]), infinity)),
            );
            negative[a] = _mm256_movemask_ps(lt(safe, zero)) as u32;
        }
        let lanes = (1u32 << (last + 1)) - 1;
        PacketRays {
            lanes: Rays8 { origin, dir, t_min },
            inv,
            fast,
            t_max,
            traceable: traceable & lanes,
            fits: _mm256_movemask_ps(finite) as u32,
            negative,
        }
    }

    /// The lanes of `group` whose directions lie in the octant of its
    /// lowest lane.
    pub fn same_octant(&self, group: u32) -> u32 {
        let lead = group.trailing_zeros();
        self.negative
            .iter()
            .fold(group, |m, &n| m & if n >> lead & 1 != 0 { n } else { !n })
    }

    /// Each lane's `t_max`.
    pub fn t_max(&self) -> [f32; LANES] {
        let mut a = [0.0f32; LANES];
        // SAFETY: stores eight floats into `a`.
        unsafe { _mm256_storeu_ps(a.as_mut_ptr(), self.t_max) };
        a
    }
}

/// Eight rows of eight floats as eight columns.
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
fn transpose(r: [__m256; 8]) -> [__m256; 8] {
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

/// A packet: the lanes in `mask` of `rays`, which share one octant.
pub struct Packet<'r> {
    pub rays: &'r PacketRays,
    pub mask: u32,
}

impl Packet<'_> {
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

/// The interval test's constants: per axis the range of the reciprocals
/// and the end of each offset's range that gives the lowest near and the
/// highest far distance (see the module notes).
struct Interval {
    near_r: [(__m256, __m256); 3],
    near_c: [__m256; 3],
    far_r: [(__m256, __m256); 3],
    far_c: [__m256; 3],
    t_min: __m256,
}

/// The smallest of the lanes in `on` (a vector mask), in every lane.
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
fn all_min(v: __m256, on: __m256) -> __m256 {
    let m = _mm256_blendv_ps(_mm256_set1_ps(f32::INFINITY), v, on);
    let m = _mm256_min_ps(m, _mm256_permute2f128_ps::<1>(m, m));
    let m = _mm256_min_ps(m, _mm256_shuffle_ps::<0b0100_1110>(m, m));
    _mm256_min_ps(m, _mm256_shuffle_ps::<0b1011_0001>(m, m))
}

/// The largest of the lanes in `on`, in every lane.
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
fn all_max(v: __m256, on: __m256) -> __m256 {
    let m = _mm256_blendv_ps(_mm256_set1_ps(f32::NEG_INFINITY), v, on);
    let m = _mm256_max_ps(m, _mm256_permute2f128_ps::<1>(m, m));
    let m = _mm256_max_ps(m, _mm256_shuffle_ps::<0b0100_1110>(m, m));
    _mm256_max_ps(m, _mm256_shuffle_ps::<0b1011_0001>(m, m))
}

/// The lane test's constants of each axis: near `r`, near `c`, far `r`,
/// far `c` (robust form: reciprocal and origin; fast form: the fused
/// constants).
#[inline(always)]
fn constants<const ROBUST: bool>(r: &PacketRays) -> [&[__m256; 3]; 4] {
    if ROBUST {
        [&r.inv, &r.lanes.origin, &r.inv, &r.lanes.origin]
    } else {
        [&r.inv, &r.fast[0], &r.fast[1], &r.fast[2]]
    }
}

/// The interval test's constants of packet `p`, written into `ia`.
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
fn interval<const ROBUST: bool>(p: &Packet, ia: &mut Interval) {
    let r = p.rays;
    let [_, near_c, _, far_c] = constants::<ROBUST>(r);
    let on = lane_mask(p.mask);
    let lead = p.mask.trailing_zeros();
    ia.t_min = all_min(r.lanes.t_min, on);
    for axis in 0..3 {
        let (r_lo, r_hi) = (all_min(r.inv[axis], on), all_max(r.inv[axis], on));
        ia.near_r[axis] = (r_lo, r_hi);
        // The fast form's far reciprocal is `r (1 + 2^-20)` lane by lane;
        // multiplying by a positive constant keeps the order, so its range
        // is the reciprocals' range times the same constant.
        ia.far_r[axis] = if ROBUST {
            (r_lo, r_hi)
        } else {
            let scale = _mm256_set1_ps(FAST_FAR_SCALE);
            (_mm256_mul_ps(r_lo, scale), _mm256_mul_ps(r_hi, scale))
        };
        // Fast form `plane * r - c`: the largest `c` lowers the near
        // distance, the smallest raises the far one. Robust form
        // `(plane - o) * r`: which end of `o` does depends on the sign of
        // `r`, the packet's octant.
        let negative_axis = r.negative[axis] >> lead & 1 != 0;
        if ROBUST && negative_axis {
            ia.near_c[axis] = all_min(near_c[axis], on);
            ia.far_c[axis] = all_max(far_c[axis], on);
        } else {
            ia.near_c[axis] = all_max(near_c[axis], on);
            ia.far_c[axis] = all_min(far_c[axis], on);
        }
    }
}

/// One plane's distance, robust `(plane - c) * r` or fast `plane * r - c`.
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
fn distance<const ROBUST: bool>(plane: __m256, r: __m256, c: __m256) -> __m256 {
    if ROBUST {
        _mm256_mul_ps(_mm256_sub_ps(plane, c), r)
    } else {
        _mm256_fmsub_ps(plane, r, c)
    }
}

/// The interval test of the node's eight children against the packet:
/// lower bounds of the entry distances and the children some ray may
/// enter within `t_max`.
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
unsafe fn interval_slab<const ROBUST: bool>(
    node: &Node8,
    ia: &Interval,
    rows: &[(usize, usize); 3],
    t_max: __m256,
) -> (__m256, u32) {
    let plane = |row: usize| _mm256_load_ps(node.planes[row].as_ptr());
    let near_t = |a: usize| {
        let p = plane(rows[a].0);
        let (lo, hi) = ia.near_r[a];
        _mm256_min_ps(
            distance::<ROBUST>(p, lo, ia.near_c[a]),
            distance::<ROBUST>(p, hi, ia.near_c[a]),
        )
    };
    let far_t = |a: usize| {
        let p = plane(rows[a].1);
        let (lo, hi) = ia.far_r[a];
        _mm256_max_ps(
            distance::<ROBUST>(p, lo, ia.far_c[a]),
            distance::<ROBUST>(p, hi, ia.far_c[a]),
        )
    };
    let near = _mm256_max_ps(
        _mm256_max_ps(near_t(0), near_t(1)),
        _mm256_max_ps(near_t(2), ia.t_min),
    );
    let far = _mm256_min_ps(_mm256_min_ps(far_t(0), far_t(1)), far_t(2));
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
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
fn lane_slab<const ROBUST: bool>(
    node: &Node8,
    c: usize,
    r: &PacketRays,
    rows: &[(usize, usize); 3],
    t_max: __m256,
) -> u32 {
    let [near_r, near_c, far_r, far_c] = constants::<ROBUST>(r);
    let plane = |row: usize| _mm256_set1_ps(node.planes[row][c]);
    let near_t = |a: usize| distance::<ROBUST>(plane(rows[a].0), near_r[a], near_c[a]);
    let far_t = |a: usize| distance::<ROBUST>(plane(rows[a].1), far_r[a], far_c[a]);
    let near = _mm256_max_ps(
        _mm256_max_ps(near_t(0), near_t(1)),
        _mm256_max_ps(near_t(2), r.lanes.t_min),
    );
    let far = _mm256_min_ps(_mm256_min_ps(far_t(0), far_t(1)), far_t(2));
    let far = if ROBUST {
        _mm256_mul_ps(far, _mm256_set1_ps(BOX_FAR_SCALE))
    } else {
        far
    };
    let far = _mm256_min_ps(far, t_max);
    _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(near, far)) as u32
}

/// The largest of the eight lanes.
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
fn horizontal_max(v: __m256) -> f32 {
    let m = _mm_max_ps(_mm256_castps256_ps128(v), _mm256_extractf128_ps::<1>(v));
    let m = _mm_max_ps(m, _mm_movehl_ps(m, m));
    let m = _mm_max_ss(m, _mm_shuffle_ps::<1>(m, m));
    _mm_cvtss_f32(m)
}

/// The lanes of `mask` as a vector mask.
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
pub fn lane_mask(mask: u32) -> __m256 {
    let bits = _mm256_setr_epi32(1, 2, 4, 8, 16, 32, 64, 128);
    _mm256_castsi256_ps(_mm256_cmpeq_epi32(
        _mm256_and_si256(_mm256_set1_epi32(mask as i32), bits),
        bits,
    ))
}

/// Lanes outside `mask` set to `-inf`, so that no box test passes there.
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
fn masked_t_max(t_max: &[f32; LANES], mask: u32) -> __m256 {
    // SAFETY: reads the eight floats of `t_max`.
    let t = unsafe { _mm256_loadu_ps(t_max.as_ptr()) };
    _mm256_blendv_ps(_mm256_set1_ps(f32::NEG_INFINITY), t, lane_mask(mask))
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
/// As [`avx2::closest`]: the token's CPU features and a non-empty `tree`.
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[allow(clippy::too_many_arguments)]
pub unsafe fn closest<const ROBUST: bool, P: PacketLeaves>(
    tree: &Tree,
    packet: &Packet,
    t_max: &mut [f32; LANES],
    leaves: &mut P,
    single: &mut impl FnMut(&mut P, usize, ChildRef, &mut f32, &mut Work) -> bool,
    work: &mut Work,
    single_below: u32,
) -> u32 {
    let zero = _mm256_setzero_ps();
    let mut ia = Interval {
        near_r: [(zero, zero); 3],
        near_c: [zero; 3],
        far_r: [(zero, zero); 3],
        far_c: [zero; 3],
        t_min: zero,
    };
    interval::<ROBUST>(packet, &mut ia);
    let lanes = packet.rays;
    let rows = packet.rows();
    let shift = _mm_cvtsi32_si128(3 * packet.octant() as i32);
    let mut refs = [MaybeUninit::<ChildRef>::uninit(); STACK];
    let mut masks = [MaybeUninit::<u32>::uninit(); STACK];
    let mut dists = [MaybeUninit::<f32>::uninit(); STACK];
    let (refs, masks, dists) = (
        refs.as_mut_ptr().cast::<ChildRef>(),
        masks.as_mut_ptr().cast::<u32>(),
        dists.as_mut_ptr().cast::<f32>(),
    );
    let mut top = 0usize;
    let mut t_lanes = masked_t_max(t_max, packet.mask);
    let mut far = horizontal_max(t_lanes);
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
                    let entering = lane_slab::<ROBUST>(node, c, lanes, &rows, t_lanes) & mask;
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
                        t_lanes = masked_t_max(t_max, packet.mask);
                        far = horizontal_max(t_lanes);
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
            t_lanes = masked_t_max(t_max, packet.mask);
            far = horizontal_max(t_lanes);
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
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[allow(clippy::too_many_arguments)]
pub unsafe fn any<const ROBUST: bool, P: PacketLeaves>(
    tree: &Tree,
    packet: &Packet,
    t_max: &[f32; LANES],
    leaves: &mut P,
    single: &mut impl FnMut(&mut P, usize, ChildRef, f32, &mut Work) -> bool,
    work: &mut Work,
    single_below: u32,
) -> u32 {
    let zero = _mm256_setzero_ps();
    let mut ia = Interval {
        near_r: [(zero, zero); 3],
        near_c: [zero; 3],
        far_r: [(zero, zero); 3],
        far_c: [zero; 3],
        t_min: zero,
    };
    interval::<ROBUST>(packet, &mut ia);
    let lanes = packet.rays;
    let rows = packet.rows();
    let mut refs = [MaybeUninit::<ChildRef>::uninit(); STACK];
    let mut masks = [MaybeUninit::<u32>::uninit(); STACK];
    let (refs, masks) = (
        refs.as_mut_ptr().cast::<ChildRef>(),
        masks.as_mut_ptr().cast::<u32>(),
    );
    let mut top = 0usize;
    let mut live = packet.mask;
    let mut t_lanes = masked_t_max(t_max, live);
    let mut far = horizontal_max(t_lanes);
    let mut current: ChildRef = 0;
    let mut mask = live;
    loop {
        if !is_leaf(current) {
            // SAFETY: the root, or an inner reference read from a node.
            let node = tree.node_unchecked(current);
            work.nodes += 1;
            let (_, passed) = interval_slab::<ROBUST>(node, &ia, &rows, _mm256_set1_ps(far));
            for c in bits(passed) {
                let entering = lane_slab::<ROBUST>(node, c, lanes, &rows, t_lanes) & mask;
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
                    t_lanes = masked_t_max(t_max, live);
                    far = horizontal_max(t_lanes);
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
            t_lanes = masked_t_max(t_max, live);
            far = horizontal_max(t_lanes);
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
