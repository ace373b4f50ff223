//! An environment light: radiance arriving from infinitely far away, read
//! from an equirectangular map (`-e FILE.exr`), and how to sample it.
//!
//! The mapping is the course framework's: row 0 is straight up (+Y), the
//! polar angle grows down the rows (`theta = acos(y)`), and the column is
//! `phi / 2 pi` with `phi = atan2(-z, x) + pi`, so the map's left edge looks
//! towards -X, a quarter across towards +Z, the middle towards +X. Texels
//! are samples at their centres, looked up bilinearly (as pbrt-v4's image
//! infinite light does): the radiance seen in a direction blends the four
//! nearest texel centres, wrapping around in `phi` and held constant above
//! the first and below the last row's centre, so a map seen directly shows
//! no texel blocks. Importance sampling draws a texel with probability
//! proportional to the mean luminance of the filtered map over its patch
//! times the patch's solid angle, then a direction uniform in solid angle
//! within it (uniform in `phi` and `cos theta`): the piecewise-constant 2D
//! distribution of pbrt (Pharr, Jakob, Humphreys, 3rd ed. §13.6.7 and
//! §14.2.4), laid out over `cos theta` so that no `sin theta` factor is
//! left in the density. A patch's mean is positive wherever the filtered
//! map is, so every direction with light has a density, and the estimate
//! is unbiased; it is no longer exact within a texel, the price of the
//! filter.

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
    /// Per texel, the mean luminance of the filtered map over its patch:
    /// what importance sampling draws by.
    weights: Vec<f32>,
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
        let weights = patch_means(&texels, w, h);
        let mut row_power = vec![0.0f64; h];
        let mut column_cdf = vec![0.0f32; w * h];
        for (j, row) in weights.chunks_exact(w).enumerate() {
            let solid_angle = texel_solid_angle(j as u32, width, height) as f64;
            let mut acc = 0.0f64;
            let mut sums = Vec::with_capacity(w);
            for &weight in row {
                acc += f64::from(weight) * solid_angle;
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
            weights,
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

    /// Where direction `dir` (unit) lies on the map, in texels: column
    /// and row, 0 at the left and top edges.
    #[inline]
    fn map_position(&self, dir: Vec3) -> (f32, f32) {
        let theta = dir.y.clamp(-1.0, 1.0).acos();
        let phi = (-dir.z).atan2(dir.x) + PI;
        (
            phi * (0.5 / PI) * self.width as f32,
            theta * (1.0 / PI) * self.height as f32,
        )
    }

    /// The texel whose patch direction `dir` (unit) lies in.
    #[inline]
    fn texel_of(&self, dir: Vec3) -> usize {
        let (x, y) = self.map_position(dir);
        let column = (x as u32).min(self.width - 1);
        let row = (y as u32).min(self.height - 1);
        (row * self.width + column) as usize
    }

    /// Radiance arriving from direction `dir` (unit): the texels around it
    /// blended bilinearly by the distance to their centres.
    #[inline]
    pub fn radiance(&self, dir: Vec3) -> Vec3 {
        let (x, y) = self.map_position(dir);
        let (x, y) = (x - 0.5, y - 0.5);
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (w, h) = (self.width as i64, self.height as i64);
        let column = |c: i64| c.rem_euclid(w) as usize;
        let row = |r: i64| r.clamp(0, h - 1) as usize * w as usize;
        let (c0, c1) = (column(x0 as i64), column(x0 as i64 + 1));
        let (r0, r1) = (row(y0 as i64), row(y0 as i64 + 1));
        let t = &self.texels;
        let top = t[r0 + c0] * (1.0 - fx) + t[r0 + c1] * fx;
        let bottom = t[r1 + c0] * (1.0 - fx) + t[r1 + c1] * fx;
        top * (1.0 - fy) + bottom * fy
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
            EnvSampling::Importance if self.power > 0.0 => {
                self.weights[self.texel_of(dir)] / self.power
            }
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
        // Radiance and density come from the same lookups that rays which
        // escape make, so light sampling and BSDF sampling see one function.
        let (radiance, pdf) = self.radiance_and_pdf(wi);
        (pdf > 0.0 && radiance != Vec3::ZERO).then_some(EnvSample { wi, radiance, pdf })
    }
}

/// The mean luminance of the bilinearly filtered map over each texel's
/// patch. Across a patch the filter's weight on the texel before, itself
/// and the one after falls as 1/8, 3/4 and 1/8 of the patch's width (the
/// integrals of the tent), in each direction; rows are held at the edges
/// and columns wrap, as the lookup does.
fn patch_means(texels: &[Vec3], w: usize, h: usize) -> Vec<f32> {
    const TENT: [(i64, f32); 3] = [(-1, 0.125), (0, 0.75), (1, 0.125)];
    let lum: Vec<f32> = texels.iter().map(|t| luminance(*t)).collect();
    let (wi, hi) = (w as i64, h as i64);
    let mut out = vec![0.0f32; w * h];
    for j in 0..hi {
        for i in 0..wi {
            let mut sum = 0.0f32;
            for (dj, kj) in TENT {
                let r = (j + dj).clamp(0, hi - 1) as usize;
                for (di, ki) in TENT {
                    let c = (i + di).rem_euclid(wi) as usize;
                    sum += kj * ki * lum[r * w + c];
                }
            }
            out[j as usize * w + i as usize] = sum;
        }
    }
    out
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
        // the filtered power, and every sample's pdf against pdf().
        let env = spotty();
        let mut counts = vec![0u32; 16 * 8];
        let n = 200_000;
        let mut rng = crate::geom::sampling::Rng::new(7, 1);
        for _ in 0..n {
            let (u, v) = rng.next_2d();
            let Some(s) = env.sample(u, v) else { continue };
            assert!((s.wi.length() - 1.0).abs() < 1e-5);
            assert_eq!(s.pdf, env.pdf(s.wi));
            assert_eq!(s.radiance, env.radiance(s.wi));
            counts[env.texel_of(s.wi)] += 1;
        }
        for (i, &c) in counts.iter().enumerate() {
            let expected =
                env.weights[i] * texel_solid_angle(i as u32 / 16, 16, 8) / env.power * n as f32;
            let sigma = expected.sqrt().max(1.0);
            assert!(
                (c as f32 - expected).abs() < 5.0 * sigma,
                "texel {i}: {c} samples, expected {expected:.1}"
            );
        }
    }

    /// The direction through the centre of texel (column, row).
    fn centre(env: &Environment, column: f32, row: f32) -> Vec3 {
        let (w, h) = env.size();
        let theta = PI * (row + 0.5) / h as f32;
        let phi = 2.0 * PI * (column + 0.5) / w as f32;
        direction(theta.cos(), theta.sin(), phi)
    }

    #[test]
    fn lookups_are_bilinear_between_texel_centres_and_wrap_around() {
        let env = spotty();
        let t = |c: usize, r: usize| env.texels[r * 16 + c];
        let close = |a: Vec3, b: Vec3| (a - b).abs().max_element() < 1e-3 * (1.0 + b.max_element());
        // At a centre, the texel itself.
        assert!(close(env.radiance(centre(&env, 5.0, 2.0)), t(5, 2)));
        // Half way to the next centre across and down: the mean.
        let across = env.radiance(centre(&env, 5.5, 2.0));
        assert!(close(across, (t(5, 2) + t(6, 2)) * 0.5), "{across}");
        let down = env.radiance(centre(&env, 5.0, 2.5));
        assert!(close(down, (t(5, 2) + t(5, 3)) * 0.5), "{down}");
        let quarter = env.radiance(centre(&env, 4.75, 2.0));
        assert!(close(quarter, t(4, 2) * 0.25 + t(5, 2) * 0.75), "{quarter}");
        // Across the seam at phi = 0: the last column blends with the first.
        let seam = env.radiance(centre(&env, 15.5, 6.0));
        assert!(close(seam, (t(15, 6) + t(0, 6)) * 0.5), "{seam}");
        // Above the first row's centre the first row holds.
        let near_pole = env.radiance(centre(&env, 3.0, -0.4));
        assert!(close(near_pole, t(3, 0)), "{near_pole}");
    }

    /// The integral of the filtered map's luminance over the sphere, by a
    /// fine midpoint rule in `phi` and `cos theta`.
    fn quadrature(env: &Environment) -> f64 {
        let (nphi, nz) = (1024, 1024);
        let mut sum = 0.0f64;
        for i in 0..nz {
            let z = 1.0 - 2.0 * (i as f32 + 0.5) / nz as f32;
            let r = (1.0 - z * z).max(0.0).sqrt();
            for k in 0..nphi {
                let phi = 2.0 * PI * (k as f32 + 0.5) / nphi as f32;
                sum += luminance(env.radiance(direction(z, r, phi))) as f64;
            }
        }
        sum * 4.0 * std::f64::consts::PI / (nphi * nz) as f64
    }

    /// Mean and standard error of luminance(L) / pdf over `n` samples.
    fn estimate(env: &Environment, n: u32, seed: u64) -> (f64, f64) {
        let mut rng = crate::geom::sampling::Rng::new(seed, 2);
        let (mut sum, mut sq) = (0.0f64, 0.0f64);
        for _ in 0..n {
            let (u, v) = rng.next_2d();
            let x = env
                .sample(u, v)
                .map_or(0.0, |s| (luminance(s.radiance) / s.pdf) as f64);
            sum += x;
            sq += x * x;
        }
        let mean = sum / n as f64;
        let var = (sq / n as f64 - mean * mean).max(0.0);
        (mean, (var / n as f64).sqrt())
    }

    #[test]
    fn a_map_of_known_integral_is_estimated_without_bias_by_both_samplings() {
        // Texels 1 + y at their centres: the filtered map stays odd in y
        // about 1, so its integral over the sphere is exactly 4 pi.
        let env = Environment::from_fn("1 + y", 32, 16, |d| Vec3::splat(1.0 + d.y));
        let truth = 4.0 * std::f64::consts::PI;
        let by_quadrature = quadrature(&env);
        assert!(
            (by_quadrature - truth).abs() < 1e-3 * truth,
            "quadrature {by_quadrature}"
        );
        let mut uniform = env.clone();
        uniform.sampling = EnvSampling::Uniform;
        for (name, env) in [("by luminance", &env), ("uniform", &uniform)] {
            let (mean, error) = estimate(env, 200_000, 5);
            println!("{name}: {mean:.4} ± {error:.4} (exact {truth:.4})");
            assert!(
                (mean - truth).abs() < 4.0 * error + 1e-4 * truth,
                "{name}: {mean} ± {error}, exact {truth}"
            );
        }
    }

    #[test]
    fn importance_sampling_a_spotty_map_is_unbiased_and_beats_uniform() {
        let mut env = spotty();
        let truth = quadrature(&env);
        let (mean, error) = estimate(&env, 200_000, 9);
        assert!(
            (mean - truth).abs() < 4.0 * error + 1e-3 * truth,
            "by luminance {mean} ± {error}, quadrature {truth}"
        );
        env.sampling = EnvSampling::Uniform;
        let (uniform, uniform_error) = estimate(&env, 200_000, 9);
        assert!(
            (uniform - truth).abs() < 4.0 * uniform_error + 1e-3 * truth,
            "uniform {uniform} ± {uniform_error}, quadrature {truth}"
        );
        println!("errors: by luminance {error:.4}, uniform {uniform_error:.4}");
        assert!(error * 3.0 < uniform_error, "{error} vs {uniform_error}");
    }

    #[test]
    fn a_black_map_gives_no_samples() {
        let env = Environment::new("black", 4, 2, vec![Vec3::ZERO; 8]);
        assert!(env.sample(0.3, 0.7).is_none());
        assert_eq!(env.pdf(Vec3::Y), 0.0);
    }
}
