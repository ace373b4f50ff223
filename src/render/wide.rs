//! Sixteen floats side by side, for passes over a wave's paths kept in
//! lists (structure of arrays): `render::integrator`'s wave in arrays and
//! `examples/soa_step.rs`. Each operation is a loop over the sixteen
//! lanes, always inlined; inside a function compiled for AVX-512 LLVM
//! makes each loop one instruction, inside one compiled for AVX2 two, and
//! elsewhere it is correct scalar code ([`Vectors`] proves which the CPU
//! runs; [`lane_pass`] compiles a pass for both). Safe code throughout,
//! and each lane's bits are those of the scalar operation: IEEE
//! additions, products, quotients and square roots, comparisons as
//! all-ones masks, selects instead of branches (docs/experiments.md, stop
//! 51: `_mm256_*` intrinsics behind these methods stayed calls in a
//! portable build, and branches kept a pass scalar). Sixteen lanes, not
//! eight, since stop 60: with AVX-512 the stepping took 9-14% less time,
//! measured against the tracing of the same run, and with AVX2 alone it
//! lost nothing (docs/experiments.md).

use crate::accel::native::cpu::{Avx2, Avx512};

/// Lanes of an [`F16`]: the step of every pass.
pub const LANES: usize = 16;

/// The vectors a pass runs on, proved by the CPU: AVX-512 where it runs
/// it (one instruction a lane loop), else AVX2 (two).
#[derive(Clone, Copy, Debug)]
pub enum Vectors {
    Avx2(Avx2),
    Avx512(Avx512),
}

impl Vectors {
    /// The widest vectors the CPU runs, given its proof of AVX2.
    pub fn widest(avx2: Avx2) -> Vectors {
        Avx512::detect().map_or(Vectors::Avx2(avx2), Vectors::Avx512)
    }
}

/// `lane_pass!(name = body(args))`: `fn name(vectors: Vectors, args)`,
/// which runs `body` (a pass over lanes, always inlined) compiled for
/// AVX-512 or for AVX2, as `vectors` proves the CPU may. The two give the
/// same bits: lane by lane, the scalar operations.
macro_rules! lane_pass {
    ($name:ident = $body:ident($($arg:ident: $ty:ty),* $(,)?)) => {
        fn $name(vectors: $crate::render::wide::Vectors, $($arg: $ty),*) {
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
                // SAFETY: an `Avx2` exists only where the CPU runs AVX2
                // (`Avx2::detect`).
                $crate::render::wide::Vectors::Avx2(_) => unsafe { avx2($($arg),*) },
                // SAFETY: an `Avx512` exists only where the CPU runs
                // AVX-512F and AVX2 (`Avx512::detect`).
                $crate::render::wide::Vectors::Avx512(_) => unsafe { avx512($($arg),*) },
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
