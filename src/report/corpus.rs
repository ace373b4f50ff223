//! The corpus replay's tables ([`crate::bench::replay_corpus`]): native
//! against Embree at its best on every mesh, the worst mesh first.

use super::table::{Cell, Flag, Table};
use std::path::Path;

use super::budget::Budget;
use crate::bench::{
    best_embree, corpus, corpus_sets, over_best, replay_mesh, CorpusMesh, CORPUS_KINDS,
};
use crate::measure::Measured;
use crate::measure::Settle;

/// Per ray kind, the worst mesh (native over the best Embree), the median
/// over meshes and the best: the answer first, the detail after.
pub fn worst_table(meshes: &[CorpusMesh]) -> Table {
    let mut table = Table::new([
        ("kind", "rays"),
        ("worst_mesh", "worst mesh"),
        ("worst", "native / best Embree there"),
        ("worst_embree", "best Embree there"),
        ("median", "median over meshes"),
        ("best_mesh", "best mesh"),
        ("best", "native / best Embree there"),
    ]);
    for kind in CORPUS_KINDS {
        let mut ratios: Vec<(f64, &str, String)> = meshes
            .iter()
            .flat_map(|m| {
                m.rows.iter().filter(|r| r.kind == kind).filter_map(|r| {
                    Some((over_best(r)?, m.name.as_str(), best_embree(r)?.name.clone()))
                })
            })
            .collect();
        if ratios.is_empty() {
            continue;
        }
        ratios.sort_by(|a, b| a.0.total_cmp(&b.0));
        let (worst, best) = (&ratios[0], &ratios[ratios.len() - 1]);
        table.row(vec![
            Cell::Text(kind.into()),
            Cell::Text(worst.1.into()),
            Cell::Ratio(worst.0),
            Cell::Text(worst.2.clone()),
            Cell::Ratio(ratios[ratios.len() / 2].0),
            Cell::Text(best.1.into()),
            Cell::Ratio(best.0),
        ]);
    }
    table
}

/// Every mesh and kind: Mrays/s by the thread's CPU time, native over
/// the best Embree, and how the timing settled.
pub fn trace_table(meshes: &[CorpusMesh]) -> Table {
    let Some(first) = meshes.iter().find_map(|m| m.rows.first()) else {
        return Table::new([("mesh", "mesh")]);
    };
    let key = |n: &str| n.replace(' ', "_");
    let mut columns: Vec<(String, String)> = vec![
        ("mesh".into(), "mesh".into()),
        ("triangles".into(), "triangles".into()),
        ("kind".into(), "rays".into()),
    ];
    for run in &first.runs {
        columns.push((
            format!("{}_mrays", key(&run.name)),
            format!("{} Mrays/s", run.name),
        ));
    }
    columns.push(("over_best".into(), "native / best Embree".into()));
    columns.push(("interval".into(), "ratio interval".into()));
    let mut table = Table::new(columns);
    for m in meshes {
        for r in &m.rows {
            let unsettled = (!r.settled).then_some(Flag::Noisy);
            let mut cells = vec![
                Cell::Text(m.name.clone()),
                Cell::Count(m.triangles as u64),
                Cell::Text(r.kind.clone()),
            ];
            cells.extend(r.runs.iter().map(|run| Cell::Measured(run.cpu, 2)));
            cells.push(over_best(r).map_or(Cell::Empty, |x| Cell::Ratio(x).flagged(unsettled)));
            cells.push(Cell::Text(format!("±{:.1}%", r.widest * 100.0)));
            table.row(cells);
        }
    }
    table
}

/// One-thread build times per mesh and backend, and native's time over
/// Embree 3's at medium quality (below 1: native builds faster).
pub fn build_table(meshes: &[CorpusMesh]) -> Table {
    let Some(first) = meshes.first() else {
        return Table::new([("mesh", "mesh")]);
    };
    let key = |n: &str| n.replace(' ', "_");
    let mut columns: Vec<(String, String)> = vec![
        ("mesh".into(), "mesh".into()),
        ("triangles".into(), "triangles".into()),
    ];
    for (name, _) in &first.builds {
        columns.push((format!("{}_ms", key(name)), format!("{name} ms")));
    }
    columns.push((
        "native_over_embree3".into(),
        "native time / embree3's".into(),
    ));
    let mut table = Table::new(columns);
    for m in meshes {
        let mut cells = vec![Cell::Text(m.name.clone()), Cell::Count(m.triangles as u64)];
        cells.extend(
            m.builds
                .iter()
                .map(|(_, t)| Cell::Measured(Measured::millis(t), 1)),
        );
        let embree3 = m.builds.iter().find(|(n, _)| n == "embree3");
        cells.push(match (m.builds.first(), embree3) {
            (Some((_, native)), Some((_, e))) => Cell::Ratio(native.median / e.median),
            _ => Cell::Empty,
        });
        table.row(cells);
    }
    table
}

/// The corpus's answer in one sentence: the worst mesh and kind, and how
/// many of the mesh-kind pairs native wins.
pub fn answer(meshes: &[CorpusMesh]) -> String {
    let pairs: Vec<(f64, &str, &str)> = meshes
        .iter()
        .flat_map(|m| {
            m.rows
                .iter()
                .filter_map(|r| Some((over_best(r)?, m.name.as_str(), r.kind.as_str())))
        })
        .collect();
    let Some(worst) = pairs.iter().min_by(|a, b| a.0.total_cmp(&b.0)) else {
        return "No Embree to compare with: only native was timed.".into();
    };
    let wins = pairs.iter().filter(|p| p.0 > 1.0).count();
    format!(
        "Native is faster than the best Embree on {wins} of {} mesh and ray kinds; the worst is {} {} rays at {:.2}x.",
        pairs.len(),
        worst.1,
        worst.2,
        worst.0
    )
}

/// Every corpus mesh measured in memory, as `hybrid bench` measures an
/// exported corpus, with the budget's rays per kind.
pub fn measure(scenes: &Path, budget: &Budget) -> Result<Vec<CorpusMesh>, String> {
    let settle = Settle {
        min: 3,
        max: 7,
        within: 0.03,
    };
    corpus::names()
        .iter()
        .map(|name| {
            let scene = corpus::load(scenes, name)?;
            let sets = corpus_sets(&scene, budget.corpus_rays)?;
            replay_mesh(name, &scene, &sets, settle)
        })
        .collect()
}

/// The report's corpus section.
pub fn markdown(meshes: &[CorpusMesh], rays: usize) -> String {
    format!(
        "## The mesh corpus: native against Embree at its best on every mesh\n\n\
         **{}**\n\n\
         Every shared mesh and four generated ones (a noisy sphere of 82k and 1.3M triangles, a soup of 100k unconnected triangles, a tube a hundred times longer than wide), {rays} rays per kind, one thread; each Embree called as plain C at medium and high build quality, native over the faster. The same with 10^6 rays: `hybrid rays corpus /tmp/corpus` then `taskset -c 1 hybrid bench /tmp/corpus`.\n\n\
         {}\n{}\nOne-thread builds, median of 3:\n\n{}\n",
        answer(meshes),
        worst_table(meshes).markdown(),
        trace_table(meshes).markdown(),
        build_table(meshes).markdown()
    )
}
