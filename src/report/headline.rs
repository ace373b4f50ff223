//! The headline: native against Embree on every scene, as speed ratios
//! (greater than 1: native is faster) for the build, each ray kind and a
//! rendered frame, on one thread and on all threads. Read from the
//! per-scene rows.

use super::scenes::SceneResult;
use super::table::{Cell, Table};
use crate::accel::config::COMPARED;

/// One row per measure, one column per scene.
pub fn table(results: &[SceneResult]) -> Table {
    let threads = results.first().map_or(1, |r| r.threads);
    let mut columns = vec![("measure".to_string(), "native / Embree speed".to_string())];
    for (i, r) in results.iter().enumerate() {
        columns.push((format!("scene_{i}"), r.scene.clone()));
    }
    let mut table = Table::new(columns);
    let mut row = |label: String, cells: Vec<Cell>| {
        let mut row = vec![Cell::Text(label)];
        row.extend(cells);
        table.row(row);
    };
    row(
        "triangles".into(),
        results
            .iter()
            .map(|r| Cell::Count(r.triangles as u64))
            .collect(),
    );
    // Builds: Embree's time over native's, so that > 1 means native is
    // faster, as for every other row.
    let build = |r: &SceneResult, all: bool| match (r.build(&COMPARED[0]), r.build(&COMPARED[1])) {
        (Some(n), Some(e)) => {
            let (n, e) = if all {
                (n.all_threads.median, e.all_threads.median)
            } else {
                (n.one_thread.median, e.one_thread.median)
            };
            Cell::Ratio(e / n)
        }
        _ => Cell::Empty,
    };
    row(
        "build, 1 thread".into(),
        results.iter().map(|r| build(r, false)).collect(),
    );
    row(
        format!("build, {threads} threads"),
        results.iter().map(|r| build(r, true)).collect(),
    );
    let kinds: Vec<&'static str> = results
        .first()
        .map(|r| r.traces.iter().map(|t| t.kind).collect())
        .unwrap_or_default();
    for kind in kinds {
        for all in [false, true] {
            let label = if all {
                format!("{kind} rays, {threads} threads")
            } else {
                format!("{kind} rays, 1 thread")
            };
            row(
                label,
                results
                    .iter()
                    .map(|r| match r.traces.iter().find(|t| t.kind == kind) {
                        Some(t) if all => Cell::Ratio(t.ratio_all_threads()),
                        Some(t) => Cell::Ratio(t.ratio()),
                        None => Cell::Empty,
                    })
                    .collect(),
            );
        }
    }
    row(
        format!("frame, {threads} threads"),
        results
            .iter()
            .map(|r| Cell::Ratio(r.frame_seconds[1].median / r.frame_seconds[0].median))
            .collect(),
    );
    table
}

/// The headline section.
pub fn markdown(table: &Table, results: &[SceneResult]) -> String {
    let rays = results
        .first()
        .and_then(|r| r.traces.first())
        .map_or(0, |t| t.rays);
    format!(
        "## Headline: native against Embree\n\nSpeed ratios, native over Embree (builds: Embree's time over native's): greater than 1 means native is faster. Medians of warmed-up repeats on the same rays (about {rays} per kind); the per-scene sections below give the absolute figures with their ranges and mark noisy ones. Ray kinds: camera (jittered pinhole grid over the framed scene), incoherent (origins uniform in the scene's bounds, uniform directions), shadow (the incoherent rays as occlusion queries reaching half the bounds' diagonal), bounce (diffuse rays leaving camera hits) and light (shadow rays from camera hits to light samples). The frame is the per-scene section's path-traced render.\n\n{}\n",
        table.markdown()
    )
}
