//! `hybrid parity`: the same rays through every backend, tables per ray
//! kind, and (`--hard`) the hard-case table. Exits 1 when agreement falls
//! below the thresholds of `docs/parity.md`.

use clap::Args;

use crate::accel::BackendConfig;
use crate::parity::{format_tables, hard, run_scene};
use crate::scene::NormalMode;

#[derive(Args, Debug, Clone)]
pub struct ParityArgs {
    #[command(flatten)]
    pub input: super::SceneInput,
    /// Rays per ray kind.
    #[arg(long, default_value_t = 10_000)]
    pub rays: usize,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Run the hard numerical cases (the scene, if given, joins them as the
    /// scanned mesh) instead of the scene comparison.
    #[arg(long)]
    pub hard: bool,
}

/// Ok(true) when every threshold holds.
pub fn run(args: &ParityArgs) -> Result<bool, String> {
    if args.rays == 0 {
        return Err("--rays 0: at least one ray per kind is needed".into());
    }
    let per_ray = if args.hard {
        HARD_BYTES_PER_RAY
    } else {
        PARITY_BYTES_PER_RAY
    };
    crate::input::check_memory(
        &format!("--rays {}", args.rays),
        (args.rays as u64).saturating_mul(per_ray),
    )?;
    let scene = args.input.load(NormalMode::Smooth)?;
    if args.hard {
        let scanned = args.input.scene.as_ref().map(|_| &scene);
        let (cases, notes) = hard::cases(args.rays, args.seed, scanned);
        for note in notes {
            say!("note: {note}");
        }
        let reports = hard::run_all(&cases).map_err(|e| e.to_string())?;
        say!(
            "hard cases, {} rays each (failures / rays per backend and mode)\n",
            args.rays
        );
        say!("{}", hard::format_table(&reports));
        let broken: Vec<String> = reports
            .iter()
            .flat_map(|r| {
                r.outcomes.iter().filter_map(move |(mode, o)| {
                    let promise_broken = r.watertight_promise
                        && *mode == BackendConfig::NATIVE_WATERTIGHT
                        && o.failures > 0;
                    (o.nans > 0 || o.panics > 0 || promise_broken)
                        .then(|| format!("{} on {}", mode.label(), r.name))
                })
            })
            .collect();
        if !broken.is_empty() {
            say!("FAILED: {}", broken.join("; "));
        }
        return Ok(broken.is_empty());
    }
    say!("{}", scene.summary());
    let tables = run_scene(&scene, args.rays, args.seed).map_err(|e| e.to_string())?;
    say!("{}", format_tables(&tables));
    let pass = tables
        .iter()
        .all(|t| t.rows.iter().all(|r| r.passes(t.minimum)));
    say!(
        "{}",
        if pass {
            "parity: every backend within the thresholds"
        } else {
            "parity: FAILED thresholds"
        }
    );
    Ok(pass)
}

/// Bytes `parity` holds per ray of each kind: five kinds of 32-byte rays
/// at once, one batch answer per ray, and what making them takes (measured:
/// 216 MiB of peak memory at 10^6 rays on tests/data/tiny.dae), rounded up.
const PARITY_BYTES_PER_RAY: u64 = 256;
/// The same for `--hard`, whose families each make `--rays` rays for
/// several scenes (measured: 137 MiB at 10^5 rays), rounded up.
const HARD_BYTES_PER_RAY: u64 = 2048;
