//! Packet traversal: up to sixteen rays of one octant (or of mixed octants,
//! see [`walk`]) walk the tree together
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

mod slab;
mod width;
mod x16;
mod x8x2;

use std::arch::x86_64::*;

use self::slab::{interval, interval_slab, lane_slab, lane_slab_mixed, masked_t_max};
pub use self::width::{Width, MAX_LANES, X8};
pub use self::x16::X16;
pub use self::x8x2::X8x2;
use super::*;
use crate::geom::Ray;

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
    /// Traceable lanes whose ray enters the tree's root box within its
    /// `t_max` ([`PacketRays::enters`]): the lanes a walk starts with.
    pub rooted: u32,
    /// Lanes whose fast-test constants are finite (none when no lane is
    /// rooted: the constants were not computed).
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

/// Whether `min` of the `n` rays whose fields are `fields` ([`Width::fields`])
/// share an octant, read from the directions' sign bits (the octants the
/// packet code sorts traceable rays by) once the rays are in lanes, so
/// that a group where no packet can form costs its transposition and
/// never the rest of the lanes' set-up.
///
/// # Safety
/// Only from `W`'s `#[target_feature]` code ([`Width`]).
#[inline(always)]
pub unsafe fn octant_holds<W: Width>(fields: &[W::V; 8], n: usize, min: u32) -> bool {
    // SAFETY: the caller runs with the width's CPU features enabled.
    let negative = unsafe {
        [
            W::signs(fields[3]),
            W::signs(fields[4]),
            W::signs(fields[5]),
        ]
    };
    let mut rest = (1u32 << n.min(W::N)) - 1;
    while rest.count_ones() >= min {
        let group = same_octant(negative, rest);
        if group.count_ones() >= min {
            return true;
        }
        rest &= !group;
    }
    false
}

/// [`octant_holds`] in plain scalar code, read from the rays' sign bits
/// before any transposition: a few instructions a ray, so that a batch
/// whose groups form no packet need not transpose each to find out.
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
    /// The first `W::N` of `n` rays (at least one) as lanes, from their
    /// fields ([`Width::fields`]), for a tree whose root box is `root`.
    /// Callers ask [`octant_holds`] first: without a packet the set-up
    /// (three divisions, the box test's constants) is paid for nothing.
    /// The fast box test's constants are left out when no lane enters
    /// the root box (camera rays into the sky): no walk reads them then.
    ///
    /// # Safety
    /// Only from `W`'s `#[target_feature]` code ([`Width`]).
    #[inline(always)]
    pub unsafe fn from_fields(fields: [W::V; 8], n: usize, root: [Vec3A; 2]) -> PacketRays<W> {
        // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
        // enabled (a detected token chose this code).
        unsafe {
            let [ox, oy, oz, dx, dy, dz, t_min, t_max] = fields;
            let (origin, dir) = ([ox, oy, oz], [dx, dy, dz]);
            let lanes = (1u32 << n.min(W::N)) - 1;
            // Ray::traceable_vectors, lane by lane.
            let limit = W::splat(crate::geom::ray::COORDINATE_LIMIT);
            let zero = W::splat(0.0);
            let mut traceable = W::le(t_min, t_max) & W::ge(t_min, zero);
            let mut moves = 0;
            for a in 0..3 {
                traceable &= W::le(W::abs(origin[a]), limit) & W::le(W::abs(dir[a]), limit);
                moves |= W::gt(W::abs(dir[a]), zero);
            }
            // BoxRay::new, lane by lane: first the reciprocals, which the
            // root's test needs.
            let tiny = W::splat(1e-20);
            let one = W::splat(1.0);
            let mut safe = [zero; 3];
            let mut inv = [zero; 3];
            let mut negative = [0u32; 3];
            for a in 0..3 {
                let d = dir[a];
                safe[a] = W::select(W::lt(W::abs(d), tiny), d, W::copysign(tiny, d));
                inv[a] = W::div(one, safe[a]);
                negative[a] = W::lt(safe[a], zero);
            }
            let mut rays = PacketRays {
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
                fast: [[zero; 3]; 3],
                t_max,
                traceable: traceable & moves & lanes,
                rooted: 0,
                fits: 0,
                negative,
            };
            rays.rooted = rays.traceable & rays.enters(root, t_max);
            if rays.rooted == 0 {
                return rays;
            }
            // Then the fast test's constants.
            let infinity = W::splat(f32::INFINITY);
            let mut fits = u32::MAX;
            for a in 0..3 {
                let sign = W::mul(origin[a], safe[a]);
                let near_k = W::add(one, W::copysign(W::splat(FAST_NEAR_MARGIN), sign));
                let far_k = W::sub(
                    W::splat(FAST_FAR_SCALE),
                    W::copysign(W::splat(FAST_FAR_MARGIN), sign),
                );
                let fast = &mut rays.fast;
                fast[0][a] = W::mul(W::mul(origin[a], near_k), inv[a]);
                fast[1][a] = W::mul(inv[a], W::splat(FAST_FAR_SCALE));
                fast[2][a] = W::mul(W::mul(origin[a], far_k), inv[a]);
                fits &= W::lt(W::abs(fast[0][a]), infinity) & W::lt(W::abs(fast[2][a]), infinity);
            }
            rays.fits = fits;
            rays
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
    /// As [`PacketRays::from_fields`].
    #[inline(always)]
    unsafe fn enters(&self, [lo, hi]: [Vec3A; 2], t_max: W::V) -> u32 {
        // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
        // enabled (a detected token chose this code) and the tree was checked by
        // `Tree::new`, so every node reference read from it is in range.
        unsafe {
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
    }

    /// Each lane's `t_max`.
    ///
    /// # Safety
    /// As [`PacketRays::from_fields`].
    #[inline(always)]
    pub unsafe fn t_max(&self) -> [f32; MAX_LANES] {
        // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
        // enabled (a detected token chose this code) and the tree was checked by
        // `Tree::new`, so every node reference read from it is in range.
        unsafe {
            let mut a = [0.0f32; MAX_LANES];
            W::store(&mut a, self.t_max);
            a
        }
    }
}

/// A packet: the lanes in `mask` of `rays`, which share one octant unless
/// walked with mixed octants ([`walk`]).
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

/// The packet's walk: closest hits (`ANY` false: children in the octant's
/// order, farthest pushed first with their entry distances; each lane's
/// `t_max` shrinks to its hit; returns the lanes that hit) or any hits
/// (`ANY` true: children in slot order, smallest box last, so first off
/// the stack, as single-ray any hit; a ray leaves the packet at its first
/// hit; returns the blocked lanes). `leaves` tests the packet's leaves;
/// `single(leaves, i, start, t_max, work)` traces ray `i` alone from
/// `start` (the single-ray kernel with ray `i`'s leaf test, leaving a
/// closest hit where `leaves` keeps lane `i`'s) and says whether it hit.
/// One walk for both queries, the choice made at compile time.
///
/// With `MIXED` the lanes may point into different octants, as Embree's
/// packets may: no interval test culls the node's children for the whole
/// packet; each used child is tested lane by lane on both of its planes
/// per axis ([`lane_slab_mixed`], the single-ray test's values), visited
/// in slot order (any hits) or the lowest lane's octant order (closest
/// hits, each pushed with the nearest entry among its lanes). Diffuse
/// bounces and shadow rays towards an area light from points side by side
/// form no packet of one octant, yet in a small tree they meet the same
/// nodes.
///
/// # Safety
/// Only from `W`'s `#[target_feature]` code ([`Width`]), which also has
/// AVX2 and FMA; `tree` is not empty.
#[inline(always)]
#[allow(clippy::too_many_arguments)]
pub unsafe fn walk<
    W: Width,
    const ROBUST: bool,
    const ANY: bool,
    const MIXED: bool,
    P: PacketLeaves<W>,
>(
    tree: &Tree,
    packet: &Packet<W>,
    t_max: &mut [f32; MAX_LANES],
    leaves: &mut P,
    single: &mut impl FnMut(&mut P, usize, ChildRef, &mut f32, &mut Work) -> bool,
    work: &mut Work,
    single_below: u32,
) -> u32 {
    // SAFETY: the caller upholds this kernel's contract: the width's CPU features are
    // enabled (a detected token chose this code) and the tree was checked by `Tree::new`,
    // so every node reference read from it is in range.
    unsafe {
        let ia = if MIXED {
            None
        } else {
            Some(interval::<W, ROBUST>(packet))
        };
        let lanes = packet.rays;
        let rows = packet.rows();
        let shift = _mm_cvtsi32_si128(3 * packet.octant() as i32);
        let mut refs = AlignedStack::<ChildRef>::new();
        let mut masks = AlignedStack::<u32>::new();
        let mut dists = AlignedStack::<f32>::new();
        let (refs, masks, dists) = (refs.as_mut_ptr(), masks.as_mut_ptr(), dists.as_mut_ptr());
        let mut top = 0usize;
        // The lanes still walking: every lane for closest hits, the lanes
        // not yet blocked for any hit.
        let mut live = packet.mask;
        let mut t_lanes = masked_t_max::<W>(t_max, live);
        let mut far = W::max_of(t_lanes, live);
        let mut current: ChildRef = 0;
        let mut mask = live;
        let mut hits = 0u32;
        loop {
            if !is_leaf(current) {
                // SAFETY: the root, or an inner reference read from a node.
                let node = tree.node_unchecked(current);
                work.nodes += 1;
                let (near, passed) = match &ia {
                    Some(ia) => interval_slab::<ROBUST>(node, ia, &rows, _mm256_set1_ps(far)),
                    None => (_mm256_setzero_ps(), node.used()),
                };
                if passed != 0 {
                    let mut places = [0u32; WIDTH];
                    let mut near_of = [0f32; WIDTH];
                    let visit = if ANY {
                        passed
                    } else {
                        // The passed children in the octant's order,
                        // farthest first: place `p` holds child
                        // `order[p] >> shift & 7`.
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
                        _mm256_storeu_si256(places.as_mut_ptr().cast(), order);
                        _mm256_storeu_ps(near_of.as_mut_ptr(), near);
                        _mm256_movemask_ps(hit_v) as u32
                    };
                    for place in bits(visit) {
                        let c = if ANY { place } else { places[place] as usize };
                        // Mixed lanes: each one's entry distance too.
                        let (entering, entries) = if MIXED {
                            let (near, entering) =
                                lane_slab_mixed::<W, ROBUST>(node, c, lanes, t_lanes);
                            (entering & mask, Some(near))
                        } else {
                            let entering = lane_slab::<W, ROBUST>(node, c, lanes, &rows, t_lanes);
                            (entering & mask, None)
                        };
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
                            if ANY {
                                live &= !hits;
                                if live == 0 {
                                    return packet.mask;
                                }
                                mask &= live;
                            }
                            t_lanes = masked_t_max::<W>(t_max, live);
                            far = W::max_of(t_lanes, live);
                            continue;
                        }
                        // SAFETY: each level leaves at most eight entries,
                        // the depth is bounded by MAX_DEPTH, and STACK
                        // holds that.
                        *refs.add(top) = child;
                        *masks.add(top) = entering;
                        if !ANY {
                            // Mixed lanes: the nearest entry among them.
                            *dists.add(top) = match entries {
                                Some(near) => W::min_each([near], entering)[0],
                                None => near_of[c],
                            };
                        }
                        top += 1;
                    }
                }
            } else {
                let (first, count) = (leaf_first(current), leaf_count(current));
                work.items += u64::from(count * mask.count_ones());
                if ANY {
                    hits |= leaves.any(first, count, mask, t_max);
                    live &= !hits;
                    if live == 0 {
                        return packet.mask;
                    }
                } else {
                    hits |= leaves.nearest(first, count, mask, t_max);
                }
                t_lanes = masked_t_max::<W>(t_max, live);
                far = W::max_of(t_lanes, live);
            }
            loop {
                if top == 0 {
                    return hits;
                }
                top -= 1;
                // SAFETY: entries below `top` were written above.
                if ANY {
                    let m = *masks.add(top) & live;
                    if m != 0 {
                        current = *refs.add(top);
                        mask = m;
                        break;
                    }
                } else if *dists.add(top) <= far {
                    current = *refs.add(top);
                    mask = *masks.add(top);
                    break;
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// [`octant_holds`] with eight lanes.
    #[target_feature(enable = "avx2,fma")]
    unsafe fn holds_x8(rays: &[Ray], min: u32) -> bool {
        // SAFETY: AVX2 is enabled here, all X8 needs.
        unsafe { octant_holds::<X8>(&X8::fields(rays), rays.len(), min) }
    }

    /// The byte counters, and the lanes' sign bits ([`octant_holds`]),
    /// agree with counting each octant's rays, for every threshold and
    /// group size, signed zeros included.
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
                if n <= 8 && is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU has AVX2, all X8 needs.
                    let lanes = unsafe { holds_x8(&rays, min) };
                    assert_eq!(lanes, expected, "X8: {counts:?}, min {min}");
                }
            }
        }
    }
}
