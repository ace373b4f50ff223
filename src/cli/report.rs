//! `hybrid report`: the performance comparison report.

use std::path::PathBuf;

use clap::Args;

use crate::report::{run as run_report, ReportOptions};

#[derive(Args, Debug, Clone)]
pub struct ReportArgs {
    /// Folder of the shared scenes (default: HYBRID_SCENES or ../shared/scenes).
    #[arg(long)]
    pub scenes: Option<PathBuf>,
    /// Output folder for report.md, report.json and the plots.
    #[arg(long, default_value = "report")]
    pub out: PathBuf,
    /// Two scenes instead of five, the same rays, fewer rounds and samples
    /// (about seven minutes on two cores).
    #[arg(long)]
    pub quick: bool,
    /// Threads for the all-threads figures (default: all cores).
    #[arg(short = 't', default_value_t = 0)]
    pub threads: usize,
    /// Size of each gallery image (default: 160 120 with --quick, else 480
    /// 360).
    #[arg(long, num_args = 2, value_names = ["W", "H"])]
    pub tile: Option<Vec<u32>>,
}

pub fn run(args: &ReportArgs) -> Result<(), String> {
    let scenes_dir = args.scenes.clone().unwrap_or_else(super::shared_scenes_dir);
    if !scenes_dir.is_dir() {
        return Err(format!(
            "{}: the shared scenes folder does not exist (use --scenes DIR)",
            scenes_dir.display()
        ));
    }
    if args.threads > super::settings::MAX_THREADS {
        return Err(format!(
            "-t {}: at most {} threads (0 means one per core)",
            args.threads,
            super::settings::MAX_THREADS
        ));
    }
    let tile = match args.tile.as_deref() {
        Some(&[w, h]) if (8..=4096).contains(&w) && (8..=4096).contains(&h) => Some((w, h)),
        Some(t) => {
            return Err(format!(
                "--tile {}: each side must be 8..=4096 pixels",
                t.iter()
                    .map(|v| v.to_string())
                    .collect::<Vec<_>>()
                    .join(" ")
            ))
        }
        None => None,
    };
    let options = ReportOptions {
        tile,
        scenes_dir,
        out_dir: args.out.clone(),
        quick: args.quick,
        threads: args.threads,
    };
    run_report(&options, &mut |line| say!("{line}"))
}
