//! Per scene: every build variant's time and memory (one thread and all
//! threads), native tree shape, ray throughput of the compared backends
//! per ray kind, Embree's stream call, and the time per frame.

use serde_json::{json, Value};

use super::budget::Budget;
use super::budget::ALL_BUILDS_UP_TO;
use super::measure::{mrays_pair, on_threads, ray_sets, time_pair, time_repeats, Timing};
use super::table::{Cell, Flag, Measured, Table};
use crate::accel::config::{BUILD_VARIANTS, COMPARED};
use crate::accel::{Accel, AccelStats, Backend, BackendConfig};
use crate::render::integrator::{PathSettings, Shading};
use crate::render::{render, RenderSettings, Silent};
use crate::scene::Scene;

/// One build variant: times on one thread and on all threads, and what
/// the backend reports about its structure.
pub struct BuildRow {
    pub config: BackendConfig,
    pub one_thread: Timing,
    pub all_threads: Timing,
    pub stats: AccelStats,
}

/// Throughput of the compared backends ([`COMPARED`]) on one ray kind.
pub struct TraceRow {
    pub kind: &'static str,
    pub rays: usize,
    /// Million rays per second per compared backend, one thread.
    pub one_thread: [Measured; 2],
    pub all_threads: [Measured; 2],
}

impl TraceRow {
    /// native / embree on one thread (greater than 1: native is faster).
    pub fn ratio(&self) -> f64 {
        self.one_thread[0].median / self.one_thread[1].median
    }

    pub fn ratio_all_threads(&self) -> f64 {
        self.all_threads[0].median / self.all_threads[1].median
    }

    /// Whether either backend traced fewer rays per second on all threads
    /// than on one.
    pub fn below_one_thread(&self) -> bool {
        (0..2).any(|i| self.all_threads[i].median < self.one_thread[i].median)
    }
}

/// Everything measured on one scene.
pub struct SceneResult {
    pub size: &'static str,
    pub scene: String,
    pub primitives: usize,
    pub triangles: usize,
    pub threads: usize,
    pub builds: Vec<BuildRow>,
    pub traces: Vec<TraceRow>,
    /// Embree's stream call and its single-ray calls on the camera rays.
    pub stream: Measured,
    pub single: Measured,
    /// Frame: width, height, spp; seconds per compared backend.
    pub frame: (u32, u32, u32),
    pub frame_seconds: [Timing; 2],
}

impl SceneResult {
    /// The build row of `config` (every compared backend has one).
    pub fn build(&self, config: &BackendConfig) -> Option<&BuildRow> {
        self.builds.iter().find(|b| b.config == *config)
    }

    /// Embree's time per frame over native's (greater than 1: native is
    /// faster).
    pub fn frame_ratio(&self) -> f64 {
        self.frame_seconds[1].median / self.frame_seconds[0].median
    }
}

/// Times `config`'s build on `threads` threads (native: the rayon pool;
/// Embree: its own build threads).
fn time_build(
    scene: &Scene,
    config: &BackendConfig,
    threads: usize,
    repeats: usize,
) -> Result<Timing, String> {
    let config = config.with_threads(threads);
    config.build(scene).map_err(|e| e.to_string())?;
    Ok(on_threads(threads, || {
        time_repeats(repeats, || config.build(scene).map(|_| ()))
    }))
}

/// Measures one scene.
pub fn measure(
    size: &'static str,
    rel: &str,
    scene: &Scene,
    budget: &Budget,
    threads: usize,
) -> Result<SceneResult, String> {
    let mut builds = Vec::new();
    let variants: &[BackendConfig] = if scene.primitive_count() <= ALL_BUILDS_UP_TO {
        &BUILD_VARIANTS
    } else {
        &COMPARED
    };
    for config in variants {
        builds.push(BuildRow {
            config: *config,
            one_thread: time_build(scene, config, 1, budget.repeats)?,
            all_threads: time_build(scene, config, threads, budget.repeats)?,
            stats: config
                .with_threads(threads)
                .build(scene)
                .map_err(|e| e.to_string())?
                .stats(),
        });
    }
    let backends = COMPARED
        .iter()
        .map(|c| c.with_threads(threads).build(scene))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let sets = ray_sets(scene, &backends[0], budget.rays);
    let traces = sets
        .iter()
        .map(|set| {
            let each = |t: usize| {
                let pair = [&backends[0], &backends[1]];
                mrays_pair(pair, &set.rays, set.query, t, budget.repeats)
            };
            TraceRow {
                kind: set.kind,
                rays: set.rays.len(),
                one_thread: each(1),
                all_threads: each(threads),
            }
        })
        .collect::<Vec<_>>();
    // Embree's stream call on the same camera rays, one thread.
    let camera = &sets[0].rays;
    let Backend::Embree(embree) = &backends[1] else {
        return Err("the second compared backend is not Embree".into());
    };
    let mut answers = Vec::with_capacity(camera.len());
    let stream = time_repeats(budget.repeats, || embree.closest_hits(camera, &mut answers));
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
    // Interleaved as the rays are: a frame takes a tenth of a second, so
    // back-to-back repeats of one backend caught the machine's drift.
    let frame_seconds = time_pair(budget.frame_repeats, |i| {
        render(scene, &backends[i], &settings, &Silent)
    });
    Ok(SceneResult {
        size,
        scene: rel.to_string(),
        primitives: scene.primitive_count(),
        triangles: scene.triangle_count(),
        threads,
        builds,
        stream: Measured::per_second_millions(camera.len(), &stream),
        single: traces[0].one_thread[1],
        traces,
        frame: (w, h, spp),
        frame_seconds,
    })
}

fn builds_table(r: &SceneResult) -> Table {
    let t = r.threads;
    let mut table = Table::new([
        ("build", "build".to_string()),
        ("ms_1_thread", "ms, 1 thread".to_string()),
        ("ms_all_threads", format!("ms, {t} threads")),
        ("memory_mib", "memory MiB".to_string()),
        ("nodes", "nodes".to_string()),
        ("depth", "depth".to_string()),
        ("sah_cost", "SAH cost".to_string()),
    ]);
    for b in &r.builds {
        let native = matches!(b.config, BackendConfig::Native(_));
        let or_empty = |c: Cell| if native { c } else { Cell::Empty };
        table.row(vec![
            Cell::Text(b.config.label()),
            Cell::Measured(Measured::millis(&b.one_thread), 2),
            Cell::Measured(Measured::millis(&b.all_threads), 2).flagged(
                (b.all_threads.median > b.one_thread.median).then_some(Flag::BelowOneThread),
            ),
            Cell::Number(b.stats.memory_bytes as f64 / (1 << 20) as f64, 2),
            or_empty(Cell::Count(b.stats.nodes as u64)),
            or_empty(Cell::Count(b.stats.depth as u64)),
            or_empty(Cell::Number(b.stats.sah_cost, 2)),
        ]);
    }
    table
}

fn traces_table(r: &SceneResult) -> Table {
    let t = r.threads;
    let [a, b] = COMPARED.map(|c| c.label());
    let mut table = Table::new([
        ("kind", "rays".to_string()),
        ("rays", "count".to_string()),
        ("native_mrays", format!("{a} Mrays/s, 1 thread")),
        ("embree_mrays", format!("{b}, 1 thread")),
        ("ratio", format!("{a}/{b}")),
        ("native_mrays_all_threads", format!("{a}, {t} threads")),
        ("embree_mrays_all_threads", format!("{b}, {t} threads")),
        ("ratio_all_threads", format!("{a}/{b}")),
    ]);
    for row in &r.traces {
        // A figure on all threads below its one-thread figure is flagged.
        let below = |i: usize| {
            Cell::Measured(row.all_threads[i], 2).flagged(
                (row.all_threads[i].median < row.one_thread[i].median)
                    .then_some(Flag::BelowOneThread),
            )
        };
        table.row(vec![
            Cell::Text(row.kind.into()),
            Cell::Count(row.rays as u64),
            Cell::Measured(row.one_thread[0], 2),
            Cell::Measured(row.one_thread[1], 2),
            Cell::ratio_of(row.ratio(), &row.one_thread),
            below(0),
            below(1),
            Cell::ratio_of(row.ratio_all_threads(), &row.all_threads),
        ]);
    }
    table
}

/// The per-scene section: Markdown and the JSON of every scene.
pub fn section(results: &[SceneResult]) -> (String, Value) {
    let mut md = String::from("## Build and trace, per scene\n\nMedians of warmed-up repeats with their range (min–max); ⚠ marks figures whose repeats spread by more than 10% (and ratios of such figures), ↓ a figure on all threads worse than the same on one thread. Ratios are native / Embree throughput: greater than 1 means native is faster.\n\n");
    let mut scenes = Vec::new();
    for r in results {
        let builds = builds_table(r);
        let traces = traces_table(r);
        let (w, h, spp) = r.frame;
        let frame = [0, 1].map(|i| r.frame_seconds[i].median);
        md += &format!(
            "### {} ({}: {} primitives)\n\n{}\n{}\nEmbree ray stream (`rtcIntersect1M`, coherent flag) on the same camera rays, 1 thread: {:.2} Mrays/s against {:.2} with single-ray calls ({:.2}x).\n\nTime per frame ({w}x{h}, {spp} spp, 3 bounces, light sampling, {} threads): native {:.3} s, embree {:.3} s (Embree's time / native's {:.2}x: greater than 1 means native is faster).\n\n",
            r.scene,
            r.size,
            r.primitives,
            builds.markdown(),
            traces.markdown(),
            r.stream.median,
            r.single.median,
            r.stream.median / r.single.median,
            r.threads,
            frame[0],
            frame[1],
            r.frame_ratio(),
        );
        scenes.push(json!({
            "scene": r.scene,
            "size": r.size,
            "primitives": r.primitives,
            "builds": builds.json(),
            "traces": traces.json(),
            "camera_stream": {"embree_stream_mrays": r.stream.median, "embree_single_mrays": r.single.median},
            "frame_seconds": {"native": frame[0], "embree": frame[1]},
        }));
    }
    (md, Value::Array(scenes))
}
