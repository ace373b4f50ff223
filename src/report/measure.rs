//! Timing: medians of warmed-up repeats, and ray throughput of a backend on
//! a fixed ray set, single-threaded or on a pool.

use std::time::Instant;

use rayon::prelude::*;

use crate::accel::{Accel, Ray, TraceCounters};

/// Median and spread of repeated measurements.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Timing {
    pub median: f64,
    pub min: f64,
    pub max: f64,
    pub repeats: usize,
}

impl Timing {
    pub fn from_samples(mut v: Vec<f64>) -> Timing {
        v.sort_by(f64::total_cmp);
        let n = v.len();
        if n == 0 {
            return Timing::default();
        }
        let median = if n % 2 == 1 {
            v[n / 2]
        } else {
            0.5 * (v[n / 2 - 1] + v[n / 2])
        };
        Timing {
            median,
            min: v[0],
            max: v[n - 1],
            repeats: n,
        }
    }

    /// Spread as a share of the median: (max - min) / median.
    pub fn spread(&self) -> f64 {
        if self.median > 0.0 {
            (self.max - self.min) / self.median
        } else {
            0.0
        }
    }
}

/// Runs `f` once to warm up, then `repeats` times; returns seconds.
pub fn time_repeats<T>(repeats: usize, mut f: impl FnMut() -> T) -> Timing {
    std::hint::black_box(f());
    Timing::from_samples(
        (0..repeats.max(1))
            .map(|_| {
                let start = Instant::now();
                std::hint::black_box(f());
                start.elapsed().as_secs_f64()
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
    let chunk = |rays: &[Ray]| {
        let mut counters = TraceCounters::default();
        rays.iter()
            .filter(|r| match query {
                Query::Closest => accel.closest_hit(r, &mut counters).is_some(),
                Query::Occluded => accel.occluded(r, &mut counters),
            })
            .count()
    };
    if threads <= 1 {
        return chunk(rays);
    }
    rays.par_chunks(256).map(chunk).sum()
}

/// Million rays per second (median over repeats) of `accel` on `rays`.
pub fn mrays<A: Accel>(
    accel: &A,
    rays: &[Ray],
    query: Query,
    threads: usize,
    repeats: usize,
) -> (f64, Timing) {
    let run = || trace_all(accel, rays, query, threads);
    let timing = if threads <= 1 {
        time_repeats(repeats, run)
    } else {
        match rayon::ThreadPoolBuilder::new().num_threads(threads).build() {
            Ok(pool) => pool.install(|| time_repeats(repeats, run)),
            Err(_) => time_repeats(repeats, run),
        }
    };
    (rays.len() as f64 / timing.median.max(1e-12) / 1e6, timing)
}
