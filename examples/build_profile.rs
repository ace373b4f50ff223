//! Developer tool: builds one scene's BVH repeatedly, for profilers
//! (`valgrind --tool=callgrind`) and build timing. By default native and
//! Embree builds alternate and both medians are printed with their ratio.
//! The native tree as the top-down splits leave it (`--build
//! sah-top-down`) is timed too: what the moves and the planned grouping
//! add to a native build.
//! `ONLY=native`, `ONLY=embree` or `ONLY=top-down` builds one (for
//! profilers).
//! `THREADS=n` uses n threads (default 1); the scene "cloud" is the
//! report's generated 1.31 M-triangle mesh.
//! `cargo run --release --example build_profile -- scene.dae [repeats]`
use std::time::Instant;

use hybrid::accel::{Accel, BackendConfig};
use hybrid::measure::{on_threads, Measured};
use hybrid::scene::{collada, NormalMode};

fn main() {
    let path = std::env::args().nth(1).expect("a scene");
    let repeats: usize = std::env::args()
        .nth(2)
        .map_or(10, |r| r.parse().expect("a count"));
    let threads = std::env::var("THREADS").map_or(1, |t| t.parse().expect("a count"));
    let only = std::env::var("ONLY").ok();
    let scene = if path == "cloud" {
        hybrid::scene::generate::sphere_cloud(64, 5, 1)
    } else {
        collada::load(path.as_ref(), NormalMode::Smooth).expect("scene loads")
    };
    let configs: Vec<(&str, BackendConfig)> = [
        ("native", BackendConfig::NATIVE),
        ("embree", BackendConfig::EMBREE.with_threads(threads)),
        ("top-down", BackendConfig::NATIVE_TOP_DOWN),
    ]
    .into_iter()
    .filter(|(name, _)| only.as_deref().is_none_or(|o| o == *name))
    .collect();
    on_threads(threads, || {
        let mut times = vec![Vec::new(); configs.len()];
        let mut sah = vec![None; configs.len()];
        for round in 0..repeats + 1 {
            for (i, (_, config)) in configs.iter().enumerate() {
                let t = Instant::now();
                let accel = std::hint::black_box(config.build(&scene).expect("builds"));
                let elapsed = t.elapsed();
                sah[i] = accel.stats().tree.map(|t| (t.sah_cost, t.wide_sah_cost));
                if round > 0 {
                    times[i].push(elapsed.as_secs_f64() * 1e3);
                }
            }
        }
        let medians: Vec<f64> = times
            .into_iter()
            .map(|t| Measured::from_samples(t).median)
            .collect();
        let line: Vec<String> = configs
            .iter()
            .zip(&medians)
            .zip(&sah)
            .map(|(((name, _), m), sah)| match sah {
                Some((b, w)) => format!("{name} {m:.2} ms (SAH cost {b:.2} binary, {w:.2} wide)"),
                None => format!("{name} {m:.2} ms"),
            })
            .collect();
        let ratio = if medians.len() >= 2 && only.is_none() {
            format!(" (embree/native {:.2}x)", medians[1] / medians[0])
        } else {
            String::new()
        };
        println!(
            "{path}, {threads} threads, median of {repeats}: {}{ratio}",
            line.join(", ")
        );
    });
}
