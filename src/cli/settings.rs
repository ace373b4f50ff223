//! The render options checked and turned into [`RenderSettings`], before
//! any work: every value outside what its option accepts is one
//! [`SettingsError`] naming the option as typed and why.

use super::render::RenderArgs;
use crate::render::camera::ThinLens;
use crate::render::camera_file::CourseCamera;
use crate::render::integrator::{DirectEstimator, PathSettings, Shading};
use crate::render::{Adaptive, Cell, Mode, RenderSettings};

pub use crate::render::film::MAX_PIXELS;

/// A camera file is 30 numbers on six lines; anything much longer is not
/// one, and is refused before it is read.
pub const MAX_CAMERA_FILE_BYTES: u64 = 64 * 1024;

/// More worker threads than this only cost memory and start-up time.
pub const MAX_THREADS: usize = 256;

/// Mean (12 bytes), sample count (4) and double-precision sum (24).
const FILM_BYTES_PER_PIXEL: u64 = 40;

/// The largest image side.
const MAX_SIDE: u32 = 1 << 15;

/// Why the options do not make a render.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SettingsError {
    /// An option's value is outside what it accepts: the option as typed.
    #[error("{option}: {why}")]
    Value { option: String, why: String },
    /// The backend `--accel` names does not load here.
    #[error("--accel {kind}: {why}")]
    Unavailable { kind: &'static str, why: String },
    /// The camera file (`-c`) cannot be read or is not one.
    #[error("{0}")]
    CameraFile(String),
    /// More pixels than one run holds.
    #[error(
        "{width} x {height} pixels to render: at most {MAX_PIXELS} ({} MiB of film) per run; split the frame with -p",
        (MAX_PIXELS * FILM_BYTES_PER_PIXEL) >> 20
    )]
    TooManyPixels { width: u32, height: u32 },
}

impl From<SettingsError> for String {
    fn from(e: SettingsError) -> String {
        e.to_string()
    }
}

/// `option` (as typed) is refused, because `why`.
fn refused(option: impl Into<String>, why: impl Into<String>) -> SettingsError {
    SettingsError::Value {
        option: option.into(),
        why: why.into(),
    }
}

impl RenderArgs {
    /// Checks the options and turns them into render settings.
    pub fn settings(&self) -> Result<RenderSettings, SettingsError> {
        let backend = self.backend();
        backend
            .available()
            .map_err(|why| SettingsError::Unavailable {
                kind: backend.kind(),
                why,
            })?;
        let (width, height) = self.resolution_checked()?;
        if self.threads > MAX_THREADS {
            return Err(refused(
                format!("-t {}", self.threads),
                format!("at most {MAX_THREADS} threads (0 means one per core)"),
            ));
        }
        let samples = self.samples();
        if samples == 0 {
            return Err(refused("-s 0", "at least one sample per pixel is needed"));
        }
        if self.light_samples == 0 {
            return Err(refused("-l 0", "at least one light sample is needed"));
        }
        if let Some(deg) = self.crease.filter(|d| !(0.0..=180.0).contains(d)) {
            return Err(refused(
                format!("--crease {deg}"),
                "the angle must be 0..=180 degrees",
            ));
        }
        if self.normals && self.mode == Some(Mode::Wavefront) {
            return Err(refused(
                "--mode wavefront",
                "normal shading runs in the reference mode only; leave out --mode",
            ));
        }
        if self.leaf > 16 {
            return Err(refused(
                format!("--leaf {}", self.leaf),
                "leaf size must be 1..=16 (or 0: by mesh size)",
            ));
        }
        if let Some(p) = self.russian_roulette().filter(|p| !(*p > 0.0 && *p <= 1.0)) {
            return Err(refused(
                format!("--rr {p}"),
                "the continuation probability must be in (0, 1]",
            ));
        }
        let cell = self.cell_checked(width, height)?;
        let (w, h) = cell.map_or((width, height), |c| (c.width, c.height));
        if u64::from(w) * u64::from(h) > MAX_PIXELS {
            return Err(SettingsError::TooManyPixels {
                width: w,
                height: h,
            });
        }
        Ok(RenderSettings {
            width,
            height,
            samples,
            threads: self.threads,
            seed: self.seed,
            camera: self.camera,
            shading: self.shading(),
            adaptive: self.adaptive_checked()?,
            cell,
            sample_range: self.sample_range_checked(samples)?,
            lens: self.lens_checked()?,
            course_camera: self.course_camera()?,
            sampler: self.sampler,
            mode: self.mode,
        })
    }

    fn resolution_checked(&self) -> Result<(u32, u32), SettingsError> {
        let (width, height) = (self.resolution[0], self.resolution[1]);
        let option = || format!("-r {width} {height}");
        if width == 0 || height == 0 {
            return Err(refused(option(), "the resolution must be at least 1 x 1"));
        }
        if width > MAX_SIDE || height > MAX_SIDE {
            return Err(refused(
                option(),
                format!("the resolution is larger than {MAX_SIDE}"),
            ));
        }
        Ok((width, height))
    }

    fn adaptive_checked(&self) -> Result<Option<Adaptive>, SettingsError> {
        let Some(a) = &self.adaptive else {
            return Ok(None);
        };
        let (batch, tolerance) = (a[0], a[1]);
        if batch < 1.0 || batch.fract() != 0.0 || !(tolerance > 0.0) || !tolerance.is_finite() {
            return Err(refused(
                format!("-a {batch} {tolerance}"),
                "BATCH must be a whole number >= 1 and TOL > 0",
            ));
        }
        Ok(Some(Adaptive {
            batch: batch as u32,
            tolerance: tolerance as f32,
        }))
    }

    /// The cell of the frame this run renders (`-p X Y W H` or `--part
    /// K/N`), if not all of it.
    fn cell_checked(&self, width: u32, height: u32) -> Result<Option<Cell>, SettingsError> {
        if let Some(text) = &self.part {
            return match two_numbers(text, "/") {
                Some((k, n)) if k < n && n <= height => {
                    let band = |k: u32| (u64::from(height) * u64::from(k) / u64::from(n)) as u32;
                    Ok(Some(Cell {
                        x: 0,
                        y: band(k),
                        width,
                        height: band(k + 1) - band(k),
                    }))
                }
                _ => Err(refused(
                    format!("--part {text}"),
                    format!("expected K/N with 0 <= K < N <= {height} (the image's rows)"),
                )),
            };
        }
        let Some(c) = &self.cell else {
            return Ok(None);
        };
        let cell = Cell {
            x: c[0],
            y: c[1],
            width: c[2],
            height: c[3],
        };
        let inside = |start: u32, size: u32, limit: u32| {
            size > 0 && start.checked_add(size).is_some_and(|end| end <= limit)
        };
        if !inside(cell.x, cell.width, width) || !inside(cell.y, cell.height, height) {
            return Err(refused(
                format!("-p {} {} {} {}", c[0], c[1], c[2], c[3]),
                format!("the cell must be non-empty and inside the {width} x {height} image"),
            ));
        }
        Ok(Some(cell))
    }

    fn lens_checked(&self) -> Result<Option<ThinLens>, SettingsError> {
        if let Some(r) = self.lens_radius.filter(|r| !(*r >= 0.0 && r.is_finite())) {
            return Err(refused(
                format!("-b {r}"),
                "the lens radius must be 0 or more",
            ));
        }
        if let Some(d) = self.focal_distance.filter(|d| !(*d > 0.0 && d.is_finite())) {
            return Err(refused(
                format!("-d {d}"),
                "the focal distance must be more than 0",
            ));
        }
        Ok(self.lens_radius.map(|radius| ThinLens {
            radius,
            focal_distance: self.focal_distance.unwrap_or(0.0),
        }))
    }

    fn course_camera(&self) -> Result<Option<CourseCamera>, SettingsError> {
        let Some(path) = &self.camera_file else {
            return Ok(None);
        };
        let name = path.display().to_string();
        let bytes = crate::input::read_regular(path, MAX_CAMERA_FILE_BYTES).map_err(|e| {
            SettingsError::CameraFile(format!("{name}: cannot read the camera file: {e}"))
        })?;
        let text = String::from_utf8(bytes).map_err(|_| {
            SettingsError::CameraFile(format!("{name}: the camera file is not UTF-8 text"))
        })?;
        CourseCamera::parse(&text, &name)
            .map(Some)
            .map_err(SettingsError::CameraFile)
    }

    fn sample_range_checked(&self, samples: u32) -> Result<Option<(u32, u32)>, SettingsError> {
        let Some(text) = &self.sample_range else {
            return Ok(None);
        };
        let option = || format!("--samples {text}");
        let range = two_numbers(text, "..").filter(|&(a, b)| a < b && b <= samples);
        if range.is_none() {
            return Err(refused(
                option(),
                format!("expected A..B with A < B <= {samples} (the -s count)"),
            ));
        }
        if self.adaptive.is_some() {
            return Err(refused(
                option(),
                "adaptive sampling (-a) decides per pixel how many samples to take and cannot be split by samples; split it with -p",
            ));
        }
        Ok(range)
    }

    fn shading(&self) -> Shading {
        if self.normals {
            return Shading::Normals;
        }
        Shading::Path(PathSettings {
            estimator: if self.hemisphere {
                DirectEstimator::Hemisphere
            } else {
                self.estimator.unwrap_or_default()
            },
            light_samples: self.light_samples,
            max_bounces: self.max_bounces(),
            accumulate: self.accumulate == 1,
            view: self.only,
            russian_roulette: self.russian_roulette(),
            background: self.background,
        })
    }

    /// What a course-style command line gets that the course's framework
    /// would not give it: with `-l` and no `--estimator`, direct lighting
    /// is MIS, where the course's is light sampling alone; and Russian
    /// roulette is off unless `--rr` is given. `None` for normals, or when
    /// the estimator was chosen.
    pub fn course_note(&self) -> Option<String> {
        let course = self.light_samples != 1 || self.max_bounces.is_some();
        if self.normals || self.hemisphere || self.estimator.is_some() || !course {
            return None;
        }
        let roulette = if self.russian_roulette().is_none() {
            ", and no Russian roulette (--rr P turns it on)"
        } else {
            ""
        };
        Some(format!(
            "note: direct lighting by MIS (light and BSDF sampling combined){roulette}; the course's estimator is light sampling alone: add --estimator light for its images"
        ))
    }

    /// Options this run ignores, one line each (printed once per command,
    /// as `hybrid: warning:` lines).
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        if let (None, Some(d)) = (self.lens_radius, self.focal_distance) {
            out.push(format!("-d {d} is ignored without a lens radius (-b)"));
        }
        if self.normals {
            let mut ignored = Vec::new();
            if self.hemisphere || self.estimator.is_some() {
                ignored.push("-H/--estimator");
            }
            if self.light_samples != 1 {
                ignored.push("-l");
            }
            if self.max_bounces.is_some_and(|m| m != 1) {
                ignored.push("-m");
            }
            if self.environment.is_some() {
                ignored.push("-e");
            }

            for flag in ignored {
                out.push(format!(
                    "{flag} is ignored with --normals (normal shading traces camera rays only)"
                ));
            }
            if self.exposure.is_some() {
                out.push(
                    "--exposure is ignored with --normals (normal colours are shown as they are)"
                        .into(),
                );
            }
        }
        if let Some(a) = &self.adaptive {
            let samples = self.samples();
            if a[0] > samples as f64 {
                out.push(format!(
                    "-a {} {}: the batch is larger than -s {samples}, so every pixel takes the -s samples and none stops early",
                    a[0], a[1]
                ));
            }
        }
        if self.crease.is_some() && self.flat {
            out.push("--crease is ignored with --flat (every face keeps its own normal)".into());
        }
        out
    }
}

/// `A<sep>B` as two whole numbers (`--part K/N`, `--samples A..B`).
fn two_numbers(text: &str, sep: &str) -> Option<(u32, u32)> {
    let (a, b) = text.split_once(sep)?;
    Some((a.trim().parse().ok()?, b.trim().parse().ok()?))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::Parser;

    #[derive(Parser)]
    struct Cli {
        #[command(flatten)]
        render: RenderArgs,
    }

    fn settings(args: &[&str]) -> Result<RenderSettings, SettingsError> {
        let cli = Cli::try_parse_from(std::iter::once("hybrid").chain(args.iter().copied()))
            .expect("the arguments parse");
        cli.render.settings()
    }

    #[test]
    fn each_refusal_names_the_option_as_typed() {
        for (args, option) in [
            (&["-r", "0", "4"][..], "-r 0 4"),
            (&["-s", "0"], "-s 0"),
            (&["--rr", "1.5"], "--rr 1.5"),
            (&["-r", "8", "8", "-p", "4", "4", "8", "1"], "-p 4 4 8 1"),
            (&["-r", "8", "8", "--part", "3/2"], "--part 3/2"),
            (&["-b=-1"], "-b -1"),
            (&["-s", "4", "--samples", "2..9"], "--samples 2..9"),
        ] {
            match settings(args) {
                Err(SettingsError::Value { option: o, .. }) => assert_eq!(o, option, "{args:?}"),
                other => panic!("{args:?}: expected a refusal of {option}, got {other:?}"),
            }
        }
        assert!(settings(&["-r", "8", "8", "-p", "0", "0", "8", "8"]).is_ok());
    }

    #[test]
    fn a_frame_larger_than_one_run_holds_is_refused_before_any_work() {
        assert_eq!(
            settings(&["-r", "32768", "32768"]).unwrap_err(),
            SettingsError::TooManyPixels {
                width: 32768,
                height: 32768
            }
        );
    }
}
