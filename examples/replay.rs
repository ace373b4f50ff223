//! Developer tool: native single rays and packets on one exported ray set,
//! traced on the calling (main) thread, best of `PASSES` passes. Where
//! `hybrid bench` interleaves every backend on a pool thread, this runs one
//! thing where its caller's stack lies, for profiling (`perf record -e
//! cpu-clock`) and for checking that speed does not depend on stack
//! placement (docs/design.md, Measuring):
//!
//! ```text
//! hybrid rays export DIR scene.dae
//! taskset -c 1 cargo run --release --example replay -- DIR camera [single|packets|both] [PASSES]
//! PAD=$(head -c 200 /dev/zero | tr '\0' x) setarch -R taskset -c 1 target/release/examples/replay DIR camera single
//! ```
//!
//! With `REPLAY_MISS=1` every ray is first moved 10^4 to the side of the
//! scene, so that all miss it: what is left is the cost outside the tree.
//!
//! Mode `groups` traces each run of `REPLAY_GROUP` (16 unless set)
//! consecutive rays as one batch query, as a renderer that keeps eight or
//! sixteen paths in lanes from camera to end would trace each bounce of a
//! group (docs/experiments.md); full groups, so an upper bound.
//!
//! Prints Mrays/s, hits and box and primitive tests per ray for each mode;
//! the loop is the report's own (`measure::trace_counted`, batch
//! queries of 256 rays).

use std::path::Path;
use std::process::ExitCode;
use std::time::Instant;

use hybrid::accel::{BackendConfig, Coherence, TraceCounters};
use hybrid::bench::{file, file_name, scene_of};
use hybrid::geom::Ray;
use hybrid::measure::trace_counted;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(dir), Some(kind)) = (args.first(), args.get(1)) else {
        eprintln!("usage: replay DIR KIND [single|packets|groups|both] [PASSES]");
        return ExitCode::from(2);
    };
    let mode = args.get(2).map_or("both", String::as_str);
    let passes: usize = match args.get(3).map(|p| p.parse()) {
        None => 5,
        Some(Ok(p)) if p > 0 => p,
        Some(_) => {
            eprintln!("replay: PASSES must be a positive whole number");
            return ExitCode::from(2);
        }
    };
    let dir = Path::new(dir);
    let loaded = file::read_triangles(&dir.join("triangles.bin")).and_then(|triangles| {
        file::read_rays(&dir.join(file_name(kind))).map(|rays| (triangles, rays))
    });
    let (triangles, (query, flat)) = match loaded {
        Ok(loaded) => loaded,
        Err(e) => {
            eprintln!("replay: {e}");
            return ExitCode::from(2);
        }
    };
    let scene = scene_of(&triangles, &dir.display().to_string());
    // REPLAY_LANES=8 or 16 asks for a packet width (16 without AVX-512:
    // two AVX2 registers per value).
    let lanes = std::env::var("REPLAY_LANES")
        .ok()
        .and_then(|l| l.parse().ok())
        .unwrap_or(0);
    let config = match BackendConfig::NATIVE {
        BackendConfig::Native(o) => BackendConfig::Native(hybrid::accel::native::NativeOptions {
            packet_lanes: lanes,
            ..o
        }),
        other => other,
    };
    let native = match config.with_threads(1).build(&scene) {
        Ok(native) => native,
        Err(e) => {
            eprintln!("replay: {e}");
            return ExitCode::from(2);
        }
    };
    let mut rays: Vec<Ray> = flat.iter().map(Ray::from_flat).collect();
    if std::env::var_os("REPLAY_MISS").is_some() {
        // Every ray moved off to the side: what is left is the cost
        // outside the tree (a packet's setup, the batch's loop).
        for r in &mut rays {
            r.origin.x += 1e4;
        }
    }
    let group = std::env::var("REPLAY_GROUP")
        .ok()
        .and_then(|g| g.parse().ok())
        .filter(|&g: &usize| g > 0)
        .unwrap_or(16);
    for name in ["single", "packets", "groups"] {
        if mode != name && !(mode == "both" && name != "groups") {
            continue;
        }
        let mut best = f64::MAX;
        let (mut hits, mut counters) = (0, TraceCounters::default());
        for _ in 0..passes {
            counters = TraceCounters::default();
            let start = Instant::now();
            hits = match name {
                "single" => trace_counted(&native, &rays, query, None, &mut counters),
                "packets" => trace_counted(
                    &native,
                    &rays,
                    query,
                    Some(Coherence::Incoherent),
                    &mut counters,
                ),
                _ => rays
                    .chunks(group)
                    .map(|g| {
                        trace_counted(
                            &native,
                            g,
                            query,
                            Some(Coherence::Incoherent),
                            &mut counters,
                        )
                    })
                    .sum(),
            };
            best = best.min(start.elapsed().as_secs_f64());
        }
        let n = rays.len() as f64;
        println!(
            "{name:8} {:.2} Mrays/s, {hits} hits, {:.1} box and {:.1} primitive tests per ray",
            n / best / 1e6,
            counters.box_tests as f64 / n,
            counters.prim_tests as f64 / n
        );
    }
    ExitCode::SUCCESS
}
