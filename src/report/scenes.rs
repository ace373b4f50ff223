//! Per scene: every build variant's time and memory (one thread and all
//! threads), native tree shape, ray throughput of the compared backends
//! per ray kind, each Embree's coherent batch call, and the time per frame.
//! The compared backends are [`compared`]: native first, then each Embree
//! present; every figure is kept per backend, in that order, and every
//! ratio is native over one of the others.

use super::budget::Budget;
use super::budget::ALL_BUILDS_UP_TO;
use crate::accel::config::{build_variants, compared};
use crate::accel::OneByOne;
use crate::accel::{Accel, AccelStats, Backend, BackendConfig};
use crate::geom::ray::FlatRay;
use crate::geom::Ray;
use crate::measure::paired::{compare, compare_batched, PairedRow};
use crate::measure::{
    coherence_of, mrays_interleaved, on_threads, paired_ratio, process_cpu_seconds, ray_sets,
    time_interleaved, time_interleaved_samples, time_repeats, time_repeats_by, trace_all,
    trace_all_batched, Measured,
};
use crate::render::integrator::{PathSettings, Shading};
use crate::render::{render, Mode, RenderSettings, Silent, WaveTimes};
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
    /// Per compared backend, the frame with every bounce in waves
    /// (`--mode wavefront`), and its ratio to the reference round by round.
    pub frame_seconds_waves: Vec<Measured>,
    pub wave_frame: Vec<(f64, f64, f64)>,
    /// Per compared backend, the default frame and the waves' frame on one
    /// thread (the fields above are on `threads`).
    pub frame_seconds_one: Vec<Measured>,
    pub frame_seconds_waves_one: Vec<Measured>,
    /// Per compared backend, where its waves' time went, summed over the
    /// timed frames (on all threads and on one).
    pub wave_times: Vec<WaveTimes>,
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
                        trace_all_batched(b, &set.rays, set.query, coherence_of(set.kind), threads)
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
    // backend in the renderer's three ways: the reference mode with camera
    // rays in packets, the same with every ray alone (its batch queries
    // answered one ray at a time), the wavefront; then the reference and
    // the wavefront again on one thread.
    let with = |mode, threads| RenderSettings {
        mode: Some(mode),
        threads,
        ..settings.clone()
    };
    let modes = [
        with(Mode::Reference, threads),
        with(Mode::Reference, threads),
        with(Mode::Wavefront, threads),
        with(Mode::Reference, 1),
        with(Mode::Wavefront, 1),
    ];
    let m = modes.len();
    // A backend's frames are neighbours in every round (forwards and
    // backwards alike), so their ratios are taken round by round.
    let mut wave_times = vec![WaveTimes::default(); backends.len()];
    let samples = time_interleaved_samples(m * backends.len(), budget.frame_repeats, |i| {
        let (backend, settings) = (&backends[i / m], &modes[i % m]);
        let out = if i % m == 1 {
            render(scene, &OneByOne(backend), settings, &Silent)
        } else {
            render(scene, backend, settings, &Silent)
        };
        wave_times[i / m] += out.wave_times;
        out
    });
    let per_backend: Vec<&[Vec<f64>]> = samples.chunks(m).collect();
    let packet_frame = per_backend
        .iter()
        .map(|modes| paired_ratio(&modes[0], &modes[1]))
        .collect();
    let wave_frame = per_backend
        .iter()
        .map(|modes| paired_ratio(&modes[2], &modes[0]))
        .collect();
    let frames: Vec<Measured> = samples
        .iter()
        .cloned()
        .map(Measured::from_samples)
        .collect();
    let frame_seconds = frames.iter().step_by(m).copied().collect();
    let frame_seconds_alone = frames.iter().skip(1).step_by(m).copied().collect();
    let frame_seconds_waves = frames.iter().skip(2).step_by(m).copied().collect();
    let frame_seconds_one = frames.iter().skip(3).step_by(m).copied().collect();
    let frame_seconds_waves_one = frames.iter().skip(4).step_by(m).copied().collect();
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
        frame_seconds_waves,
        wave_frame,
        frame_seconds_one,
        frame_seconds_waves_one,
        wave_times,
    })
}
