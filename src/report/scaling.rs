//! How cost grows with scene size, on meshes like users' meshes: a scanned
//! mesh (sky/bunny.dae) subdivided to millions of triangles, and clouds of
//! copies of it; builds and one-thread traces of the compared backends,
//! with time per ray fitted as a power of n and as logarithmic growth.
//!
//! The generated bumpy plates this section measured before made both
//! backends' time per ray grow as n^0.40: every ray met a near-grazing
//! surface whose triangles shrank with n, so the workload, not the trees,
//! drew that curve.

use std::path::Path;

use glam::{Mat3, Vec3};

use super::budget::{Budget, SCANNED};
use super::plot::{line_fit, loglog, loglog_slope, Series};
use super::table::{Cell, Table};
use crate::accel::config::compared;
use crate::accel::BackendConfig;
use crate::geom::sampling::{uniform_sphere, Rng};
use crate::geom::Ray;
use crate::measure::{mrays_interleaved, time_repeats, Measured, Query};
use crate::scene::generate::{subdivide, SceneBuilder};
use crate::scene::{Material, NormalMode, Scene};

/// The two families of meshes, in the order of the rows.
pub const FAMILIES: [&str; 2] = ["bunny subdivided", "cloud of bunnies"];

/// One mesh: build time and one-thread throughput per compared backend.
pub struct ScalingRow {
    /// Which of [`FAMILIES`].
    pub family: &'static str,
    pub triangles: usize,
    pub build: Vec<Measured>,
    pub mrays: Vec<Measured>,
}

pub struct Scaling {
    /// The compared backends, native first: the order of every vector.
    pub compared: Vec<BackendConfig>,
    pub rows: Vec<ScalingRow>,
}

/// The scanned mesh's triangles, transforms applied.
type Mesh = (Vec<Vec3>, Vec<[u32; 3]>);

fn scanned(dir: &Path) -> Result<Mesh, String> {
    let scene = super::load(dir, SCANNED)?;
    Ok((scene.mesh.positions.clone(), scene.mesh.indices.clone()))
}

fn scene_of(name: &str, meshes: &[Mesh]) -> Scene {
    let mut b = SceneBuilder::new(name);
    let m = b.material(Material::DEFAULT);
    for (positions, tris) in meshes {
        b.mesh(positions, tris, m);
    }
    b.finish(NormalMode::Flat)
}

/// The scanned mesh split `levels` times (4^levels times the triangles,
/// the same surface).
fn subdivided(mesh: &Mesh, levels: u32) -> Scene {
    let mut out = mesh.clone();
    for _ in 0..levels {
        out = subdivide(&out.0, &out.1);
    }
    scene_of(&format!("{SCANNED} subdivided {levels}x"), &[out])
}

/// `count` copies of the scanned mesh, each turned about +Y, scaled by
/// 0.4 to 1 and placed at random in a cube that grows with the count (so
/// copies overlap a little, as a scanned scene's objects do). The same
/// count gives the same scene.
fn cloud(mesh: &Mesh, count: u32) -> Scene {
    let mut rng = Rng::new(u64::from(count), 31);
    let (lo, hi) = mesh.0.iter().fold((Vec3::MAX, Vec3::MIN), |(lo, hi), p| {
        (lo.min(*p), hi.max(*p))
    });
    let (centre, size) = ((lo + hi) * 0.5, (hi - lo).max_element());
    let side = size * 1.2 * (count as f32).cbrt();
    let copies: Vec<Mesh> = (0..count)
        .map(|_| {
            let turn = Mat3::from_rotation_y(rng.next_f32() * std::f32::consts::TAU);
            let scale = 0.4 + 0.6 * rng.next_f32();
            let at = Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) * side;
            let positions = mesh
                .0
                .iter()
                .map(|p| at + turn * ((*p - centre) * scale))
                .collect();
            (positions, mesh.1.clone())
        })
        .collect();
    scene_of(&format!("{count} copies of {SCANNED}"), &copies)
}

/// Rays from a sphere around the scene towards random points in the
/// middle half of its bounds: about every ray meets the mesh, at every
/// size, from every side.
fn rays_into(scene: &Scene, n: usize) -> Vec<Ray> {
    let b = scene.bounds();
    let (centre, extent) = ((b.min + b.max) * 0.5, b.max - b.min);
    let radius = extent.length();
    let mut rng = Rng::new(77, 9);
    (0..n)
        .map(|_| {
            let (u, v) = rng.next_2d();
            let origin = centre + uniform_sphere(u, v) * radius;
            let target = centre
                + (Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32()) - 0.5) * extent * 0.5;
            Ray::new(origin, (target - origin).normalize())
        })
        .collect()
}

pub fn measure(dir: &Path, budget: &Budget) -> Result<Scaling, String> {
    let mesh = scanned(dir)?;
    let compared = compared();
    let mut rows = Vec::new();
    let scenes = (0..=budget.scaling_subdivisions)
        .map(|levels| (FAMILIES[0], subdivided(&mesh, levels)))
        .chain(
            budget
                .scaling_clouds
                .iter()
                .map(|&count| (FAMILIES[1], cloud(&mesh, count))),
        );
    for (family, scene) in scenes {
        let set = rays_into(&scene, budget.scaling_rays);
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
            family,
            triangles: scene.triangle_count(),
            build,
            mrays,
        });
    }
    Ok(Scaling { compared, rows })
}

impl Scaling {
    fn family<'a>(&'a self, family: &'a str) -> impl Iterator<Item = &'a ScalingRow> {
        self.rows.iter().filter(move |r| r.family == family)
    }

    /// The log-log slope of backend `i`'s build time over `family`.
    fn build_slope(&self, family: &str, i: usize) -> f64 {
        let points: Vec<(f64, f64)> = self
            .family(family)
            .map(|r| (r.triangles as f64, r.build[i].median * 1e3))
            .collect();
        loglog_slope(&points)
    }
}

pub fn table(s: &Scaling) -> Table {
    let labels: Vec<String> = s.compared.iter().map(BackendConfig::label).collect();
    let mut columns = vec![
        ("mesh".to_string(), "mesh".to_string()),
        ("triangles".to_string(), "triangles".to_string()),
    ];
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
        let mut cells = vec![
            Cell::Text(r.family.to_string()),
            Cell::Count(r.triangles as u64),
        ];
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

/// Backend `i`'s time per ray over `family` fitted two ways: as a power
/// of n (`(slope, R²)` of ln t against ln n) and as logarithmic growth
/// (`(ns per doubling of n, R²)` of t against log2 n), a BVH's ideal.
pub fn trace_fits(s: &Scaling, family: &str, i: usize) -> ((f64, f64), (f64, f64)) {
    let points = |f: fn(f64) -> f64, g: fn(f64) -> f64| -> Vec<(f64, f64)> {
        s.family(family)
            .map(|r| (f(r.triangles as f64), g(1e3 / r.mrays[i].median)))
            .collect()
    };
    let (p, _, p2) = line_fit(&points(f64::ln, f64::ln));
    let (l, _, l2) = line_fit(&points(f64::log2, |t| t));
    ((p, p2), (l, l2))
}

pub fn slopes_table(s: &Scaling) -> Table {
    let mut table = Table::new([
        ("mesh", "mesh"),
        ("backend", "backend"),
        ("build", "build time ∝ n^"),
        ("ns_per_ray", "time per ray ∝ n^"),
        ("power_r2", "R², power fit"),
        ("ns_per_doubling", "ns per ray per doubling of n (log fit)"),
        ("log_r2", "R², log fit"),
    ]);
    for family in FAMILIES {
        for (i, c) in s.compared.iter().enumerate() {
            let ((p, p2), (l, l2)) = trace_fits(s, family, i);
            table.row(vec![
                Cell::Text(family.to_string()),
                Cell::Text(c.label()),
                Cell::Number(s.build_slope(family, i), 2),
                Cell::Number(p, 2),
                Cell::Number(p2, 3),
                Cell::Number(l, 1),
                Cell::Number(l2, 3),
            ]);
        }
    }
    table
}

/// What the fits say, in words, per family: the measured exponent, and
/// which of the two forms describes native's time per ray better.
fn growth_text(s: &Scaling) -> String {
    let mut out = Vec::new();
    for family in FAMILIES {
        if s.family(family).count() < 3 {
            continue;
        }
        let ((p, p2), (l, l2)) = trace_fits(s, family, 0);
        let better = if l2 >= p2 {
            "logarithmic growth, a BVH's ideal, fits it at least as well as a power"
        } else {
            "a power of n fits it better than logarithmic growth, a BVH's ideal"
        };
        out.push(format!(
            "On the {family}, native's time per ray grows as n^{p:.2} (R² {p2:.3}), or by {l:.1} ns per doubling of n (R² {l2:.3}): {better}."
        ));
    }
    out.push("A build is O(n log n), a slope a little over 1.".into());
    out.join(" ")
}

/// Draws `scaling_build.svg` and `scaling_trace.svg` into `out`: one line
/// per backend and family.
pub fn plot(s: &Scaling, out: &Path) -> Result<(), String> {
    let lines = |value: &dyn Fn(&ScalingRow, usize) -> f64| -> Vec<Series> {
        FAMILIES
            .iter()
            .enumerate()
            .flat_map(|(f, family)| {
                s.compared.iter().enumerate().map(move |(i, c)| {
                    let points: Vec<(f64, f64)> = s
                        .family(family)
                        .map(|r| (r.triangles as f64, value(r, i)))
                        .collect();
                    Series {
                        name: format!(
                            "{}, {family} (slope {:.2})",
                            c.label(),
                            loglog_slope(&points)
                        ),
                        points,
                        colour: i,
                        style: f,
                    }
                })
            })
            .collect()
    };
    loglog(
        &out.join("scaling_build.svg"),
        "build time against triangles",
        "triangles",
        "build time (ms)",
        &lines(&|r, i| r.build[i].median * 1e3),
    )?;
    loglog(
        &out.join("scaling_trace.svg"),
        "trace time per ray against triangles",
        "triangles",
        "ns per ray (1 thread)",
        &lines(&|r, i| 1e3 / r.mrays[i].median),
    )
}

pub fn markdown(s: &Scaling) -> String {
    format!(
        "## How cost grows with scene size\n\nThe scanned `{SCANNED}` split into four triangles per triangle, again and again (the same surface, ever finer), and clouds of turned and scaled copies of it; rays from a sphere around each scene into the middle of its bounds. Builds on all threads (median of repeats), traces on one thread with the same rays.\n\n{}\n{}\n{}\n\n![build scaling](scaling_build.svg)\n![trace scaling](scaling_trace.svg)\n\n",
        table(s).markdown(),
        slopes_table(s).markdown(),
        growth_text(s)
    )
}
