//! The samplers at equal samples and at equal time: relative MSE against a
//! high-sample reference, render time, and efficiency (one over relative
//! MSE times time: higher is better) per scene, sampler and estimator, on
//! the shared Cornell boxes and the project's glossy scene.

use std::path::Path;

use super::table::{Cell, Table};
use crate::accel::BackendConfig;
use crate::choice::Choice;
use crate::render::film::Film;
use crate::render::integrator::{DirectEstimator, PathSettings, Shading};
use crate::render::{render, RenderSettings, Sampler, Silent};
use crate::scene::builtin::GLOSSY;
use crate::scene::Scene;

/// The scenes of the study: the shared Cornell boxes (an area light, a
/// point light, a mirror and glass) and the glossy spheres.
pub const SCENES: [&str; 3] = ["sky/CBbunny.dae", "sky/CBempty.dae", "sky/CBspheres.dae"];

/// The estimators compared.
const ESTIMATORS: [(&str, DirectEstimator); 2] = [
    ("MIS", DirectEstimator::Mis),
    ("light", DirectEstimator::LightSampling),
];

/// Bounces of every render.
const MAX_BOUNCES: u32 = 5;

/// Seeds each measured point averages its squared error over.
const SEEDS: u32 = 16;

/// The study's sizes: resolution, samples per pixel of the points, and of
/// the reference (rendered with the independent sampler on other seeds,
/// so the reference's own noise is shared by both samplers).
pub struct SamplerBudget {
    pub resolution: (u32, u32),
    pub spp: Vec<u32>,
    pub reference_spp: u32,
}

impl SamplerBudget {
    pub fn new(quick: bool) -> SamplerBudget {
        if quick {
            SamplerBudget {
                resolution: (48, 36),
                spp: vec![16, 64],
                reference_spp: 4096,
            }
        } else {
            SamplerBudget {
                resolution: (96, 72),
                spp: vec![16, 64, 256],
                reference_spp: 16384,
            }
        }
    }
}

/// One scene, sampler, estimator and sample count.
pub struct SamplerPoint {
    pub scene: String,
    pub sampler: Sampler,
    pub estimator: &'static str,
    pub spp: u32,
    /// Mean over the seeds of the relative MSE (pbrt's: the squared error
    /// over the reference's square plus 0.01, per channel, averaged).
    pub rel_mse: f64,
    pub seconds: f64,
}

impl SamplerPoint {
    /// One over relative MSE times seconds.
    pub fn efficiency(&self) -> f64 {
        1.0 / (self.rel_mse * self.seconds).max(1e-300)
    }
}

pub struct SamplerStudy {
    pub threads: usize,
    pub budget: SamplerBudget,
    pub points: Vec<SamplerPoint>,
}

/// Relative mean squared error of `film` against `reference`.
pub fn rel_mse(film: &Film, reference: &Film) -> f64 {
    let mut sum = 0.0;
    for (a, b) in film.pixels.iter().zip(&reference.pixels) {
        for c in 0..3 {
            let (x, r) = (f64::from(a[c]), f64::from(b[c]));
            sum += (x - r).powi(2) / (r * r + 0.01);
        }
    }
    sum / (3 * film.pixels.len()) as f64
}

fn settings(
    (w, h): (u32, u32),
    threads: usize,
    spp: u32,
    seed: u64,
    sampler: Sampler,
    estimator: DirectEstimator,
) -> RenderSettings {
    RenderSettings {
        width: w,
        height: h,
        samples: spp,
        threads,
        seed,
        sampler,
        shading: Shading::Path(PathSettings {
            estimator,
            max_bounces: MAX_BOUNCES,
            light_samples: 1,
            ..PathSettings::default()
        }),
        ..RenderSettings::default()
    }
}

/// Measures every point on native, `threads` threads.
pub fn measure(dir: &Path, quick: bool, threads: usize) -> Result<SamplerStudy, String> {
    let budget = SamplerBudget::new(quick);
    let mut scenes: Vec<(String, Scene)> = Vec::new();
    for rel in SCENES {
        scenes.push((rel.to_string(), super::load(dir, rel)?));
    }
    scenes.push((GLOSSY.name.to_string(), super::load_builtin(GLOSSY)?));
    let mut points = Vec::new();
    for (name, scene) in &scenes {
        let accel = BackendConfig::NATIVE
            .with_threads(threads)
            .build(scene)
            .map_err(|e| e.to_string())?;
        for (label, estimator) in ESTIMATORS {
            let reference = render(
                scene,
                &accel,
                &settings(
                    budget.resolution,
                    threads,
                    budget.reference_spp,
                    424_242,
                    Sampler::Independent,
                    estimator,
                ),
                &Silent,
            )
            .film;
            for &spp in &budget.spp {
                // The two samplers' renders alternate, so drift in the
                // machine's speed reaches both alike.
                let mut sums = [(0.0, 0.0); 2];
                for seed in 0..SEEDS {
                    for (k, sampler) in Sampler::ALL.iter().enumerate() {
                        let s = settings(
                            budget.resolution,
                            threads,
                            spp,
                            u64::from(seed) + 1,
                            *sampler,
                            estimator,
                        );
                        let out = render(scene, &accel, &s, &Silent);
                        sums[k].0 += rel_mse(&out.film, &reference);
                        sums[k].1 += out.seconds;
                    }
                }
                for (k, sampler) in Sampler::ALL.iter().enumerate() {
                    let n = f64::from(SEEDS);
                    points.push(SamplerPoint {
                        scene: name.clone(),
                        sampler: *sampler,
                        estimator: label,
                        spp,
                        rel_mse: sums[k].0 / n,
                        seconds: sums[k].1 / n,
                    });
                }
            }
        }
    }
    Ok(SamplerStudy {
        threads,
        budget,
        points,
    })
}

impl SamplerStudy {
    /// The point of `sampler` matching `p` otherwise.
    fn twin(&self, p: &SamplerPoint, sampler: Sampler) -> Option<&SamplerPoint> {
        self.points.iter().find(|q| {
            q.sampler == sampler
                && q.scene == p.scene
                && q.estimator == p.estimator
                && q.spp == p.spp
        })
    }
}

/// Every point, with Sobol's gain over independent at equal samples and
/// at equal time (the efficiency ratio).
pub fn table(study: &SamplerStudy) -> Table {
    let mut t = Table::new([
        ("scene", "scene"),
        ("estimator", "estimator"),
        ("spp", "spp"),
        ("sampler", "sampler"),
        ("rel_mse", "relMSE"),
        ("seconds", "seconds"),
        ("efficiency", "efficiency"),
        ("gain_equal_spp", "independent / this relMSE"),
        ("gain_equal_time", "this / independent efficiency"),
    ]);
    for p in &study.points {
        let twin = study.twin(p, Sampler::Independent);
        t.row(vec![
            Cell::Text(p.scene.clone()),
            Cell::Text(p.estimator.into()),
            Cell::Number(f64::from(p.spp), 0),
            Cell::Text(p.sampler.name().into()),
            Cell::Number(p.rel_mse, 6),
            Cell::Number(p.seconds, 3),
            Cell::Number(p.efficiency(), 0),
            twin.map_or(Cell::Empty, |q| Cell::Ratio(q.rel_mse / p.rel_mse)),
            twin.map_or(Cell::Empty, |q| {
                Cell::Ratio(p.efficiency() / q.efficiency())
            }),
        ]);
    }
    t
}

/// The section: one sentence, then the table and how to reproduce it.
pub fn markdown(study: &SamplerStudy) -> String {
    // Each Sobol point with its gain, the worst first.
    let mut gains: Vec<(&SamplerPoint, f64)> = study
        .points
        .iter()
        .filter(|p| p.sampler == Sampler::Sobol)
        .filter_map(|p| Some((p, study.twin(p, Sampler::Independent)?.rel_mse / p.rel_mse)))
        .collect();
    gains.sort_by(|a, b| a.1.total_cmp(&b.1));
    let summary = match (gains.first(), gains.last()) {
        (Some((worst, lo)), Some((best, hi))) => format!(
            "independent numbers' relative MSE over Sobol's at equal samples (above 1: Sobol is better) runs from {lo:.2}x at worst ({}, {}, {} spp) to {hi:.2}x ({}, {}, {} spp)",
            worst.scene, worst.estimator, worst.spp, best.scene, best.estimator, best.spp
        ),
        _ => "no points".into(),
    };
    let (w, h) = study.budget.resolution;
    format!(
        "## Samplers: error at equal samples and at equal time\n\nThe Sobol sampler (`--sampler sobol`: every dimension pair from an Owen-scrambled Sobol sequence per pixel) against independent numbers (`--sampler independent`: R2 pixel positions, PCG32 elsewhere): {summary}. Native, {w}x{h}, {} bounces, one light sample, {} threads, the mean of {SEEDS} seeds per point, against a {}-spp reference rendered with independent numbers on another seed; efficiency is 1 / (relMSE x seconds). Reproduce: `hybrid report` (this section), or any point with `hybrid render SCENE -r {w} {h} -s N -m {} --sampler sobol|independent`.\n\n{}\n",
        MAX_BOUNCES,
        study.threads,
        study.budget.reference_spp,
        MAX_BOUNCES,
        table(study).markdown()
    )
}
