//! The AVX2 kernels: the 8-wide slab test, compress-shuffle pushes and
//! prefetches, reached only with an [`Avx2`] token and a [`Tree`].

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
    /// Shift that selects the octant's 3-bit field of `Node8::order`.
    shift: __m128i,
}

#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
fn lanes<const ROBUST: bool>(ray: &BoxRay) -> Lanes {
    let splat = |v: Vec3A| {
        [
            _mm256_set1_ps(v.x),
            _mm256_set1_ps(v.y),
            _mm256_set1_ps(v.z),
        ]
    };
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
        shift: _mm_cvtsi32_si128(3 * ray.octant() as i32),
    }
}

/// The 8-wide slab test: entry distances and the hit lanes.
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
unsafe fn slab<const ROBUST: bool>(node: &Node8, l: &Lanes, t_max: __m256) -> (__m256, __m256) {
    // SAFETY: the caller holds the `Avx2` token (or runs inside a function that took it),
    // so AVX2 is enabled; node references come from a tree checked by `Tree::new`, and
    // stack pushes stay below `MAX_DEPTH` entries per level, the stack's length.
    unsafe {
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
    // SAFETY: the caller holds the `Avx2` token (or runs inside a function that took it),
    // so AVX2 is enabled; node references come from a tree checked by `Tree::new`, and
    // stack pushes stay below `MAX_DEPTH` entries per level, the stack's length.
    unsafe {
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
        // The nearest from the permuted references (one shuffle), not from
        // `order` and `child` (two dependent loads on the way to the next
        // node).
        let pick = _mm256_permutevar8x32_epi32(children, _mm256_set1_epi32(nearest as i32));
        _mm256_cvtsi256_si32(pick) as ChildRef
    }
}

/// Any-hit's push: no order to compute, the hit children in slot
/// order (decreasing size); returns the last, the smallest, and writes
/// the others to the stack at `*top`.
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
#[inline]
unsafe fn push_any(node: &Node8, mask: u32, refs: *mut ChildRef, top: &mut usize) -> ChildRef {
    // SAFETY: the caller holds the `Avx2` token (or runs inside a function that took it),
    // so AVX2 is enabled; node references come from a tree checked by `Tree::new`, and
    // stack pushes stay below `MAX_DEPTH` entries per level, the stack's length.
    unsafe {
        let pack = _mm256_loadu_si256(COMPRESS[mask as usize].as_ptr().cast());
        let children = _mm256_load_si256(node.child.as_ptr().cast());
        _mm256_storeu_si256(
            refs.add(*top).cast(),
            _mm256_permutevar8x32_epi32(children, pack),
        );
        *top += mask.count_ones() as usize - 1;
        node.child[31 - mask.leading_zeros() as usize]
    }
}

/// One ray's walk from `start`: the root, or (packet traversal handing one
/// ray over) a child reference read from one of the tree's nodes. The
/// closest hit (`ANY` false: children pushed nearest first with their
/// entry distances, `t_max` shrinking to each hit, true if any) or any hit
/// within `t_max` (`ANY` true: children in slot order, no distances, true
/// at the first). One walk for both queries, the choice made at compile
/// time, so each query's code is what it was written out alone.
///
/// # Safety
/// Needs the token's CPU features (AVX2, FMA, bit counting), a non-empty
/// `tree` and a `start` as above; the tree's type proves the rest
/// (references in range, depth at most [`MAX_DEPTH`], so the stack holds
/// every push).
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
pub unsafe fn walk<const ROBUST: bool, const ANY: bool, L: Leaves>(
    _cpu: Avx2,
    tree: &Tree,
    ray: &BoxRay,
    t_max: &mut f32,
    leaves: &mut L,
    work: &mut Work,
    start: ChildRef,
) -> bool {
    // SAFETY: the caller holds the `Avx2` token (or runs inside a function that took it),
    // so AVX2 is enabled; node references come from a tree checked by `Tree::new`, and
    // stack pushes stay below `MAX_DEPTH` entries per level, the stack's length.
    unsafe {
        let l = lanes::<ROBUST>(ray);
        let mut refs = AlignedStack::<ChildRef>::new();
        let mut dists = AlignedStack::<f32>::new();
        let (refs, dists) = (refs.as_mut_ptr(), dists.as_mut_ptr());
        let mut top = 0usize;
        let mut far = _mm256_set1_ps(*t_max);
        let mut current = start;
        let mut hit = false;
        loop {
            if !is_leaf(current) {
                // SAFETY: `current` is the root of a non-empty tree or an
                // inner reference read from one of its nodes.
                let node = tree.node_unchecked(current);
                // The child line is read only once the hit mask is known;
                // asked for now, its miss overlaps the plane lines' misses.
                _mm_prefetch::<_MM_HINT_T0>(node.child.as_ptr().cast());
                work.nodes += 1;
                let (near, hits) = slab::<ROBUST>(node, &l, far);
                let mask = _mm256_movemask_ps(hits) as u32;
                if mask != 0 {
                    current = if mask & (mask - 1) == 0 {
                        node.child[mask.trailing_zeros() as usize]
                    } else if ANY {
                        push_any(node, mask, refs, &mut top)
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
                    // SAFETY: entries below `top` were written by a push.
                    prefetch(tree, leaves, *refs.add(top - 1));
                }
                let count = leaf_count(current);
                work.items += count as u64;
                if ANY {
                    if leaves.any(leaf_first(current), count, *t_max) {
                        return true;
                    }
                } else if let Some(t) = leaves.nearest(leaf_first(current), count, *t_max) {
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
                // SAFETY: entries below `top` were written by a push (with
                // their distances, for the closest hit).
                if ANY || *dists.add(top) <= *t_max {
                    current = *refs.add(top);
                    break;
                }
            }
        }
    }
}

/// Most rays of one occlusion stream: one bit each in a `u64` mask.
pub const STREAM: usize = 64;

/// Occlusion of up to [`STREAM`] rays walking the tree together: each node
/// is visited once for every ray of the stream that enters it and tested
/// against those rays one by one (the single-ray slab test), and each hit
/// child is pushed once with the mask of the rays that enter it (Embree 3's
/// `bvh_intersector_stream`; Barringer and Akenine-Möller 2014). A blocked
/// ray leaves every mask. Each ray meets exactly the boxes and leaves its
/// single-ray any-hit walk would, in another order: the same answer.
/// `leaves(i)` gives ray `i`'s leaf test. Returns the rays blocked among
/// `active`.
///
/// # Safety
/// Needs the token's CPU features, a non-empty `tree`, and `rays` and
/// `t_max` at least as long as the highest ray in `active`.
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
pub unsafe fn any_stream<const ROBUST: bool, L: Leaves>(
    _cpu: Avx2,
    tree: &Tree,
    rays: &[BoxRay],
    t_max: &[f32],
    active: u64,
    leaves: &mut impl FnMut(usize) -> L,
    work: &mut Work,
) -> u64 {
    // SAFETY: the caller holds the `Avx2` token (or runs inside a function that took it),
    // so AVX2 is enabled; node references come from a tree checked by `Tree::new`, and
    // stack pushes stay below `MAX_DEPTH` entries per level, the stack's length.
    unsafe {
        let mut stack = AlignedStack::<(ChildRef, u64)>::new();
        let stack = stack.as_mut_ptr();
        let mut top = 0usize;
        let mut blocked = 0u64;
        let (mut current, mut mask) = (0 as ChildRef, active);
        loop {
            mask &= !blocked;
            if mask != 0 {
                if !is_leaf(current) {
                    // SAFETY: as in `closest`.
                    let node = tree.node_unchecked(current);
                    work.nodes += u64::from(mask.count_ones());
                    // Per child the rays entering it, children 0-3 and 4-7.
                    let (mut low, mut high) = (_mm256_setzero_si256(), _mm256_setzero_si256());
                    let mut rest = mask;
                    while rest != 0 {
                        let i = rest.trailing_zeros() as usize;
                        rest &= rest - 1;
                        // SAFETY: the caller's slices cover every ray in `active`.
                        let ray = rays.get_unchecked(i);
                        let far = _mm256_set1_ps(*t_max.get_unchecked(i));
                        let (_, hits) = slab::<ROBUST>(node, &lanes::<ROBUST>(ray), far);
                        let hits = _mm256_castps_si256(hits);
                        let bit = _mm256_set1_epi64x((1u64 << i) as i64);
                        let wide =
                            |half: __m128i| _mm256_and_si256(_mm256_cvtepi32_epi64(half), bit);
                        low = _mm256_or_si256(low, wide(_mm256_castsi256_si128(hits)));
                        high = _mm256_or_si256(high, wide(_mm256_extracti128_si256::<1>(hits)));
                    }
                    let mut entering = [0u64; WIDTH];
                    _mm256_storeu_si256(entering.as_mut_ptr().cast(), low);
                    _mm256_storeu_si256(entering.as_mut_ptr().add(4).cast(), high);
                    // Every entered child pushed, the first slot (the
                    // largest) deepest, so the smallest is walked first, as
                    // single-ray any hit does.
                    for (c, &rays_in) in entering.iter().enumerate() {
                        // SAFETY: every level leaves at most seven entries
                        // and the depth is bounded by MAX_DEPTH; a child no
                        // ray enters is written and overwritten.
                        stack.add(top).write((node.child[c], rays_in));
                        top += usize::from(rays_in != 0);
                    }
                } else {
                    let (first, count) = (leaf_first(current), leaf_count(current));
                    let mut rest = mask;
                    while rest != 0 {
                        let i = rest.trailing_zeros() as usize;
                        rest &= rest - 1;
                        work.items += u64::from(count);
                        if leaves(i).any(first, count, *t_max.get_unchecked(i)) {
                            blocked |= 1 << i;
                        }
                    }
                }
            }
            if top == 0 {
                return blocked;
            }
            top -= 1;
            // SAFETY: entries below `top` were written above.
            (current, mask) = *stack.add(top);
        }
    }
}

/// Closest hits of up to [`STREAM`] rays walking the tree together, as
/// [`any_stream`] walks occlusion rays: each node visited once for the
/// stream's rays that enter it within their current `t_max`, its entered
/// children pushed with their rays in the octant order of the stream's
/// lowest ray (nearest last). Each ray's `t_max` shrinks to its hits;
/// `leaves[i]` keeps ray `i`'s nearest so far, with which a tie is
/// decided by slot, so the visiting order cannot change an answer.
/// Returns the rays that hit.
///
/// # Safety
/// As [`any_stream`]; `leaves` as long as `rays`.
#[target_feature(enable = "avx2,fma,popcnt,lzcnt,bmi1,bmi2")]
pub unsafe fn closest_stream<const ROBUST: bool, L: Leaves>(
    _cpu: Avx2,
    tree: &Tree,
    rays: &[BoxRay],
    t_max: &mut [f32],
    active: u64,
    leaves: &mut [L],
    work: &mut Work,
) -> u64 {
    // SAFETY: as in `any_stream`.
    unsafe {
        let mut stack = AlignedStack::<(ChildRef, u64)>::new();
        let stack = stack.as_mut_ptr();
        let mut top = 0usize;
        let mut found = 0u64;
        let (mut current, mut mask) = (0 as ChildRef, active);
        loop {
            if mask != 0 {
                if !is_leaf(current) {
                    // SAFETY: as in `closest`.
                    let node = tree.node_unchecked(current);
                    work.nodes += u64::from(mask.count_ones());
                    let (mut low, mut high) = (_mm256_setzero_si256(), _mm256_setzero_si256());
                    let mut rest = mask;
                    while rest != 0 {
                        let i = rest.trailing_zeros() as usize;
                        rest &= rest - 1;
                        let ray = rays.get_unchecked(i);
                        let far = _mm256_set1_ps(*t_max.get_unchecked(i));
                        let (_, hits) = slab::<ROBUST>(node, &lanes::<ROBUST>(ray), far);
                        let hits = _mm256_castps_si256(hits);
                        let bit = _mm256_set1_epi64x((1u64 << i) as i64);
                        let wide =
                            |half: __m128i| _mm256_and_si256(_mm256_cvtepi32_epi64(half), bit);
                        low = _mm256_or_si256(low, wide(_mm256_castsi256_si128(hits)));
                        high = _mm256_or_si256(high, wide(_mm256_extracti128_si256::<1>(hits)));
                    }
                    let mut entering = [0u64; WIDTH];
                    _mm256_storeu_si256(entering.as_mut_ptr().cast(), low);
                    _mm256_storeu_si256(entering.as_mut_ptr().add(4).cast(), high);
                    let octant = rays.get_unchecked(mask.trailing_zeros() as usize).octant();
                    // In the octant order of the stream's lowest ray,
                    // farthest first, so the nearest is walked first.
                    for place in 0..WIDTH {
                        let c = node.ordered(octant, place);
                        let rays_in = entering[c];
                        // SAFETY: every level leaves at most eight entries
                        // and the depth is bounded by MAX_DEPTH; a child no
                        // ray enters is written and overwritten.
                        stack.add(top).write((node.child[c], rays_in));
                        top += usize::from(rays_in != 0);
                    }
                } else {
                    let (first, count) = (leaf_first(current), leaf_count(current));
                    let mut rest = mask;
                    while rest != 0 {
                        let i = rest.trailing_zeros() as usize;
                        rest &= rest - 1;
                        work.items += u64::from(count);
                        let t = t_max.get_unchecked_mut(i);
                        if let Some(hit) = leaves.get_unchecked_mut(i).nearest(first, count, *t) {
                            *t = hit;
                            found |= 1 << i;
                        }
                    }
                }
            }
            if top == 0 {
                return found;
            }
            top -= 1;
            (current, mask) = *stack.add(top);
        }
    }
}
