//! `hybrid rays export DIR SCENE` and `hybrid bench DIR`: the report's ray
//! sets as files anyone can replay, and their replay on every backend
//! against Embree called as a plain C program calls it.

use std::path::PathBuf;

use clap::{Args, Subcommand};

use super::SceneInput;
use crate::bench::{batched_table, export, export_corpus, is_corpus, replay, replay_corpus, table};
use crate::measure::{on_threads, Settle};
use crate::scene::NormalMode;

#[derive(Args, Debug, Clone)]
pub struct RaysArgs {
    #[command(subcommand)]
    pub command: RaysCommand,
}

#[derive(Subcommand, Debug, Clone)]
pub enum RaysCommand {
    /// Write a scene's triangles (transforms applied) and every ray kind of
    /// the report into DIR (format: docs/rays.md).
    Export(ExportArgs),
    /// Write the mesh corpus the traversal is judged on: every shared mesh
    /// and four generated ones, one export each in DIR/<mesh>/; `hybrid
    /// bench DIR` replays them all, worst mesh first.
    Corpus(CorpusArgs),
}

#[derive(Args, Debug, Clone)]
pub struct CorpusArgs {
    /// The folder to write (created if missing; its corpus folders are
    /// replaced).
    pub dir: PathBuf,
    /// Folder of the shared scenes (default: HYBRID_SCENES or
    /// ../shared/scenes).
    #[arg(long)]
    pub scenes: Option<PathBuf>,
    /// Rays per kind and mesh.
    #[arg(long, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(1..=(1 << 26)))]
    pub rays: u64,
}

#[derive(Args, Debug, Clone)]
pub struct ExportArgs {
    /// The folder to write (created if missing; its ray files are replaced).
    pub dir: PathBuf,
    #[command(flatten)]
    pub input: SceneInput,
    /// Rays per kind.
    #[arg(long, default_value_t = 1_000_000, value_parser = clap::value_parser!(u64).range(1..=(1 << 26)))]
    pub rays: u64,
}

#[derive(Args, Debug, Clone)]
pub struct BenchArgs {
    /// A folder written by `hybrid rays export`.
    pub dir: PathBuf,
    /// Fewest interleaved rounds per ray kind.
    #[arg(long, default_value_t = 5, value_parser = clap::value_parser!(u64).range(3..=1000))]
    pub min_rounds: u64,
    /// Most rounds: a kind whose ratios have not settled by then is flagged.
    #[arg(long, default_value_t = 21, value_parser = clap::value_parser!(u64).range(3..=1000))]
    pub max_rounds: u64,
    /// Stop once each ratio to native is known within this many percent
    /// (95% interval of the median).
    #[arg(long, default_value_t = 3.0)]
    pub within: f64,
    /// Compare the batched modes instead: native packets against Embree's
    /// packets of 8 and 16 and Embree 3's stream, as a plain C caller.
    #[arg(long)]
    pub batched: bool,
}

/// Checks a `rays` command line as [`run_rays`] does before any work: the
/// memory the rays take and the folder an export writes.
pub fn check_rays(args: &RaysArgs) -> Result<(), String> {
    match &args.command {
        RaysCommand::Export(a) => {
            // Every kind's rays are held at once, as rays and as file
            // records, with the hits the bounce and light rays start from.
            crate::input::check_memory(
                &format!("--rays {}", a.rays),
                a.rays.saturating_mul(EXPORT_BYTES_PER_RAY),
            )?;
            crate::bench::check_export_dir(&a.dir)
        }
        RaysCommand::Corpus(a) => {
            // One mesh's export is held at a time.
            crate::input::check_memory(
                &format!("--rays {}", a.rays),
                a.rays.saturating_mul(EXPORT_BYTES_PER_RAY),
            )?;
            crate::bench::check_corpus_dir(&a.dir)
        }
    }
}

pub fn run_rays(args: &RaysArgs) -> Result<(), String> {
    check_rays(args)?;
    match &args.command {
        RaysCommand::Export(a) => {
            let scene = a.input.load(NormalMode::Smooth)?;
            let out = export(&scene, &a.dir, a.rays as usize)?;
            if out.spheres_dropped > 0 {
                super::report_line(
                    "warning",
                    &format!(
                        "{} spheres left out: the files hold triangles, and the rays were made on them alone",
                        out.spheres_dropped
                    ),
                );
            }
            say!(
                "wrote {} triangles and {} ray sets to {}: {}",
                out.triangles,
                out.sets.len(),
                a.dir.display(),
                out.sets
                    .iter()
                    .map(|(n, c)| format!("{n} ({c})"))
                    .collect::<Vec<_>>()
                    .join(", ")
            );
            Ok(())
        }
        RaysCommand::Corpus(a) => {
            let scenes = a.scenes.clone().unwrap_or_else(super::shared_scenes_dir);
            export_corpus(&scenes, &a.dir, a.rays as usize, |name, out| {
                say!(
                    "{name}: {} triangles, {} ray sets",
                    out.triangles,
                    out.sets.len()
                );
            })?;
            say!("wrote the corpus to {}", a.dir.display());
            Ok(())
        }
    }
}

pub fn run_bench(args: &BenchArgs) -> Result<(), String> {
    if !(args.within > 0.0 && args.within.is_finite()) {
        return Err(format!(
            "--within {}: the bound must be more than 0 percent",
            args.within
        ));
    }
    if args.min_rounds > args.max_rounds {
        return Err(format!(
            "--min-rounds {} is more than --max-rounds {}",
            args.min_rounds, args.max_rounds
        ));
    }
    let settle = Settle {
        min: args.min_rounds as usize,
        max: args.max_rounds as usize,
        within: args.within / 100.0,
    };
    if is_corpus(&args.dir) {
        return bench_corpus(args, settle);
    }
    let rows = on_threads(1, || replay(&args.dir, settle, args.batched))?;
    say!(
        "Replay of {} on one thread: Mrays/s by the thread's CPU time (median and range of the rounds); every run of a kind interleaved, rounds until each ratio to native is known within ±{}% (95% interval of the median of the per-round ratios) or --max-rounds (then ⚠).\n",
        args.dir.display(),
        args.within
    );
    let table = if args.batched {
        batched_table(&rows)
    } else {
        table(&rows)
    };
    say!("{}", table.markdown());
    Ok(())
}

/// `hybrid bench` on a corpus: every mesh replayed, then the answer, the
/// worst mesh per kind, every mesh's rays and the builds.
fn bench_corpus(args: &BenchArgs, settle: Settle) -> Result<(), String> {
    use crate::report::corpus::{answer, build_table, trace_table, worst_table};
    if args.batched {
        return Err(format!(
            "--batched: {} is a corpus; replay one mesh's folder in it to compare the batched modes",
            args.dir.display()
        ));
    }
    let meshes = replay_corpus(&args.dir, settle, |m| {
        eprintln!("{}: replayed", m.name);
    })?;
    say!(
        "Corpus {} on one thread: native against each Embree called as plain C at medium and high build quality; Mrays/s by the thread's CPU time, rounds until each ratio to native is known within ±{}% or --max-rounds (then ⚠).\n",
        args.dir.display(),
        args.within
    );
    say!("**{}**\n", answer(&meshes));
    say!("{}", worst_table(&meshes).markdown());
    say!("{}", trace_table(&meshes).markdown());
    say!("One-thread builds, median of 3 (milliseconds):\n");
    say!("{}", build_table(&meshes).markdown());
    Ok(())
}

/// Bytes an export holds per ray of each kind: six kinds of 32-byte rays,
/// one kind's file records and write buffer, and the hits behind the
/// secondary kinds (measured: 266 MiB of peak memory at 10^6 rays on
/// tests/data/tiny.dae), rounded up.
const EXPORT_BYTES_PER_RAY: u64 = 320;
