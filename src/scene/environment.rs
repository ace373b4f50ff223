//! An environment light: radiance arriving from infinitely far away, read
//! from an equirectangular map (`-e FILE.exr`), and how to sample it.
//!
//! The mapping is the course framework's: row 0 is straight up (+Y), the
//! polar angle grows down the rows (`theta = acos(y)`), and the column is
//! `phi / 2 pi` with `phi = atan2(-z, x) + pi`, so the map's left edge looks
//! towards -X, a quarter across towards +Z, the middle towards +X. Each
//! texel is a constant radiance over its patch of directions (no
//! filtering), which makes importance sampling exact: a texel is picked
//! with probability proportional to luminance times its solid angle, and
//! the direction is uniform in solid angle within the texel (uniform in
//! `phi` and `cos theta`), so the density of a direction is the texel's
//! luminance over the map's total power. This is the piecewise-constant 2D
//! distribution of pbrt (Pharr, Jakob, Humphreys, 3rd ed. §13.6.7 and
//! §14.2.4), laid out over `cos theta` instead of `theta` so that no
//! `sin theta` factor is left in the estimate.

use std::f32::consts::PI;
use std::path::Path;

use glam::Vec3;

use crate::geom::sampling::{luminance, uniform_sphere};

/// Largest map read: 8192 x 4096 texels (about 0.5 GiB with its tables).
/// The largest map file read (an uncompressed 4096 x 2048 RGBA float EXR
/// is 128 MiB).
pub const MAX_MAP_BYTES: u64 = 1 << 30;

pub const MAX_TEXELS: u64 = 8192 * 4096;

/// How light sampling draws directions from the map.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum EnvSampling {
    /// By luminance (the default).
    #[default]
    Importance,
    /// Uniformly over the sphere (`--env-uniform`), to show the difference.
    Uniform,
}

#[derive(Debug, thiserror::Error)]
#[error("{path}: {what}")]
pub struct EnvironmentError {
    pub path: String,
    pub what: String,
}

/// A direction drawn from the map.
#[derive(Clone, Copy, Debug)]
pub struct EnvSample {
    pub wi: Vec3,
    pub radiance: Vec3,
    /// Density in solid angle.
    pub pdf: f32,
}

#[derive(Clone, Debug)]
pub struct Environment {
    /// Where the map came from (for messages).
    pub name: String,
    width: u32,
    height: u32,
    /// Row-major, row 0 at +Y.
    texels: Vec<Vec3>,
    /// Cumulative probability of picking each row.
    row_cdf: Vec<f32>,
    /// Per row, cumulative probability of each column given the row.
    column_cdf: Vec<f32>,
    /// Sum of luminance times solid angle over the texels.
    power: f32,
    pub sampling: EnvSampling,
}

impl Environment {
    /// A map of `width` x `height` texels, row-major from +Y down.
    /// Texels must be finite and not negative.
    pub fn new(name: &str, width: u32, height: u32, texels: Vec<Vec3>) -> Environment {
        assert_eq!(texels.len(), width as usize * height as usize);
        let (w, h) = (width as usize, height as usize);
        let mut row_power = vec![0.0f64; h];
        let mut column_cdf = vec![0.0f32; w * h];
        for (j, row) in texels.chunks_exact(w).enumerate() {
            let solid_angle = texel_solid_angle(j as u32, width, height) as f64;
            let mut acc = 0.0f64;
            let mut sums = Vec::with_capacity(w);
            for t in row {
                acc += luminance(*t) as f64 * solid_angle;
                sums.push(acc);
            }
            row_power[j] = acc;
            normalise_into(&sums, acc, &mut column_cdf[j * w..(j + 1) * w]);
        }
        let power: f64 = row_power.iter().sum();
        let mut running = 0.0;
        let row_sums: Vec<f64> = row_power
            .iter()
            .map(|p| {
                running += p;
                running
            })
            .collect();
        let mut row_cdf = vec![0.0f32; h];
        normalise_into(&row_sums, power, &mut row_cdf);
        Environment {
            name: name.to_string(),
            width,
            height,
            texels,
            row_cdf,
            column_cdf,
            power: power as f32,
            sampling: EnvSampling::Importance,
        }
    }

    /// Reads an equirectangular map from an image file (EXR for radiance;
    /// any format the `image` crate reads works, taken as linear).
    /// Reads an equirectangular map: a regular file of at most
    /// [`MAX_MAP_BYTES`] and [`MAX_TEXELS`] texels, checked before decoding.
    pub fn load(path: &Path) -> Result<Environment, EnvironmentError> {
        let name = path.display().to_string();
        let fail = |what: String| EnvironmentError {
            path: name.clone(),
            what,
        };
        // A FIFO would block the decoder, a device feed it forever.
        crate::input::check_regular(path, MAX_MAP_BYTES)
            .map_err(|e| fail(format!("cannot read the environment map: {e}")))?;
        let reader = image::ImageReader::open(path)
            .map_err(|e| fail(format!("cannot read the environment map: {e}")))?
            .with_guessed_format()
            .map_err(|e| fail(format!("cannot read the environment map: {e}")))?;
        let (width, height) = reader
            .into_dimensions()
            .map_err(|e| fail(format!("not an image the environment light can read: {e}")))?;
        if width == 0 || height == 0 || u64::from(width) * u64::from(height) > MAX_TEXELS {
            return Err(fail(format!(
                "the map is {width} x {height}; it must be 1 x 1 to {MAX_TEXELS} texels"
            )));
        }
        let decoded = image::ImageReader::open(path)
            .and_then(|r| r.with_guessed_format())
            .map_err(|e| fail(format!("cannot read the environment map: {e}")))?
            .decode()
            .map_err(|e| fail(format!("not an image the environment light can read: {e}")))?
            .into_rgb32f();
        let mut texels = Vec::with_capacity(width as usize * height as usize);
        for (x, y, p) in decoded.enumerate_pixels() {
            let c = Vec3::from(p.0);
            if !c.is_finite() || c.min_element() < 0.0 {
                return Err(fail(format!(
                    "texel ({x}, {y}) is ({}, {}, {}); radiance must be finite and not negative",
                    c.x, c.y, c.z
                )));
            }
            texels.push(c);
        }
        Ok(Environment::new(&name, width, height, texels))
    }

    /// A map made in code: `radiance` of each texel's central direction.
    pub fn from_fn(
        name: &str,
        width: u32,
        height: u32,
        radiance: impl Fn(Vec3) -> Vec3,
    ) -> Environment {
        let mut texels = Vec::with_capacity(width as usize * height as usize);
        for row in 0..height {
            let theta = PI * (row as f32 + 0.5) / height as f32;
            for column in 0..width {
                let phi = 2.0 * PI * (column as f32 + 0.5) / width as f32;
                texels.push(radiance(direction(theta.cos(), theta.sin(), phi)));
            }
        }
        Environment::new(name, width, height, texels)
    }

    /// Writes the map as an RGB EXR that [`Environment::load`] reads back.
    pub fn save(&self, path: &Path) -> Result<(), EnvironmentError> {
        let mut image = image::Rgb32FImage::new(self.width, self.height);
        for (t, p) in self.texels.iter().zip(image.pixels_mut()) {
            p.0 = t.to_array();
        }
        image.save(path).map_err(|e| EnvironmentError {
            path: path.display().to_string(),
            what: format!("cannot write the environment map: {e}"),
        })
    }

    pub fn size(&self) -> (u32, u32) {
        (self.width, self.height)
    }

    /// The texel that direction `dir` (unit) sees.
    #[inline]
    fn texel_of(&self, dir: Vec3) -> usize {
        let theta = dir.y.clamp(-1.0, 1.0).acos();
        let phi = (-dir.z).atan2(dir.x) + PI;
        let column = ((phi * (0.5 / PI) * self.width as f32) as u32).min(self.width - 1);
        let row = ((theta * (1.0 / PI) * self.height as f32) as u32).min(self.height - 1);
        (row * self.width + column) as usize
    }

    /// Radiance arriving from direction `dir` (unit).
    #[inline]
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        self.texels[self.texel_of(dir)]
    }

    /// The density (solid angle) with which [`Environment::sample`] draws
    /// `dir`.
    pub fn pdf(&self, dir: Vec3) -> f32 {
        self.radiance_and_pdf(dir).1
    }

    /// Radiance from `dir` and the density of drawing `dir`, from one
    /// texel lookup.
    #[inline]
    pub fn radiance_and_pdf(&self, dir: Vec3) -> (Vec3, f32) {
        let radiance = self.radiance(dir);
        let pdf = match self.sampling {
            EnvSampling::Uniform => 0.25 / PI,
            EnvSampling::Importance if self.power > 0.0 => luminance(radiance) / self.power,
            EnvSampling::Importance => 0.0,
        };
        (radiance, pdf)
    }

    /// A direction drawn with `(u, v)` in [0, 1)^2; `None` when the map
    /// is black there (or everywhere).
    pub fn sample(&self, u: f32, v: f32) -> Option<EnvSample> {
        let wi = match self.sampling {
            EnvSampling::Uniform => uniform_sphere(u, v),
            EnvSampling::Importance => {
                if !(self.power > 0.0) {
                    return None;
                }
                let w = self.width as usize;
                let (row, u) = pick(&self.row_cdf, u);
                let (column, v) = pick(&self.column_cdf[row * w..(row + 1) * w], v);
                let (top, bottom) = row_cosines(row as u32, self.height);
                let cos_theta = top + (bottom - top) * u;
                let sin_theta = (1.0 - cos_theta * cos_theta).max(0.0).sqrt();
                let phi = 2.0 * PI * (column as f32 + v) / self.width as f32;
                direction(cos_theta, sin_theta, phi)
            }
        };
        // Radiance and density are those of the texel the direction looks
        // up, so that light sampling and BSDF-sampled rays that escape see
        // the same function.
        let (radiance, pdf) = self.radiance_and_pdf(wi);
        (pdf > 0.0 && radiance != Vec3::ZERO).then_some(EnvSample { wi, radiance, pdf })
    }
}

/// The direction at polar angle `theta` (from +Y) and azimuth `phi`, in
/// the course's layout (the inverse of [`Environment::texel_of`]).
#[inline]
fn direction(cos_theta: f32, sin_theta: f32, phi: f32) -> Vec3 {
    Vec3::new(-phi.cos() * sin_theta, cos_theta, phi.sin() * sin_theta)
}

/// `cos theta` at the top and the bottom edge of row `row` of `height`.
fn row_cosines(row: u32, height: u32) -> (f32, f32) {
    let edge = |r: u32| (PI * r as f32 / height as f32).cos();
    (edge(row), edge(row + 1))
}

/// Solid angle of one texel of row `row`.
fn texel_solid_angle(row: u32, width: u32, height: u32) -> f32 {
    let (top, bottom) = row_cosines(row, height);
    2.0 * PI / width as f32 * (top - bottom)
}

/// `sums / total` into `out`, ending at exactly 1 (all zeros when `total`
/// is zero).
fn normalise_into(sums: &[f64], total: f64, out: &mut [f32]) {
    if !(total > 0.0) {
        out.fill(0.0);
        return;
    }
    for (o, s) in out.iter_mut().zip(sums) {
        *o = (s / total) as f32;
    }
    if let Some(last) = out.last_mut() {
        *last = 1.0;
    }
}

/// The bin of `cdf` that `u` falls in, and `u` rescaled to [0, 1) within
/// it. Bins of zero probability are never picked.
fn pick(cdf: &[f32], u: f32) -> (usize, f32) {
    let i = cdf.partition_point(|&c| c <= u).min(cdf.len() - 1);
    let below = if i == 0 { 0.0 } else { cdf[i - 1] };
    let width = cdf[i] - below;
    let rest = if width > 0.0 {
        ((u - below) / width).clamp(0.0, 1.0 - f32::EPSILON / 2.0)
    } else {
        0.5
    };
    (i, rest)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A map with a few bright texels on a dim sky.
    fn spotty() -> Environment {
        let (w, h) = (16u32, 8u32);
        let mut texels = vec![Vec3::splat(0.1); (w * h) as usize];
        texels[(2 * w + 5) as usize] = Vec3::new(40.0, 30.0, 20.0);
        texels[(6 * w + 12) as usize] = Vec3::new(0.0, 5.0, 0.0);
        texels[3] = Vec3::ZERO;
        Environment::new("spotty", w, h, texels)
    }

    #[test]
    fn texel_solid_angles_cover_the_sphere() {
        let total: f32 = (0..8).map(|r| 16.0 * texel_solid_angle(r, 16, 8)).sum();
        assert!((total - 4.0 * PI).abs() < 1e-4, "total solid angle {total}");
    }

    #[test]
    fn directions_map_to_the_course_layout() {
        let env = spotty();
        let texel = |d: Vec3| {
            let i = env.texel_of(d.normalize());
            (i % 16, i / 16)
        };
        // Up is row 0, down the last row; phi = atan2(-z, x) + pi.
        assert_eq!(texel(Vec3::new(0.01, 1.0, 0.0)).1, 0);
        assert_eq!(texel(Vec3::new(0.01, -1.0, 0.0)).1, 7);
        // Just past the left edge (-X), a quarter (+Z), half (+X) and
        // three quarters (-Z) of the way across.
        assert_eq!(texel(Vec3::new(-1.0, 0.01, 0.01)), (0, 3));
        assert_eq!(texel(Vec3::new(0.01, 0.01, 1.0)), (4, 3));
        assert_eq!(texel(Vec3::new(1.0, 0.01, -0.01)), (8, 3));
        assert_eq!(texel(Vec3::new(-0.01, 0.01, -1.0)), (12, 3));
    }

    #[test]
    fn samples_land_in_the_texel_they_picked_with_the_density_pdf_reports() {
        // Histogram of samples over texels against each texel's share of
        // the power, and every sample's pdf against pdf().
        let env = spotty();
        let mut counts = vec![0u32; 16 * 8];
        let n = 200_000;
        let mut rng = crate::geom::sampling::Rng::new(7, 1);
        for _ in 0..n {
            let (u, v) = rng.next_2d();
            let s = env.sample(u, v).expect("the map has light");
            assert!((s.wi.length() - 1.0).abs() < 1e-5);
            assert_eq!(s.pdf, env.pdf(s.wi));
            assert_eq!(s.radiance, env.radiance(s.wi));
            counts[env.texel_of(s.wi)] += 1;
        }
        assert_eq!(counts[3], 0, "a black texel was sampled");
        for (i, &c) in counts.iter().enumerate() {
            let t = env.texels[i];
            let expected =
                luminance(t) * texel_solid_angle(i as u32 / 16, 16, 8) / env.power * n as f32;
            let sigma = expected.sqrt().max(1.0);
            assert!(
                (c as f32 - expected).abs() < 5.0 * sigma,
                "texel {i}: {c} samples, expected {expected:.1}"
            );
        }
    }

    #[test]
    fn the_estimate_of_total_irradiance_is_exact_for_importance_and_unbiased_for_uniform() {
        // The integral of luminance over the sphere is the map's power: with
        // importance sampling every sample's L / pdf is that integral.
        let mut env = spotty();
        let mut rng = crate::geom::sampling::Rng::new(3, 2);
        for _ in 0..1000 {
            let (u, v) = rng.next_2d();
            let s = env.sample(u, v).unwrap();
            let estimate = luminance(s.radiance) / s.pdf;
            assert!((estimate - env.power).abs() < 1e-3 * env.power);
        }
        env.sampling = EnvSampling::Uniform;
        let n = 400_000;
        let mean: f64 = (0..n)
            .filter_map(|_| {
                let (u, v) = rng.next_2d();
                env.sample(u, v)
            })
            .map(|s| (luminance(s.radiance) / s.pdf) as f64)
            .sum::<f64>()
            / n as f64;
        assert!(
            (mean as f32 - env.power).abs() < 0.03 * env.power,
            "uniform mean {mean} vs power {}",
            env.power
        );
    }

    #[test]
    fn a_black_map_gives_no_samples() {
        let env = Environment::new("black", 4, 2, vec![Vec3::ZERO; 8]);
        assert!(env.sample(0.3, 0.7).is_none());
        assert_eq!(env.pdf(Vec3::Y), 0.0);
    }
}
