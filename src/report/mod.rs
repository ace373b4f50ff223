//! The BVH performance comparison report: build and trace speed of the
//! backends side by side, speed against error, scaling with scene size,
//! and a gallery, measured in one run and written as `report.md`,
//! `report.json` and plots.
//!
//! Sections, each measuring into typed rows: [`scenes`] (per-scene builds
//! and traces), [`headline`] (read from the per-scene rows), [`brute`],
//! [`error`], [`sampler`], [`adaptive`], [`environment`], [`scaling`], [`gallery`]. [`table`] is the one writer of
//! rows as Markdown and JSON; [`budget`] holds the sizes and scene lists;
//! [`crate::measure`], [`plot`], [`sheet`] and [`machine`] are their tools.

pub mod adaptive;
pub mod brute;
pub mod budget;
pub mod corpus;
pub mod environment;
pub mod error;
pub mod fireflies;
pub mod gallery;
pub mod headline;
pub mod machine;
pub mod paired;
pub mod plot;
pub mod sampler;
pub mod scaling;
pub mod scene_tables;
pub mod scenes;
pub mod sheet;
pub mod table;

use std::path::{Path, PathBuf};
use std::time::Instant;

use serde_json::json;

use self::budget::{report_scenes, Budget};
use crate::accel::config::compared;
use crate::accel::{Accel, AccelError};
use crate::scene::builtin::Builtin;
use crate::scene::{collada, NormalMode, Scene};

/// What to run and where to write it.
pub struct ReportOptions {
    pub scenes_dir: PathBuf,
    pub out_dir: PathBuf,
    /// Two scenes instead of five, fewer rounds, samples and resolutions:
    /// about seven minutes on two cores.
    pub quick: bool,
    /// Threads for the "all threads" figures; 0 means all cores.
    pub threads: usize,
    /// The gallery's image size, if not the budget's.
    pub tile: Option<(u32, u32)>,
}

/// Loads a shared scene of the report.
pub(crate) fn load(dir: &Path, rel: &str) -> Result<Scene, String> {
    collada::load(&dir.join(rel), NormalMode::Smooth).map_err(|e| e.to_string())
}

/// Loads one of the project's own scenes.
pub(crate) fn load_builtin(builtin: Builtin) -> Result<Scene, String> {
    builtin.load(NormalMode::Smooth).map_err(|e| e.to_string())
}

/// `n` and its noun, plural unless `n` is one: `1 thread`, `2 threads`.
pub(crate) fn counted(n: usize, noun: &str) -> String {
    if n == 1 {
        format!("1 {noun}")
    } else {
        format!("{n} {noun}s")
    }
}

fn threads_or_all(threads: usize) -> usize {
    if threads == 0 {
        std::thread::available_parallelism()
            .map(|n| n.get())
            .unwrap_or(1)
    } else {
        threads
    }
}

/// Writes the report; `log` receives one line per finished step.
pub fn run(options: &ReportOptions, log: &mut dyn FnMut(&str)) -> Result<(), String> {
    let start = Instant::now();
    let mut step = |what: &str| {
        log(&format!(
            "report: {what} ({:.0} s)",
            start.elapsed().as_secs_f64()
        ))
    };
    let mut budget = Budget::new(options.quick);
    if let Some(tile) = options.tile {
        budget.gallery = tile;
    }
    let threads = threads_or_all(options.threads);
    for rel in budget::shared_scenes(options.quick) {
        load(&options.scenes_dir, rel).map_err(|e| {
            format!(
                "the report needs {rel} from --scenes {}: {e}",
                options.scenes_dir.display()
            )
        })?;
    }
    let out = &options.out_dir;
    std::fs::create_dir_all(out)
        .map_err(|e| format!("{}: cannot create the folder: {e}", out.display()))?;
    let machine = machine::Machine::detect();
    // Which kernels each backend runs here (native's traversal and packet
    // width, Embree's version and ISA), so a reader on another CPU knows
    // which figures apply to theirs.
    let kernels = compared()
        .iter()
        .map(|c| {
            let stats = c.build(&Scene::default())?.stats();
            Ok(format!(
                "{}: {}; batches: {}",
                c.label(),
                stats.details,
                stats.batch_call
            ))
        })
        .collect::<Result<Vec<String>, AccelError>>()
        .map_err(|e| e.to_string())?;
    let embree_version = kernels[1..].join("; ");

    let mut per_scene = Vec::new();
    for s in &report_scenes(options.quick) {
        let scene = s.load(&options.scenes_dir)?;
        per_scene.push(scenes::measure(
            s.size,
            &s.name(),
            &scene,
            &budget,
            threads,
        )?);
        step(&format!("{} measured", s.name()));
    }
    let brute_rows = brute::measure(&options.scenes_dir, &budget)?;
    step("brute force measured");
    let error_study = error::measure(&budget, threads)?;
    error::plot(&error_study, out)?;
    step("speed against error measured");
    let sampler_study = sampler::measure(&options.scenes_dir, options.quick, threads)?;
    step("samplers measured");
    let adaptive_study = adaptive::measure(&options.scenes_dir, &budget, threads)?;
    step("adaptive against uniform measured");
    let environment_study = environment::measure(&budget, threads, out)?;
    step("environment light measured");
    let corpus_study = corpus::measure(&options.scenes_dir, &budget)?;
    step("mesh corpus measured");
    let scaling = scaling::measure(&options.scenes_dir, &budget)?;
    scaling::plot(&scaling, out)?;
    step("scaling measured");
    let gallery_md = gallery::section(&options.scenes_dir, out, &budget, threads)?;
    step("gallery rendered");

    let headline = headline::table(&per_scene);
    let (scenes_md, scenes_json) = scene_tables::section(&per_scene);
    let (packets_md, packets_json) = scene_tables::packets_section(&per_scene);
    let brute_table = brute::table(&brute_rows);
    let answer = headline::answer(&per_scene);
    let mut md = format!(
        "# hybrid: native BVH against Embree\n\n{answer}Measured on {} ({}; ISA {}), {}, hybrid {}, on {}. Settings: {} run, {} rays per ray kind, medians of {} warmed-up repeats ({} per frame; range in parentheses: min–max), all-threads figures on {}.\n\n",
        machine.cpu,
        counted(machine.cores, "core"),
        machine.isa.join(" "),
        machine.rustc,
        machine.crate_version,
        machine.date,
        if options.quick { "quick" } else { "full" },
        budget.rays,
        budget.repeats,
        budget.frame_repeats,
        counted(threads, "thread"),
    );
    md += &format!("Kernels: {}.\n\n", kernels.join(". "));
    if let Some(cap) = crate::simd::cpu::Isa::cap_note() {
        md += &format!("{cap}.\n\n");
    }
    let verdict = headline::verdict(&per_scene, &headline);
    md += &verdict;
    md += &headline::markdown(&headline, &per_scene);
    md += &error::headline(&error_study);
    md += &packets_md;
    md += &scenes_md;
    md += &format!(
        "## With and without acceleration (camera rays, 1 thread)\n\n{}\n",
        brute_table.markdown()
    );
    md += &error::markdown(&error_study);
    md += &sampler::markdown(&sampler_study);
    md += &adaptive::markdown(&adaptive_study);
    md += &environment::markdown(&environment_study, &budget);
    md += &corpus::markdown(&corpus_study, budget.corpus_rays);
    md += &scaling::markdown(&scaling);
    md += &gallery_md;
    md += &format!(
        "\nThe whole report took {:.0} s.\n",
        start.elapsed().as_secs_f64()
    );
    let report_json = json!({
        "machine": {"cpu": machine.cpu, "cores": machine.cores, "isa": machine.isa, "rustc": machine.rustc, "hybrid": machine.crate_version, "embree": embree_version, "kernels": kernels, "isa_ceiling": crate::simd::cpu::Isa::ceiling().name(), "date": machine.date},
        "settings": {"quick": options.quick, "rays": budget.rays, "repeats": budget.repeats, "frame_repeats": budget.frame_repeats, "threads": threads},
        "answer": answer.trim(),
        "verdict": verdict.trim(),
        "headline": headline.json(),
        "scenes": scenes_json,
        "packets": packets_json,
        "brute_force": brute_table.json(),
        "speed_vs_error": {
            "scene": error_study.scene,
            "points": error::points_table(&error_study).json(),
            "slopes": error::slopes_table(&error_study).json(),
            "equal_time_seconds": error_study.equal_time(),
            "equal_time": error::equal_time_table(&error_study).json(),
        },
        "samplers": sampler::table(&sampler_study).json(),
        "adaptive_vs_uniform": adaptive::table(&adaptive_study).json(),
        "environment": environment::table(&environment_study).json(),
        "corpus": {
            "answer": corpus::answer(&corpus_study),
            "worst": corpus::worst_table(&corpus_study).json(),
            "rays": corpus::trace_table(&corpus_study).json(),
            "builds": corpus::build_table(&corpus_study).json(),
        },
        "scaling": {
            "rows": scaling::table(&scaling).json(),
            "slopes": scaling::slopes_table(&scaling).json(),
        },
        "seconds": start.elapsed().as_secs_f64(),
    });
    let write = |name: &str, text: &str| {
        std::fs::write(out.join(name), text)
            .map_err(|e| format!("{}: {e}", out.join(name).display()))
    };
    write("report.md", &md)?;
    write(
        "report.json",
        &serde_json::to_string_pretty(&report_json).map_err(|e| e.to_string())?,
    )?;
    step(&format!("wrote {}", out.join("report.md").display()));
    Ok(())
}

#[cfg(test)]
mod tests {
    #[test]
    fn counts_of_one_are_singular_and_others_plural() {
        assert_eq!(super::counted(1, "thread"), "1 thread");
        assert_eq!(super::counted(2, "core"), "2 cores");
        assert_eq!(super::counted(0, "thread"), "0 threads");
    }
}
