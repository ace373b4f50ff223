//! Choosing a range's split (binned SAH over all axes, or the median) and
//! partitioning its references by it.

use super::*;

/// The split `rec` should take, or `None` when it becomes a leaf.
pub(super) fn find_split(refs: &[PrimRef], rec: &Record, settings: &Settings) -> Option<Split> {
    let n = rec.len();
    if n == 1 {
        return None;
    }
    let extent = rec.cent.hi - rec.cent.lo;
    let widest = if extent.x >= extent.y && extent.x >= extent.z {
        0
    } else if extent.y >= extent.z {
        1
    } else {
        2
    };
    if extent.max_element() <= 0.0 {
        return (n > settings.max_leaf).then_some(Split::Half);
    }
    match settings.method {
        BuildMethod::Median => (n > settings.max_leaf).then_some(Split::Median { axis: widest }),
        // One block holds the whole range: every way to halve it is tried
        // (at most seven), cheaper than binning and exact.
        BuildMethod::Sah | BuildMethod::SahTopDown if n <= LEAF_BLOCK && n <= settings.max_leaf => {
            small_split(refs, rec, settings.split_cost)
        }
        BuildMethod::Sah | BuildMethod::SahTopDown => {
            let best = binned_sah(refs, rec);
            let leaf = rec.geom.half_area() * leaf_cost(n);
            match best {
                Some((cost, split)) => {
                    let split_cost = rec.geom.half_area() * settings.split_cost + cost;
                    (n > settings.max_leaf || split_cost < leaf).then_some(split)
                }
                None => (n > settings.max_leaf).then_some(Split::Half),
            }
        }
    }
}

/// The split of a range of at most [`LEAF_BLOCK`] primitives (one block as
/// a leaf) into two leaves, if it costs less than the leaf: both sides are
/// one block each, so only their boxes' areas decide.
fn small_split(refs: &[PrimRef], rec: &Record, split_cost: f32) -> Option<Split> {
    let n = refs.len();
    debug_assert!((2..=LEAF_BLOCK).contains(&n));
    if split_cost >= TRAVERSAL_COST {
        // Two blocks and a split never cost less than one block.
        return None;
    }
    let area = rec.geom.half_area();
    let mut best = (area * (1.0 - split_cost), None);
    // Reference 0 stays right, so each division is tried once.
    for left in 1..(1u8 << (n - 1)) {
        let left = left << 1;
        let (mut l, mut r) = (Aabb::EMPTY, Aabb::EMPTY);
        for (i, p) in refs.iter().enumerate() {
            if left >> i & 1 != 0 {
                l.grow(&p.aabb());
            } else {
                r.grow(&p.aabb());
            }
        }
        let cost = l.half_area() + r.half_area();
        if cost < best.0 {
            best = (cost, Some(left));
        }
    }
    best.1.map(|left| Split::Subset { left })
}

/// `2^23`: adding it to a float in `[0, 2^22)` leaves the nearest integer
/// in the low mantissa bits.
const ROUNDING: f32 = 8_388_608.0;

/// The bin of a scaled centroid coordinate `x = (c - lo) * scale`: its
/// floor, computed as the nearest integer to `x - 1/2` (one addition of
/// [`ROUNDING`] instead of a saturating conversion; only exact bin
/// boundaries may round down). Binning ([`bins_of`], all axes at once) and
/// partitioning (one axis) do the same operations per lane, so they agree.
#[inline(always)]
fn bin_of(c: f32, lo: f32, scale: f32) -> usize {
    let x = ((c - lo) * scale - 0.5).max(0.0) + ROUNDING;
    ((x.to_bits() - ROUNDING.to_bits()) as usize).min(BINS - 1)
}

/// [`bin_of`] on all three axes.
#[inline(always)]
fn bins_of(centroid2: Vec3A, lo: Vec3A, scale: Vec3A) -> [usize; 3] {
    let f =
        ((centroid2 - lo) * scale - Vec3A::splat(0.5)).max(Vec3A::ZERO) + Vec3A::splat(ROUNDING);
    f.to_array()
        .map(|x| ((x.to_bits() - ROUNDING.to_bits()) as usize).min(BINS - 1))
}

/// Bins of all three axes: geometry bounds and counts. A split's two
/// sides get their geometry bounds from the bins (unions of bins, exact)
/// before any reference moves; the partition only adds centroid bounds.
#[derive(Clone, Copy)]
struct BinSet {
    boxes: [[Aabb; BINS]; 3],
    counts: [[u32; BINS]; 3],
}

impl BinSet {
    const CLEAR: BinSet = BinSet {
        boxes: [[Aabb::EMPTY; BINS]; 3],
        counts: [[0; BINS]; 3],
    };

    #[inline(always)]
    fn add(&mut self, r: &PrimRef, lo: Vec3A, scale: Vec3A) {
        let a = r.aabb();
        let b = bins_of(a.centroid2(), lo, scale);
        for (axis, &bin) in b.iter().enumerate() {
            self.boxes[axis][bin].grow(&a);
            self.counts[axis][bin] += 1;
        }
    }

    /// Adds `other`'s primitives. Exact (minima, maxima and counts), so
    /// the bins do not depend on how a range was divided.
    fn merge(&mut self, other: &BinSet) {
        for axis in 0..3 {
            for i in 0..BINS {
                self.boxes[axis][i].grow(&other.boxes[axis][i]);
                self.counts[axis][i] += other.counts[axis][i];
            }
        }
    }

    /// Geometry bounds of the bins `range` of `axis`.
    fn union(&self, axis: usize, range: std::ops::Range<usize>) -> Aabb {
        let mut acc = Aabb::EMPTY;
        for b in &self.boxes[axis][range] {
            acc.grow(b);
        }
        acc
    }
}

/// Ranges at least this large are binned in parallel chunks when the pool
/// has several threads: the first levels would otherwise run on one.
pub(super) const PARALLEL_BINNING: usize = 4096;

/// Adds `refs` to `bins` (binned with the grid `lo`, `scale`). The sets
/// are 1.7 KB: filled in place, never returned by value.
fn bin_range(refs: &[PrimRef], lo: Vec3A, scale: Vec3A, bins: &mut BinSet) {
    if refs.len() >= PARALLEL_BINNING && rayon::current_num_threads() > 1 {
        let parts = refs
            .par_chunks(PARALLEL_BINNING / 4)
            .map(|chunk| {
                let mut part = BinSet::CLEAR;
                bin_range(chunk, lo, scale, &mut part);
                part
            })
            .reduce(
                || BinSet::CLEAR,
                |mut a, b| {
                    a.merge(&b);
                    a
                },
            );
        bins.merge(&parts);
        return;
    }
    if refs.len() < 2 * BINS {
        for r in refs {
            bins.add(r, lo, scale);
        }
        return;
    }
    // Neighbours in the mesh mostly share a bin, which would chain every
    // update to the previous one through memory: odd primitives go to a
    // second set, merged afterwards (as Embree does).
    let mut odd = BinSet::CLEAR;
    let mut pairs = refs.chunks_exact(2);
    for pair in &mut pairs {
        bins.add(&pair[0], lo, scale);
        odd.add(&pair[1], lo, scale);
    }
    for r in pairs.remainder() {
        bins.add(r, lo, scale);
    }
    bins.merge(&odd);
}

/// The cheapest binned split of `rec` over all axes: unnormalized cost
/// (half areas times leaf costs of both sides) and the split.
fn binned_sah(refs: &[PrimRef], rec: &Record) -> Option<(f32, Split)> {
    let lo = rec.cent.lo;
    let extent = rec.cent.hi - rec.cent.lo;
    // Just under `bins`, so the largest centroid lands in the last bin.
    let k = BINS as f32 * (1.0 - 1e-6);
    let scale = Vec3A::select(extent.cmpgt(Vec3A::ZERO), k / extent, Vec3A::ZERO);
    let mut bins = BinSet::CLEAR;
    bin_range(refs, lo, scale, &mut bins);
    let counts = &bins.counts;
    // Cost, axis and first bin of the right side.
    let mut best: Option<(f32, usize, usize)> = None;
    for axis in 0..3 {
        if extent[axis] <= 0.0 {
            continue;
        }
        // Only boundaries after non-empty bins: every boundary between the
        // same two non-empty bins gives the same partition, and the first
        // of them is the one a full sweep would keep.
        let mut used = [0usize; BINS];
        let mut k = 0;
        for (i, &c) in counts[axis].iter().enumerate() {
            used[k] = i;
            k += (c > 0) as usize;
        }
        let used = &used[..k];
        let (boxes, count) = (&bins.boxes[axis], &counts[axis]);
        // right_cost[j]: cost of the bins from used[j] on.
        let mut right_cost = [0.0f32; BINS];
        let (mut acc, mut n) = (Aabb::EMPTY, 0u32);
        for j in (1..used.len()).rev() {
            acc.grow(&boxes[used[j]]);
            n += count[used[j]];
            right_cost[j] = acc.half_area() * leaf_cost(n as usize);
        }
        let (mut acc, mut n) = (Aabb::EMPTY, 0u32);
        for j in 0..used.len().saturating_sub(1) {
            acc.grow(&boxes[used[j]]);
            n += count[used[j]];
            let cost = acc.half_area() * leaf_cost(n as usize) + right_cost[j + 1];
            if best.is_none_or(|(c, _, _)| cost < c) {
                best = Some((cost, axis, used[j] + 1));
            }
        }
    }
    best.map(|(cost, axis, boundary)| {
        let split = Split::Binned {
            axis,
            boundary,
            lo: lo[axis],
            scale: scale[axis],
            left: bins.union(axis, 0..boundary),
            right: bins.union(axis, boundary..BINS),
        };
        (cost, split)
    })
}

/// Partitions `refs` (exactly `rec`'s range) by `rec`'s split; returns the
/// two sides with their bounds (splits not yet chosen).
pub(super) fn apply_split(refs: &mut [PrimRef], rec: &Record) -> (Record, Record) {
    let n = refs.len();
    let side = |start: usize, end: usize, geom: Aabb, cent: Aabb| Record {
        start,
        end,
        geom,
        cent,
        split: None,
    };
    if let Some(Split::Binned {
        axis,
        boundary,
        lo,
        scale,
        left,
        right,
    }) = rec.split
    {
        // Branch-free Lomuto partition: the side of a primitive follows
        // the data, so a branch on it mispredicts; instead every step swaps
        // (everything between the two cursors is on the right) and moves
        // the cursor by the side.
        let mut i = 0;
        for k in 0..n {
            let c = refs[k].lo[axis] + refs[k].hi[axis];
            let is_left = bin_of(c, lo, scale) < boundary;
            refs.swap(i, k);
            i += is_left as usize;
        }
        if i > 0 && i < n {
            // Geometry bounds came with the split; centroid bounds take one
            // more pass over each side, cheaper than a selection per
            // reference in the loop above (measured: a quarter off builds).
            return (
                side(rec.start, rec.start + i, left, centroid_bounds(&refs[..i])),
                side(rec.start + i, rec.end, right, centroid_bounds(&refs[i..])),
            );
        }
    }
    let mid = match rec.split {
        Some(Split::Subset { left }) => {
            // At most four references: a stable partition by the mask.
            let mut order = [refs[0]; LEAF_BLOCK];
            let mut k = 0;
            for side in [true, false] {
                for (i, p) in refs.iter().enumerate() {
                    if (left >> i & 1 != 0) == side {
                        order[k] = *p;
                        k += 1;
                    }
                }
            }
            refs.copy_from_slice(&order[..n]);
            left.count_ones() as usize
        }
        Some(Split::Median { axis }) => {
            let mid = n / 2;
            refs.select_nth_unstable_by(mid, |a, b| {
                a.aabb().centroid2()[axis].total_cmp(&b.aabb().centroid2()[axis])
            });
            mid
        }
        // Half, or a binned split that separated nothing (it always does;
        // this keeps the ranges valid whatever happens).
        _ => n / 2,
    };
    let ((lg, lc), (rg, rc)) = (bounds_of(&refs[..mid]), bounds_of(&refs[mid..]));
    (
        side(rec.start, rec.start + mid, lg, lc),
        side(rec.start + mid, rec.end, rg, rc),
    )
}
