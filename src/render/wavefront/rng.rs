//! Sixteen generators side by side, each lane with
//! [`Rng`](crate::geom::sampling::Rng)'s own bits.

use super::lists::Rngs;
use super::L;
use crate::geom::sampling;
use crate::simd::lanes::F16;

/// Sixteen generators side by side: [`Rng`](sampling::Rng) lane by lane,
/// its bits. A wave's generators are all of one kind (one render draws
/// PCG32 numbers or Sobol points throughout), so the kind is read once,
/// from the first lane, and every lane steps as that kind.
#[derive(Clone, Copy)]
pub(super) struct Rng16 {
    state: [u64; L],
    inc: [u64; L],
    sobol: bool,
}

// Lane loops index their arrays, as `F16`'s do.
#[allow(clippy::needless_range_loop)]
impl Rng16 {
    #[inline(always)]
    pub(super) fn load(r: &Rngs, i: usize) -> Rng16 {
        let inc: [u64; L] = r.inc[i..i + L].try_into().expect("sixteen increments");
        let sobol = sampling::is_sobol(inc[0]);
        debug_assert!(
            inc.iter().all(|&c| sampling::is_sobol(c) == sobol),
            "one kind"
        );
        Rng16 {
            state: r.state[i..i + L].try_into().expect("sixteen states"),
            inc,
            sobol,
        }
    }

    #[inline(always)]
    pub(super) fn store(&self, r: &mut Rngs, i: usize) {
        r.state[i..i + L].copy_from_slice(&self.state);
        r.inc[i..i + L].copy_from_slice(&self.inc);
    }

    /// `Rng::next_u32` in the lanes of `mask`; the others keep their
    /// state (their outputs are not used).
    #[inline(always)]
    pub(super) fn next_u32(&mut self, mask: F16) -> [u32; L] {
        if self.sobol {
            return self.pairs(mask).0;
        }
        let mut out = [0; L];
        for l in 0..L {
            let old = self.state[l];
            let new = sampling::step(old, self.inc[l]);
            // All ones where the lane steps: a select without a branch.
            let keep = 0u64.wrapping_sub(u64::from(mask.0[l].to_bits() != 0));
            self.state[l] = (new & keep) | (old & !keep);
            out[l] = sampling::output(old);
        }
        out
    }

    /// A Sobol point's next pair in the lanes of `mask`
    /// (`Rng::next_2d`'s); the others keep their state.
    #[inline(always)]
    fn pairs(&mut self, mask: F16) -> ([u32; L], [u32; L]) {
        let (mut x, mut y) = ([0; L], [0; L]);
        for l in 0..L {
            let old = self.state[l];
            let (index, pair) = ((old >> 32) as u32, old as u32);
            (x[l], y[l]) = sampling::sobol_pair(index, pair, self.inc[l]);
            let keep = 0u64.wrapping_sub(u64::from(mask.0[l].to_bits() != 0));
            self.state[l] = (sampling::sobol_next(old) & keep) | (old & !keep);
        }
        (x, y)
    }

    /// `Rng::next_f32` in the lanes of `mask`.
    #[inline(always)]
    pub(super) fn next_f32(&mut self, mask: F16) -> F16 {
        F16::unit(&self.next_u32(mask))
    }

    /// `Rng::next_2d` in the lanes of `mask`: two numbers of PCG32, or a
    /// Sobol point's next pair.
    #[inline(always)]
    pub(super) fn next_2d(&mut self, mask: F16) -> (F16, F16) {
        if self.sobol {
            let (x, y) = self.pairs(mask);
            return (F16::unit(&x), F16::unit(&y));
        }
        (self.next_f32(mask), self.next_f32(mask))
    }

    /// `Rng::split`, every lane.
    #[inline(always)]
    pub(super) fn split(&mut self) -> Rng16 {
        let mut child = Rng16 {
            state: [0; L],
            inc: [0; L],
            sobol: self.sobol,
        };
        if self.sobol {
            for l in 0..L {
                (child.state[l], child.inc[l]) = sampling::sobol_child(self.state[l], self.inc[l]);
                self.state[l] = sampling::sobol_next(self.state[l]);
            }
            return child;
        }
        let all = F16::splat(f32::from_bits(u32::MAX));
        let (hi, lo) = (self.next_u32(all), self.next_u32(all));
        for l in 0..L {
            let key = (u64::from(hi[l]) << 32) | u64::from(lo[l]);
            child.state[l] = sampling::mix(key);
            child.inc[l] = sampling::split_inc(self.inc[l]);
        }
        child
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::sampling::Rng;

    /// Sixteen generators side by side give each generator's own numbers,
    /// bit for bit: lanes masked out keep their state, and a split gives
    /// each lane the child `Rng::split` gives.
    #[test]
    fn generators_in_lanes_give_the_numbers_of_each_alone() {
        for sobol in [false, true] {
            let make = |l: u32| {
                if sobol {
                    Rng::sobol(7, l, 3 * l, 11 + l)
                } else {
                    Rng::for_sample(7, l, 3 * l, 11 + l)
                }
            };
            let mut alone: Vec<Rng> = (0..L as u32).map(make).collect();
            let mut rngs = Rngs::default();
            rngs.sized(L);
            for (l, r) in alone.iter().enumerate() {
                rngs.set(l, r);
            }
            let mut lanes = Rng16::load(&rngs, 0);
            let (on, off) = (f32::from_bits(u32::MAX), 0.0);
            for round in 0..50 {
                // Every third lane, shifted each round, sits out.
                let mask = F16(std::array::from_fn(|l| {
                    if (l + round) % 3 == 0 {
                        off
                    } else {
                        on
                    }
                }));
                if round % 2 == 0 {
                    let out = lanes.next_f32(mask);
                    for (l, r) in alone.iter_mut().enumerate() {
                        if mask.is(l) {
                            assert_eq!(out.0[l].to_bits(), r.next_f32().to_bits());
                        }
                    }
                } else {
                    let (u, v) = lanes.next_2d(mask);
                    for (l, r) in alone.iter_mut().enumerate() {
                        if mask.is(l) {
                            let (a, b) = r.next_2d();
                            assert_eq!(
                                (u.0[l].to_bits(), v.0[l].to_bits()),
                                (a.to_bits(), b.to_bits())
                            );
                        }
                    }
                }
            }
            let children = lanes.split();
            let mut split = Rngs::default();
            split.sized(L);
            lanes.store(&mut rngs, 0);
            children.store(&mut split, 0);
            for (l, r) in alone.iter_mut().enumerate() {
                let child = r.split();
                assert_eq!(rngs.get(l).parts(), r.parts(), "lane {l}, sobol {sobol}");
                assert_eq!(split.get(l).parts(), child.parts(), "lane {l}'s child");
            }
        }
    }
}
