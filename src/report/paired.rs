//! One-thread figures that a busy machine cannot fool and a plain C
//! program reproduces: every backend on the same rays, each Embree both
//! through hybrid's wrapper and as a plain C caller (`Accel::
//! trace_as_c_caller`), timed by the thread's CPU time in interleaved
//! rounds until every ratio to native is known within the bound
//! ([`Settle`]). `hybrid bench` and the report's trace tables both use it.

use super::measure::{time_settled, trace_all, Measured, Query, Settle};
use super::table::{Cell, Flag, Table};
use crate::accel::Accel;
use crate::geom::ray::FlatRay;
use crate::geom::Ray;

/// One replayed ray set.
pub struct PairedRow {
    pub kind: String,
    pub rays: usize,
    /// Rays that hit (closest hit) or are blocked (occlusion), by native.
    pub hits: usize,
    /// Per run (native first): its name and Mrays/s by thread CPU time and
    /// by wall time.
    pub runs: Vec<(String, Measured, Measured)>,
    pub rounds: usize,
    pub settled: bool,
    pub widest: f64,
}

/// Times `flat` on each backend (native first), and as a plain C caller
/// for each backend that is a C library, interleaved until the ratios to
/// native settle.
pub fn compare<A: Accel>(
    kind: &str,
    query: Query,
    flat: &[FlatRay],
    backends: &[(String, &A)],
    settle: Settle,
) -> PairedRow {
    let rays: Vec<Ray> = flat.iter().map(Ray::from_flat).collect();
    let occluded = query == Query::Occluded;
    // (name, backend, as a C caller)
    let mut runs: Vec<(String, &A, bool)> = Vec::new();
    for &(ref label, accel) in backends {
        if accel.trace_as_c_caller(&[], occluded).is_some() {
            runs.push((format!("{label} plain C"), accel, true));
        }
        runs.push((label.clone(), accel, false));
    }
    let timed = time_settled(runs.len(), settle, |i| {
        let (_, accel, c) = runs[i];
        let hits = if c {
            accel.trace_as_c_caller(flat, occluded).unwrap_or(0)
        } else {
            trace_all(accel, &rays, query, 1)
        };
        std::hint::black_box(hits);
    });
    PairedRow {
        kind: kind.to_string(),
        rays: flat.len(),
        hits: trace_all(backends[0].1, &rays, query, 1),
        runs: runs
            .iter()
            .enumerate()
            .map(|(i, (name, _, _))| {
                (
                    name.clone(),
                    Measured::per_second_millions(flat.len(), &timed.cpu[i]),
                    Measured::per_second_millions(flat.len(), &timed.wall[i]),
                )
            })
            .collect(),
        rounds: timed.rounds,
        settled: timed.settled,
        widest: timed.widest,
    }
}

/// The replay as a table: Mrays/s by CPU time per run, native over each
/// plain-C Embree, each wrapper over its plain C, and how the timing
/// settled.
pub fn table(rows: &[PairedRow]) -> Table {
    let names: Vec<String> = rows
        .first()
        .map(|r| r.runs.iter().map(|(n, _, _)| n.clone()).collect())
        .unwrap_or_default();
    let key = |n: &str| n.replace([' ', '(', ')'], "_");
    let mut columns: Vec<(String, String)> = vec![
        ("kind".into(), "rays".into()),
        ("rays".into(), "count".into()),
        ("hits".into(), "hits".into()),
    ];
    for n in &names {
        columns.push((format!("{}_mrays", key(n)), format!("{n} Mrays/s")));
    }
    let plain: Vec<usize> = (0..names.len())
        .filter(|&i| names[i].ends_with(" plain C"))
        .collect();
    for &i in &plain {
        columns.push((
            format!("native_over_{}", key(&names[i])),
            format!("native / {}", names[i]),
        ));
        columns.push((
            format!("wrapper_over_{}", key(&names[i])),
            format!(
                "{} wrapper / plain C",
                names[i].trim_end_matches(" plain C")
            ),
        ));
    }
    columns.push(("rounds".into(), "rounds".into()));
    columns.push(("interval".into(), "ratio interval".into()));
    let mut table = Table::new(columns);
    for r in rows {
        let mrays = |i: usize| r.runs[i].1;
        let mut cells = vec![
            Cell::Text(r.kind.clone()),
            Cell::Count(r.rays as u64),
            Cell::Count(r.hits as u64),
        ];
        cells.extend((0..r.runs.len()).map(|i| Cell::Measured(mrays(i), 2)));
        let unsettled = (!r.settled).then_some(Flag::Noisy);
        for &i in &plain {
            cells.push(Cell::Ratio(mrays(0).median / mrays(i).median).flagged(unsettled));
            // The wrapper's run follows its plain-C run.
            cells.push(Cell::Ratio(mrays(i + 1).median / mrays(i).median).flagged(unsettled));
        }
        cells.push(Cell::Count(r.rounds as u64));
        cells.push(Cell::Text(format!("±{:.1}%", r.widest * 100.0)));
        table.row(cells);
    }
    table
}
