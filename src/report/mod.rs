//! The BVH performance comparison report: build and trace speed of the
//! backends side by side, speed against error, scaling with scene size,
//! and a gallery, measured in one run and written as `report.md`,
//! `report.json` and plots.
//!
//! - [`measure`]: medians of warmed-up repeats, ray throughput;
//! - [`plot`]: log-log SVG plots and fitted slopes;
//! - [`gallery`]: image grids;
//! - [`machine`]: what the figures were measured on.

pub mod gallery;
pub mod machine;
pub mod measure;
pub mod plot;

use std::path::{Path, PathBuf};
use std::time::Instant;

use glam::Vec3;
use serde_json::{json, Value};

use self::measure::{mrays, time_repeats, Query, Timing};
use self::plot::{loglog, loglog_slope, Series};
use crate::accel::brute::BruteForce;
use crate::accel::embree::{BuildQuality, EmbreeAccel, EmbreeOptions};
use crate::accel::native::bvh::BuildMethod;
use crate::accel::native::{NativeBvh, NativeOptions};
use crate::accel::{Accel, Ray};
use crate::parity::rays;
use crate::render::film::{Film, ToneMap};
use crate::render::integrator::{DirectEstimator, PathSettings, Shading};
use crate::render::{render, Adaptive, RenderSettings, Silent};
use crate::scene::generate::{plate, SceneBuilder};
use crate::scene::{collada, Material, NormalMode, Scene};

/// What to run and where to write it.
pub struct ReportOptions {
    pub scenes_dir: PathBuf,
    pub out_dir: PathBuf,
    /// Reduced sizes, repeats and resolutions: under two minutes on two cores.
    pub quick: bool,
    /// Threads for the "all threads" figures; 0 means all cores.
    pub threads: usize,
}

/// Sizes of the work, full or quick.
struct Budget {
    rays: usize,
    repeats: usize,
    frame: (u32, u32, u32),
    error_resolution: (u32, u32),
    reference_spp: u32,
    error_spp: Vec<u32>,
    adaptive_cap: u32,
    scaling: Vec<usize>,
    scaling_rays: usize,
    gallery: (u32, u32),
    gallery_spp: u32,
    spp_series: Vec<u32>,
    adaptive_gallery: (u32, f32, u32),
}

impl Budget {
    fn new(quick: bool) -> Budget {
        if quick {
            Budget {
                rays: 50_000,
                repeats: 3,
                frame: (120, 90, 4),
                error_resolution: (64, 48),
                reference_spp: 512,
                error_spp: vec![1, 2, 4, 8, 16, 32],
                adaptive_cap: 64,
                scaling: vec![1_000, 10_000, 100_000, 1_000_000],
                scaling_rays: 10_000,
                gallery: (80, 60),
                gallery_spp: 4,
                spp_series: vec![1, 4, 16, 64],
                adaptive_gallery: (16, 0.1, 256),
            }
        } else {
            Budget {
                rays: 200_000,
                repeats: 7,
                frame: (320, 240, 8),
                error_resolution: (160, 120),
                reference_spp: 8192,
                error_spp: vec![1, 2, 4, 8, 16, 32, 64, 128, 256],
                adaptive_cap: 1024,
                scaling: vec![1_000, 10_000, 100_000, 1_000_000, 2_000_000],
                scaling_rays: 100_000,
                gallery: (480, 360),
                gallery_spp: 64,
                spp_series: vec![1, 2, 4, 8, 16, 64, 256, 1024],
                adaptive_gallery: (64, 0.05, 2048),
            }
        }
    }
}

/// The three shared scenes of the per-scene tables.
pub const SCENES: [(&str, &str); 3] = [
    ("small", "sky/CBspheres_lambertian.dae"),
    ("medium", "sky/CBbunny.dae"),
    ("large", "meshedit/maxplanck.dae"),
];
/// Small scenes for the "with and without acceleration" table.
pub const BRUTE_FORCE_SCENES: [&str; 4] = [
    "sky/CBempty.dae",
    "sky/CBspheres_lambertian.dae",
    "meshedit/teapot.dae",
    "keenan/banana.dae",
];

fn load(dir: &Path, rel: &str) -> Result<Scene, String> {
    collada::load(&dir.join(rel), NormalMode::Smooth).map_err(|e| e.to_string())
}

fn ms(t: &Timing) -> String {
    format!(
        "{:.2} ({:.2}–{:.2})",
        t.median * 1e3,
        t.min * 1e3,
        t.max * 1e3
    )
}

fn threads_or_all(threads: usize) -> usize {
    if threads == 0 {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    } else {
        threads
    }
}

/// Writes the report; `log` receives one line per finished step.
pub fn run(options: &ReportOptions, log: &mut dyn FnMut(&str)) -> Result<(), String> {
    let start = Instant::now();
    let budget = Budget::new(options.quick);
    let threads = threads_or_all(options.threads);
    std::fs::create_dir_all(&options.out_dir).map_err(|e| {
        format!(
            "{}: cannot create the folder: {e}",
            options.out_dir.display()
        )
    })?;
    let machine = machine::Machine::detect();
    let embree_version = {
        let s = Scene::default();
        EmbreeAccel::build(&s, &EmbreeOptions::default())
            .map(|e| e.description())
            .map_err(|e| e.to_string())?
    };

    let mut md = String::new();
    md += "# hybrid: native BVH against Embree\n\n";
    md += &format!(
        "Measured on {} ({} cores; ISA {}), {}, hybrid {}, {}, on {}. Settings: {} run, {} rays per ray kind, medians of {} warmed-up repeats (spread in parentheses: min–max), all-threads figures on {threads} threads.\n\n",
        machine.cpu,
        machine.cores,
        machine.isa.join(" "),
        machine.rustc,
        machine.crate_version,
        embree_version,
        machine.date,
        if options.quick { "quick" } else { "full" },
        budget.rays,
        budget.repeats
    );
    let mut json_scenes = Vec::new();

    // Per-scene builds and traces.
    let mut per_scene = String::from("## Build and trace, per scene\n\n");
    for (size, rel) in SCENES {
        let scene = load(&options.scenes_dir, rel)?;
        let (section, value) = scene_section(size, rel, &scene, &budget, threads)?;
        per_scene += &section;
        json_scenes.push(value);
        log(&format!(
            "report: {rel} measured ({:.0} s)",
            start.elapsed().as_secs_f64()
        ));
    }

    md += &headline(&json_scenes);
    md += &per_scene;
    md += &brute_force_section(&options.scenes_dir, &budget)?;
    log(&format!(
        "report: brute force measured ({:.0} s)",
        start.elapsed().as_secs_f64()
    ));

    let (section, error_json) =
        error_section(&options.scenes_dir, &options.out_dir, &budget, threads)?;
    md += &section;
    log(&format!(
        "report: speed against error measured ({:.0} s)",
        start.elapsed().as_secs_f64()
    ));

    let (section, scaling_json) = scaling_section(&options.out_dir, &budget)?;
    md += &section;
    log(&format!(
        "report: scaling measured ({:.0} s)",
        start.elapsed().as_secs_f64()
    ));

    md += &gallery_section(&options.scenes_dir, &options.out_dir, &budget, threads)?;
    log(&format!(
        "report: gallery rendered ({:.0} s)",
        start.elapsed().as_secs_f64()
    ));

    md += &format!(
        "\nThe whole report took {:.0} s.\n",
        start.elapsed().as_secs_f64()
    );
    let report_json = json!({
        "machine": {"cpu": machine.cpu, "cores": machine.cores, "isa": machine.isa, "rustc": machine.rustc, "hybrid": machine.crate_version, "embree": embree_version, "date": machine.date},
        "settings": {"quick": options.quick, "rays": budget.rays, "repeats": budget.repeats, "threads": threads},
        "scenes": json_scenes,
        "speed_vs_error": error_json,
        "scaling": scaling_json,
        "seconds": start.elapsed().as_secs_f64(),
    });
    let write = |name: &str, text: &str| {
        std::fs::write(options.out_dir.join(name), text)
            .map_err(|e| format!("{}: {e}", options.out_dir.join(name).display()))
    };
    write("report.md", &md)?;
    write(
        "report.json",
        &serde_json::to_string_pretty(&report_json).map_err(|e| e.to_string())?,
    )?;
    log(&format!(
        "report: wrote {}",
        options.out_dir.join("report.md").display()
    ));
    Ok(())
}

/// The summary table at the top: one thread, per scene and ray kind, with
/// the builds beside them.
fn headline(scenes: &[Value]) -> String {
    let mut md = String::from(
        "## Headline (1 thread, Mrays/s; build in ms)\n\n| scene | primitives | native build | embree build | camera native / embree | shadow native / embree | bounce native / embree |\n|---|---|---|---|---|---|---|\n",
    );
    for s in scenes {
        let f = |v: &Value| v.as_f64().unwrap_or(f64::NAN);
        let rays = |kind: &str| {
            let r = &s["rays"][kind];
            format!(
                "{:.2} / {:.2} ({:.2}x)",
                f(&r["native_mrays"]),
                f(&r["embree_mrays"]),
                f(&r["ratio"])
            )
        };
        md += &format!(
            "| {} | {} | {:.2} | {:.2} | {} | {} | {} |\n",
            s["scene"].as_str().unwrap_or("?"),
            s["primitives"],
            f(&s["native_build_ms"]),
            f(&s["embree_build_ms"]),
            rays("camera"),
            rays("shadow"),
            rays("bounce")
        );
    }
    md + "\n"
}

fn scene_section(
    size: &str,
    rel: &str,
    scene: &Scene,
    budget: &Budget,
    threads: usize,
) -> Result<(String, Value), String> {
    let mut md = format!(
        "### {rel} ({size}: {} primitives)\n\n",
        scene.primitive_count()
    );
    md += "| build | time ms, median (min–max) | memory MiB | nodes | depth | SAH cost |\n|---|---|---|---|---|---|\n";
    let mut builds = Vec::new();
    let mib = |b: usize| b as f64 / (1 << 20) as f64;
    for (label, method) in [
        ("native SAH (binned)", BuildMethod::Sah),
        ("native median split", BuildMethod::Median),
    ] {
        let opts = NativeOptions {
            method,
            ..NativeOptions::default()
        };
        let t = time_repeats(budget.repeats, || NativeBvh::build(scene, &opts));
        let s = NativeBvh::build(scene, &opts).stats();
        md += &format!(
            "| {label} | {} | {:.2} | {} | {} | {:.2} |\n",
            ms(&t),
            mib(s.memory_bytes),
            s.nodes,
            s.depth,
            s.sah_cost
        );
        builds.push(json!({"build": label, "ms": t.median * 1e3, "ms_min": t.min * 1e3, "ms_max": t.max * 1e3, "memory_bytes": s.memory_bytes, "nodes": s.nodes, "depth": s.depth, "sah_cost": s.sah_cost}));
    }
    for quality in [BuildQuality::Low, BuildQuality::Medium, BuildQuality::High] {
        let opts = EmbreeOptions {
            quality,
            threads,
            ..EmbreeOptions::default()
        };
        let t = time_repeats(budget.repeats, || {
            EmbreeAccel::build(scene, &opts).map(|_| ())
        });
        let s = EmbreeAccel::build(scene, &opts)
            .map_err(|e| e.to_string())?
            .stats();
        md += &format!(
            "| embree {quality:?} | {} | {:.2} | – | – | – |\n",
            ms(&t),
            mib(s.memory_bytes)
        );
        builds.push(json!({"build": format!("embree {quality:?}"), "ms": t.median * 1e3, "ms_min": t.min * 1e3, "ms_max": t.max * 1e3, "memory_bytes": s.memory_bytes}));
    }
    let native = NativeBvh::build(scene, &NativeOptions::default());
    let embree = EmbreeAccel::build(
        scene,
        &EmbreeOptions {
            threads,
            ..EmbreeOptions::default()
        },
    )
    .map_err(|e| e.to_string())?;
    let native_stats = native.stats();
    let native_build = time_repeats(budget.repeats, || {
        NativeBvh::build(scene, &NativeOptions::default())
    });
    let embree_build = time_repeats(budget.repeats, || {
        EmbreeAccel::build(
            scene,
            &EmbreeOptions {
                threads,
                ..EmbreeOptions::default()
            },
        )
        .map(|_| ())
    });

    let sets: [(&str, Query, Vec<Ray>); 3] = [
        (
            "camera",
            Query::Closest,
            rays::camera_rays(scene, budget.rays, 1),
        ),
        (
            "shadow",
            Query::Occluded,
            rays::shadow_rays(scene, &native, budget.rays, 2),
        ),
        (
            "bounce",
            Query::Closest,
            rays::bounce_rays(scene, &native, budget.rays, 3),
        ),
    ];
    md += &format!(
        "\n| rays | native Mrays/s, 1 thread | embree, 1 thread | native/embree | native, {threads} threads | embree, {threads} threads | native/embree |\n|---|---|---|---|---|---|---|\n"
    );
    let mut ray_json = serde_json::Map::new();
    for (kind, query, set) in &sets {
        let (n1, tn1) = mrays(&native, set, *query, 1, budget.repeats);
        let (e1, te1) = mrays(&embree, set, *query, 1, budget.repeats);
        let (na, _) = mrays(&native, set, *query, threads, budget.repeats);
        let (ea, _) = mrays(&embree, set, *query, threads, budget.repeats);
        md += &format!(
            "| {kind} ({} rays) | {n1:.2} (±{:.0}%) | {e1:.2} (±{:.0}%) | {:.2} | {na:.2} | {ea:.2} | {:.2} |\n",
            set.len(),
            50.0 * tn1.spread(),
            50.0 * te1.spread(),
            n1 / e1,
            na / ea
        );
        ray_json.insert(
            kind.to_string(),
            json!({"rays": set.len(), "native_mrays": n1, "embree_mrays": e1, "ratio": n1 / e1, "native_mrays_all_threads": na, "embree_mrays_all_threads": ea, "ratio_all_threads": na / ea}),
        );
    }
    // Embree's stream call on the same camera rays, one thread.
    let camera = &sets[0].2;
    let mut answers = Vec::with_capacity(camera.len());
    let stream = time_repeats(budget.repeats, || embree.closest_hits(camera, &mut answers));
    let stream_mrays = camera.len() as f64 / stream.median / 1e6;
    let single_mrays = ray_json["camera"]["embree_mrays"]
        .as_f64()
        .unwrap_or(f64::NAN);
    md += &format!(
        "\nEmbree ray stream (`rtcIntersect1M`, coherent flag) on the same camera rays, 1 thread: {stream_mrays:.2} Mrays/s against {single_mrays:.2} with single-ray calls ({:.2}x).\n",
        stream_mrays / single_mrays
    );
    ray_json.insert(
        "camera_stream".into(),
        json!({"embree_stream_mrays": stream_mrays, "embree_single_mrays": single_mrays}),
    );
    let (w, h, spp) = budget.frame;
    let settings = RenderSettings {
        width: w,
        height: h,
        samples: spp,
        threads,
        seed: 1,
        shading: Shading::Path(PathSettings {
            max_bounces: 3,
            light_samples: 1,
            ..PathSettings::default()
        }),
        ..RenderSettings::default()
    };
    let frame_native = time_repeats(budget.repeats.min(3), || {
        render(scene, &native, &settings, &Silent)
    });
    let frame_embree = time_repeats(budget.repeats.min(3), || {
        render(scene, &embree, &settings, &Silent)
    });
    md += &format!(
        "\nTime per frame ({w}x{h}, {spp} spp, 3 bounces, light sampling, {threads} threads): native {:.3} s, embree {:.3} s (native/embree time {:.2}).\n\n",
        frame_native.median,
        frame_embree.median,
        frame_native.median / frame_embree.median
    );
    let value = json!({
        "scene": rel,
        "size": size,
        "primitives": scene.primitive_count(),
        "native_build_ms": native_build.median * 1e3,
        "embree_build_ms": embree_build.median * 1e3,
        "native_nodes": native_stats.nodes,
        "native_depth": native_stats.depth,
        "native_sah_cost": native_stats.sah_cost,
        "builds": builds,
        "rays": Value::Object(ray_json),
        "frame_seconds": {"native": frame_native.median, "embree": frame_embree.median},
    });
    Ok((md, value))
}

fn brute_force_section(dir: &Path, budget: &Budget) -> Result<String, String> {
    let mut md = String::from("## With and without acceleration (camera rays, 1 thread)\n\n| scene | primitives | none Mrays/s | native Mrays/s | embree Mrays/s | native speed-up over none |\n|---|---|---|---|---|---|\n");
    for rel in BRUTE_FORCE_SCENES {
        let scene = load(dir, rel)?;
        let set = rays::camera_rays(&scene, (budget.rays / 4).max(2_000), 4);
        let brute = BruteForce::build(&scene);
        let native = NativeBvh::build(&scene, &NativeOptions::default());
        let embree =
            EmbreeAccel::build(&scene, &EmbreeOptions::default()).map_err(|e| e.to_string())?;
        let (b, _) = mrays(&brute, &set, Query::Closest, 1, budget.repeats.min(3));
        let (n, _) = mrays(&native, &set, Query::Closest, 1, budget.repeats);
        let (e, _) = mrays(&embree, &set, Query::Closest, 1, budget.repeats);
        md += &format!(
            "| {rel} | {} | {b:.3} | {n:.2} | {e:.2} | {:.1}x |\n",
            scene.primitive_count(),
            n / b
        );
    }
    Ok(md + "\n")
}

/// One line of the speed-against-error study.
struct ErrorPoint {
    seconds: f64,
    rmse: f64,
    spp: f64,
}

fn error_section(
    dir: &Path,
    out: &Path,
    budget: &Budget,
    threads: usize,
) -> Result<(String, Value), String> {
    let rel = "sky/CBspheres_lambertian.dae";
    let scene = load(dir, rel)?;
    let (w, h) = budget.error_resolution;
    let native = NativeBvh::build(&scene, &NativeOptions::default());
    let embree = EmbreeAccel::build(
        &scene,
        &EmbreeOptions {
            threads,
            ..EmbreeOptions::default()
        },
    )
    .map_err(|e| e.to_string())?;
    let path = |estimator| PathSettings {
        estimator,
        max_bounces: 3,
        light_samples: 1,
        ..PathSettings::default()
    };
    let settings = |spp: u32, seed: u64, estimator, adaptive: Option<Adaptive>| RenderSettings {
        width: w,
        height: h,
        samples: spp,
        threads,
        seed,
        shading: Shading::Path(path(estimator)),
        adaptive,
        ..RenderSettings::default()
    };
    let reference = render(
        &scene,
        &native,
        &settings(
            budget.reference_spp,
            987_654,
            DirectEstimator::LightSampling,
            None,
        ),
        &Silent,
    )
    .film;
    let rmse = |film: &Film| -> f64 {
        let sum: f64 = film
            .pixels
            .iter()
            .zip(&reference.pixels)
            .map(|(a, b)| (*a - *b).length_squared() as f64 / 3.0)
            .sum();
        (sum / film.pixels.len() as f64).sqrt()
    };
    let mut series: Vec<(String, Vec<ErrorPoint>)> = Vec::new();
    for (backend, accel) in [
        ("native", &native as &dyn DynRender),
        ("embree", &embree as &dyn DynRender),
    ] {
        for (label, estimator) in [
            ("hemisphere", DirectEstimator::Hemisphere),
            ("light sampling", DirectEstimator::LightSampling),
        ] {
            let points = budget
                .error_spp
                .iter()
                .map(|&spp| {
                    let (film, seconds) =
                        accel.render_timed(&scene, &settings(spp, 1, estimator, None));
                    ErrorPoint {
                        seconds,
                        rmse: rmse(&film),
                        spp: spp as f64,
                    }
                })
                .collect();
            series.push((format!("{backend}, {label}"), points));
        }
        let points = [0.4f32, 0.2, 0.1, 0.05, 0.025]
            .iter()
            .map(|&tol| {
                let s = settings(
                    budget.adaptive_cap,
                    1,
                    DirectEstimator::LightSampling,
                    Some(Adaptive {
                        batch: 8,
                        tolerance: tol,
                    }),
                );
                let (film, seconds) = accel.render_timed(&scene, &s);
                let spp =
                    film.samples.iter().map(|&n| n as f64).sum::<f64>() / film.samples.len() as f64;
                ErrorPoint {
                    seconds,
                    rmse: rmse(&film),
                    spp,
                }
            })
            .collect();
        series.push((format!("{backend}, adaptive (light sampling)"), points));
    }
    let plot_series: Vec<Series> = series
        .iter()
        .map(|(name, pts)| Series {
            name: name.clone(),
            points: pts.iter().map(|p| (p.seconds, p.rmse)).collect(),
        })
        .collect();
    loglog(
        &out.join("speed_vs_error.svg"),
        &format!("{rel}: RMSE against render time"),
        "render time (s)",
        "RMSE vs reference",
        &plot_series,
    )?;
    let mut md = format!(
        "## Speed against error\n\n`{rel}` at {w}x{h}, 3 bounces, one light sample, {threads} threads; error is the RMSE of linear radiance against a reference rendered once with {} spp (native, light sampling, another seed). Adaptive sampling uses batches of 8 up to {} spp with tolerances 0.4 .. 0.025. Each point is one render.\n\n![speed against error](speed_vs_error.svg)\n\n| series | spp | seconds | RMSE | slope of log RMSE / log time |\n|---|---|---|---|---|\n",
        budget.reference_spp, budget.adaptive_cap
    );
    let mut json_series = Vec::new();
    for (name, pts) in &series {
        let slope = loglog_slope(&pts.iter().map(|p| (p.seconds, p.rmse)).collect::<Vec<_>>());
        for (i, p) in pts.iter().enumerate() {
            md += &format!(
                "| {} | {:.1} | {:.4} | {:.4} | {} |\n",
                if i == 0 { name.as_str() } else { "" },
                p.spp,
                p.seconds,
                p.rmse,
                if i == 0 {
                    format!("{slope:.2}")
                } else {
                    String::new()
                }
            );
        }
        json_series.push(json!({"series": name, "slope": slope, "points": pts.iter().map(|p| json!({"spp": p.spp, "seconds": p.seconds, "rmse": p.rmse})).collect::<Vec<_>>()}));
    }
    md += "\nA Monte Carlo estimator's RMSE falls as time^-1/2 (slope -0.5); at equal time the lower line is the better estimator. The two backends trace the same paths, so their lines differ only by trace speed.\n\n";
    Ok((md, json!({"scene": rel, "series": json_series})))
}

/// Renders through any backend with the timing the study needs.
trait DynRender {
    fn render_timed(&self, scene: &Scene, settings: &RenderSettings) -> (Film, f64);
}

impl<A: Accel> DynRender for A {
    fn render_timed(&self, scene: &Scene, settings: &RenderSettings) -> (Film, f64) {
        let out = render(scene, self, settings, &Silent);
        (out.film, out.seconds)
    }
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
    let mut rng = crate::render::sampling::Rng::new(77, 9);
    (0..n)
        .map(|_| {
            let target = Vec3::new(rng.next_f32() * 1.8 - 0.9, rng.next_f32() * 1.8 - 0.9, 0.0);
            let origin = Vec3::new(rng.next_f32() * 4.0 - 2.0, rng.next_f32() * 4.0 - 2.0, 3.0);
            Ray::new(origin, (target - origin).normalize())
        })
        .collect()
}

fn scaling_section(out: &Path, budget: &Budget) -> Result<(String, Value), String> {
    let set = plate_rays(budget.scaling_rays);
    let mut rows = Vec::new();
    let mut md = String::from("## How cost grows with scene size\n\nGenerated bumpy plates; builds on all threads (median of repeats), traces on one thread with the same rays.\n\n| triangles | native build ms | embree build ms | native Mrays/s | embree Mrays/s | native/embree trace |\n|---|---|---|---|---|---|\n");
    for &size in &budget.scaling {
        let scene = bumpy_plate(size);
        let tris = scene.triangle_count();
        let repeats = if tris >= 1_000_000 {
            2
        } else {
            budget.repeats.min(5)
        };
        let nb = time_repeats(repeats, || {
            NativeBvh::build(&scene, &NativeOptions::default())
        });
        let eb = time_repeats(repeats, || {
            EmbreeAccel::build(&scene, &EmbreeOptions::default()).map(|_| ())
        });
        let native = NativeBvh::build(&scene, &NativeOptions::default());
        let embree =
            EmbreeAccel::build(&scene, &EmbreeOptions::default()).map_err(|e| e.to_string())?;
        let (nm, _) = mrays(&native, &set, Query::Closest, 1, repeats);
        let (em, _) = mrays(&embree, &set, Query::Closest, 1, repeats);
        md += &format!(
            "| {tris} | {:.2} | {:.2} | {nm:.2} | {em:.2} | {:.2} |\n",
            nb.median * 1e3,
            eb.median * 1e3,
            nm / em
        );
        rows.push((tris as f64, nb.median * 1e3, eb.median * 1e3, nm, em));
    }
    let build = |i: usize| -> Vec<(f64, f64)> {
        rows.iter()
            .map(|r| (r.0, if i == 0 { r.1 } else { r.2 }))
            .collect()
    };
    let trace = |i: usize| -> Vec<(f64, f64)> {
        rows.iter()
            .map(|r| (r.0, 1e3 / if i == 0 { r.3 } else { r.4 }))
            .collect()
    };
    let (nbs, ebs, nts, ets) = (
        loglog_slope(&build(0)),
        loglog_slope(&build(1)),
        loglog_slope(&trace(0)),
        loglog_slope(&trace(1)),
    );
    loglog(
        &out.join("scaling_build.svg"),
        "build time against triangles",
        "triangles",
        "build time (ms)",
        &[
            Series {
                name: format!("native (slope {nbs:.2})"),
                points: build(0),
            },
            Series {
                name: format!("embree (slope {ebs:.2})"),
                points: build(1),
            },
        ],
    )?;
    loglog(
        &out.join("scaling_trace.svg"),
        "trace time per ray against triangles",
        "triangles",
        "ns per ray (1 thread)",
        &[
            Series {
                name: format!("native (slope {nts:.2})"),
                points: trace(0),
            },
            Series {
                name: format!("embree (slope {ets:.2})"),
                points: trace(1),
            },
        ],
    )?;
    md += &format!(
        "\nFitted log-log slopes: build time ∝ n^{nbs:.2} (native), n^{ebs:.2} (embree); time per ray ∝ n^{nts:.2} (native), n^{ets:.2} (embree). A BVH build is O(n log n) (slope a little over 1) and a traversal O(log n) (slope near 0).\n\n![build scaling](scaling_build.svg)\n![trace scaling](scaling_trace.svg)\n\n"
    );
    let value = json!({
        "rows": rows.iter().map(|r| json!({"triangles": r.0, "native_build_ms": r.1, "embree_build_ms": r.2, "native_mrays": r.3, "embree_mrays": r.4})).collect::<Vec<_>>(),
        "slopes": {"native_build": nbs, "embree_build": ebs, "native_ns_per_ray": nts, "embree_ns_per_ray": ets},
    });
    Ok((md, value))
}

fn gallery_section(
    dir: &Path,
    out: &Path,
    budget: &Budget,
    threads: usize,
) -> Result<String, String> {
    let (w, h) = budget.gallery;
    let shoot =
        |scene: &Scene, samples: u32, shading: Shading, adaptive: Option<Adaptive>| -> Film {
            let accel = NativeBvh::build(scene, &NativeOptions::default());
            let settings = RenderSettings {
                width: w,
                height: h,
                samples,
                threads,
                seed: 1,
                shading,
                adaptive,
                ..RenderSettings::default()
            };
            render(scene, &accel, &settings, &Silent).film
        };
    let pt = |m: u32, l: u32| PathSettings {
        max_bounces: m,
        light_samples: l,
        ..PathSettings::default()
    };
    let png = |f: &Film| {
        image::RgbImage::from_raw(f.width, f.height, f.to_rgb8(ToneMap::Reference))
            .expect("film size")
    };
    let bunny = load(dir, "sky/CBbunny.dae")?;
    let spheres = load(dir, "sky/CBspheres_lambertian.dae")?;
    let mut md = format!("## Gallery\n\nThe course write-up's series, rendered on the native backend at {w}x{h} (the Embree images are identical, see `docs/parity.md`).\n\n");

    let normals: Vec<image::RgbImage> = [
        "sky/CBspheres_lambertian.dae",
        "sky/CBbunny.dae",
        "meshedit/maxplanck.dae",
        "keenan/banana.dae",
    ]
    .iter()
    .map(|rel| {
        let s = load(dir, rel)?;
        let f = shoot(&s, 4, Shading::Normals, None);
        Ok(
            image::RgbImage::from_raw(f.width, f.height, f.to_rgb8(ToneMap::Identity))
                .expect("film size"),
        )
    })
    .collect::<Result<_, String>>()?;
    gallery::write_grid(&out.join("gallery_normals.png"), &normals, 4)?;
    md += "Normal shading: CBspheres_lambertian, CBbunny, maxplanck, banana.\n\n![normals](gallery_normals.png)\n\n";

    let lights: Vec<_> = [1, 4, 16, 64]
        .iter()
        .map(|&l| png(&shoot(&bunny, 1, Shading::Path(pt(1, l)), None)))
        .collect();
    gallery::write_grid(&out.join("gallery_light_samples.png"), &lights, 4)?;
    md += "CBbunny, direct lighting at `-s 1` with `-l 1, 4, 16, 64`: the soft shadows' noise falls.\n\n![light samples](gallery_light_samples.png)\n\n";

    let spp = budget.gallery_spp;
    let mut bounces = Vec::new();
    for accumulate in [false, true] {
        for m in 0..=5 {
            bounces.push(png(&shoot(
                &bunny,
                spp,
                Shading::Path(PathSettings {
                    accumulate,
                    ..pt(m, 1)
                }),
                None,
            )));
        }
    }
    gallery::write_grid(&out.join("gallery_bounces.png"), &bounces, 6)?;
    md += &format!("CBbunny at {spp} spp, `-m 0..5`: top row only the m-th bounce (`-o 0`), bottom row accumulated (`-o 1`).\n\n![bounces](gallery_bounces.png)\n\n");

    let rr: Vec<_> = [0, 1, 2, 3, 4, 100]
        .iter()
        .map(|&m| {
            png(&shoot(
                &bunny,
                spp,
                Shading::Path(PathSettings {
                    russian_roulette: Some(0.7),
                    ..pt(m, 1)
                }),
                None,
            ))
        })
        .collect();
    gallery::write_grid(&out.join("gallery_russian_roulette.png"), &rr, 6)?;
    md += "CBbunny with Russian roulette (continuation 0.7), `-m 0, 1, 2, 3, 4, 100`.\n\n![russian roulette](gallery_russian_roulette.png)\n\n";

    let series: Vec<_> = budget
        .spp_series
        .iter()
        .map(|&s| png(&shoot(&spheres, s, Shading::Path(pt(3, 1)), None)))
        .collect();
    gallery::write_grid(&out.join("gallery_samples.png"), &series, 4)?;
    md += &format!("CBspheres_lambertian, 3 bounces, `-s {}`.\n\n![samples per pixel](gallery_samples.png)\n\n", budget.spp_series.iter().map(|s| s.to_string()).collect::<Vec<_>>().join(", "));

    let (batch, tol, cap) = budget.adaptive_gallery;
    let mut adaptive = Vec::new();
    let mut mean_spp = Vec::new();
    for scene in [&bunny, &spheres] {
        let film = shoot(
            scene,
            cap,
            Shading::Path(pt(5, 1)),
            Some(Adaptive {
                batch,
                tolerance: tol,
            }),
        );
        let rate: Vec<u8> = film
            .samples
            .iter()
            .flat_map(|&n| crate::render::film::rate_colour(n as f32 / cap as f32))
            .collect();
        mean_spp
            .push(film.samples.iter().map(|&n| n as f64).sum::<f64>() / film.samples.len() as f64);
        adaptive.push(png(&film));
        adaptive.push(image::RgbImage::from_raw(w, h, rate).expect("film size"));
    }
    gallery::write_grid(&out.join("gallery_adaptive.png"), &adaptive, 4)?;
    md += &format!(
        "Adaptive sampling `-a {batch} {tol} -s {cap}`, 5 bounces: CBbunny and its sample rate (mean {:.0} spp), CBspheres_lambertian and its rate (mean {:.0} spp); blue = few samples, red = the cap.\n\n![adaptive](gallery_adaptive.png)\n",
        mean_spp[0], mean_spp[1]
    );
    Ok(md)
}
