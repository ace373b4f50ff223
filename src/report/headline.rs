//! The headline: native against Embree on every scene, as speed ratios
//! (greater than 1: native is faster) for the build, each ray kind and a
//! rendered frame, on one thread and on all threads. Read from the
//! per-scene rows.

use super::scenes::{BuildRow, SceneResult};
use super::table::{Cell, Flag, Measured, Table};
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
            let pick =
                |b: &BuildRow| Measured::seconds(if all { &b.all_threads } else { &b.one_thread });
            let (tn, te) = (pick(n), pick(e));
            let slower = |b: &BuildRow| b.all_threads.median > b.one_thread.median;
            Cell::ratio_of(te.median / tn.median, &[tn, te])
                .flagged((all && (slower(n) || slower(e))).then_some(Flag::BelowOneThread))
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
                        Some(t) if all => Cell::ratio_of(t.ratio_all_threads(), &t.all_threads)
                            .flagged(t.below_one_thread().then_some(Flag::BelowOneThread)),
                        Some(t) => Cell::ratio_of(t.ratio(), &t.one_thread),
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
            .map(|r| {
                let seconds = r.frame_seconds.each_ref().map(Measured::seconds);
                Cell::ratio_of(r.frame_ratio(), &seconds)
            })
            .collect(),
    );
    table
}

/// The measures the verdict reads, one thread: label and ratio per scene.
fn one_thread_ratios(r: &SceneResult) -> Vec<(String, f64)> {
    let mut out = Vec::new();
    for t in &r.traces {
        out.push((format!("{} rays", t.kind), t.ratio()));
    }
    if let (Some(n), Some(e)) = (r.build(&COMPARED[0]), r.build(&COMPARED[1])) {
        out.push(("builds".into(), e.one_thread.median / n.one_thread.median));
    }
    out
}

/// `a–bx` (or `ax` when they round alike).
fn range(values: &[f64]) -> String {
    let lo = values.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = values.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    if format!("{lo:.2}") == format!("{hi:.2}") {
        format!("{lo:.2}x")
    } else {
        format!("{lo:.2}–{hi:.2}x")
    }
}

/// Ratios below this are where native is said to fall behind (within 5%
/// the two are called even).
const BEHIND: f64 = 0.95;

/// The report's opening paragraph: what the headline table says, in words,
/// from the measured ratios (greater than 1: native is faster).
pub fn verdict(results: &[SceneResult], table: &Table) -> String {
    let meshes: Vec<&SceneResult> = results.iter().filter(|r| r.triangles >= 10_000).collect();
    let small: Vec<&SceneResult> = results.iter().filter(|r| r.triangles < 10_000).collect();
    let threads = results.first().map_or(1, |r| r.threads);
    let mut text = String::new();
    // Each measure's range over a group of scenes (every scene has the
    // same measures in the same order).
    let describe = |group: &[&SceneResult]| -> Vec<String> {
        let per_scene: Vec<Vec<(String, f64)>> =
            group.iter().map(|r| one_thread_ratios(r)).collect();
        let Some(first) = per_scene.first() else {
            return Vec::new();
        };
        first
            .iter()
            .enumerate()
            .map(|(i, (label, _))| {
                let values: Vec<f64> = per_scene
                    .iter()
                    .filter_map(|s| s.get(i))
                    .map(|m| m.1)
                    .collect();
                format!("{} on {label}", range(&values))
            })
            .collect()
    };
    if !meshes.is_empty() {
        text += &format!(
            "On one thread, on the {} meshes of 10^4 triangles or more, the native BVH's speed is {} Embree's (ratios native / Embree: greater than 1 means native is faster). ",
            meshes.len(),
            describe(&meshes).join(", ")
        );
    }
    if !small.is_empty() {
        let names: Vec<String> = small
            .iter()
            .map(|r| format!("{}-primitive", r.primitives))
            .collect();
        text += &format!(
            "On the {} scene{} it is {}. ",
            names.join(" and "),
            if small.len() > 1 { "s" } else { "" },
            describe(&small).join(", ")
        );
    }
    let frames: Vec<f64> = results.iter().map(SceneResult::frame_ratio).collect();
    if !frames.is_empty() {
        text += &format!(
            "A path-traced frame on {threads} threads renders at {} of Embree's speed. ",
            range(&frames)
        );
    }
    let behind: Vec<String> = results
        .iter()
        .filter_map(|r| {
            let lost: Vec<String> = one_thread_ratios(r)
                .into_iter()
                .filter(|(_, v)| *v < BEHIND)
                .map(|(label, v)| format!("{label} {v:.2}x"))
                .collect();
            (!lost.is_empty()).then(|| format!("{} ({})", r.scene, lost.join(", ")))
        })
        .collect();
    if behind.is_empty() {
        text += "On one thread native is at least Embree's equal (within 5%) on every scene and measure.";
    } else {
        text += &format!(
            "On one thread native falls behind (below {BEHIND}x) on {}.",
            behind.join("; ")
        );
    }
    let (noisy, below) = (table.count(Flag::Noisy), table.count(Flag::BelowOneThread));
    if noisy + below > 0 {
        text += &format!(
            " Of the headline's figures, {noisy} rest on repeats that spread by more than 10% ({}) and {below} on {threads} threads fell below their one-thread figure ({}): read those with care, or measure again.",
            Flag::Noisy.mark(),
            Flag::BelowOneThread.mark()
        );
    }
    format!("{text}\n\n")
}

/// The headline section.
pub fn markdown(table: &Table, results: &[SceneResult]) -> String {
    let rays = results
        .first()
        .and_then(|r| r.traces.first())
        .map_or(0, |t| t.rays);
    format!(
        "## Headline: native against Embree\n\nSpeed ratios, native over Embree (builds and frames: Embree's time over native's): greater than 1 means native is faster. Medians of warmed-up repeats on the same rays (about {rays} per kind), native's and Embree's trace and frame repeats interleaved; ⚠ marks a ratio one of whose two figures spread by more than 10% over its repeats, ↓ a figure on all threads below the same figure on one thread (the per-scene sections below give the absolute figures with their ranges). Ray kinds: camera (jittered pinhole grid over the framed scene), incoherent (origins uniform in the scene's bounds, uniform directions), shadow (the incoherent rays as occlusion queries reaching half the bounds' diagonal), bounce (diffuse rays leaving camera hits) and light (shadow rays from camera hits to light samples). The frame is the per-scene section's path-traced render.\n\n{}\n",
        table.markdown()
    )
}
