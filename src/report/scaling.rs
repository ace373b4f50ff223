//! How cost grows with scene size: builds and traces of the compared
//! backends on generated bumpy plates of 10^3 to 2·10^6 triangles, with
//! fitted log-log slopes.

use std::path::Path;

use glam::Vec3;

use super::budget::Budget;
use super::measure::{mrays_interleaved, time_repeats, Measured, Query};
use super::plot::{line_fit, loglog, loglog_slope, Series};
use super::table::{Cell, Table};
use crate::accel::config::compared;
use crate::accel::BackendConfig;
use crate::geom::sampling::Rng;
use crate::geom::Ray;
use crate::scene::generate::{plate, SceneBuilder};
use crate::scene::{Material, NormalMode, Scene};

/// One generated mesh: build time and one-thread throughput per compared
/// backend.
pub struct ScalingRow {
    pub triangles: usize,
    pub build: Vec<Measured>,
    pub mrays: Vec<Measured>,
}

pub struct Scaling {
    /// The compared backends, native first: the order of every vector.
    pub compared: Vec<BackendConfig>,
    pub rows: Vec<ScalingRow>,
    /// Fitted slopes: build time per compared backend, time per ray per
    /// compared backend.
    pub build_slopes: Vec<f64>,
    pub trace_slopes: Vec<f64>,
}

/// A bumpy square of about `triangles` triangles (a displaced grid, so the
/// BVH has real depth to sort out).
pub fn bumpy_plate(triangles: usize) -> Scene {
    let n = ((triangles as f64 / 2.0).sqrt().round() as u32).max(1);
    let (mut positions, tris) = plate(n);
    for p in &mut positions {
        p.z =
            0.05 * (p.x * 13.0).sin() * (p.y * 11.0).cos() + 0.02 * (p.x * 57.0 + p.y * 31.0).sin();
    }
    let mut b = SceneBuilder::new(&format!("bumpy plate, {} triangles", tris.len()));
    let m = b.material(Material::DEFAULT);
    b.mesh(&positions, &tris, m);
    b.finish(NormalMode::Flat)
}

/// Rays from above the plate towards random points on it.
fn plate_rays(n: usize) -> Vec<Ray> {
    let mut rng = Rng::new(77, 9);
    (0..n)
        .map(|_| {
            let target = Vec3::new(rng.next_f32() * 1.8 - 0.9, rng.next_f32() * 1.8 - 0.9, 0.0);
            let origin = Vec3::new(rng.next_f32() * 4.0 - 2.0, rng.next_f32() * 4.0 - 2.0, 3.0);
            Ray::new(origin, (target - origin).normalize())
        })
        .collect()
}

pub fn measure(budget: &Budget) -> Result<Scaling, String> {
    let set = plate_rays(budget.scaling_rays);
    let compared = compared();
    let mut rows = Vec::new();
    for &size in &budget.scaling {
        let scene = bumpy_plate(size);
        let repeats = if scene.triangle_count() >= 1_000_000 {
            2
        } else {
            budget.repeats.min(5)
        };
        let build = compared
            .iter()
            .map(|c| time_repeats(repeats, || c.build(&scene).map(|_| ())))
            .collect();
        let backends = compared
            .iter()
            .map(|c| c.build(&scene))
            .collect::<Result<Vec<_>, _>>()
            .map_err(|e| e.to_string())?;
        let all: Vec<_> = backends.iter().collect();
        let mrays = mrays_interleaved(&all, &set, Query::Closest, 1, repeats);
        rows.push(ScalingRow {
            triangles: scene.triangle_count(),
            build,
            mrays,
        });
    }
    let build_points = |i: usize| -> Vec<(f64, f64)> {
        rows.iter()
            .map(|r| (r.triangles as f64, r.build[i].median * 1e3))
            .collect()
    };
    let trace_points = |i: usize| -> Vec<(f64, f64)> {
        rows.iter()
            .map(|r| (r.triangles as f64, 1e3 / r.mrays[i].median))
            .collect()
    };
    let build_slopes = (0..compared.len())
        .map(|i| loglog_slope(&build_points(i)))
        .collect();
    let trace_slopes = (0..compared.len())
        .map(|i| loglog_slope(&trace_points(i)))
        .collect();
    Ok(Scaling {
        compared,
        rows,
        build_slopes,
        trace_slopes,
    })
}

pub fn table(s: &Scaling) -> Table {
    let labels: Vec<String> = s.compared.iter().map(BackendConfig::label).collect();
    let mut columns = vec![("triangles".to_string(), "triangles".to_string())];
    columns.extend(
        labels
            .iter()
            .map(|l| (format!("{l}_build_ms"), format!("{l} build ms"))),
    );
    columns.extend(
        labels
            .iter()
            .map(|l| (format!("{l}_mrays"), format!("{l} Mrays/s"))),
    );
    columns.extend(labels[1..].iter().map(|l| {
        (
            format!("native_over_{l}"),
            format!("native/{l} trace speed (> 1: native faster)"),
        )
    }));
    let mut table = Table::new(columns);
    for r in &s.rows {
        let mut cells = vec![Cell::Count(r.triangles as u64)];
        cells.extend(
            r.build
                .iter()
                .map(|b| Cell::Measured(Measured::millis(b), 2)),
        );
        cells.extend(r.mrays.iter().map(|m| Cell::Measured(*m, 2)));
        cells.extend((1..labels.len()).map(|j| {
            Cell::ratio_of(
                r.mrays[0].median / r.mrays[j].median,
                &[r.mrays[0], r.mrays[j]],
            )
        }));
        table.row(cells);
    }
    table
}

/// Backend `i`'s time per ray fitted two ways: as a power of n (`(slope,
/// R²)` of ln t against ln n) and as logarithmic growth (`(ns per
/// doubling of n, R²)` of t against log2 n), a BVH's ideal.
pub fn trace_fits(s: &Scaling, i: usize) -> ((f64, f64), (f64, f64)) {
    let points = |f: fn(f64) -> f64, g: fn(f64) -> f64| -> Vec<(f64, f64)> {
        s.rows
            .iter()
            .map(|r| (f(r.triangles as f64), g(1e3 / r.mrays[i].median)))
            .collect()
    };
    let (p, _, p2) = line_fit(&points(f64::ln, f64::ln));
    let (l, _, l2) = line_fit(&points(f64::log2, |t| t));
    ((p, p2), (l, l2))
}

pub fn slopes_table(s: &Scaling) -> Table {
    let mut table = Table::new([
        ("backend", "backend"),
        ("build", "build time ∝ n^"),
        ("ns_per_ray", "time per ray ∝ n^"),
        ("power_r2", "R², power fit"),
        ("ns_per_doubling", "ns per ray per doubling of n (log fit)"),
        ("log_r2", "R², log fit"),
    ]);
    for (i, c) in s.compared.iter().enumerate() {
        let ((_, p2), (l, l2)) = trace_fits(s, i);
        table.row(vec![
            Cell::Text(c.label()),
            Cell::Number(s.build_slopes[i], 2),
            Cell::Number(s.trace_slopes[i], 2),
            Cell::Number(p2, 3),
            Cell::Number(l, 1),
            Cell::Number(l2, 3),
        ]);
    }
    table
}

/// What the fits say, in words: the measured exponent, and which of the
/// two forms describes native's time per ray better.
fn growth_text(s: &Scaling) -> String {
    if s.rows.len() < 3 {
        return String::new();
    }
    let ((p, p2), (l, l2)) = trace_fits(s, 0);
    let better = if l2 >= p2 {
        "logarithmic growth, a BVH's ideal, fits it at least as well as a power"
    } else {
        "a power of n fits it better than logarithmic growth, a BVH's ideal: on these meshes the work per ray (triangles near each ray), not only the tree's depth, grows with n"
    };
    format!(
        "Native's time per ray grows as n^{p:.2} (R² {p2:.3}), or by {l:.1} ns per doubling of n (R² {l2:.3}): {better}. A build is O(n log n), a slope a little over 1."
    )
}

/// Draws `scaling_build.svg` and `scaling_trace.svg` into `out`.
pub fn plot(s: &Scaling, out: &Path) -> Result<(), String> {
    let lines = |value: &dyn Fn(&ScalingRow, usize) -> f64, slopes: &[f64]| -> Vec<Series> {
        s.compared
            .iter()
            .enumerate()
            .map(|(i, c)| Series {
                name: format!("{} (slope {:.2})", c.label(), slopes[i]),
                points: s
                    .rows
                    .iter()
                    .map(|r| (r.triangles as f64, value(r, i)))
                    .collect(),
            })
            .collect()
    };
    loglog(
        &out.join("scaling_build.svg"),
        "build time against triangles",
        "triangles",
        "build time (ms)",
        &lines(&|r, i| r.build[i].median * 1e3, &s.build_slopes),
    )?;
    loglog(
        &out.join("scaling_trace.svg"),
        "trace time per ray against triangles",
        "triangles",
        "ns per ray (1 thread)",
        &lines(&|r, i| 1e3 / r.mrays[i].median, &s.trace_slopes),
    )
}

pub fn markdown(s: &Scaling) -> String {
    format!(
        "## How cost grows with scene size\n\nGenerated bumpy plates; builds on all threads (median of repeats), traces on one thread with the same rays.\n\n{}\n{}\n{}\n\n![build scaling](scaling_build.svg)\n![trace scaling](scaling_trace.svg)\n\n",
        table(s).markdown(),
        slopes_table(s).markdown(),
        growth_text(s)
    )
}
