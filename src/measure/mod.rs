//! Measurement, below the report and `hybrid bench` and outside the
//! product: medians of warmed-up repeats, ray throughput of a backend (or
//! of two, interleaved) on a fixed ray set, single-threaded or on a pool,
//! the ray sets the report and the benches measure, and the paired replay
//! against each library called as plain C ([`paired`]).

pub mod paired;

use std::time::Instant;

use rayon::prelude::*;

use crate::accel::{Accel, Coherence, TraceCounters};
use crate::geom::Ray;
use crate::parity::rays;
use crate::scene::Scene;

/// Repeats whose spread (max - min over the median) exceeds this are
/// marked noisy in the Markdown and flagged in the JSON.
pub const NOISY_SPREAD: f64 = 0.10;

/// A figure measured several times: its median, smallest and largest value.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Measured {
    pub median: f64,
    pub min: f64,
    pub max: f64,
}

impl Measured {
    /// The median and range of `v` (zero when empty).
    pub fn from_samples(mut v: Vec<f64>) -> Measured {
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n == 0 {
            return Measured::default();
        }
        let median = if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        };
        Measured {
            median,
            min: v[0],
            max: v[n - 1],
        }
    }

    /// Milliseconds of a timing given in seconds.
    pub fn millis(t: &Measured) -> Measured {
        Measured {
            median: t.median * 1e3,
            min: t.min * 1e3,
            max: t.max * 1e3,
        }
    }

    /// Million items per second for `items` processed in each repeat of `t`.
    pub fn per_second_millions(items: usize, t: &Measured) -> Measured {
        let rate = |s: f64| items as f64 / s.max(1e-12) / 1e6;
        Measured {
            median: rate(t.median),
            min: rate(t.max),
            max: rate(t.min),
        }
    }

    /// (max - min) / median.
    pub fn spread(&self) -> f64 {
        if self.median > 0.0 {
            (self.max - self.min) / self.median
        } else {
            0.0
        }
    }

    pub fn is_noisy(&self) -> bool {
        self.spread() > NOISY_SPREAD
    }
}

/// Runs `f` once to warm up, then `repeats` times; returns seconds.
pub fn time_repeats<T>(repeats: usize, f: impl FnMut() -> T) -> Measured {
    let start = Instant::now();
    time_repeats_by(repeats, || start.elapsed().as_secs_f64(), f)
}

/// [`time_repeats`] by the clock `now` (seconds).
pub fn time_repeats_by<T>(
    repeats: usize,
    now: impl Fn() -> f64,
    mut f: impl FnMut() -> T,
) -> Measured {
    std::hint::black_box(f());
    Measured::from_samples(
        (0..repeats.max(1))
            .map(|_| {
                let start = now();
                std::hint::black_box(f());
                now() - start
            })
            .collect(),
    )
}

/// Which query the rays exercise.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Query {
    Closest,
    Occluded,
}

/// Traces every ray once; returns the number of hits (so the work cannot
/// be optimized away).
pub fn trace_all<A: Accel>(accel: &A, rays: &[Ray], query: Query, threads: usize) -> usize {
    let chunk =
        |rays: &[Ray]| trace_counted(accel, rays, query, None, &mut TraceCounters::default());
    if threads <= 1 {
        return chunk(rays);
    }
    // Rayon splits an indexed iterator about as many times as there are
    // threads unless work is stolen; rays whose cost varies along the array
    // (camera rows of sky, then of mesh) left one thread idle for the end
    // of every pass. Jobs of at most 1024 rays balance them.
    rays.par_chunks(256).with_max_len(4).map(chunk).sum()
}

/// As [`trace_all`], through the backend's batch queries
/// ([`Accel::closest_hits`], [`Accel::occluded_all`]) [`BATCH`] rays at a
/// time, answers into buffers on the stack, closest hits with the
/// `coherence` hint ([`coherence_of`] the rays' kind).
pub fn trace_all_batched<A: Accel>(
    accel: &A,
    rays: &[Ray],
    query: Query,
    coherence: Coherence,
    threads: usize,
) -> usize {
    let chunk = |rays: &[Ray]| {
        trace_counted(
            accel,
            rays,
            query,
            Some(coherence),
            &mut TraceCounters::default(),
        )
    };
    if threads <= 1 {
        return chunk(rays);
    }
    rays.par_chunks(BATCH).with_max_len(4).map(chunk).sum()
}

/// Rays per call of the batch queries in the batched measurements.
pub const BATCH: usize = 256;

/// `rays` traced on the calling thread, one query per ray or (`batched`,
/// with its coherence hint) through the backend's batch queries [`BATCH`]
/// at a time: how many hit
/// (or are blocked), the work added to `counters`. The loop every trace
/// measurement times.
#[inline]
pub fn trace_counted<A: Accel>(
    accel: &A,
    rays: &[Ray],
    query: Query,
    batched: Option<Coherence>,
    counters: &mut TraceCounters,
) -> usize {
    match (batched, query) {
        (None, Query::Closest) => rays
            .iter()
            .filter(|r| accel.closest_hit(r, counters).is_some())
            .count(),
        (None, Query::Occluded) => rays.iter().filter(|r| accel.occluded(r, counters)).count(),
        (Some(coherence), Query::Closest) => rays
            .chunks(BATCH)
            .map(|rays| {
                let out = &mut [None; BATCH][..rays.len()];
                accel.closest_hits(rays, coherence, out, counters);
                out.iter().filter(|h| h.is_some()).count()
            })
            .sum(),
        (Some(_), Query::Occluded) => rays
            .chunks(BATCH)
            .map(|rays| {
                let out = &mut [false; BATCH][..rays.len()];
                accel.occluded_all(rays, out, counters);
                out.iter().filter(|&&b| b).count()
            })
            .sum(),
    }
}

/// Million rays per second (median and range over repeats) of `accel` on
/// `rays`.
pub fn mrays<A: Accel>(
    accel: &A,
    rays: &[Ray],
    query: Query,
    threads: usize,
    repeats: usize,
) -> Measured {
    let timing = pooled(threads, || {
        time_repeats(repeats, || trace_all(accel, rays, query, threads))
    });
    Measured::per_second_millions(rays.len(), &timing)
}

/// Timings of `n` runs measured together: after one warm-up each, their
/// repeats interleave, forwards then backwards (A B C, C B A, A B C, ...),
/// so all see the same machine state, where back-to-back blocks of repeats
/// let drift in clock speed, caches or the other core's load land on one
/// of them only.
pub fn time_interleaved<T>(n: usize, repeats: usize, run: impl FnMut(usize) -> T) -> Vec<Measured> {
    time_interleaved_samples(n, repeats, run)
        .into_iter()
        .map(Measured::from_samples)
        .collect()
}

/// [`time_interleaved`]'s seconds, every repeat of every run in round
/// order: `samples[i][r]` is run `i` in round `r`.
pub fn time_interleaved_samples<T>(
    n: usize,
    repeats: usize,
    run: impl FnMut(usize) -> T,
) -> Vec<Vec<f64>> {
    let start = Instant::now();
    time_interleaved_samples_by(n, repeats, || start.elapsed().as_secs_f64(), run)
}

/// [`time_interleaved_samples`] by the clock `now` (seconds).
pub fn time_interleaved_samples_by<T>(
    n: usize,
    repeats: usize,
    now: impl Fn() -> f64,
    mut run: impl FnMut(usize) -> T,
) -> Vec<Vec<f64>> {
    for i in 0..n {
        std::hint::black_box(run(i));
    }
    let mut seconds = vec![Vec::new(); n];
    for round in 0..repeats.max(1) {
        for k in 0..n {
            let i = if round % 2 == 0 { k } else { n - 1 - k };
            let start = now();
            std::hint::black_box(run(i));
            seconds[i].push(now() - start);
        }
    }
    seconds
}

/// `a / b` round by round for two runs timed in the same rounds: the
/// median of those ratios and its 95% interval (`(lo, median, hi)`,
/// [`median_interval`]). A round's two runs see the same machine, so
/// the pairs cancel drift that a ratio of two medians keeps.
pub fn paired_ratio(a: &[f64], b: &[f64]) -> (f64, f64, f64) {
    let ratios: Vec<f64> = a.iter().zip(b).map(|(a, b)| a / b).collect();
    median_interval(&ratios)
}

/// The CPU time this thread has used, in seconds
/// (`CLOCK_THREAD_CPUTIME_ID`): what a one-thread figure counts, so that
/// other work on a busy machine, which takes wall time from the thread but
/// not CPU time, does not move it.
pub fn thread_cpu_seconds() -> f64 {
    cpu_seconds(libc::CLOCK_THREAD_CPUTIME_ID)
}

/// The CPU time every thread of this process has used, in seconds
/// (`CLOCK_PROCESS_CPUTIME_ID`): a one-thread build's figure, which must
/// count the build's own thread (Embree may build on one of its own even
/// when asked for one thread) and not other processes' work.
pub fn process_cpu_seconds() -> f64 {
    cpu_seconds(libc::CLOCK_PROCESS_CPUTIME_ID)
}

fn cpu_seconds(clock: libc::clockid_t) -> f64 {
    let mut t = libc::timespec {
        tv_sec: 0,
        tv_nsec: 0,
    };
    // SAFETY: `t` is a valid timespec to write; both clock ids are
    // constants every Linux kernel since 2.6.12 knows.
    let ok = unsafe { libc::clock_gettime(clock, &mut t) } == 0;
    if ok {
        t.tv_sec as f64 + t.tv_nsec as f64 * 1e-9
    } else {
        f64::NAN
    }
}

/// How one-thread runs stop repeating: after at least `min` rounds (and
/// never before three), once
/// every run's ratio to run 0 is known within this much (the 95% interval
/// of the median of the per-round ratios), or after `max` rounds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Settle {
    pub min: usize,
    pub max: usize,
    /// Half-width of the interval, relative to the median (0.03: ±3%).
    pub within: f64,
}

/// One-thread timings of several runs measured together.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Settled {
    /// Per run: thread CPU seconds per repeat.
    pub cpu: Vec<Measured>,
    /// Per run: wall seconds per repeat.
    pub wall: Vec<Measured>,
    pub rounds: usize,
    /// Whether every ratio to run 0 settled within the bound before the
    /// cap (else the figures are flagged).
    pub settled: bool,
    /// The widest relative half-width of the ratios' intervals.
    pub widest: f64,
}

/// The 95% interval of the median of `v` from order statistics (ranks
/// `n/2 ± 0.98 sqrt(n)`), with no assumption on the distribution.
pub fn median_interval(v: &[f64]) -> (f64, f64, f64) {
    let mut v: Vec<f64> = v.to_vec();
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n == 0 {
        return (0.0, 0.0, 0.0);
    }
    let half = 0.98 * (n as f64).sqrt();
    let centre = n as f64 / 2.0;
    let lo = ((centre - half).floor().max(1.0) as usize).min(n) - 1;
    let hi = ((centre + half).ceil() as usize).clamp(1, n) - 1;
    let median = Measured::from_samples(v.clone()).median;
    (v[lo], median, v[hi])
}

/// What [`time_settled`] asks of a run: the untimed pass over a prefix of
/// its rays just before each timed one ([`Pass::Prime`]), or the timed
/// pass over all of them.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pass {
    Prime,
    Timed,
}

impl Pass {
    /// The part of `items` this pass covers: the first sixteenth (at
    /// least one) for a primer, all of them for a timed pass.
    pub fn part<T>(self, items: &[T]) -> &[T] {
        match self {
            Pass::Prime => &items[..items.len().div_ceil(16)],
            Pass::Timed => items,
        }
    }
}

/// Runs `n` closures in interleaved rounds (forwards, then backwards) on
/// this thread, timing each by thread CPU time and by wall time, until the
/// ratios of run 0's CPU time to every other run's settle ([`Settle`]).
///
/// Each timed pass follows an untimed [`Pass::Prime`] of the same run, so
/// it starts with its own tree and code in the caches, as a program that
/// traces only with that backend does; without it, each pass began with
/// the previous run's data there, and hybrid bench read Embree's packets
/// of 16 on CBbunny's camera rays at 0.78-0.86x of what an independent C
/// program timing them back to back read (0.95-1.02x with it).
pub fn time_settled(n: usize, settle: Settle, mut run: impl FnMut(usize, Pass)) -> Settled {
    for i in 0..n {
        run(i, Pass::Timed);
    }
    let mut cpu = vec![Vec::new(); n];
    let mut wall = vec![Vec::new(); n];
    let mut out = Settled::default();
    for round in 0..settle.max.max(1) {
        for k in 0..n {
            let i = if round % 2 == 0 { k } else { n - 1 - k };
            run(i, Pass::Prime);
            let (c, w) = (thread_cpu_seconds(), Instant::now());
            run(i, Pass::Timed);
            wall[i].push(w.elapsed().as_secs_f64());
            cpu[i].push(thread_cpu_seconds() - c);
        }
        out.rounds = round + 1;
        // Fewer than three ratios bound nothing.
        if out.rounds < settle.min.max(3) {
            continue;
        }
        out.widest = (1..n)
            .map(|j| {
                let (lo, median, hi) = paired_ratio(&cpu[0], &cpu[j]);
                ((hi - median) / median).max((median - lo) / median)
            })
            .fold(0.0, f64::max);
        if out.widest <= settle.within {
            out.settled = true;
            break;
        }
    }
    out.cpu = cpu.into_iter().map(Measured::from_samples).collect();
    out.wall = wall.into_iter().map(Measured::from_samples).collect();
    out
}

/// Million rays per second of several backends on the same `rays`, their
/// repeats interleaved ([`time_interleaved`]).
pub fn mrays_interleaved<A: Accel>(
    accels: &[&A],
    rays: &[Ray],
    query: Query,
    threads: usize,
    repeats: usize,
) -> Vec<Measured> {
    pooled(threads, || {
        time_interleaved(accels.len(), repeats, |i| {
            trace_all(accels[i], rays, query, threads)
        })
        .iter()
        .map(|t| Measured::per_second_millions(rays.len(), t))
        .collect()
    })
}

/// `f` on a pool of `threads` threads, or on this thread for one.
fn pooled<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    if threads <= 1 {
        f()
    } else {
        on_threads(threads, f)
    }
}

/// Runs `f` on a rayon pool of `threads` threads (the global pool when
/// such a pool cannot be made).
pub fn on_threads<T: Send>(threads: usize, f: impl FnOnce() -> T + Send) -> T {
    match rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
        Ok(pool) => pool.install(f),
        Err(_) => f(),
    }
}

/// A named set of rays and the query they exercise.
pub struct RaySet {
    pub kind: &'static str,
    pub query: Query,
    pub rays: Vec<Ray>,
}

/// How alike a kind's rays are ([`RAY_KINDS`], the wave kinds): camera
/// rays are coherent, the others not.
pub fn coherence_of(kind: &str) -> Coherence {
    if kind.starts_with("camera") {
        Coherence::Coherent
    } else {
        Coherence::Incoherent
    }
}

/// The ray kinds of [`ray_sets`], in its order (the files of `hybrid rays
/// export` are named after them).
pub const RAY_KINDS: [&str; 6] = [
    "camera",
    "camera rows",
    "incoherent",
    "shadow",
    "bounce",
    "light",
];

/// The ray kinds the report and the benches trace, about `n` each:
/// - `camera`: jittered pinhole rays in tile order over the framed scene
///   (as the renderer traces them);
/// - `camera rows`: the same rays in scanline order;
/// - `incoherent`: origins uniform in the scene's bounds, uniform
///   directions;
/// - `shadow`: the incoherent rays as occlusion queries reaching half the
///   bounds' diagonal;
/// - `bounce`: diffuse rays leaving camera hits (as the path tracer sends);
/// - `light`: shadow rays from camera hits to light samples (as the path
///   tracer sends).
///
/// Hit points are found with `finder`.
pub fn ray_sets<A: Accel>(scene: &Scene, finder: &A, n: usize) -> Vec<RaySet> {
    vec![
        RaySet {
            kind: RAY_KINDS[0],
            query: Query::Closest,
            rays: rays::camera_rays(scene, n, 1),
        },
        RaySet {
            kind: RAY_KINDS[1],
            query: Query::Closest,
            rays: rays::camera_rays_in(scene, n, 1, rays::CameraOrder::Rows),
        },
        RaySet {
            kind: RAY_KINDS[2],
            query: Query::Closest,
            rays: rays::incoherent_rays(scene, n, 5),
        },
        RaySet {
            kind: RAY_KINDS[3],
            query: Query::Occluded,
            rays: rays::occlusion_rays(scene, n, 5),
        },
        RaySet {
            kind: RAY_KINDS[4],
            query: Query::Closest,
            rays: rays::bounce_rays(scene, finder, n, 3),
        },
        RaySet {
            kind: RAY_KINDS[5],
            query: Query::Occluded,
            rays: rays::shadow_rays(scene, finder, n, 2),
        },
    ]
}

#[cfg(test)]
mod tests;
