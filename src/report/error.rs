//! Speed against error: RMSE against a high-sample reference as a function
//! of render time, per compared backend and estimator (hemisphere, light
//! sampling, adaptive).

use std::path::Path;

use super::budget::{Budget, ERROR_SCENE};
use super::load;
use super::plot::{loglog, loglog_slope, Series};
use super::table::{Cell, Table};
use crate::accel::config::COMPARED;
use crate::accel::Accel;
use crate::render::film::Film;
use crate::render::integrator::{DirectEstimator, PathSettings, Shading};
use crate::render::{render, Adaptive, RenderSettings, Silent};
use crate::scene::Scene;

/// One render of the study.
pub struct ErrorPoint {
    pub seconds: f64,
    pub rmse: f64,
    /// Mean samples per pixel.
    pub spp: f64,
}

/// One line of the plot.
pub struct ErrorSeries {
    pub name: String,
    pub points: Vec<ErrorPoint>,
}

impl ErrorSeries {
    /// Slope of log RMSE against log time.
    pub fn slope(&self) -> f64 {
        loglog_slope(
            &self
                .points
                .iter()
                .map(|p| (p.seconds, p.rmse))
                .collect::<Vec<_>>(),
        )
    }
}

/// The estimators of the study: the course's two, each at uniform samples.
const ESTIMATORS: [(&str, DirectEstimator); 2] = [
    ("hemisphere", DirectEstimator::Hemisphere),
    ("light sampling", DirectEstimator::LightSampling),
];
/// Adaptive sampling's tolerances, one render each.
const ADAPTIVE_TOLERANCES: [f32; 5] = [0.4, 0.2, 0.1, 0.05, 0.025];
/// Adaptive sampling's batch.
const ADAPTIVE_BATCH: u32 = 8;

pub struct ErrorStudy {
    pub scene: &'static str,
    pub resolution: (u32, u32),
    pub threads: usize,
    pub reference_spp: u32,
    pub adaptive_cap: u32,
    pub series: Vec<ErrorSeries>,
}

fn settings(
    (w, h): (u32, u32),
    threads: usize,
    spp: u32,
    seed: u64,
    estimator: DirectEstimator,
    adaptive: Option<Adaptive>,
) -> RenderSettings {
    RenderSettings {
        width: w,
        height: h,
        samples: spp,
        threads,
        seed,
        shading: Shading::Path(PathSettings {
            estimator,
            max_bounces: 3,
            light_samples: 1,
            ..PathSettings::default()
        }),
        adaptive,
        ..RenderSettings::default()
    }
}

fn rmse(film: &Film, reference: &Film) -> f64 {
    let sum: f64 = film
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(a, b)| (*a - *b).length_squared() as f64 / 3.0)
        .sum();
    (sum / film.pixels.len() as f64).sqrt()
}

fn point<A: Accel>(scene: &Scene, accel: &A, s: &RenderSettings, reference: &Film) -> ErrorPoint {
    let out = render(scene, accel, s, &Silent);
    ErrorPoint {
        seconds: out.seconds,
        rmse: rmse(&out.film, reference),
        spp: out.film.samples.iter().map(|&n| n as f64).sum::<f64>()
            / out.film.samples.len() as f64,
    }
}

pub fn measure(dir: &Path, budget: &Budget, threads: usize) -> Result<ErrorStudy, String> {
    let scene = load(dir, ERROR_SCENE)?;
    let res = budget.error_resolution;
    let backends = COMPARED
        .iter()
        .map(|c| c.with_threads(threads).build(&scene))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let reference = render(
        &scene,
        &backends[0],
        &settings(
            res,
            threads,
            budget.reference_spp,
            987_654,
            DirectEstimator::LightSampling,
            None,
        ),
        &Silent,
    )
    .film;
    let mut series = Vec::new();
    for (config, accel) in COMPARED.iter().zip(&backends) {
        let backend = config.kind();
        for (label, estimator) in ESTIMATORS {
            let points = budget
                .error_spp
                .iter()
                .map(|&spp| {
                    let s = settings(res, threads, spp, 1, estimator, None);
                    point(&scene, accel, &s, &reference)
                })
                .collect();
            series.push(ErrorSeries {
                name: format!("{backend}, {label}"),
                points,
            });
        }
        let points = ADAPTIVE_TOLERANCES
            .iter()
            .map(|&tolerance| {
                let adaptive = Adaptive {
                    batch: ADAPTIVE_BATCH,
                    tolerance,
                };
                let s = settings(
                    res,
                    threads,
                    budget.adaptive_cap,
                    1,
                    DirectEstimator::LightSampling,
                    Some(adaptive),
                );
                point(&scene, accel, &s, &reference)
            })
            .collect();
        series.push(ErrorSeries {
            name: format!("{backend}, adaptive (light sampling)"),
            points,
        });
    }
    Ok(ErrorStudy {
        scene: ERROR_SCENE,
        resolution: res,
        threads,
        reference_spp: budget.reference_spp,
        adaptive_cap: budget.adaptive_cap,
        series,
    })
}

/// Every render of the study as rows.
pub fn points_table(study: &ErrorStudy) -> Table {
    let mut table = Table::new([
        ("series", "series"),
        ("spp", "spp"),
        ("seconds", "seconds"),
        ("rmse", "RMSE"),
    ]);
    for s in &study.series {
        for p in &s.points {
            table.row(vec![
                Cell::Text(s.name.clone()),
                Cell::Number(p.spp, 1),
                Cell::Number(p.seconds, 4),
                Cell::Number(p.rmse, 4),
            ]);
        }
    }
    table
}

/// One row per series: its fitted slope.
pub fn slopes_table(study: &ErrorStudy) -> Table {
    let mut table = Table::new([
        ("series", "series"),
        ("slope", "slope of log RMSE / log time"),
    ]);
    for s in &study.series {
        table.row(vec![Cell::Text(s.name.clone()), Cell::Number(s.slope(), 2)]);
    }
    table
}

/// Draws the study's plot into `out/speed_vs_error.svg`.
pub fn plot(study: &ErrorStudy, out: &Path) -> Result<(), String> {
    let series: Vec<Series> = study
        .series
        .iter()
        .map(|s| Series {
            name: s.name.clone(),
            points: s.points.iter().map(|p| (p.seconds, p.rmse)).collect(),
        })
        .collect();
    loglog(
        &out.join("speed_vs_error.svg"),
        &format!("{}: RMSE against render time", study.scene),
        "render time (s)",
        "RMSE vs reference",
        &series,
    )
}

pub fn markdown(study: &ErrorStudy) -> String {
    let (w, h) = study.resolution;
    format!(
        "## Speed against error\n\n`{}` at {w}x{h}, 3 bounces, one light sample, {} threads; error is the RMSE of linear radiance against a reference rendered once with {} spp (native, light sampling, another seed). Adaptive sampling uses batches of {ADAPTIVE_BATCH} up to {} spp with tolerances 0.4 .. 0.025. Each point is one render.\n\n![speed against error](speed_vs_error.svg)\n\n{}\n{}\nA Monte Carlo estimator's RMSE falls as time^-1/2 (slope -0.5); at equal time the lower line is the better estimator. The two backends trace the same paths, so their lines differ only by trace speed.\n\n",
        study.scene,
        study.threads,
        study.reference_spp,
        study.adaptive_cap,
        slopes_table(study).markdown(),
        points_table(study).markdown(),
    )
}
