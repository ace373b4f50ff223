//! Random numbers and the warps from the unit square to directions.
//!
//! Every camera sample gets its own generator, derived from the seed, the
//! pixel and the sample index, so an image never depends on how pixels are
//! spread over threads, and a path's random numbers never depend on the
//! settings of the paths before it.

use glam::Vec3;

/// PCG32 (O'Neill 2014, "PCG: a family of simple fast space-efficient
/// statistically good algorithms for random number generation"), XSH-RR.
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

    #[inline]
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = step(old, self.inc);
        output(old)
    }

    /// Uniform in [0, 1).
    #[inline]
    pub fn next_f32(&mut self) -> f32 {
        (self.next_u32() >> 8) as f32 * (1.0 / (1u32 << 24) as f32)
    }

    #[inline]
    pub fn next_2d(&mut self) -> (f32, f32) {
        (self.next_f32(), self.next_f32())
    }
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
