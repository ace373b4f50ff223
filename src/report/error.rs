//! Speed against error: RMSE against a high-sample reference as a function
//! of render time on the project's glossy scene, per compared backend and
//! direct-lighting estimator (hemisphere, light sampling, MIS, and
//! adaptive sampling with MIS), and each estimator's RMSE at one common
//! render time.

use std::path::Path;

use super::budget::Budget;
use super::plot::{loglog, loglog_slope, Series};
use super::table::{Cell, Table};
use crate::accel::config::compared;
use crate::accel::Accel;
use crate::render::film::Film;
use crate::render::integrator::{DirectEstimator, PathSettings, Shading};
use crate::render::{render, Adaptive, RenderSettings, Silent};
use crate::scene::builtin::GLOSSY;
use crate::scene::{NormalMode, Scene};

/// One render of the study.
pub struct ErrorPoint {
    pub seconds: f64,
    pub rmse: f64,
    /// Mean samples per pixel.
    pub spp: f64,
}

/// One line of the plot.
pub struct ErrorSeries {
    pub backend: &'static str,
    /// The estimator's label; `adaptive` marks adaptive sampling.
    pub estimator: &'static str,
    pub adaptive: bool,
    pub points: Vec<ErrorPoint>,
}

impl ErrorSeries {
    pub fn name(&self) -> String {
        if self.adaptive {
            format!("{}, adaptive ({})", self.backend, self.estimator)
        } else {
            format!("{}, {}", self.backend, self.estimator)
        }
    }

    /// RMSE at `seconds`, interpolated on log-log axes between the two
    /// renders around it; `None` outside the series' range of times.
    pub fn rmse_at(&self, seconds: f64) -> Option<f64> {
        let mut points: Vec<(f64, f64)> = self.points.iter().map(|p| (p.seconds, p.rmse)).collect();
        points.sort_by(|a, b| a.0.total_cmp(&b.0));
        points.windows(2).find_map(|w| {
            let ((t0, e0), (t1, e1)) = (w[0], w[1]);
            if !(t0..=t1).contains(&seconds) || e0 <= 0.0 || e1 <= 0.0 {
                return None;
            }
            if t1 <= t0 {
                return Some(e0.min(e1));
            }
            let f = (seconds / t0).ln() / (t1 / t0).ln();
            Some((e0.ln() + f * (e1 / e0).ln()).exp())
        })
    }

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

/// The estimators of the study, each at uniform samples: the course's two
/// and multiple importance sampling (the gallery shows the same three).
pub const ESTIMATORS: [(&str, DirectEstimator); 3] = [
    ("hemisphere", DirectEstimator::Hemisphere),
    ("light sampling", DirectEstimator::LightSampling),
    ("MIS", DirectEstimator::Mis),
];
/// Adaptive sampling's tolerances, one render each.
const ADAPTIVE_TOLERANCES: [f32; 5] = [0.4, 0.2, 0.1, 0.05, 0.025];
/// Adaptive sampling's batch.
const ADAPTIVE_BATCH: u32 = 8;
/// Bounces of every render of the study: the glossy spheres reflect the
/// walls, which are lit directly and by one more bounce.
const MAX_BOUNCES: u32 = 3;

pub struct ErrorStudy {
    pub scene: &'static str,
    pub max_bounces: u32,
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
            max_bounces: MAX_BOUNCES,
            light_samples: 1,
            ..PathSettings::default()
        }),
        adaptive,
        ..RenderSettings::default()
    }
}

pub(crate) fn rmse(film: &Film, reference: &Film) -> f64 {
    let sum: f64 = film
        .pixels
        .iter()
        .zip(&reference.pixels)
        .map(|(a, b)| (*a - *b).length_squared() as f64 / 3.0)
        .sum();
    (sum / film.pixels.len() as f64).sqrt()
}

/// Renders of a point: at few samples one render's RMSE is a poor
/// estimate of the estimator's (a heavy-tailed estimator's render usually
/// misses its rare bright samples and reads low), so points below
/// [`SEEDED_SAMPLES`] spp average over enough seeds to make that many
/// samples per pixel in all, at most [`MAX_SEEDS`].
const SEEDED_SAMPLES: u32 = 64;
const MAX_SEEDS: u32 = 16;

/// One point of a series: the root mean square of the RMSE over seeds
/// (the expected squared error's root) and the mean time of a render.
fn point<A: Accel>(scene: &Scene, accel: &A, s: &RenderSettings, reference: &Film) -> ErrorPoint {
    let seeds = (SEEDED_SAMPLES / s.samples.max(1)).clamp(1, MAX_SEEDS);
    let (mut seconds, mut squared, mut spp) = (0.0, 0.0, 0.0);
    for k in 0..seeds {
        let seeded = RenderSettings {
            seed: s.seed + u64::from(k),
            ..s.clone()
        };
        let out = render(scene, accel, &seeded, &Silent);
        seconds += out.seconds;
        squared += rmse(&out.film, reference).powi(2);
        spp +=
            out.film.samples.iter().map(|&n| n as f64).sum::<f64>() / out.film.samples.len() as f64;
    }
    let n = f64::from(seeds);
    ErrorPoint {
        seconds: seconds / n,
        rmse: (squared / n).sqrt(),
        spp: spp / n,
    }
}

pub fn measure(budget: &Budget, threads: usize) -> Result<ErrorStudy, String> {
    let scene = GLOSSY.load(NormalMode::Smooth).map_err(|e| e.to_string())?;
    let res = budget.error_resolution;
    let compared = compared();
    let backends = compared
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
            DirectEstimator::Mis,
            None,
        ),
        &Silent,
    )
    .film;
    let mut series = Vec::new();
    for (config, accel) in compared.iter().zip(&backends) {
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
                backend,
                estimator: label,
                adaptive: false,
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
                    DirectEstimator::Mis,
                    Some(adaptive),
                );
                point(&scene, accel, &s, &reference)
            })
            .collect();
        series.push(ErrorSeries {
            backend,
            estimator: "MIS",
            adaptive: true,
            points,
        });
    }
    Ok(ErrorStudy {
        scene: GLOSSY.name,
        max_bounces: MAX_BOUNCES,
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
                Cell::Text(s.name()),
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
        table.row(vec![Cell::Text(s.name()), Cell::Number(s.slope(), 2)]);
    }
    table
}

impl ErrorStudy {
    /// The common render time of the equal-time comparison: the longest
    /// time every uniform-sample series reached.
    pub fn equal_time(&self) -> Option<f64> {
        self.series
            .iter()
            .filter(|s| !s.adaptive)
            .map(|s| s.points.iter().map(|p| p.seconds).fold(0.0, f64::max))
            .min_by(f64::total_cmp)
    }

    /// RMSE at [`ErrorStudy::equal_time`] of `backend`'s uniform-sample
    /// series with `estimator`.
    pub fn rmse_at_equal_time(&self, backend: &str, estimator: &str) -> Option<f64> {
        let t = self.equal_time()?;
        self.series
            .iter()
            .find(|s| !s.adaptive && s.backend == backend && s.estimator == estimator)?
            .rmse_at(t)
    }
}

/// Each series' RMSE at the common time, and its ratio to light sampling
/// on the same backend (below 1: lower error than light sampling).
pub fn equal_time_table(study: &ErrorStudy) -> Table {
    let mut table = Table::new([
        ("series", "series"),
        ("rmse", "RMSE at equal time"),
        ("over_light", "RMSE / light sampling's (< 1: less error)"),
    ]);
    let Some(t) = study.equal_time() else {
        return table;
    };
    for s in &study.series {
        let rmse = s.rmse_at(t);
        let light = study.rmse_at_equal_time(s.backend, "light sampling");
        table.row(vec![
            Cell::Text(s.name()),
            rmse.map_or(Cell::Empty, |e| Cell::Number(e, 4)),
            match (rmse, light) {
                (Some(e), Some(l)) => Cell::Ratio(e / l),
                _ => Cell::Empty,
            },
        ]);
    }
    table
}

/// The headline's lines on error: MIS against the course's estimators at
/// equal time, per backend.
pub fn headline(study: &ErrorStudy) -> String {
    let Some(t) = study.equal_time() else {
        return String::new();
    };
    let mut md = format!(
        "Error at equal time ({t:.2} s per render, `{}`, {} bounces, {}), RMSE against the reference:\n\n",
        study.scene,
        study.max_bounces,
        super::counted(study.threads, "thread")
    );
    for backend in compared().iter().map(|c| c.kind()) {
        let at = |e| study.rmse_at_equal_time(backend, e);
        if let (Some(m), Some(l), Some(h)) = (at("MIS"), at("light sampling"), at("hemisphere")) {
            md += &format!(
                "- {backend}: MIS {m:.4}, light sampling {l:.4}, hemisphere {h:.4}: MIS has {:.2}x light sampling's error ({:.0}x less time for the same error) and {:.2}x hemisphere's.\n",
                m / l,
                (l / m).powi(2),
                m / h
            );
        }
    }
    md + "\n"
}

/// Draws the study's plot into `out/speed_vs_error.svg`.
pub fn plot(study: &ErrorStudy, out: &Path) -> Result<(), String> {
    // One colour per backend, one line and marker per estimator (adaptive
    // sampling counted as an estimator of its own).
    fn index_of<K: PartialEq>(list: &mut Vec<K>, key: K) -> usize {
        list.iter().position(|k| *k == key).unwrap_or_else(|| {
            list.push(key);
            list.len() - 1
        })
    }
    let mut backends: Vec<&str> = Vec::new();
    let mut estimators: Vec<(&str, bool)> = Vec::new();
    let series: Vec<Series> = study
        .series
        .iter()
        .map(|s| Series {
            name: s.name(),
            points: s.points.iter().map(|p| (p.seconds, p.rmse)).collect(),
            colour: index_of(&mut backends, s.backend),
            style: index_of(&mut estimators, (s.estimator, s.adaptive)),
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
    let equal = match study.equal_time() {
        Some(t) => format!(
            "At equal time ({t:.2} s, the longest every uniform series reached; log-log interpolation between the renders around it):\n\n{}\n",
            equal_time_table(study).markdown()
        ),
        None => String::new(),
    };
    format!(
        "## Speed against error\n\n`{}` (the project's glossy scene: rough metal spheres of Beckmann alpha 0.025 and 0.25, a mirror sphere, an area light) at {w}x{h}, {} bounces, one light sample, {}; error is the RMSE of linear radiance against a reference rendered once with {} spp (native, MIS, another seed). Adaptive sampling (MIS) uses batches of {ADAPTIVE_BATCH} up to {} spp with tolerances 0.4 .. 0.025. Each point is the root mean square of the RMSE of renders of different seeds (enough for {SEEDED_SAMPLES} samples per pixel in all, at most {MAX_SEEDS} renders) at the mean time of one: a single render at a few samples usually misses a heavy-tailed estimator's rare bright samples and reads low. {}\n\n![speed against error](speed_vs_error.svg)\n\n{equal}\n{}\n{}\nA Monte Carlo estimator's RMSE falls as time^-1/2 (slope -0.5); at equal time the lower line is the better estimator, and an error ratio r is a time ratio r^2. The two backends trace the same paths, so their lines differ only by trace speed.\n\n",
        study.scene,
        study.max_bounces,
        super::counted(study.threads, "thread"),
        study.reference_spp,
        study.adaptive_cap,
        rising_text(study),
        slopes_table(study).markdown(),
        points_table(study).markdown(),
    )
}

/// The series whose error rises somewhere along the time axis (a point
/// more than 10% below a later one), named with why.
fn rising_text(study: &ErrorStudy) -> String {
    let rises = |s: &&ErrorSeries| {
        s.points.iter().enumerate().any(|(i, p)| {
            s.points[i + 1..]
                .iter()
                .any(|later| p.rmse < 0.9 * later.rmse)
        })
    };
    let (hemisphere, other): (Vec<&ErrorSeries>, Vec<&ErrorSeries>) = study
        .series
        .iter()
        .filter(rises)
        .partition(|s| s.estimator == "hemisphere");
    let names = |v: &[&ErrorSeries]| v.iter().map(|s| s.name()).collect::<Vec<_>>().join(", ");
    let mut out = Vec::new();
    if !hemisphere.is_empty() {
        out.push(format!(
            "Even so, an early point lies more than 10% below a later one in {}: hemisphere sampling finds the light's reflection in the near-mirror sphere on rare samples only, so its error is heavy-tailed, and short renders, which rarely catch those samples, read low until renders are long enough to.",
            names(&hemisphere)
        ));
    }
    if !other.is_empty() {
        out.push(format!(
            "An early point lies more than 10% below a later one in {} too (the spread of the few renders behind a point).",
            names(&other)
        ));
    }
    if out.is_empty() {
        out.push("Every series' error falls from its first point on.".into());
    }
    out.join(" ")
}
