//! Developer tool: builds one scene's BVH repeatedly, for profilers
//! (`valgrind --tool=callgrind`) and build timing. By default native and
//! Embree builds alternate and both medians are printed with their ratio;
//! `ONLY=native` or `ONLY=embree` builds one backend (for profilers).
//! `THREADS=n` uses n threads (default 1); the scene "cloud" is the
//! report's generated 1.31 M-triangle mesh.
//! `cargo run --release --example build_profile -- scene.dae [repeats]`
use std::time::Instant;

use hybrid::accel::BackendConfig;
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
    ]
    .into_iter()
    .filter(|(name, _)| only.as_deref().is_none_or(|o| o == *name))
    .collect();
    on_threads(threads, || {
        let mut times = vec![Vec::new(); configs.len()];
        for round in 0..repeats + 1 {
            for (i, (_, config)) in configs.iter().enumerate() {
                let t = Instant::now();
                std::hint::black_box(config.build(&scene).expect("builds"));
                if round > 0 {
                    times[i].push(t.elapsed().as_secs_f64() * 1e3);
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
            .map(|((name, _), m)| format!("{name} {m:.2} ms"))
            .collect();
        let ratio = if medians.len() == 2 {
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
