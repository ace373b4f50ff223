//! Sixteen floats side by side, for passes over many paths kept in lists
//! (structure of arrays): the renderer's wavefront. Each operation is a
//! loop over the sixteen lanes, always inlined; inside a function compiled
//! for AVX-512 LLVM makes each loop one instruction, inside one compiled
//! for AVX2 two, and in the scalar twin it is portable code (SSE2 at
//! most). [`Vectors`] says which the CPU runs, [`lane_pass`] compiles a
//! pass for all three. Safe code throughout, and each lane's bits are
//! those of the scalar operation: IEEE additions, products, quotients and
//! square roots, comparisons as all-ones masks, selects instead of
//! branches (intrinsics behind these methods stayed calls in a portable
//! build, and branches kept a pass scalar: docs/experiments.md).

use crate::simd::cpu::{Avx2, Avx512};

/// Lanes of an [`F16`]: the step of every pass.
pub const LANES: usize = 16;

/// The vectors a pass runs on: AVX-512 where the CPU runs it (one
/// instruction a lane loop), else AVX2 (two), else the portable twin.
/// The first two hold the token that proves the CPU runs them.
#[derive(Clone, Copy, Debug)]
pub enum Vectors {
    Scalar,
    Avx2(Avx2),
    Avx512(Avx512),
}

impl Vectors {
    /// The widest vectors this CPU runs (and `HYBRID_ISA` allows).
    pub fn widest() -> Vectors {
        match (Avx512::detect(), Avx2::detect()) {
            (Some(avx512), _) => Vectors::Avx512(avx512),
            (None, Some(avx2)) => Vectors::Avx2(avx2),
            (None, None) => Vectors::Scalar,
        }
    }

    /// Their name, as `hybrid render` prints it.
    pub fn name(self) -> &'static str {
        match self {
            Vectors::Scalar => "scalar",
            Vectors::Avx2(_) => "AVX2",
            Vectors::Avx512(_) => "AVX-512",
        }
    }
}

/// `lane_pass!(vis name = body(args))`: `vis fn name(vectors: Vectors, args)`,
/// which runs `body` (a pass over lanes, always inlined) compiled for
/// AVX-512, for AVX2 or as portable code, as `vectors` says the CPU may.
/// The three give the same bits: lane by lane, the scalar operations.
macro_rules! lane_pass {
    ($vis:vis $name:ident = $body:ident($($arg:ident: $ty:ty),* $(,)?)) => {
        $vis fn $name(vectors: $crate::simd::lanes::Vectors, $($arg: $ty),*) {
            /// # Safety
            /// The CPU must run AVX2.
            #[target_feature(enable = "avx2")]
            unsafe fn avx2($($arg: $ty),*) {
                $body($($arg),*)
            }
            /// # Safety
            /// The CPU must run AVX-512 (foundation) and AVX2.
            #[target_feature(enable = "avx512f,avx2")]
            unsafe fn avx512($($arg: $ty),*) {
                $body($($arg),*)
            }
            match vectors {
                $crate::simd::lanes::Vectors::Scalar => $body($($arg),*),
                // SAFETY: an `Avx2` exists only where the CPU runs AVX2
                // (`Avx2::detect`).
                $crate::simd::lanes::Vectors::Avx2(_) => unsafe { avx2($($arg),*) },
                // SAFETY: an `Avx512` exists only where the CPU runs
                // AVX-512F and AVX2 (`Avx512::detect`).
                $crate::simd::lanes::Vectors::Avx512(_) => unsafe { avx512($($arg),*) },
            }
        }
    };
}
pub(crate) use lane_pass;

/// `[e(0), e(1), e(2)]` for an expression `e` of `k`, written out: a
/// closure there may stay a call, which the passes cannot afford.
#[macro_export]
macro_rules! each3 {
    (|$k:ident| $e:expr) => {
        [
            {
                let $k = 0;
                $e
            },
            {
                let $k = 1;
                $e
            },
            {
                let $k = 2;
                $e
            },
        ]
    };
}

/// `a.map(f)` for a one-argument closure or a function, written out as
/// [`each3`] is.
#[macro_export]
macro_rules! map3 {
    ($a:expr, |$x:ident| $e:expr) => {{
        let a = $a;
        $crate::each3!(|k| {
            let $x = a[k];
            $e
        })
    }};
    ($a:expr, $f:path) => {{
        let a = $a;
        $crate::each3!(|k| $f(a[k]))
    }};
}

/// Sixteen floats side by side. Every operation is a loop over the
/// sixteen, inlined into the passes ([`lane_pass`]), where LLVM makes
/// each loop one AVX-512 instruction or two AVX2 ones. Safe code
/// throughout; the same bits as sixteen scalar operations.
#[derive(Clone, Copy)]
#[repr(align(64))]
pub struct F16(pub [f32; LANES]);

// Lane loops index their arrays: the form LLVM turns into one instruction
// (iterator chains over two arrays it did not always).
#[allow(clippy::needless_range_loop)]
impl F16 {
    #[inline(always)]
    pub fn each(self, f: impl Fn(f32) -> f32) -> F16 {
        let mut out = [0.0; LANES];
        for l in 0..LANES {
            out[l] = f(self.0[l]);
        }
        F16(out)
    }
    #[inline(always)]
    pub fn zip(self, o: F16, f: impl Fn(f32, f32) -> f32) -> F16 {
        let mut out = [0.0; LANES];
        for l in 0..LANES {
            out[l] = f(self.0[l], o.0[l]);
        }
        F16(out)
    }
    #[inline(always)]
    pub fn splat(x: f32) -> F16 {
        F16([x; LANES])
    }
    #[inline(always)]
    pub fn load(a: &[f32]) -> F16 {
        F16(a[..LANES].try_into().expect("sixteen floats"))
    }
    #[inline(always)]
    pub fn store(self, a: &mut [f32]) {
        a[..LANES].copy_from_slice(&self.0);
    }
    /// Uniform in [0, 1) from sixteen generator outputs (`Rng::next_f32`).
    #[inline(always)]
    pub fn unit(a: &[u32]) -> F16 {
        let mut out = [0.0; LANES];
        for l in 0..LANES {
            out[l] = (a[l] >> 8) as f32 * (1.0 / (1u32 << 24) as f32);
        }
        F16(out)
    }
    #[inline(always)]
    pub fn sqrt(self) -> F16 {
        self.each(f32::sqrt)
    }
    #[inline(always)]
    pub fn abs(self) -> F16 {
        self.each(f32::abs)
    }
    #[inline(always)]
    pub fn floor(self) -> F16 {
        self.each(f32::floor)
    }
    /// `f32::min` lane by lane (its NaN and zero rules).
    #[inline(always)]
    pub fn min(self, o: F16) -> F16 {
        self.zip(o, f32::min)
    }
    /// `f32::max` lane by lane.
    #[inline(always)]
    pub fn max(self, o: F16) -> F16 {
        self.zip(o, f32::max)
    }
    #[inline(always)]
    pub fn copysign(self, sign: F16) -> F16 {
        self.zip(sign, f32::copysign)
    }
    // Masks: all bits set where true (as a comparison instruction leaves).
    #[inline(always)]
    pub fn mask(self, o: F16, f: impl Fn(f32, f32) -> bool) -> F16 {
        self.zip(o, |a, b| f32::from_bits(if f(a, b) { u32::MAX } else { 0 }))
    }
    #[inline(always)]
    pub fn lt(self, o: F16) -> F16 {
        self.mask(o, |a, b| a < b)
    }
    #[inline(always)]
    pub fn gt(self, o: F16) -> F16 {
        self.mask(o, |a, b| a > b)
    }
    #[inline(always)]
    pub fn le(self, o: F16) -> F16 {
        self.mask(o, |a, b| a <= b)
    }
    #[inline(always)]
    pub fn ne(self, o: F16) -> F16 {
        self.mask(o, |a, b| a != b)
    }
    #[inline(always)]
    pub fn bits(self, o: F16, f: impl Fn(u32, u32) -> u32) -> F16 {
        self.zip(o, |a, b| f32::from_bits(f(a.to_bits(), b.to_bits())))
    }
    #[inline(always)]
    pub fn and(self, o: F16) -> F16 {
        self.bits(o, |a, b| a & b)
    }
    #[inline(always)]
    pub fn or(self, o: F16) -> F16 {
        self.bits(o, |a, b| a | b)
    }
    #[inline(always)]
    pub fn and_not(self, o: F16) -> F16 {
        self.bits(o, |a, b| a & !b)
    }
    /// Whether lane `l` of a mask is set.
    #[inline(always)]
    pub fn is(self, l: usize) -> bool {
        self.0[l].to_bits() != 0
    }
    /// `a` where `mask`, else `b`.
    #[inline(always)]
    pub fn select(mask: F16, a: F16, b: F16) -> F16 {
        let mut out = [0.0; LANES];
        for l in 0..LANES {
            out[l] = if mask.0[l].to_bits() != 0 {
                a.0[l]
            } else {
                b.0[l]
            };
        }
        F16(out)
    }
    /// The quadrant of a whole number of quarter turns: odd, and in the
    /// upper half turn.
    #[inline(always)]
    pub fn quadrant(self) -> (F16, F16) {
        let bit =
            |b: i32| self.each(|q| f32::from_bits(if (q as i32) & b != 0 { u32::MAX } else { 0 }));
        (bit(1), bit(2))
    }
    /// [`crate::geom::sampling::sin_cos_turns`] lane by lane: the same
    /// operations in the same order, the quarter turn applied by selects
    /// and exact negations.
    #[inline(always)]
    pub fn sin_cos_turns(self) -> (F16, F16) {
        use crate::geom::sampling::{COS_POLY, SIN_POLY};
        let t = F16::splat(4.0) * self;
        let quarter = (t + F16::splat(0.5)).floor();
        let x = (t - quarter) * F16::splat(std::f32::consts::FRAC_PI_2);
        let z = x * x;
        let (s0, s1, s2) = (
            F16::splat(SIN_POLY[0]),
            F16::splat(SIN_POLY[1]),
            F16::splat(SIN_POLY[2]),
        );
        let (c0, c1, c2) = (
            F16::splat(COS_POLY[0]),
            F16::splat(COS_POLY[1]),
            F16::splat(COS_POLY[2]),
        );
        let sin = ((s0 * z + s1) * z + s2) * z * x + x;
        let cos = ((c0 * z + c1) * z + c2) * z * z - F16::splat(0.5) * z + F16::splat(1.0);
        let (odd, upper) = quarter.quadrant();
        let (sin, cos) = (F16::select(odd, cos, sin), F16::select(odd, sin, cos));
        let flip_cos = odd.bits(upper, |a, b| a ^ b);
        (
            F16::select(upper, -sin, sin),
            F16::select(flip_cos, -cos, cos),
        )
    }
    /// `x.next_up()` where `offset > 0`, `next_down` where below, `x`
    /// where zero (`Ray::spawn`'s last step): the standard library's
    /// steps on the bits, without its branches.
    #[inline(always)]
    pub fn away(self, offset: F16) -> F16 {
        let mut out = [0.0; LANES];
        for l in 0..LANES {
            let (x, o) = (self.0[l], offset.0[l]);
            // Conditions as all-ones masks, so that the loop has no branch.
            let all = |c: bool| 0u32.wrapping_sub(c as u32);
            let pick = |m: u32, a: u32, b: u32| (a & m) | (b & !m);
            let bits = x.to_bits();
            let abs = bits & 0x7fff_ffff;
            let negative = all(bits != abs);
            let (up, down) = (all(o > 0.0), all(o < 0.0));
            // The magnitude grows going up from a positive number or down
            // from a negative one, and shrinks the other way.
            let grow = (up & !negative) | (down & negative);
            let shrink = (up & negative) | (down & !negative);
            let stepped = bits.wrapping_add(grow & 1).wrapping_sub(shrink & 1);
            let zero_to = (down & 0x8000_0000) | 1;
            let keep = all(abs > 0x7f80_0000) | (all(abs == 0x7f80_0000) & grow);
            let next = pick(
                all(abs == 0) & (up | down),
                zero_to,
                pick(keep, bits, stepped),
            );
            out[l] = f32::from_bits(next);
        }
        F16(out)
    }
}

macro_rules! op {
    ($trait:ident, $f:ident, $op:tt) => {
        impl std::ops::$trait for F16 {
            type Output = F16;
            #[inline(always)]
            fn $f(self, o: F16) -> F16 {
                self.zip(o, |a, b| a $op b)
            }
        }
    };
}
op!(Add, add, +);
op!(Sub, sub, -);
op!(Mul, mul, *);
op!(Div, div, /);

impl std::ops::Neg for F16 {
    type Output = F16;
    #[inline(always)]
    fn neg(self) -> F16 {
        self.each(|x| -x)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geom::sampling::sin_cos_turns;

    /// Every number a generator's `next_f32` gives (`k / 2^24`) and the
    /// turn's end: the lanes' sine and cosine have the scalar function's
    /// bits.
    #[test]
    fn sines_and_cosines_in_lanes_have_the_scalar_bits() {
        let mut lanes = [0.0f32; LANES];
        for k in 0..=(1u32 << 24) {
            lanes[k as usize % LANES] = k as f32 / (1u32 << 24) as f32;
            if k as usize % LANES == LANES - 1 || k == 1 << 24 {
                let (s16, c16) = F16(lanes).sin_cos_turns();
                for (l, &t) in lanes.iter().enumerate() {
                    let (s, c) = sin_cos_turns(t);
                    assert_eq!(
                        (s16.0[l].to_bits(), c16.0[l].to_bits()),
                        (s.to_bits(), c.to_bits()),
                        "turns {t}"
                    );
                }
            }
        }
    }
}
