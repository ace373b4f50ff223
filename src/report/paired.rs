//! The paired replay's tables ([`crate::measure::paired`]): Mrays/s by CPU
//! time per run and the ratios the report and `hybrid bench` print.

use super::table::{Cell, Flag, Table};
use crate::measure::paired::{PairedRow, Run};

/// The replay as a table: Mrays/s by CPU time per run, native over each
/// plain-C Embree, each wrapper over its plain C, and how the timing
/// settled.
pub fn table(rows: &[PairedRow]) -> Table {
    let Some(first) = rows.first() else {
        return Table::new([("kind", "rays")]);
    };
    let key = |n: &str| n.replace(' ', "_");
    let mut columns: Vec<(String, String)> = vec![
        ("kind".into(), "rays".into()),
        ("rays".into(), "count".into()),
        ("hits".into(), "hits".into()),
    ];
    for run in &first.runs {
        columns.push((
            format!("{}_mrays", key(&run.name)),
            format!("{} Mrays/s", run.name),
        ));
    }
    let plain: Vec<&Run> = first.runs.iter().filter(|r| r.plain_c).collect();
    for run in &plain {
        columns.push((
            format!("native_over_{}", key(&run.name)),
            format!("native / {}", run.name),
        ));
        columns.push((
            format!("wrapper_over_{}", key(&run.name)),
            format!(
                "{} wrapper / plain C",
                first.own(run.backend).map_or("", |r| &r.name)
            ),
        ));
    }
    columns.push(("rounds".into(), "rounds".into()));
    columns.push(("interval".into(), "ratio interval".into()));
    let mut table = Table::new(columns);
    for r in rows {
        let mut cells = vec![
            Cell::Text(r.kind.clone()),
            Cell::Count(r.rays as u64),
            Cell::Count(r.hits as u64),
        ];
        cells.extend(r.runs.iter().map(|run| Cell::Measured(run.cpu, 2)));
        let unsettled = (!r.settled).then_some(Flag::Noisy);
        let native = r.runs[0].cpu.median;
        for c in r.runs.iter().filter(|run| run.plain_c) {
            let own = r.own(c.backend).map_or(f64::NAN, |o| o.cpu.median);
            cells.push(Cell::Ratio(native / c.cpu.median).flagged(unsettled));
            cells.push(Cell::Ratio(own / c.cpu.median).flagged(unsettled));
        }
        cells.push(Cell::Count(r.rounds as u64));
        cells.push(Cell::Text(format!("±{:.1}%", r.widest * 100.0)));
        table.row(cells);
    }
    table
}

/// The batched replay as a table: Mrays/s by CPU time per run, then native
/// packets over native single rays and over Embree's best run (any mode),
/// naming it.
pub fn batched_table(rows: &[PairedRow]) -> Table {
    let Some(first) = rows.first() else {
        return Table::new([("kind", "rays")]);
    };
    let key = |n: &str| n.replace(' ', "_");
    let mut columns: Vec<(String, String)> = vec![
        ("kind".into(), "rays".into()),
        ("rays".into(), "count".into()),
    ];
    for run in &first.runs {
        columns.push((
            format!("{}_mrays", key(&run.name)),
            format!("{} Mrays/s", run.name),
        ));
    }
    columns.push((
        "packets_over_single".into(),
        "native packets / single".into(),
    ));
    columns.push((
        "packets_over_best_embree".into(),
        "native packets / best Embree".into(),
    ));
    columns.push(("best_embree".into(), "best Embree".into()));
    columns.push(("rounds".into(), "rounds".into()));
    columns.push(("interval".into(), "ratio interval".into()));
    let mut table = Table::new(columns);
    for r in rows {
        let mut cells = vec![Cell::Text(r.kind.clone()), Cell::Count(r.rays as u64)];
        cells.extend(r.runs.iter().map(|run| Cell::Measured(run.cpu, 2)));
        let unsettled = (!r.settled).then_some(Flag::Noisy);
        let (single, packets) = (r.runs[0].cpu.median, r.runs[1].cpu.median);
        let best = r
            .runs
            .iter()
            .filter(|run| run.plain_c)
            .max_by(|a, b| a.cpu.median.total_cmp(&b.cpu.median));
        cells.push(Cell::Ratio(packets / single).flagged(unsettled));
        match best {
            Some(b) => {
                cells.push(Cell::Ratio(packets / b.cpu.median).flagged(unsettled));
                cells.push(Cell::Text(b.describe()));
            }
            None => {
                cells.push(Cell::Text("-".into()));
                cells.push(Cell::Text("-".into()));
            }
        }
        cells.push(Cell::Count(r.rounds as u64));
        cells.push(Cell::Text(format!("±{:.1}%", r.widest * 100.0)));
        table.row(cells);
    }
    table
}
