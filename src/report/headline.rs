//! The headline: native against each Embree on every scene, as speed ratios
//! (greater than 1: native is faster) for the build, each ray kind and a
//! rendered frame, on one thread and on all threads. Read from the
//! per-scene rows.

use super::scenes::{BuildRow, SceneResult, Verdict, BEHIND};
use super::table::{Cell, Flag, Table};
use crate::accel::BackendConfig;

/// The Embree backends the headline compares native with: every compared
/// backend after native, by its index in [`SceneResult::compared`].
fn rivals(results: &[SceneResult]) -> Vec<(usize, String)> {
    results.first().map_or(Vec::new(), |r| {
        r.compared
            .iter()
            .enumerate()
            .skip(1)
            .map(|(j, c)| (j, c.label()))
            .collect()
    })
}

/// Builds: backend `j`'s time over `i`'s, so that > 1 means `i` is faster,
/// as for every other row.
fn build_ratio(r: &SceneResult, i: usize, j: usize, all: bool) -> Cell {
    match (r.build(&r.compared[i]), r.build(&r.compared[j])) {
        (Some(a), Some(b)) => {
            let pick = |b: &BuildRow| *(if all { &b.all_threads } else { &b.one_thread });
            let (ta, tb) = (pick(a), pick(b));
            let slower = |b: &BuildRow| b.all_threads.median > b.one_thread.median;
            Cell::ratio_of(tb.median / ta.median, &[ta, tb])
                .flagged((all && (slower(a) || slower(b))).then_some(Flag::BelowOneThread))
        }
        _ => Cell::Empty,
    }
}

/// One row per measure and Embree version, one column per scene.
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
    // On one thread only, the all-threads rows say nothing new.
    let thread_counts: &[bool] = if threads > 1 {
        &[false, true]
    } else {
        &[false]
    };
    let on = |all: bool| {
        if all {
            super::counted(threads, "thread")
        } else {
            "1 thread".into()
        }
    };
    let kinds: Vec<&'static str> = results
        .first()
        .map(|r| r.traces.iter().map(|t| t.kind).collect())
        .unwrap_or_default();
    for (j, rival) in rivals(results) {
        for &all in thread_counts {
            row(
                format!("build, {}, vs {rival}", on(all)),
                results.iter().map(|r| build_ratio(r, 0, j, all)).collect(),
            );
        }
        for kind in &kinds {
            for &all in thread_counts {
                row(
                    format!("{kind} rays, {}, vs {rival}", on(all)),
                    results
                        .iter()
                        .map(|r| match r.traces.iter().find(|t| t.kind == *kind) {
                            Some(t) if all => {
                                Cell::ratio_of(t.ratio_all_threads(j), &t.pair(j, true))
                                    .flagged(t.below_one_thread(j).then_some(Flag::BelowOneThread))
                            }
                            Some(t) => Cell::Ratio(t.ratio(j))
                                .flagged(t.verdict_unsure(j).then_some(Flag::Noisy)),
                            None => Cell::Empty,
                        })
                        .collect(),
                );
            }
        }
        row(
            format!("{rival} wrapper / plain C speed, 1 thread, slowest ray kind"),
            results
                .iter()
                .map(|r| {
                    r.traces
                        .iter()
                        .filter_map(|t| t.wrapper_speed(j))
                        .reduce(f64::min)
                        .map_or(Cell::Empty, Cell::Ratio)
                })
                .collect(),
        );
        row(
            format!("frame, {}, vs {rival}", on(true)),
            results
                .iter()
                .map(|r| Cell::ratio_of(r.frame_ratio(j), &r.frame_pair(j)))
                .collect(),
        );
    }
    table
}

/// Embree 4 against Embree 3 where both are present: Embree 4's speed over
/// Embree 3's per measure (builds and frames: Embree 3's time over Embree
/// 4's), one thread; `None` without both.
pub fn versions_table(results: &[SceneResult]) -> Option<Table> {
    let first = results.first()?;
    let find = |c: BackendConfig| first.index(&c);
    let (e3, e4) = (find(BackendConfig::EMBREE)?, find(BackendConfig::EMBREE4)?);
    let mut columns = vec![(
        "measure".to_string(),
        "Embree 4 / Embree 3 speed".to_string(),
    )];
    for (i, r) in results.iter().enumerate() {
        columns.push((format!("scene_{i}"), r.scene.clone()));
    }
    let mut table = Table::new(columns);
    let mut cells = vec![Cell::Text("build, 1 thread".into())];
    cells.extend(results.iter().map(|r| build_ratio(r, e4, e3, false)));
    table.row(cells);
    for (k, t) in first.traces.iter().enumerate() {
        let mut cells = vec![Cell::Text(format!("{} rays, 1 thread", t.kind))];
        cells.extend(results.iter().map(|r| {
            let t = &r.traces[k];
            let pair = [t.baseline(e4), t.baseline(e3)];
            Cell::ratio_of(pair[0].median / pair[1].median, &pair)
        }));
        table.row(cells);
    }
    let mut cells = vec![Cell::Text(format!(
        "frame, {}",
        super::counted(first.threads, "thread")
    ))];
    cells.extend(results.iter().map(|r| {
        let pair = [r.frame_pair(e4)[1], r.frame_pair(e3)[1]];
        Cell::ratio_of(pair[1].median / pair[0].median, &pair)
    }));
    table.row(cells);
    Some(table)
}

/// The measures the verdict reads, one thread, against backend `j`: label
/// and ratio per scene.
fn one_thread_ratios(r: &SceneResult, j: usize) -> Vec<(String, f64)> {
    let mut out = Vec::new();
    for t in &r.traces {
        out.push((format!("{} rays", t.kind), t.ratio(j)));
    }
    if let (Some(n), Some(e)) = (r.build(&r.compared[0]), r.build(&r.compared[j])) {
        out.push(("builds".into(), e.one_thread.median / n.one_thread.median));
    }
    out
}

/// Where the order of the camera rays (the renderer's tiles or scanline
/// rows) changes what native against backend `j` reads as: ahead (above
/// 1.05x), even, or behind (below [`BEHIND`]).
fn camera_order(meshes: &[&SceneResult], j: usize) -> String {
    let class = Verdict::of;
    let ratio =
        |r: &SceneResult, kind: &str| r.traces.iter().find(|t| t.kind == kind).map(|t| t.ratio(j));
    let changed: Vec<String> = meshes
        .iter()
        .filter_map(|r| {
            let (tiles, rows) = (ratio(r, "camera")?, ratio(r, "camera rows")?);
            (class(tiles) != class(rows))
                .then(|| format!("{} (tiles {tiles:.2}x, rows {rows:.2}x)", r.scene))
        })
        .collect();
    if changed.is_empty() {
        "The camera rays' order (tiles or scanline rows) does not change that verdict on any mesh. "
            .into()
    } else {
        format!(
            "The camera rays' order changes the verdict on {}. ",
            changed.join("; ")
        )
    }
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

/// The report's first sentence per Embree: coherent rays (camera, light),
/// incoherent rays (incoherent, shadow, bounce), builds and frames, each
/// as the range of native's speed over that Embree's across the scenes
/// (one thread; frames on the report's threads). The verdict below gives
/// each measure and scene.
pub fn answer(results: &[SceneResult]) -> String {
    let threads = results.first().map_or(1, |r| r.threads);
    let parts: Vec<String> = rivals(results)
        .into_iter()
        .map(|(j, rival)| {
            // The verdict's measures, every scene's, picked by label.
            let measured: Vec<(String, f64)> = results
                .iter()
                .flat_map(|r| one_thread_ratios(r, j))
                .collect();
            let of = |labels: &[&str]| -> Vec<f64> {
                measured
                    .iter()
                    .filter(|(label, _)| labels.contains(&label.as_str()))
                    .map(|m| m.1)
                    .collect()
            };
            let coherent = of(&["camera rays", "camera rows rays", "light rays"]);
            let incoherent = of(&["incoherent rays", "shadow rays", "bounce rays"]);
            let builds = of(&["builds"]);
            let frames: Vec<f64> = results.iter().map(|r| r.frame_ratio(j)).collect();
            let mut said = Vec::new();
            if !coherent.is_empty() {
                said.push(format!(
                    "coherent rays (camera, light) at {}",
                    range(&coherent)
                ));
            }
            if !incoherent.is_empty() {
                said.push(format!(
                    "incoherent ones (incoherent, shadow, bounce) at {}",
                    range(&incoherent)
                ));
            }
            if !builds.is_empty() {
                said.push(format!("builds at {}", range(&builds)));
            }
            if !frames.is_empty() {
                said.push(format!(
                    "path-traced frames on {} at {}",
                    super::counted(threads, "thread"),
                    range(&frames)
                ));
            }
            format!("against {rival}, native runs {}", said.join(", "))
        })
        .collect();
    if parts.is_empty() {
        return String::new();
    }
    let modes: Vec<ModeFrames> = results
        .iter()
        .flat_map(|r| {
            r.compared.iter().enumerate().map(|(i, c)| ModeFrames {
                scene: &r.scene,
                backend: c.label(),
                ratio: r.packet_frame[i],
                batched: r.frame_seconds[i].median,
                alone: r.frame_seconds_alone[i].median,
            })
        })
        .collect();
    format!(
        "{}**In short:** {} of that Embree's speed (greater than 1: native is faster; one thread unless said, over the {} scenes below, figures marked ⚠ included). {}\n\n",
        which_is_faster(results),
        parts.join("; "),
        results.len(),
        own_modes(&modes)
    )
}

/// The report's first sentence: which backend is faster here, and where
/// it is not, the worst case named (scene, measure, ratio) against each
/// Embree; every ratio is native's speed over that Embree's.
pub fn which_is_faster(results: &[SceneResult]) -> String {
    let mut said = Vec::new();
    for (j, rival) in rivals(results) {
        let mut all: Vec<(String, String, f64)> = Vec::new();
        for r in results {
            for (what, ratio) in one_thread_ratios(r, j) {
                all.push((r.scene.clone(), what, ratio));
            }
            all.push((r.scene.clone(), "frames".into(), r.frame_ratio(j)));
        }
        let all: Vec<_> = all.into_iter().filter(|m| m.2.is_finite()).collect();
        let Some(worst) = all.iter().min_by(|a, b| a.2.total_cmp(&b.2)) else {
            continue;
        };
        let ahead = all.iter().filter(|m| m.2 > 1.0).count();
        let (scene, what, ratio) = worst;
        said.push(if ratio > &1.0 {
            format!(
                "native is faster than {rival} on all {} measures; its smallest lead is {what} on {scene}, {ratio:.2}x",
                all.len()
            )
        } else {
            format!(
                "native is faster than {rival} on {ahead} of {} measures, and slower at worst on {scene}'s {what}, {ratio:.2}x its speed",
                all.len()
            )
        });
    }
    if said.is_empty() {
        return String::new();
    }
    format!("**Which is faster here:** {}.\n\n", said.join("; "))
}

/// One one-thread ray measure against an Embree: its ratio, and whether
/// its interval spans two verdicts.
struct Settling {
    what: String,
    ratio: f64,
    unsure: bool,
}

/// Which conclusions survive the noise (issue 50): the measures whose
/// whole interval reads one verdict, counted by verdict (those behind
/// named), and the ones that do not, named, so that no one reads a
/// verdict into them.
fn survivors(measures: &[Settling], rival: &str) -> String {
    if measures.is_empty() {
        return String::new();
    }
    let settled: Vec<&Settling> = measures.iter().filter(|m| !m.unsure).collect();
    let count = |v: Verdict| settled.iter().filter(|m| Verdict::of(m.ratio) == v).count();
    let behind: Vec<String> = settled
        .iter()
        .filter(|m| Verdict::of(m.ratio) == Verdict::Behind)
        .map(|m| format!("{} {:.2}x", m.what, m.ratio))
        .collect();
    let unsettled: Vec<String> = measures
        .iter()
        .filter(|m| m.unsure)
        .map(|m| format!("{} {:.2}x", m.what, m.ratio))
        .collect();
    let mut text = format!(
        "What survives the noise against {rival}: of {} one-thread ray measures, {} hold one verdict over their whole interval: native ahead on {}, even on {}, behind on {}{}. ",
        measures.len(),
        settled.len(),
        count(Verdict::Ahead),
        count(Verdict::Even),
        count(Verdict::Behind),
        if behind.is_empty() {
            String::new()
        } else {
            format!(" ({})", behind.join(", "))
        }
    );
    if !unsettled.is_empty() {
        text += &format!(
            "{} do not, and say neither ahead, even nor behind: {}. ",
            unsettled.len(),
            unsettled.join(", ")
        );
    }
    text
}

/// One backend's frame on one scene in the renderer's two modes.
struct ModeFrames<'a> {
    scene: &'a str,
    backend: String,
    /// Batched over alone, round by round: `(lo, median, hi)`.
    ratio: (f64, f64, f64),
    /// Median seconds, camera rays batched and every ray alone.
    batched: f64,
    alone: f64,
}

/// Where a backend's frame is slower in the renderer's default mode
/// (camera rays in batches) than with every ray alone, all the interval
/// above 1: said with both frames, since a frame figure then blames the
/// wrong thing (issue 50). Otherwise one clause that none is.
fn own_modes(modes: &[ModeFrames]) -> String {
    let losing: Vec<String> = modes
        .iter()
        .filter(|m| m.ratio.0 > 1.0)
        .map(|m| {
            format!(
                "{} on {} ({:.2} s batched, {:.2} s alone: {:.3}x, interval {:.3}–{:.3})",
                m.backend, m.scene, m.batched, m.alone, m.ratio.1, m.ratio.0, m.ratio.2
            )
        })
        .collect();
    if losing.is_empty() {
        let medians: Vec<f64> = modes.iter().map(|m| m.ratio.1).collect();
        if medians.is_empty() {
            return String::new();
        }
        return format!(
            "No backend's frame is surely slower with camera rays in batches (the reference mode, the default where the wavefront's lanes do not take the scene) than with every ray alone (batched over alone {}).",
            range(&medians)
        );
    }
    format!(
        "A backend's own batching slows its frame, every round: {}; its frame figures above are in the default mode.",
        losing.join("; ")
    )
}

/// The report's opening paragraph: what the headline table says, in words,
/// from the measured ratios (greater than 1: native is faster).
pub fn verdict(results: &[SceneResult], table: &Table) -> String {
    let meshes: Vec<&SceneResult> = results.iter().filter(|r| r.triangles >= 10_000).collect();
    let small: Vec<&SceneResult> = results.iter().filter(|r| r.triangles < 10_000).collect();
    let threads = results.first().map_or(1, |r| r.threads);
    let mut text = String::new();
    for (j, rival) in rivals(results) {
        // Each measure's range over a group of scenes (every scene has the
        // same measures in the same order).
        let describe = |group: &[&SceneResult]| -> Vec<String> {
            let per_scene: Vec<Vec<(String, f64)>> =
                group.iter().map(|r| one_thread_ratios(r, j)).collect();
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
                "Against {rival}, on one thread, on the {} meshes of 10^4 triangles or more, the native BVH's speed is {} {rival}'s (greater than 1 means native is faster). ",
                meshes.len(),
                describe(&meshes).join(", ")
            );
        }
        if !meshes.is_empty() {
            text += &camera_order(&meshes, j);
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
        let frames: Vec<f64> = results.iter().map(|r| r.frame_ratio(j)).collect();
        if !frames.is_empty() {
            text += &format!(
                "A path-traced frame on {} renders at {} of {rival}'s speed. ",
                super::counted(threads, "thread"),
                range(&frames)
            );
        }
        let behind: Vec<String> = results
            .iter()
            .filter_map(|r| {
                let lost: Vec<String> = one_thread_ratios(r, j)
                    .into_iter()
                    .filter(|(_, v)| *v < BEHIND)
                    .map(|(label, v)| format!("{label} {v:.2}x"))
                    .collect();
                (!lost.is_empty()).then(|| format!("{} ({})", r.scene, lost.join(", ")))
            })
            .collect();
        let measures: Vec<Settling> = results
            .iter()
            .flat_map(|r| {
                r.traces.iter().map(|t| Settling {
                    what: format!("{} rays on {}", t.kind, r.scene),
                    ratio: t.ratio(j),
                    unsure: t.verdict_unsure(j),
                })
            })
            .collect();
        text += &survivors(&measures, &rival);
        if behind.is_empty() {
            text += &format!("On one thread native is at least {rival}'s equal (within 5%) on every scene and measure.\n\n");
        } else {
            text += &format!(
                "On one thread native falls behind {rival} (below {BEHIND}x) on {}.\n\n",
                behind.join("; ")
            );
        }
    }
    let (noisy, below) = (table.count(Flag::Noisy), table.count(Flag::BelowOneThread));
    if noisy > 0 {
        text += &format!(
            "Of the headline's figures, {noisy} are marked {} (a one-thread ratio whose interval, unsettled at the round cap, spans two verdicts: behind below 0.95x, even, ahead above 1.05x; or an all-threads figure whose repeats spread by more than 10%): read those with care, or measure again. ",
            Flag::Noisy.mark()
        );
    }
    if below > 0 {
        text += &format!(
            "{below} figures on {} fell below their one-thread figure ({}). ",
            super::counted(threads, "thread"),
            Flag::BelowOneThread.mark()
        );
    }
    if noisy + below > 0 {
        text = text.trim_end().to_string() + "\n\n";
    }
    text
}

/// The headline section.
pub fn markdown(table: &Table, results: &[SceneResult]) -> String {
    let rays = results
        .first()
        .and_then(|r| r.traces.first())
        .map_or(0, |t| t.rays);
    let repeats = results.first().map_or(0, |r| r.repeats);
    format!(
        "## Headline: native against Embree\n\nSpeed ratios, native over each Embree present (`vs embree3`: Debian's 3.13.5; `vs embree4`: Embree 4, its version in the machine section), builds and frames as that Embree's time over native's: greater than 1 means native is faster. On one thread Embree is called as a plain C program calls it (`csrc/embree_plain.c`: one `rtcIntersect1` or `rtcOccluded1` per ray), so that no wrapper's cost is credited to native; the wrapper's own speed against it is a row (each Embree's batch call is in the per-scene sections). One-thread figures are Mrays/s by the thread's CPU time, every run of a ray kind interleaved in rounds until each ratio to native is known within ±3% (95% interval of the median of the per-round ratios) or the round cap, then ⚠; all-threads figures are wall-clock medians of {repeats} interleaved repeats, ⚠ where a figure spread by more than 10%, ↓ where it fell below its one-thread figure. About {rays} rays per kind, the same for every backend (`hybrid rays export` writes them as files, `hybrid bench` replays them; docs/rays.md). Ray kinds: camera (jittered pinhole grid over the framed scene, in the renderer's 8x8 tiles), camera rows (the same rays in scanline order), incoherent (origins uniform in the scene's bounds, uniform directions), shadow (the incoherent rays as occlusion queries reaching half the bounds' diagonal), bounce (diffuse rays leaving camera hits) and light (shadow rays from camera hits to light samples). The frame is the per-scene section's path-traced render.\n\n{}\n{}",
        table.markdown(),
        versions_table(results).map_or(String::new(), |t| format!(
            "### Embree 4 against Embree 3\n\nEmbree 4's speed over Embree 3's on the same rays and frames, both at medium quality (builds and frames: Embree 3's time over Embree 4's), greater than 1 means Embree 4 is faster.\n\n{}\n",
            t.markdown()
        ))
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn mode(scene: &str, backend: &str, ratio: (f64, f64, f64)) -> ModeFrames<'static> {
        ModeFrames {
            scene: Box::leak(scene.to_string().into_boxed_str()),
            backend: backend.to_string(),
            ratio,
            batched: 2.0 * ratio.1,
            alone: 2.0,
        }
    }

    /// A mode that loses in every round is named with both frames; one
    /// whose interval reaches below 1 is not.
    #[test]
    fn the_summary_names_a_backend_whose_batching_slows_its_frame() {
        let modes = [
            mode("CBbunny", "native", (1.02, 1.05, 1.08)),
            mode("CBbunny", "embree4", (0.97, 1.01, 1.04)),
            mode("maxplanck", "native", (0.95, 0.97, 0.99)),
        ];
        let text = own_modes(&modes);
        assert!(
            text.contains("native on CBbunny (2.10 s batched, 2.00 s alone"),
            "{text}"
        );
        assert!(
            !text.contains("embree4") && !text.contains("maxplanck"),
            "{text}"
        );
        let calm = own_modes(&modes[1..]);
        assert!(
            calm.starts_with("No backend's frame is surely slower"),
            "{calm}"
        );
    }

    /// Settled measures are counted by verdict and those behind named;
    /// unsettled ones are named apart, and never counted as a verdict.
    #[test]
    fn the_verdict_says_which_measures_survive_the_noise() {
        let m = |what: &str, ratio: f64, unsure: bool| Settling {
            what: what.into(),
            ratio,
            unsure,
        };
        let text = survivors(
            &[
                m("camera rays on A", 1.30, false),
                m("shadow rays on A", 0.80, false),
                m("light rays on A", 0.96, true),
                m("bounce rays on B", 1.01, false),
            ],
            "embree4",
        );
        assert!(
            text.contains("of 4 one-thread ray measures, 3 hold one verdict"),
            "{text}"
        );
        assert!(
            text.contains("ahead on 1, even on 1, behind on 1 (shadow rays on A 0.80x)"),
            "{text}"
        );
        assert!(
            text.contains(
                "1 do not, and say neither ahead, even nor behind: light rays on A 0.96x"
            ),
            "{text}"
        );
    }
}
