//! Leaf data in the order the nodes list their leaves: each leaf's
//! primitives become items (4-wide triangle blocks, watertight triangles,
//! spheres), and its reference is pointed at them. With several threads the
//! nodes are cut into runs whose items are counted first, so every run fills
//! its own slice of the output at once.

use rayon::prelude::*;

use super::memory;
use super::node::{is_leaf, leaf, leaf_count, Node8};

/// Items of the leaves of `nodes`: a leaf of `count` primitives from slot
/// `first` gets `count.div_ceil(per_item)` items, written by `fill(first,
/// count, items)`. Leaf references are rewritten to name their items.
pub fn pack<T, F>(nodes: &mut [Node8], per_item: u32, empty: T, fill: F) -> Vec<T>
where
    T: Copy + Send + Sync,
    F: Fn(u32, u32, &mut [T]) + Sync,
{
    let items = |count: u32| count.div_ceil(per_item) as usize;
    let items_of = |run: &[Node8]| -> usize {
        run.iter()
            .flat_map(|n| n.children())
            .filter(|(r, _)| is_leaf(*r))
            .map(|(r, _)| items(leaf_count(r)))
            .sum()
    };
    let threads = rayon::current_num_threads();
    if threads == 1 {
        let mut out: Vec<T> = memory::reserve(items_of(nodes));
        for node in nodes.iter_mut() {
            node.remap_leaves(|first, count| {
                let at = out.len();
                out.resize(at + items(count), empty);
                fill(first, count, &mut out[at..]);
                leaf(at as u32, items(count) as u32)
            });
        }
        return out;
    }
    let run = nodes.len().div_ceil(4 * threads).max(1);
    let counts: Vec<usize> = nodes.par_chunks(run).map(items_of).collect();
    let mut out = memory::reserve(counts.iter().sum());
    out.par_extend(rayon::iter::repeat_n(empty, counts.iter().sum()));
    let mut slices = Vec::with_capacity(counts.len());
    let (mut rest, mut base) = (&mut out[..], 0usize);
    for &c in &counts {
        let (head, tail) = rest.split_at_mut(c);
        slices.push((head, base));
        (rest, base) = (tail, base + c);
    }
    nodes
        .par_chunks_mut(run)
        .zip(slices)
        .for_each(|(run, (slice, base))| {
            let mut at = 0usize;
            for node in run {
                node.remap_leaves(|first, count| {
                    let n = items(count);
                    fill(first, count, &mut slice[at..at + n]);
                    let r = leaf((base + at) as u32, n as u32);
                    at += n;
                    r
                });
            }
        });
    out
}
