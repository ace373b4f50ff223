//! Per scene: every build variant's time and memory (one thread and all
//! threads), native tree shape, ray throughput of the compared backends
//! per ray kind, each Embree's coherent batch call, and the time per frame.
//! The compared backends are [`compared`]: native first, then each Embree
//! present; every figure is kept per backend, in that order, and every
//! ratio is native over one of the others.

use serde_json::{json, Value};

use super::budget::Budget;
use super::budget::ALL_BUILDS_UP_TO;
use super::measure::{
    mrays_interleaved, on_threads, process_cpu_seconds, ray_sets, time_interleaved, time_repeats,
    time_repeats_by, Measured,
};
use super::paired::compare;
use super::table::{Cell, Flag, Table};
use crate::accel::config::{build_variants, compared};
use crate::accel::{Accel, AccelStats, Backend, BackendConfig, TraceCounters, TreeFacts};
use crate::geom::ray::FlatRay;
use crate::geom::Ray;
use crate::render::integrator::{PathSettings, Shading};
use crate::render::{render, RenderSettings, Silent};
use crate::scene::Scene;

/// One build variant: times on one thread and on all threads, and what
/// the backend reports about its structure.
pub struct BuildRow {
    pub config: BackendConfig,
    pub one_thread: Measured,
    pub all_threads: Measured,
    pub stats: AccelStats,
}

/// Ratios below this are where native is said to fall behind (within 5%
/// the two are called even).
pub const BEHIND: f64 = 0.95;

/// How a native-over-backend ratio reads.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// Below [`BEHIND`].
    Behind,
    Even,
    /// Above 1.05x.
    Ahead,
}

impl Verdict {
    pub fn of(ratio: f64) -> Verdict {
        if ratio < BEHIND {
            Verdict::Behind
        } else if ratio > 1.05 {
            Verdict::Ahead
        } else {
            Verdict::Even
        }
    }
}

/// Throughput of the compared backends ([`compared`]) on one ray kind.
pub struct TraceRow {
    pub kind: &'static str,
    pub rays: usize,
    /// Million rays per second per compared backend through its `Accel`,
    /// one thread, by the thread's CPU time.
    pub one_thread: Vec<Measured>,
    /// Per compared backend: the same rays traced as a plain C program
    /// calls its library (Embree; `None` for native), one thread.
    pub plain_c: Vec<Option<Measured>>,
    pub all_threads: Vec<Measured>,
    /// Interleaved rounds of the one-thread figures, and whether every
    /// ratio to native settled within the budget's bound.
    pub rounds: usize,
    pub settled: bool,
    /// The widest relative half-width of the ratios' 95% intervals.
    pub widest: f64,
}

impl TraceRow {
    /// What backend `j` is compared by on one thread: its library called
    /// as plain C does where it has one, else its `Accel`.
    pub fn baseline(&self, j: usize) -> Measured {
        self.plain_c[j].unwrap_or(self.one_thread[j])
    }

    /// native / backend `j` on one thread (greater than 1: native is
    /// faster), against its plain-C baseline.
    pub fn ratio(&self, j: usize) -> f64 {
        self.one_thread[0].median / self.baseline(j).median
    }

    /// Whether the one-thread ratio to backend `j` did not settle and its
    /// interval spans two verdicts (behind below 0.95x, even, ahead above
    /// 1.05x): the one case its flag changes a conclusion.
    pub fn verdict_unsure(&self, j: usize) -> bool {
        let r = self.ratio(j);
        !self.settled
            && Verdict::of(r * (1.0 - self.widest)) != Verdict::of(r * (1.0 + self.widest))
    }

    /// Backend `j`'s speed through hybrid's wrapper over its plain-C
    /// speed (below 1: the wrapper costs), where it has a plain C caller.
    pub fn wrapper_speed(&self, j: usize) -> Option<f64> {
        self.plain_c[j].map(|c| self.one_thread[j].median / c.median)
    }

    pub fn ratio_all_threads(&self, j: usize) -> f64 {
        self.all_threads[0].median / self.all_threads[j].median
    }

    /// The two figures `ratio(j)` rests on.
    pub fn pair(&self, j: usize, all: bool) -> [Measured; 2] {
        if all {
            [self.all_threads[0], self.all_threads[j]]
        } else {
            [self.one_thread[0], self.baseline(j)]
        }
    }

    /// Whether native or backend `j` traced fewer rays per second on all
    /// threads than on one.
    pub fn below_one_thread(&self, j: usize) -> bool {
        [0, j]
            .iter()
            .any(|&i| self.all_threads[i].median < self.one_thread[i].median)
    }
}

/// Everything measured on one scene.
pub struct SceneResult {
    pub size: &'static str,
    pub scene: String,
    pub primitives: usize,
    pub triangles: usize,
    pub threads: usize,
    /// Repeats of each all-threads figure.
    pub repeats: usize,
    /// The compared backends, native first: the order of every per-backend
    /// vector below.
    pub compared: Vec<BackendConfig>,
    pub builds: Vec<BuildRow>,
    pub traces: Vec<TraceRow>,
    /// Per compared backend: its coherent batch call
    /// ([`Accel::closest_hits`]) on the camera rays, one thread: how the
    /// backend calls it, and the figure.
    pub batch: Vec<(&'static str, Measured)>,
    /// Frame: width, height, spp; seconds per compared backend.
    pub frame: (u32, u32, u32),
    pub frame_seconds: Vec<Measured>,
}

impl SceneResult {
    /// The build row of `config` (every compared backend has one).
    pub fn build(&self, config: &BackendConfig) -> Option<&BuildRow> {
        self.builds.iter().find(|b| b.config == *config)
    }

    /// The index of `config` among the compared backends.
    pub fn index(&self, config: &BackendConfig) -> Option<usize> {
        self.compared.iter().position(|c| c == config)
    }

    /// Backend `j`'s time per frame over native's (greater than 1: native
    /// is faster).
    pub fn frame_ratio(&self, j: usize) -> f64 {
        self.frame_seconds[j].median / self.frame_seconds[0].median
    }

    /// The two frame times `frame_ratio(j)` rests on.
    pub fn frame_pair(&self, j: usize) -> [Measured; 2] {
        [0, j].map(|i| self.frame_seconds[i])
    }
}

/// Times `config`'s build on `threads` threads (native: the rayon pool;
/// Embree: its own build threads): on one thread by the process's CPU
/// time, which a busy machine's other work does not move; on all threads
/// by the wall clock.
fn time_build(
    scene: &Scene,
    config: &BackendConfig,
    threads: usize,
    repeats: usize,
) -> Result<Measured, String> {
    let config = config.with_threads(threads);
    config.build(scene).map_err(|e| e.to_string())?;
    let build = || config.build(scene).map(|_| ());
    Ok(on_threads(threads, || {
        if threads == 1 {
            time_repeats_by(repeats, process_cpu_seconds, build)
        } else {
            time_repeats(repeats, build)
        }
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
    let compared = compared();
    let mut builds = Vec::new();
    let variants = if scene.primitive_count() <= ALL_BUILDS_UP_TO {
        build_variants()
    } else {
        compared.clone()
    };
    for config in &variants {
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
    let backends = compared
        .iter()
        .map(|c| c.with_threads(threads).build(scene))
        .collect::<Result<Vec<_>, _>>()
        .map_err(|e| e.to_string())?;
    let sets = ray_sets(scene, &backends[0], budget.rays);
    let labelled: Vec<(String, &Backend)> = compared
        .iter()
        .zip(&backends)
        .map(|(c, b)| (c.label(), b))
        .collect();
    let traces = sets
        .iter()
        .map(|set| {
            let flat: Vec<FlatRay> = set.rays.iter().map(Ray::flat).collect();
            let one = on_threads(1, || {
                compare(set.kind, set.query, &flat, &labelled, budget.settle)
            });
            let one_thread: Vec<Measured> = (0..backends.len())
                .map(|b| one.own(b).map_or(Measured::default(), |r| r.cpu))
                .collect();
            let plain_c = (0..backends.len())
                .map(|b| one.plain_c(b).map(|r| r.cpu))
                .collect();
            let all: Vec<_> = backends.iter().collect();
            TraceRow {
                kind: set.kind,
                rays: set.rays.len(),
                one_thread,
                plain_c,
                all_threads: if threads > 1 {
                    mrays_interleaved(&all, &set.rays, set.query, threads, budget.repeats)
                } else {
                    Vec::new()
                },
                rounds: one.rounds,
                settled: one.settled,
                widest: one.widest,
            }
        })
        .collect::<Vec<_>>();
    // Each backend's batch call on the same camera rays, one thread.
    let camera = &sets[0].rays;
    let mut answers = vec![None; camera.len()];
    let batch = backends
        .iter()
        .map(|b| {
            let mut counters = TraceCounters::default();
            let t = time_repeats(budget.repeats, || {
                b.closest_hits(camera, &mut answers, &mut counters)
            });
            (
                b.stats().batch_call,
                Measured::per_second_millions(camera.len(), &t),
            )
        })
        .collect();
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
    let frame_seconds = time_interleaved(backends.len(), budget.frame_repeats, |i| {
        render(scene, &backends[i], &settings, &Silent)
    });
    Ok(SceneResult {
        size,
        scene: rel.to_string(),
        primitives: scene.primitive_count(),
        triangles: scene.triangle_count(),
        threads,
        repeats: budget.repeats,
        compared,
        builds,
        batch,
        traces,
        frame: (w, h, spp),
        frame_seconds,
    })
}

fn builds_table(r: &SceneResult) -> Table {
    let t = r.threads;
    let mut table = Table::new([
        ("build", "build".to_string()),
        ("ms_1_thread", "ms, 1 thread (CPU time)".to_string()),
        ("ms_all_threads", format!("ms, {t} threads")),
        ("memory_mib", "memory MiB".to_string()),
        ("nodes", "nodes".to_string()),
        ("depth", "depth".to_string()),
        ("sah_cost", "SAH cost".to_string()),
    ]);
    for b in &r.builds {
        let tree = |f: fn(&TreeFacts) -> Cell| b.stats.tree.as_ref().map_or(Cell::Empty, f);
        table.row(vec![
            Cell::Text(b.config.label()),
            Cell::Measured(Measured::millis(&b.one_thread), 2),
            Cell::Measured(Measured::millis(&b.all_threads), 2).flagged(
                (b.all_threads.median > b.one_thread.median).then_some(Flag::BelowOneThread),
            ),
            Cell::Number(b.stats.memory_bytes as f64 / (1 << 20) as f64, 2),
            tree(|t| Cell::Count(t.nodes as u64)),
            tree(|t| Cell::Count(t.depth as u64)),
            tree(|t| Cell::Number(t.sah_cost, 2)),
        ]);
    }
    table
}

fn traces_table(r: &SceneResult) -> Table {
    let t = r.threads;
    let labels: Vec<String> = r.compared.iter().map(BackendConfig::label).collect();
    // Backends with a plain-C baseline (Embree), by index.
    let with_c: Vec<usize> = r
        .traces
        .first()
        .map(|row| {
            (1..labels.len())
                .filter(|&j| row.plain_c[j].is_some())
                .collect()
        })
        .unwrap_or_default();
    let mut columns = vec![
        ("kind".to_string(), "rays".to_string()),
        ("rays".to_string(), "count".to_string()),
    ];
    for l in &labels {
        columns.push((format!("{l}_mrays"), format!("{l} Mrays/s, 1 thread")));
    }
    for &j in &with_c {
        let l = &labels[j];
        columns.push((format!("{l}_plain_c_mrays"), format!("{l} plain C")));
    }
    for l in &labels[1..] {
        columns.push((format!("native_over_{l}"), format!("{}/{l}", labels[0])));
    }
    for &j in &with_c {
        let l = &labels[j];
        columns.push((
            format!("{l}_wrapper_over_plain_c"),
            format!("{l} wrapper/plain C"),
        ));
    }
    columns.push(("rounds".to_string(), "rounds".to_string()));
    // On one thread the all-threads columns would repeat the figures.
    let all_threads = t > 1;
    if all_threads {
        for l in &labels {
            columns.push((format!("{l}_mrays_all_threads"), format!("{l} {t} threads")));
        }
        for l in &labels[1..] {
            columns.push((
                format!("native_over_{l}_all_threads"),
                format!("{}/{l}, {t} threads", labels[0]),
            ));
        }
    }
    let mut table = Table::new(columns);
    for row in &r.traces {
        let mut cells = vec![Cell::Text(row.kind.into()), Cell::Count(row.rays as u64)];
        cells.extend(row.one_thread.iter().map(|m| Cell::Measured(*m, 2)));
        cells.extend(with_c.iter().map(|&j| match row.plain_c[j] {
            Some(m) => Cell::Measured(m, 2),
            None => Cell::Empty,
        }));
        cells.extend((1..labels.len()).map(|j| {
            Cell::Ratio(row.ratio(j)).flagged(row.verdict_unsure(j).then_some(Flag::Noisy))
        }));
        cells.extend(with_c.iter().map(|&j| match row.wrapper_speed(j) {
            Some(s) => Cell::Ratio(s),
            None => Cell::Empty,
        }));
        cells.push(Cell::Count(row.rounds as u64));
        if all_threads {
            // A figure on all threads below its one-thread figure is flagged.
            cells.extend(row.all_threads.iter().enumerate().map(|(i, m)| {
                Cell::Measured(*m, 2)
                    .flagged((m.median < row.one_thread[i].median).then_some(Flag::BelowOneThread))
            }));
            cells.extend(
                (1..labels.len())
                    .map(|j| Cell::ratio_of(row.ratio_all_threads(j), &row.pair(j, true))),
            );
        }
        table.row(cells);
    }
    table
}

/// Each backend's batch call against its own single-ray calls, one thread.
fn batch_table(r: &SceneResult) -> Table {
    let mut table = Table::new([
        ("backend", "backend".to_string()),
        ("batch_call", "batch call".to_string()),
        ("batch_mrays", "batch Mrays/s".to_string()),
        ("single_mrays", "single-ray Mrays/s".to_string()),
        ("batch_over_single", "batch / single".to_string()),
    ]);
    for (i, c) in r.compared.iter().enumerate() {
        let single = r.traces[0].one_thread[i];
        let (call, batch) = &r.batch[i];
        table.row(vec![
            Cell::Text(c.label()),
            Cell::Text(call.to_string()),
            Cell::Measured(*batch, 2),
            Cell::Measured(single, 2),
            Cell::ratio_of(batch.median / single.median, &[*batch, single]),
        ]);
    }
    table
}

/// The per-scene section: Markdown and the JSON of every scene.
pub fn section(results: &[SceneResult]) -> (String, Value) {
    let mut md = String::from("## Build and trace, per scene\n\nMedians of warmed-up repeats with their range (min–max); ⚠ marks figures whose repeats spread by more than 10% (and ratios of such figures), ↓ a figure on all threads worse than the same on one thread. Ratios are native / each Embree's throughput: greater than 1 means native is faster.\n\n");
    let mut scenes = Vec::new();
    for r in results {
        let builds = builds_table(r);
        let traces = traces_table(r);
        let batch = batch_table(r);
        let (w, h, spp) = r.frame;
        let frames: Vec<String> = r
            .compared
            .iter()
            .enumerate()
            .map(|(i, c)| {
                let ratio = if i == 0 {
                    String::new()
                } else {
                    format!(" ({:.2}x)", r.frame_ratio(i))
                };
                format!("{} {:.3} s{ratio}", c.label(), r.frame_seconds[i].median)
            })
            .collect();
        md += &format!(
            "### {} ({}: {} primitives)\n\n{}\n{}\nBatch calls on the same camera rays, 1 thread:\n\n{}\nTime per frame ({w}x{h}, {spp} spp, 3 bounces, light sampling, {} threads): {} (in parentheses each Embree's time / native's: greater than 1 means native is faster).\n\n",
            r.scene,
            r.size,
            r.primitives,
            builds.markdown(),
            traces.markdown(),
            batch.markdown(),
            r.threads,
            frames.join(", "),
        );
        let frame_json: serde_json::Map<String, Value> = r
            .compared
            .iter()
            .zip(&r.frame_seconds)
            .map(|(c, t)| (c.label(), json!(t.median)))
            .collect();
        scenes.push(json!({
            "scene": r.scene,
            "size": r.size,
            "primitives": r.primitives,
            "builds": builds.json(),
            "traces": traces.json(),
            "camera_batch": batch.json(),
            "frame_seconds": frame_json,
        }));
    }
    (md, Value::Array(scenes))
}
