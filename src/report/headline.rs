//! The headline: per scene, the builds and one-thread throughput of the
//! compared backends on every ray kind, read from the per-scene rows.

use super::scenes::SceneResult;
use super::table::{Cell, Measured, Table};
use crate::accel::config::COMPARED;

/// The headline table (1 thread, Mrays/s; builds in ms on one thread).
pub fn table(results: &[SceneResult]) -> Table {
    let kinds: Vec<&'static str> = results
        .first()
        .map(|r| r.traces.iter().map(|t| t.kind).collect())
        .unwrap_or_default();
    let [a, b] = COMPARED.map(|c| c.label());
    let mut columns = vec![
        ("scene".to_string(), "scene".to_string()),
        ("primitives".into(), "primitives".into()),
        ("native_build_ms".into(), format!("{a} build")),
        ("embree_build_ms".into(), format!("{b} build")),
    ];
    for kind in &kinds {
        columns.push((format!("{kind}_native"), format!("{kind} {a}")));
        columns.push((format!("{kind}_embree"), format!("{kind} {b}")));
        columns.push((format!("{kind}_ratio"), format!("{kind} {a}/{b}")));
    }
    let mut table = Table::new(columns);
    for r in results {
        let build = |i: usize| match r.build(&COMPARED[i]) {
            Some(b) => Cell::Measured(Measured::millis(&b.one_thread), 2),
            None => Cell::Empty,
        };
        let mut row = vec![
            Cell::Text(r.scene.clone()),
            Cell::Count(r.primitives as u64),
            build(0),
            build(1),
        ];
        for t in &r.traces {
            row.push(Cell::Measured(t.one_thread[0], 2));
            row.push(Cell::Measured(t.one_thread[1], 2));
            row.push(Cell::Ratio(t.ratio()));
        }
        table.row(row);
    }
    table
}
