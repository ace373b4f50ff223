//! Random numbers and the warps from the unit square to directions.
//!
//! Every camera sample gets its own generator, derived from the seed, the
//! pixel and the sample index, so an image never depends on how pixels are
//! spread over threads, and a path's random numbers never depend on the
//! settings of the paths before it. A generator is either independent
//! numbers (PCG32) or one camera sample's point of an Owen-scrambled Sobol
//! sequence padded to any number of dimensions ([`Rng::sobol`]): the same
//! interface, so the integrators draw from either without knowing which.

use glam::Vec3;

/// A camera sample's numbers: PCG32 (O'Neill 2014, "PCG: a family of
/// simple fast space-efficient statistically good algorithms for random
/// number generation", XSH-RR), or a point of a padded Owen-scrambled
/// Sobol sequence ([`Rng::sobol`]).
///
/// Two words hold either: PCG32's state and increment, whose increment is
/// always odd; or, with an even second word, the Sobol point's sample
/// index (high half of the first word), the next dimension pair (its low
/// half), and the pixel's scrambling seed (the second word).
#[derive(Clone, Debug)]
pub struct Rng {
    state: u64,
    inc: u64,
}

/// SplitMix64 finalizer (Steele et al. 2014), to spread structured seeds.
pub(crate) fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

/// PCG32's next state after `state` (its LCG step).
#[inline(always)]
pub(crate) fn step(state: u64, inc: u64) -> u64 {
    state
        .wrapping_mul(6_364_136_223_846_793_005)
        .wrapping_add(inc)
}

/// PCG32's output for `state` (XSH-RR).
#[inline(always)]
pub(crate) fn output(state: u64) -> u32 {
    let xorshifted = (((state >> 18) ^ state) >> 27) as u32;
    xorshifted.rotate_right((state >> 59) as u32)
}

/// The increment of a child of a generator whose increment is `inc`
/// ([`Rng::split`]): a stream of its own.
#[inline(always)]
pub(crate) fn split_inc(inc: u64) -> u64 {
    (inc ^ 0x5851_F42D_4C95_7F2D) | 1
}

impl Rng {
    pub fn new(seed: u64, stream: u64) -> Rng {
        let mut rng = Rng {
            state: 0,
            inc: (mix(stream) << 1) | 1,
        };
        rng.next_u32();
        rng.state = rng.state.wrapping_add(mix(seed));
        rng.next_u32();
        rng
    }

    /// A generator of its own, keyed by this one's next number: for work
    /// that may be skipped without moving this generator's later numbers
    /// (one number is drawn whether or not the child is used). Cheaper
    /// than [`Rng::new`]: one mix for the state, and a stream of its own
    /// (another increment), since it is made at every path vertex.
    #[inline]
    pub fn split(&mut self) -> Rng {
        if self.is_sobol() {
            let (state, inc) = sobol_child(self.state, self.inc);
            self.state = sobol_next(self.state);
            return Rng { state, inc };
        }
        let key = (u64::from(self.next_u32()) << 32) | u64::from(self.next_u32());
        Rng {
            state: mix(key),
            inc: split_inc(self.inc),
        }
    }

    /// Its state and increment, for lists that keep generators side by
    /// side ([`Rng::from_parts`] gives it back).
    #[inline]
    pub(crate) fn parts(&self) -> (u64, u64) {
        (self.state, self.inc)
    }

    #[inline]
    pub(crate) fn from_parts(state: u64, inc: u64) -> Rng {
        Rng { state, inc }
    }

    /// The generator of camera sample `sample` of pixel `(x, y)`.
    pub fn for_sample(seed: u64, x: u32, y: u32, sample: u32) -> Rng {
        let pixel = ((y as u64) << 32) | x as u64;
        Rng::new(seed ^ mix(pixel), sample as u64)
    }

    /// Sample `sample` of pixel `(x, y)` as a point of an Owen-scrambled
    /// Sobol sequence: every pair of numbers it draws ([`Rng::next_2d`];
    /// a single number takes a pair's first) is the sample's point of the
    /// first two Sobol dimensions, its index shuffled and its coordinates
    /// scrambled by hashes of the pixel, the seed and the pair (Burley
    /// 2020, "Practical Hash-based Owen Scrambling", JCGT 9(4); pbrt-v4's
    /// `PaddedSobolSampler`). The samples of one pixel thus cover each
    /// pair's square as a (0, 2)-sequence does, stratified at every power
    /// of two, while different pairs stay independent; each point is
    /// uniform, so an estimate is unbiased at any sample count.
    pub fn sobol(seed: u64, x: u32, y: u32, sample: u32) -> Rng {
        let pixel = ((y as u64) << 32) | x as u64;
        Rng {
            state: (sample as u64) << 32,
            inc: mix(seed ^ mix(pixel).rotate_left(29)) << 1,
        }
    }

    /// Whether this draws Sobol points (else PCG32 numbers).
    #[inline(always)]
    pub(crate) fn is_sobol(&self) -> bool {
        is_sobol(self.inc)
    }

    /// The next dimension pair of a Sobol point.
    #[inline(always)]
    fn sobol_pair(&mut self) -> (u32, u32) {
        let (index, pair) = ((self.state >> 32) as u32, self.state as u32);
        self.state = sobol_next(self.state);
        sobol_pair(index, pair, self.inc)
    }

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        if self.is_sobol() {
            return self.sobol_pair().0;
        }
        let old = self.state;
        self.state = step(old, self.inc);
        output(old)
    }

    /// Uniform in [0, 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        unit(self.next_u32())
    }

    /// Two numbers uniform in [0, 1): one dimension pair of a Sobol point,
    /// or two independent numbers.
    #[inline]
    pub fn next_2d(&mut self) -> (f32, f32) {
        if self.is_sobol() {
            let (a, b) = self.sobol_pair();
            return (unit(a), unit(b));
        }
        (self.next_f32(), self.next_f32())
    }
}

/// Whether a generator whose second word is `inc` draws Sobol points:
/// PCG32's increment is always odd, a Sobol seed even.
#[inline(always)]
pub(crate) fn is_sobol(inc: u64) -> bool {
    inc & 1 == 0
}

/// A number uniform in [0, 1) from 32 random bits (their top 24).
#[inline(always)]
pub(crate) fn unit(bits: u32) -> f32 {
    (bits >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
}

/// A Sobol generator's state after it drew a pair: the next pair.
#[inline(always)]
pub(crate) fn sobol_next(state: u64) -> u64 {
    (state & !0xffff_ffff) | u64::from((state as u32).wrapping_add(1))
}

/// The child a Sobol generator `(state, inc)` splits off at its next
/// pair: the same sample index, its own pairs from the first, a seed of
/// its own (even, so it stays a Sobol generator).
#[inline(always)]
pub(crate) fn sobol_child(state: u64, inc: u64) -> (u64, u64) {
    let pair = state as u32;
    let seed = mix(inc ^ (u64::from(pair) << 33 | 1 << 32));
    (state & !0xffff_ffff, seed << 1)
}

/// The Owen scramble of a 32-bit fraction whose bits are given reversed
/// (first digit in bit 0): Laine and Karras's hash permutation as Burley
/// 2020 improved it, where each bit depends only on the bits below it, so
/// each digit of the fraction is flipped by a hash of the digits before it.
#[inline(always)]
fn laine_karras(mut x: u32, seed: u32) -> u32 {
    x = x.wrapping_add(seed);
    x ^= x.wrapping_mul(0x6c50_b47c);
    x ^= x.wrapping_mul(0xb82f_1e52);
    x ^= x.wrapping_mul(0xc7af_e638);
    x ^= x.wrapping_mul(0x8d22_f6e6);
    x
}

/// `x` (a fraction, first digit in bit 31) Owen-scrambled by `seed`.
#[inline(always)]
fn owen(x: u32, seed: u32) -> u32 {
    laine_karras(x.reverse_bits(), seed).reverse_bits()
}

/// The second Sobol dimension's generator matrix (the polynomial `x + 1`:
/// direction numbers `v_{k+1} = v_k ^ (v_k >> 1)` from `v_0 = 2^31`),
/// applied a byte of the index at a time: `SOBOL1[k][b]` is the point of
/// index `b << 8k`, and the point of any index is the XOR of its bytes'.
static SOBOL1: [[u32; 256]; 4] = sobol1_tables();

const fn sobol1_tables() -> [[u32; 256]; 4] {
    let mut tables = [[0u32; 256]; 4];
    let mut k = 0;
    while k < 4 {
        let mut b = 0;
        while b < 256 {
            // Direction number of index bit 8k + j, for each set bit j.
            let mut v = 1u32 << 31;
            let mut skip = 0;
            while skip < 8 * k {
                v ^= v >> 1;
                skip += 1;
            }
            let (mut x, mut j) = (0u32, 0);
            while j < 8 {
                if b & (1 << j) != 0 {
                    x ^= v;
                }
                v ^= v >> 1;
                j += 1;
            }
            tables[k][b] = x;
            b += 1;
        }
        k += 1;
    }
    tables
}

/// Point `index` of the second Sobol dimension (a 32-bit fraction); the
/// first is `index.reverse_bits()`.
#[inline(always)]
fn sobol1(index: u32) -> u32 {
    let byte = |k: usize| SOBOL1[k][((index >> (8 * k)) & 0xff) as usize];
    byte(0) ^ byte(1) ^ byte(2) ^ byte(3)
}

/// Dimension pair `pair` of the Sobol point of sample `index` under the
/// pixel seed `inc`: the index shuffled by an Owen scramble of its own (a
/// block of `2^k` consecutive indices goes to another such block, whose
/// points are as stratified), then each coordinate Owen-scrambled; three
/// seeds hashed from the pixel's and the pair.
#[inline(always)]
pub(crate) fn sobol_pair(index: u32, pair: u32, inc: u64) -> (u32, u32) {
    let h = mix(inc ^ u64::from(pair));
    let (shuffle, sx, sy) = (h as u32, (h >> 32) as u32, mix(h) as u32);
    let i = owen(index, shuffle);
    // The first dimension is `i` reversed, and its Owen scramble reverses
    // it again: `owen(i.reverse_bits(), sx)` with the two reversals gone.
    let x = laine_karras(i, sx).reverse_bits();
    (x, owen(sobol1(i), sy))
}

/// Position of camera sample `sample` inside pixel `(x, y)`, in [0, 1)^2:
/// Roberts' R2 sequence (the 2D Kronecker sequence of the plastic number,
/// "The unreasonable effectiveness of quasirandom sequences", 2018),
/// shifted per pixel by a random offset (Cranley–Patterson rotation).
/// Every sample is uniform over the pixel, so the estimate stays unbiased,
/// but the samples of one pixel cover it evenly: edges of bright emitters
/// and of their reflections converge far faster than with independent
/// positions. It depends only on the seed, the pixel and the index.
pub fn pixel_position(seed: u64, x: u32, y: u32, sample: u32) -> (f32, f32) {
    const G: f64 = 1.324_717_957_244_746;
    let offset = mix(seed ^ mix(((y as u64) << 32) | x as u64).rotate_left(17));
    let u0 = (offset >> 40) as f64 / (1u64 << 24) as f64;
    let v0 = ((offset >> 16) & 0xff_ffff) as f64 / (1u64 << 24) as f64;
    let i = sample as f64;
    let u = (u0 + i / G).fract();
    let v = (v0 + i / (G * G)).fract();
    // f32 rounding may reach 1.0 from just below it.
    (
        (u as f32).min(1.0 - f32::EPSILON / 2.0),
        (v as f32).min(1.0 - f32::EPSILON / 2.0),
    )
}

/// An orthonormal frame around a unit normal (Duff et al. 2017, "Building an
/// orthonormal basis, revisited").
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    pub s: Vec3,
    pub t: Vec3,
    pub n: Vec3,
}

impl Frame {
    pub fn new(n: Vec3) -> Frame {
        let sign = 1.0f32.copysign(n.z);
        let a = -1.0 / (sign + n.z);
        let b = n.x * n.y * a;
        let s = Vec3::new(1.0 + sign * n.x * n.x * a, sign * b, -sign * n.x);
        let t = Vec3::new(b, sign + n.y * n.y * a, -n.y);
        Frame { s, t, n }
    }

    #[inline]
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        self.s * v.x + self.t * v.y + self.n * v.z
    }

    #[inline]
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        Vec3::new(v.dot(self.s), v.dot(self.t), v.dot(self.n))
    }
}

/// Uniform direction on the unit sphere; pdf `1 / (4 pi)`.
/// A point of the unit disk, uniform by area: Shirley and Chiu's concentric
/// map (1997), which keeps strata of the square compact on the disk.
pub fn concentric_disk(u: f32, v: f32) -> (f32, f32) {
    let (a, b) = (2.0 * u - 1.0, 2.0 * v - 1.0);
    if a == 0.0 && b == 0.0 {
        return (0.0, 0.0);
    }
    let (r, theta) = if a.abs() > b.abs() {
        (a, std::f32::consts::FRAC_PI_4 * (b / a))
    } else {
        (
            b,
            std::f32::consts::FRAC_PI_2 - std::f32::consts::FRAC_PI_4 * (a / b),
        )
    };
    (r * theta.cos(), r * theta.sin())
}

pub fn uniform_sphere(u: f32, v: f32) -> Vec3 {
    let z = 1.0 - 2.0 * u;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * v;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

/// Uniform direction on the +z hemisphere; pdf `1 / (2 pi)`.
pub fn uniform_hemisphere(u: f32, v: f32) -> Vec3 {
    let z = u;
    let r = (1.0 - z * z).max(0.0).sqrt();
    let phi = 2.0 * std::f32::consts::PI * v;
    Vec3::new(r * phi.cos(), r * phi.sin(), z)
}

pub const UNIFORM_HEMISPHERE_PDF: f32 = 0.5 * std::f32::consts::FRAC_1_PI;

/// Cosine-weighted direction on the +z hemisphere (Malley's method); pdf
/// `cos / pi`. The angle's sine and cosine are [`sin_cos_turns`], which
/// the wave's lanes compute eight at a time with the same bits.
pub fn cosine_hemisphere(u: f32, v: f32) -> Vec3 {
    let r = u.sqrt();
    let (sin, cos) = sin_cos_turns(v);
    Vec3::new(r * cos, r * sin, (1.0 - u).max(0.0).sqrt())
}

/// The polynomials of [`sin_cos_turns`] on `[-pi/4, pi/4]`, in `x^2`:
/// Moshier's single-precision minimax coefficients (Cephes `sinf.c`,
/// `cosf.c`), sine's from `x^3` up, cosine's from `x^4` up.
pub const SIN_POLY: [f32; 3] = [-1.951_529_6e-4, 8.332_161e-3, -1.666_665_5e-1];
pub const COS_POLY: [f32; 3] = [2.443_315_7e-5, -1.388_731_6e-3, 4.166_664_6e-2];

/// `(sin, cos)` of `turns` whole turns (the angle `2 pi turns`), `turns`
/// in `[0, 1]`, within 2^-23 of the exact values (9.1e-8 at worst over
/// every `k / 2^24`). The nearest quarter turn is taken off exactly (`4
/// turns` and the difference are exact), the rest is at most an eighth
/// of a turn, where the polynomials hold; separate products and sums, no
/// fused multiply-add, so that the lanes' twin (`F16::sin_cos_turns`)
/// gives each lane these bits. Inline, where libm's `sincosf` is a call:
/// the wavefront's passes run it sixteen lanes at a time, where libm's
/// calls lane by lane measured slower (docs/experiments.md).
#[inline]
pub fn sin_cos_turns(turns: f32) -> (f32, f32) {
    let t = 4.0 * turns;
    let quarter = (t + 0.5).floor();
    let x = (t - quarter) * std::f32::consts::FRAC_PI_2;
    let z = x * x;
    let [s0, s1, s2] = SIN_POLY;
    let [c0, c1, c2] = COS_POLY;
    let sin = ((s0 * z + s1) * z + s2) * z * x + x;
    let cos = ((c0 * z + c1) * z + c2) * z * z - 0.5 * z + 1.0;
    match quarter as i32 & 3 {
        0 => (sin, cos),
        1 => (cos, -sin),
        2 => (-sin, -cos),
        _ => (-cos, sin),
    }
}

/// Luminance (Rec. 709 weights): the "illuminance" of adaptive sampling.
#[inline]
pub fn luminance(c: Vec3) -> f32 {
    0.2126 * c.x + 0.7152 * c.y + 0.0722 * c.z
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every number a generator's `next_f32` gives (`k / 2^24`) and the
    /// turn's end: sine and cosine within 2^-23 of the exact values (the
    /// lanes' twin is held to these bits in `crate::simd::lanes`).
    #[test]
    fn sines_and_cosines_of_turns_are_close() {
        let mut worst = 0.0f64;
        for k in 0..=(1u32 << 24) {
            let turns = k as f32 / (1u32 << 24) as f32;
            let (sin, cos) = sin_cos_turns(turns);
            let angle = std::f64::consts::TAU * f64::from(turns);
            worst = worst
                .max((f64::from(sin) - angle.sin()).abs())
                .max((f64::from(cos) - angle.cos()).abs());
        }
        assert!(worst < 2f64.powi(-23), "largest error {worst:e}");
    }

    /// Each dimension pair of a pixel's first `2^m` Sobol samples is a
    /// (0, m, 2)-net: every `2^a x 2^(m-a)` grid of the square holds
    /// exactly one point per cell, for every `a`; and so are the pairs of
    /// the light stream a sample splits off. Independent numbers fail it.
    #[test]
    fn sobol_pairs_are_stratified_at_powers_of_two() {
        let net = |points: &[(f32, f32)], m: u32| {
            (0..=m).all(|a| {
                let (nx, ny) = (1usize << a, 1usize << (m - a));
                let mut cells = vec![0u8; nx * ny];
                for &(u, v) in points {
                    cells[(v * ny as f32) as usize * nx + (u * nx as f32) as usize] += 1;
                }
                cells.iter().all(|&c| c == 1)
            })
        };
        for (x, y) in [(0, 0), (17, 3), (4000, 2999)] {
            for m in [2, 4, 6, 8] {
                let n = 1u32 << m;
                let mut samples: Vec<Rng> = (0..n).map(|i| Rng::sobol(9, x, y, i)).collect();
                for pair in 0..6 {
                    let points: Vec<_> = samples.iter_mut().map(|r| r.next_2d()).collect();
                    assert!(net(&points, m), "pixel ({x}, {y}), 2^{m}, pair {pair}");
                }
                let mut lights: Vec<Rng> = samples.iter_mut().map(|r| r.split()).collect();
                let points: Vec<_> = lights.iter_mut().map(|r| r.next_2d()).collect();
                assert!(net(&points, m), "pixel ({x}, {y}), 2^{m}, the light stream");
            }
            let mut independent: Vec<Rng> = (0..64).map(|i| Rng::for_sample(9, x, y, i)).collect();
            let points: Vec<_> = independent.iter_mut().map(|r| r.next_2d()).collect();
            assert!(!net(&points, 6), "independent numbers stratified by chance");
        }
    }

    /// On a smooth integral of known value over one pair's square, the
    /// Sobol sampler's RMS error over many pixels falls faster than
    /// `1/sqrt(N)` from 16 to 1024 samples, where independent numbers fall
    /// as `1/sqrt(N)`. Pairs are padded (each shuffled on its own), so on a
    /// product of two pairs' functions the rate across pairs is Monte
    /// Carlo's, but the error is still lower, and the mean is right.
    #[test]
    fn sobol_error_falls_faster_than_independent_numbers() {
        let rms = |make: &dyn Fn(u32, u32) -> Rng, n: u32, pairs: u32| {
            // f = prod over pairs of (u + v^2) * 1.2: mean (5/6 * 1.2)^pairs.
            let exact = (5.0f64 / 6.0 * 1.2).powi(pairs as i32);
            let pixels = 256u32;
            let mut squared = 0.0f64;
            for p in 0..pixels {
                let mut sum = 0.0f64;
                for i in 0..n {
                    let mut r = make(p, i);
                    let mut f = 1.0f64;
                    for _ in 0..pairs {
                        let (u, v) = r.next_2d();
                        f *= f64::from(u + v * v) * 1.2;
                    }
                    sum += f;
                }
                squared += (sum / f64::from(n) - exact).powi(2);
            }
            (squared / f64::from(pixels)).sqrt()
        };
        let sobol = |p: u32, i: u32| Rng::sobol(5, p, 7, i);
        let independent = |p: u32, i: u32| Rng::for_sample(5, p, 7, i);
        let slope = |make: &dyn Fn(u32, u32) -> Rng, pairs| {
            let (a, b) = (rms(make, 16, pairs), rms(make, 1024, pairs));
            ((b / a).ln() / (1024f64 / 16.0).ln(), a, b)
        };
        for pairs in [1, 2] {
            let (s, s16, s1024) = slope(&sobol, pairs);
            let (i, i16, i1024) = slope(&independent, pairs);
            eprintln!("{pairs} pairs: sobol {s16:.2e} -> {s1024:.2e} (slope {s:.2}); independent {i16:.2e} -> {i1024:.2e} (slope {i:.2})");
            assert!(
                (i + 0.5).abs() < 0.15,
                "independent numbers fall as N^{i:.2}"
            );
            assert!(s16 < i16 / 2.0 && s1024 < i1024 / 2.0, "{pairs} pairs");
            if pairs == 1 {
                assert!(s < -0.9, "Sobol's error falls as N^{s:.2}");
            }
        }
    }

    #[test]
    fn pixel_positions_cover_the_pixel_evenly() {
        // 64 samples in an 8x8 grid of cells: independent positions leave
        // 23 cells empty on average and put 4 or more into some cell; the
        // rotated R2 sequence leaves about 10 empty and never puts more
        // than 2 into one.
        for (x, y) in [(0, 0), (5, 3), (1000, 700)] {
            let mut cells = [0u32; 64];
            for i in 0..64 {
                let (u, v) = pixel_position(7, x, y, i);
                assert!((0.0..1.0).contains(&u) && (0.0..1.0).contains(&v));
                cells[(v * 8.0) as usize * 8 + (u * 8.0) as usize] += 1;
            }
            let empty = cells.iter().filter(|&&n| n == 0).count();
            assert!(empty <= 12, "pixel ({x}, {y}): {empty} of 64 cells empty");
            assert!(cells.iter().all(|&n| n <= 2), "pixel ({x}, {y}): {cells:?}");
        }
        assert_eq!(pixel_position(7, 5, 3, 9), pixel_position(7, 5, 3, 9));
        assert_ne!(pixel_position(7, 5, 3, 9), pixel_position(7, 6, 3, 9));
        assert_ne!(pixel_position(7, 5, 3, 9), pixel_position(8, 5, 3, 9));
    }

    #[test]
    fn frames_are_orthonormal() {
        for n in [
            Vec3::Z,
            -Vec3::Z,
            Vec3::X,
            Vec3::new(0.3, -0.5, 0.81).normalize(),
        ] {
            let f = Frame::new(n);
            for (a, b) in [(f.s, f.t), (f.t, f.n), (f.s, f.n)] {
                assert!(a.dot(b).abs() < 1e-5, "frame of {n} is not orthogonal");
            }
            let v = Vec3::new(0.2, 0.3, 0.9);
            assert!((f.to_local(f.to_world(v)) - v).length() < 1e-5);
        }
    }

    #[test]
    fn samples_are_uniform_in_the_unit_interval() {
        let mut rng = Rng::new(7, 0);
        let n = 100_000;
        let mean: f64 = (0..n).map(|_| rng.next_f32() as f64).sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 0.005, "mean {mean}");
    }
}
