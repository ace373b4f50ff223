//! Adaptive against uniform sampling at equal time, on scenes of different
//! character: each scene's adaptive render (`-a BATCH TOL -s CAP`), a
//! uniform render of about the same mean samples per pixel, both timed and
//! compared with a high-sample reference; the uniform error is carried to
//! the adaptive render's time by Monte Carlo's `RMSE ∝ time^-1/2`.

use std::path::Path;

use super::budget::{Budget, SERIES_SCENE};
use super::error::rmse;
use super::table::{Cell, Table};
use super::{load, load_builtin};
use crate::accel::{Accel, BackendConfig};
use crate::geom::sampling::luminance;
use crate::measure::Measured;
use crate::render::film::Film;
use crate::render::integrator::{PathSettings, Shading};
use crate::render::{render, Adaptive, RenderSettings, Silent};
use crate::scene::builtin::{CORNELL, GLOSSY};
use crate::scene::Scene;

/// Bounces of every render of the study.
const MAX_BOUNCES: u32 = 5;

/// One scene's comparison.
pub struct AdaptiveRow {
    pub scene: String,
    pub adaptive_seconds: f64,
    pub adaptive_rmse: f64,
    pub adaptive_spp: f64,
    /// Share of pixels that stopped after one batch, and that ran to the cap.
    pub stopped_early: f64,
    pub capped: f64,
    /// Of the pixels that stopped after one batch: the share that is
    /// background (black in the reference, exact after one batch), and
    /// the share of adaptive's squared error they carry.
    pub stopped_background: f64,
    pub stopped_error: f64,
    pub uniform_spp: u32,
    pub uniform_seconds: f64,
    pub uniform_rmse: f64,
}

impl AdaptiveRow {
    /// Uniform sampling's RMSE at the adaptive render's time.
    pub fn uniform_rmse_at_equal_time(&self) -> f64 {
        self.uniform_rmse * (self.uniform_seconds / self.adaptive_seconds).sqrt()
    }

    /// Uniform's error over adaptive's at equal time: greater than 1 means
    /// adaptive sampling wins.
    pub fn advantage(&self) -> f64 {
        self.uniform_rmse_at_equal_time() / self.adaptive_rmse
    }
}

pub struct AdaptiveStudy {
    pub resolution: (u32, u32),
    pub reference_spp: u32,
    pub adaptive: Adaptive,
    pub cap: u32,
    pub rows: Vec<AdaptiveRow>,
}

/// Measures every scene of the study.
pub fn measure(dir: &Path, budget: &Budget, threads: usize) -> Result<AdaptiveStudy, String> {
    let (resolution, reference_spp, batch, tolerance, cap) = budget.adaptive_study;
    let adaptive = Adaptive { batch, tolerance };
    let scenes = [
        (CORNELL.name, load_builtin(CORNELL)?),
        (GLOSSY.name, load_builtin(GLOSSY)?),
        (SERIES_SCENE, load(dir, SERIES_SCENE)?),
    ];
    let mut rows = Vec::new();
    for (name, scene) in &scenes {
        let accel = BackendConfig::NATIVE
            .build(scene)
            .map_err(|e| e.to_string())?;
        let settings = |samples: u32, seed: u64, adaptive: Option<Adaptive>| RenderSettings {
            width: resolution.0,
            height: resolution.1,
            samples,
            threads,
            seed,
            shading: Shading::Path(PathSettings {
                max_bounces: MAX_BOUNCES,
                ..PathSettings::default()
            }),
            adaptive,
            ..RenderSettings::default()
        };
        let reference = render(scene, &accel, &settings(reference_spp, 777, None), &Silent).film;
        let (a_seconds, a_film) = timed(scene, &accel, &settings(cap, 1, Some(adaptive)), budget);
        let pixels = a_film.samples.len() as f64;
        let mean = a_film.mean_samples();
        let (mut stopped, mut background, mut stopped_sq, mut all_sq) = (0usize, 0usize, 0.0, 0.0);
        for ((n, a), r) in a_film
            .samples
            .iter()
            .zip(&a_film.pixels)
            .zip(&reference.pixels)
        {
            let sq = f64::from((*a - *r).length_squared());
            all_sq += sq;
            if *n <= batch {
                stopped += 1;
                stopped_sq += sq;
                background += usize::from(luminance(*r) < 1e-4);
            }
        }
        let uniform_spp = mean.round().max(1.0) as u32;
        let (u_seconds, u_film) = timed(scene, &accel, &settings(uniform_spp, 1, None), budget);
        rows.push(AdaptiveRow {
            scene: name.to_string(),
            adaptive_seconds: a_seconds,
            adaptive_rmse: rmse(&a_film, &reference),
            adaptive_spp: mean,
            stopped_early: stopped as f64 / pixels,
            capped: a_film.samples.iter().filter(|&&n| n >= cap).count() as f64 / pixels,
            stopped_background: background as f64 / stopped.max(1) as f64,
            stopped_error: if all_sq > 0.0 {
                stopped_sq / all_sq
            } else {
                0.0
            },
            uniform_spp,
            uniform_seconds: u_seconds,
            uniform_rmse: rmse(&u_film, &reference),
        });
    }
    Ok(AdaptiveStudy {
        resolution,
        reference_spp,
        adaptive,
        cap,
        rows,
    })
}

/// The median time of a few renders after a first, warm-up one, and that
/// first render's film (the same every time).
fn timed<A: Accel>(scene: &Scene, accel: &A, s: &RenderSettings, budget: &Budget) -> (f64, Film) {
    let film = render(scene, accel, s, &Silent).film;
    let seconds = (0..budget.repeats.min(3))
        .map(|_| render(scene, accel, s, &Silent).seconds)
        .collect();
    (Measured::from_samples(seconds).median, film)
}

pub fn table(study: &AdaptiveStudy) -> Table {
    let mut table = Table::new([
        ("scene", "scene"),
        ("adaptive_spp", "adaptive: mean spp"),
        ("stopped_early", "stopped after one batch"),
        ("capped", "ran to the cap"),
        ("stopped_background", "of those, background"),
        ("stopped_error", "their share of adaptive's squared error"),
        ("adaptive_rmse", "adaptive RMSE"),
        ("uniform_spp", "uniform spp"),
        ("uniform_rmse_equal_time", "uniform RMSE at adaptive's time"),
        ("advantage", "uniform / adaptive RMSE (> 1: adaptive wins)"),
    ]);
    for r in &study.rows {
        table.row(vec![
            Cell::Text(r.scene.clone()),
            Cell::Number(r.adaptive_spp, 1),
            Cell::Text(format!("{:.0}%", 100.0 * r.stopped_early)),
            Cell::Text(format!("{:.0}%", 100.0 * r.capped)),
            Cell::Text(format!("{:.0}%", 100.0 * r.stopped_background)),
            Cell::Text(format!("{:.0}%", 100.0 * r.stopped_error)),
            Cell::Number(r.adaptive_rmse, 4),
            Cell::Count(r.uniform_spp as u64),
            Cell::Number(r.uniform_rmse_at_equal_time(), 4),
            Cell::Ratio(r.advantage()),
        ]);
    }
    table
}

/// Which wins where, and why, in words from the measured figures.
fn findings(study: &AdaptiveStudy) -> String {
    let mut out = String::new();
    for r in &study.rows {
        let early = 100.0 * r.stopped_early;
        let background = 100.0 * r.stopped_background;
        let share = 100.0 * r.stopped_error;
        let winner = if r.advantage() > 1.05 {
            format!(
                "adaptive sampling wins ({:.2}x less error at equal time)",
                r.advantage()
            )
        } else if r.advantage() < 0.95 {
            format!(
                "uniform sampling wins (adaptive has {:.2}x its error at equal time)",
                1.0 / r.advantage()
            )
        } else {
            "the two are even (within 5%)".to_string()
        };
        let why = if r.advantage() < 0.95 {
            format!(
                "{early:.0}% of the pixels stopped after one batch, {background:.0}% of them background (exact), yet the stopped pixels carry {share:.0}% of adaptive's squared error: where an edge of something bright (the light seen directly, radiance 8 against walls below 1) crosses a pixel, a first batch whose samples all fall on one side of it has no variance, so the test stops the pixel with its coverage wrong"
            )
        } else {
            format!(
                "{early:.0}% of the pixels stopped after one batch and {background:.0}% of those are background, exact after one batch, so the samples saved there went where the noise is; the stopped pixels carry {share:.0}% of adaptive's squared error"
            )
        };
        out += &format!("- `{}`: {winner}: {why}.\n", r.scene);
    }
    out
}

pub fn markdown(study: &AdaptiveStudy) -> String {
    let (w, h) = study.resolution;
    let a = study.adaptive;
    format!(
        "## Adaptive against uniform sampling at equal time\n\nEach scene rendered at {w}x{h}, {MAX_BOUNCES} bounces, MIS, on the native backend: once with adaptive sampling (`-a {} {} -s {}`) and once uniformly at the adaptive render's mean samples per pixel; RMSE of linear radiance against a uniform reference of {} spp (another seed). Times are medians of repeated renders; uniform sampling's error is carried to the adaptive render's time by RMSE ∝ time^-1/2, so the last column compares the two at equal time.\n\n{}\n{}\nAdaptive sampling pays where much of the frame is exact after one batch and the rest is noisy, and loses where its early stops are wrong: its test bounds each pixel's error by the spread of its own first samples, which a pixel's sharp edge need not show (the tolerance here, {}, is relative to each pixel's mean).\n\n",
        a.batch,
        a.tolerance,
        study.cap,
        study.reference_spp,
        table(study).markdown(),
        findings(study),
        a.tolerance
    )
}
