//! Per scene: every build variant's time and memory (one thread and all
//! threads), native tree shape, ray throughput of the compared backends
//! per ray kind, each Embree's coherent batch call, and the time per frame.
//! The compared backends are [`compared`]: native first, then each Embree
//! present; every figure is kept per backend, in that order, and every
//! ratio is native over one of the others.

use serde_json::{json, Value};

use super::budget::Budget;
use super::budget::ALL_BUILDS_UP_TO;
use super::paired::batched_table;
use super::table::{Cell, Flag, Table};
use crate::accel::config::{build_variants, compared};
use crate::accel::{Accel, AccelStats, Backend, BackendConfig, TreeFacts};
use crate::geom::ray::FlatRay;
use crate::geom::Ray;
use crate::measure::paired::{compare, compare_batched, PairedRow};
use crate::measure::{
    mrays_interleaved, on_threads, paired_ratio, process_cpu_seconds, ray_sets, time_interleaved,
    time_interleaved_samples, time_repeats, time_repeats_by, trace_all, trace_all_batched,
    Measured,
};
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
    /// Camera and light rays in every mode each backend has (native
    /// single and packets; each Embree as a plain C caller, single and
    /// batched), one thread ([`compare_batched`]).
    pub batched: Vec<PairedRow>,
    /// The same kinds on all threads: per compared backend, single rays
    /// and its batch query ([`Accel::closest_hits`] /
    /// [`Accel::occluded_all`]), Mrays/s by wall clock.
    pub batched_all: Vec<(&'static str, Vec<[Measured; 2]>)>,
    /// Per compared backend, how its batch query traces.
    pub batch_calls: Vec<&'static str>,
    /// Frame: width, height, spp; seconds per compared backend, camera
    /// rays in packets (the renderer's default) and alone.
    pub frame: (u32, u32, u32),
    pub frame_seconds: Vec<Measured>,
    pub frame_seconds_alone: Vec<Measured>,
    /// Per compared backend, the frame with packets over without, round
    /// by round ([`paired_ratio`]): `(lo, median, hi)`.
    pub packet_frame: Vec<(f64, f64, f64)>,
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
    // Camera and light rays in every batched mode, one thread and all.
    let batched_sets: Vec<_> = sets
        .iter()
        .filter(|s| s.kind == "camera" || s.kind == "light")
        .collect();
    let batched = batched_sets
        .iter()
        .map(|set| {
            let flat: Vec<FlatRay> = set.rays.iter().map(Ray::flat).collect();
            on_threads(1, || {
                compare_batched(set.kind, set.query, &flat, &labelled, budget.settle)
            })
        })
        .collect();
    let batched_all = batched_sets
        .iter()
        .map(|set| {
            let figures = on_threads(threads, || {
                time_interleaved(2 * backends.len(), budget.repeats, |i| {
                    let b = &backends[i / 2];
                    if i % 2 == 0 {
                        trace_all(b, &set.rays, set.query, threads)
                    } else {
                        trace_all_batched(b, &set.rays, set.query, threads)
                    }
                })
            });
            let rate = |m: &Measured| Measured::per_second_millions(set.rays.len(), m);
            let pairs = figures
                .chunks(2)
                .map(|p| [rate(&p[0]), rate(&p[1])])
                .collect();
            (set.kind, pairs)
        })
        .collect();
    let batch_calls = backends.iter().map(|b| b.stats().batch_call).collect();
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
    // back-to-back repeats of one backend caught the machine's drift. Each
    // backend with packets (camera and first shadow rays), then alone.
    let alone = RenderSettings {
        packets: false,
        ..settings.clone()
    };
    // A backend's two frames are neighbours in every round (forwards and
    // backwards alike), so their ratio is taken round by round.
    let samples = time_interleaved_samples(2 * backends.len(), budget.frame_repeats, |i| {
        let settings = if i % 2 == 0 { &settings } else { &alone };
        render(scene, &backends[i / 2], settings, &Silent)
    });
    let packet_frame = samples
        .chunks(2)
        .map(|pair| paired_ratio(&pair[0], &pair[1]))
        .collect();
    let frames: Vec<Measured> = samples.into_iter().map(Measured::from_samples).collect();
    let frame_seconds = frames.iter().step_by(2).copied().collect();
    let frame_seconds_alone = frames.iter().skip(1).step_by(2).copied().collect();
    Ok(SceneResult {
        size,
        scene: rel.to_string(),
        primitives: scene.primitive_count(),
        triangles: scene.triangle_count(),
        threads,
        repeats: budget.repeats,
        compared,
        builds,
        batched,
        batched_all,
        batch_calls,
        traces,
        frame: (w, h, spp),
        frame_seconds,
        frame_seconds_alone,
        packet_frame,
    })
}

fn builds_table(r: &SceneResult) -> Table {
    let t = r.threads;
    let mut table = Table::new([
        ("build", "build".to_string()),
        ("ms_1_thread", "ms, 1 thread (CPU time)".to_string()),
        (
            "ms_all_threads",
            format!("ms, {}", super::counted(t, "thread")),
        ),
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

/// Each backend's batch query against its own single rays, all threads.
fn batched_all_table(r: &SceneResult) -> Table {
    let t = r.threads;
    let mut columns = vec![("kind", "rays".to_string())];
    let labels: Vec<String> = r.compared.iter().map(|c| c.label()).collect();
    let mut keys = Vec::new();
    for l in &labels {
        keys.push((format!("{l}_single"), format!("{l} single, {t} threads")));
        keys.push((format!("{l}_batch"), format!("{l} batch, {t} threads")));
    }
    keys.push((
        "native_batch_over_best".into(),
        "native batch / best Embree".into(),
    ));
    let mut table = Table::new(
        columns
            .drain(..)
            .map(|(k, v)| (k.to_string(), v))
            .chain(keys),
    );
    for (kind, pairs) in &r.batched_all {
        let mut cells = vec![Cell::Text(kind.to_string())];
        for pair in pairs {
            cells.push(Cell::Measured(pair[0], 2));
            cells.push(Cell::Measured(pair[1], 2));
        }
        let native = pairs[0][1];
        let best = pairs[1..]
            .iter()
            .flatten()
            .max_by(|a, b| a.median.total_cmp(&b.median));
        cells.push(match best {
            Some(b) => Cell::ratio_of(native.median / b.median, &[native, *b]),
            None => Cell::Empty,
        });
        table.row(cells);
    }
    table
}

/// The packets' figures against issue 28's targets, one line per scene
/// and ray kind: native packets over Embree's best mode on one thread
/// (plain C) and on all threads, and each backend's frame time with
/// packets over without.
pub fn packets_section(results: &[SceneResult]) -> (String, Value) {
    let mut table = Table::new([
        ("scene", "scene".to_string()),
        ("kind", "rays".to_string()),
        (
            "packets_over_single",
            "native packets / single, 1 thread".to_string(),
        ),
        (
            "packets_over_best_1",
            "native packets / best Embree, 1 thread".to_string(),
        ),
        ("best_embree_1", "best Embree, 1 thread".to_string()),
        (
            "packets_over_best_all",
            "native packets / best Embree, all threads".to_string(),
        ),
        ("target", "target".to_string()),
    ]);
    let mut frames = Vec::new();
    for r in results {
        for (row, (_, pairs)) in r.batched.iter().zip(&r.batched_all) {
            let (single, packets) = (row.runs[0].cpu.median, row.runs[1].cpu.median);
            let best = row
                .runs
                .iter()
                .filter(|run| run.plain_c)
                .max_by(|a, b| a.cpu.median.total_cmp(&b.cpu.median));
            let best_all = pairs[1..]
                .iter()
                .flatten()
                .map(|m| m.median)
                .fold(f64::NAN, f64::max);
            let target = if row.kind == "camera" { 1.2 } else { 1.0 };
            table.row(vec![
                Cell::Text(r.scene.clone()),
                Cell::Text(row.kind.clone()),
                Cell::Ratio(packets / single),
                best.map_or(Cell::Empty, |b| Cell::Ratio(packets / b.cpu.median)),
                best.map_or(Cell::Empty, |b| Cell::Text(b.describe())),
                Cell::Ratio(pairs[0][1].median / best_all),
                Cell::Text(format!("≥ {target:.1}x")),
            ]);
        }
        frames.push(format!(
            "{}: {}",
            r.scene,
            r.compared
                .iter()
                .enumerate()
                .map(|(i, c)| {
                    let (lo, median, hi) = r.packet_frame[i];
                    format!("{} {median:.3}x ({lo:.3}–{hi:.3})", c.label())
                })
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    let md = format!(
        "## Packets\n\nCamera rays and the light rays of the camera's first hits, traced in batches: native in packets of sixteen rays of one octant with AVX-512, else eight (an interval test of each node's children against the packet, then the single-ray slab test lane by lane, leaves tested all the packet's rays per triangle, a child entered by one ray handed to the single-ray kernel); Embree in each batched mode its version has, called from C (`rtcIntersect8`/`rtcIntersect16`, `rtcOccluded8`/`rtcOccluded16`, Embree 3's `rtcIntersect1M`/`rtcOccluded1M` stream), each mode with the coherent hint or without, whichever traced the rays faster in a trial (the best mode names it). One thread: Mrays/s by CPU time, interleaved rounds as the headline's; all threads: wall clock, each backend's batch query and single rays. Targets (issue 28): native packets at least 1.2x Embree's best mode on camera rays and 1.0x on light rays.\n\n{}\nFrame time with camera rays and the first hits' shadow rays in packets over without (below 1: packets are faster; the per-scene sections' frame, same image either way), the median of the ratios of frames rendered one after the other in each of the interleaved rounds, with its 95% interval in parentheses: {}.\n\n",
        table.markdown(),
        frames.join("; ")
    );
    (md, json!({ "targets": table.json() }))
}

/// The per-scene section: Markdown and the JSON of every scene.
pub fn section(results: &[SceneResult]) -> (String, Value) {
    let mut md = String::from("## Build and trace, per scene\n\nMedians of warmed-up repeats with their range (min–max); ⚠ marks figures whose repeats spread by more than 10% (and ratios of such figures), ↓ a figure on all threads worse than the same on one thread. Ratios are native / each Embree's throughput: greater than 1 means native is faster.\n\n");
    let mut scenes = Vec::new();
    for r in results {
        let builds = builds_table(r);
        let traces = traces_table(r);
        let batched = batched_table(&r.batched);
        let batched_all = batched_all_table(r);
        let calls: Vec<String> = r
            .compared
            .iter()
            .zip(&r.batch_calls)
            .map(|(c, call)| format!("{}: {call}", c.label()))
            .collect();
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
                format!(
                    "{} {:.3} s{ratio}, {:.3} s without packets",
                    c.label(),
                    r.frame_seconds[i].median,
                    r.frame_seconds_alone[i].median
                )
            })
            .collect();
        md += &format!(
            "### {} ({}: {} primitives)\n\n{}\n{}\nCamera and light rays in every batched mode, 1 thread (Mrays/s by CPU time; each Embree called from C):\n\n{}\nThe same on {} threads, through each backend's batch query ({}):\n\n{}\nTime per frame ({w}x{h}, {spp} spp, 3 bounces, light sampling, {} threads; camera rays and first hits' shadow rays in packets unless said): {} (in parentheses each Embree's time / native's: greater than 1 means native is faster).\n\n",
            r.scene,
            r.size,
            r.primitives,
            builds.markdown(),
            traces.markdown(),
            batched.markdown(),
            r.threads,
            calls.join("; "),
            batched_all.markdown(),
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
            "batched": batched.json(),
            "batched_all_threads": batched_all.json(),
            "frame_seconds": frame_json,
            "frame_seconds_without_packets": r
                .compared
                .iter()
                .zip(&r.frame_seconds_alone)
                .map(|(c, t)| (c.label(), json!(t.median)))
                .collect::<serde_json::Map<String, Value>>(),
            "frame_with_packets_over_without": r
                .compared
                .iter()
                .zip(&r.packet_frame)
                .map(|(c, (lo, median, hi))| {
                    (c.label(), json!({ "median": median, "lo": lo, "hi": hi }))
                })
                .collect::<serde_json::Map<String, Value>>(),
        }));
    }
    (md, Value::Array(scenes))
}
