//! Developer tool: one-thread throughput of the compared backends on the
//! report's ray kinds, interleaved so both see the same machine state.
//! Run pinned: `taskset -c 1 cargo run --release --example trace -- \
//! [--rays N] [--repeats R] scene.dae...`

use std::time::Instant;

use hybrid::accel::config::compared;
use hybrid::accel::{Accel, BackendConfig};
use hybrid::measure::{on_threads, ray_sets, trace_all, Measured};
use hybrid::scene::{collada, NormalMode};

fn main() {
    let mut args: Vec<String> = std::env::args().skip(1).collect();
    let mut take = |flag: &str, default: usize| -> usize {
        match args.iter().position(|a| a == flag) {
            Some(i) => {
                let v = args[i + 1].parse().expect("a number");
                args.drain(i..i + 2);
                v
            }
            None => default,
        }
    };
    let rays = take("--rays", 1_000_000);
    let repeats = take("--repeats", 5);
    on_threads(1, || {
        for path in &args {
            // "cloud": the report's generated mesh of 1.31 M triangles.
            let scene = if path == "cloud" {
                hybrid::scene::generate::sphere_cloud(64, 5, 1)
            } else {
                collada::load(path.as_ref(), NormalMode::Smooth).expect("scene loads")
            };
            let compared = compared();
            let builds: Vec<Measured> = compared
                .iter()
                .map(|c| {
                    let c = c.with_threads(1);
                    let mut v = Vec::new();
                    for _ in 0..repeats + 1 {
                        let t = Instant::now();
                        std::hint::black_box(c.build(&scene).expect("builds"));
                        v.push(t.elapsed().as_secs_f64());
                    }
                    Measured::from_samples(v[1..].to_vec())
                })
                .collect();
            let backends: Vec<_> = compared
                .iter()
                .map(|c| c.with_threads(1).build(&scene).expect("builds"))
                .collect();
            let others: Vec<String> = compared[1..]
                .iter()
                .zip(&builds[1..])
                .map(|(c, b)| {
                    format!(
                        "{} {:.2} ms ({:.2}x)",
                        c.label(),
                        b.median * 1e3,
                        b.median / builds[0].median
                    )
                })
                .collect();
            println!(
                "{path}: {} triangles; build native {:.2} ms, {}; SAH cost {:.2}",
                scene.triangle_count(),
                builds[0].median * 1e3,
                others.join(", "),
                backends[0].stats().tree.map_or(0.0, |t| t.sah_cost)
            );
            let finder = BackendConfig::NATIVE.build(&scene).expect("builds");
            for set in ray_sets(&scene, &finder, rays) {
                let mut times = vec![Vec::new(); backends.len()];
                for round in 0..repeats + 1 {
                    for (i, b) in backends.iter().enumerate() {
                        let t = Instant::now();
                        std::hint::black_box(trace_all(b, &set.rays, set.query, 1));
                        if round > 0 {
                            times[i].push(t.elapsed().as_secs_f64());
                        }
                    }
                }
                let t: Vec<Measured> = times.into_iter().map(Measured::from_samples).collect();
                let m = |t: &Measured| set.rays.len() as f64 / t.median / 1e6;
                let spread = |t: &Measured| 100.0 * (t.max - t.min) / t.median;
                let others: Vec<String> = compared[1..]
                    .iter()
                    .zip(&t[1..])
                    .map(|(c, e)| {
                        format!(
                            "{} {:7.2} (±{:.0}%): {:.2}x",
                            c.label(),
                            m(e),
                            spread(e),
                            m(&t[0]) / m(e)
                        )
                    })
                    .collect();
                println!(
                    "  {:10} {:>8} rays: native {:7.2} Mrays/s (±{:.0}%), {}",
                    set.kind,
                    set.rays.len(),
                    m(&t[0]),
                    spread(&t[0]),
                    others.join(", ")
                );
            }
        }
    });
}
