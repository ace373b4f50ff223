//! One-thread figures that a busy machine cannot fool and a plain C
//! program reproduces: every backend on the same rays, each Embree both
//! through hybrid's wrapper and as a plain C caller ([`PlainC`]), timed by the thread's CPU time in interleaved
//! rounds until every ratio to native is known within the bound
//! ([`Settle`]). `hybrid bench` and the report's trace tables both use it.

use super::{
    coherence_of, paired_ratio, thread_cpu_seconds, time_interleaved_samples_by, time_settled,
    trace_all, trace_all_batched, Measured, Pass, Query, Settle, Settled,
};
use crate::accel::config::Backend;
use crate::accel::embree::PlainC;
use crate::accel::BatchMode;
use crate::geom::ray::FlatRay;
use crate::geom::Ray;

/// One timed run: a backend through its `Accel`, or its library called as
/// plain C.
#[derive(Clone, Debug)]
pub struct Run {
    pub name: String,
    /// Index of the backend in the list given to [`compare`].
    pub backend: usize,
    pub plain_c: bool,
    /// For a library's batched mode, whether it ran with the coherent hint
    /// ([`faster_hint`]).
    pub coherent: Option<bool>,
    /// Mrays/s by thread CPU time, and by wall time.
    pub cpu: Measured,
    pub wall: Measured,
}

impl Run {
    /// The run's name, with the hint of a batched mode.
    pub fn describe(&self) -> String {
        match self.coherent {
            Some(true) => format!("{}, coherent hint", self.name),
            Some(false) => format!("{}, no hint", self.name),
            None => self.name.clone(),
        }
    }
}

/// One replayed ray set.
pub struct PairedRow {
    pub kind: String,
    pub rays: usize,
    /// Rays that hit (closest hit) or are blocked (occlusion), by native.
    pub hits: usize,
    /// Native first; each plain-C run just before its backend's own.
    pub runs: Vec<Run>,
    pub rounds: usize,
    pub settled: bool,
    pub widest: f64,
}

impl PairedRow {
    /// Backend `b` through its `Accel`.
    pub fn own(&self, b: usize) -> Option<&Run> {
        self.runs.iter().find(|r| r.backend == b && !r.plain_c)
    }

    /// Backend `b`'s library called as plain C, where it has one.
    pub fn plain_c(&self, b: usize) -> Option<&Run> {
        self.runs.iter().find(|r| r.backend == b && r.plain_c)
    }
}

/// Times `flat` on each backend (native first), and as a plain C caller
/// for each backend that is a C library, interleaved until the ratios to
/// native settle.
pub fn compare(
    kind: &str,
    query: Query,
    flat: &[FlatRay],
    backends: &[(String, &Backend)],
    settle: Settle,
) -> PairedRow {
    compare_runs(kind, query, flat, backends, settle, true)
}

/// [`compare`] with each C library as a plain C caller only (no run
/// through hybrid's wrapper): the corpus's replay, where only native and
/// Embree at its best matter.
pub fn compare_plain(
    kind: &str,
    query: Query,
    flat: &[FlatRay],
    backends: &[(String, &Backend)],
    settle: Settle,
) -> PairedRow {
    compare_runs(kind, query, flat, backends, settle, false)
}

fn compare_runs(
    kind: &str,
    query: Query,
    flat: &[FlatRay],
    backends: &[(String, &Backend)],
    settle: Settle,
    wrappers: bool,
) -> PairedRow {
    let rays: Vec<Ray> = flat.iter().map(Ray::from_flat).collect();
    let occluded = query == Query::Occluded;
    // (name, backend index, as a C caller, no batched hint)
    let mut runs: Vec<(String, usize, bool, Option<bool>)> = Vec::new();
    for (b, (label, accel)) in backends.iter().enumerate() {
        let c = accel.plain_c().is_some();
        if c {
            runs.push((format!("{label} plain C"), b, true, None));
        }
        if wrappers || !c {
            runs.push((label.clone(), b, false, None));
        }
    }
    // Run 0 is native's own; its answers are the row's hit count.
    let mut hits = 0;
    let timed = time_settled(runs.len(), settle, |i, pass| {
        let (_, b, c, _) = runs[i];
        let accel = backends[b].1;
        let n = match accel.plain_c() {
            Some(library) if c => library.trace(pass.part(flat), occluded),
            _ => trace_all(accel, pass.part(&rays), query, 1),
        };
        if i == 0 && pass == Pass::Timed {
            hits = n;
        }
        std::hint::black_box(n);
    });
    row(kind, flat.len(), hits, runs, &timed)
}

/// A replayed set's row from its runs `(name, backend, plain C)` and
/// their timings.
fn row(
    kind: &str,
    rays: usize,
    hits: usize,
    runs: Vec<(String, usize, bool, Option<bool>)>,
    timed: &Settled,
) -> PairedRow {
    let rate = |m: &Measured| Measured::per_second_millions(rays, m);
    PairedRow {
        kind: kind.to_string(),
        rays,
        hits,
        runs: runs
            .into_iter()
            .enumerate()
            .map(|(i, (name, backend, plain_c, coherent))| Run {
                name,
                backend,
                plain_c,
                coherent,
                cpu: rate(&timed.cpu[i]),
                wall: rate(&timed.wall[i]),
            })
            .collect(),
        rounds: timed.rounds,
        settled: timed.settled,
        widest: timed.widest,
    }
}

/// Whether a library's batched `mode` traces `flat` faster with the
/// coherent hint than without: both ways after a warm-up, in two
/// interleaved rounds by the thread's CPU time, the median of the
/// per-round ratios. Embree asks for the hint on coherent rays, but which rays gain
/// depends on the scene: the light rays of a tile's first hits ran faster
/// with it on maxplanck (Embree 3's packets of 16, one thread: 10.5
/// against 5.4 Mrays/s) and slower on CBbunny (19.3 against 24.6), so
/// Embree at its best is whichever of the two was faster.
pub fn faster_hint(
    library: &dyn PlainC,
    flat: &[FlatRay],
    occluded: bool,
    mode: BatchMode,
) -> bool {
    let seconds = time_interleaved_samples_by(2, 2, thread_cpu_seconds, |way| {
        library.trace_batched(flat, occluded, mode, way == 0)
    });
    paired_ratio(&seconds[0], &seconds[1]).1 <= 1.0
}

/// Times `flat` in every mode each backend has: native one ray at a time
/// and in packets ([`Accel::closest_hits`]); each Embree as a plain C
/// caller, one ray at a time and in each batched mode its version has
/// (packets of 8 and 16; Embree 3's stream), each mode with the coherent
/// hint or without, whichever traced these rays faster ([`faster_hint`]).
/// Interleaved until the ratios to native single rays settle.
pub fn compare_batched(
    kind: &str,
    query: Query,
    flat: &[FlatRay],
    backends: &[(String, &Backend)],
    settle: Settle,
) -> PairedRow {
    let rays: Vec<Ray> = flat.iter().map(Ray::from_flat).collect();
    let occluded = query == Query::Occluded;
    // (name, backend index, as a C caller, batched mode and hint; None:
    // single)
    #[derive(Clone)]
    enum Mode {
        Single,
        Batch,
        C(Option<(BatchMode, bool)>),
    }
    let mut runs: Vec<(String, usize, Mode)> = Vec::new();
    for (b, (label, accel)) in backends.iter().enumerate() {
        if let Some(library) = accel.plain_c() {
            runs.push((format!("{label} plain C"), b, Mode::C(None)));
            for mode in BatchMode::ALL {
                if library.trace_batched(&[], occluded, mode, false).is_some() {
                    let coherent = faster_hint(library, flat, occluded, mode);
                    runs.push((
                        format!("{label} {}", mode.name()),
                        b,
                        Mode::C(Some((mode, coherent))),
                    ));
                }
            }
        } else {
            runs.push((label.clone(), b, Mode::Single));
            runs.push((format!("{label} packets"), b, Mode::Batch));
        }
    }
    let mut hits = 0;
    let timed = time_settled(runs.len(), settle, |i, pass| {
        let (_, b, mode) = &runs[i];
        let accel = backends[*b].1;
        let (flat, rays) = (pass.part(flat), pass.part(&rays));
        let n = match mode {
            Mode::Single => trace_all(accel, rays, query, 1),
            Mode::Batch => trace_all_batched(accel, rays, query, coherence_of(kind), 1),
            Mode::C(batch) => {
                let library = accel
                    .plain_c()
                    .expect("a C run is made only for a C library");
                match batch {
                    None => library.trace(flat, occluded),
                    Some((m, coherent)) => library
                        .trace_batched(flat, occluded, *m, *coherent)
                        .unwrap_or(0),
                }
            }
        };
        if i == 0 && pass == Pass::Timed {
            hits = n;
        }
        std::hint::black_box(n);
    });
    let runs = runs
        .into_iter()
        .map(|(name, b, mode)| match mode {
            Mode::C(batch) => (name, b, true, batch.map(|(_, coherent)| coherent)),
            Mode::Single | Mode::Batch => (name, b, false, None),
        })
        .collect();
    row(kind, flat.len(), hits, runs, &timed)
}
