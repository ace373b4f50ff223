//! Developer tool: builds one scene's native BVH repeatedly on one thread,
//! for profilers (`valgrind --tool=callgrind`) and build timing.
use std::time::Instant;

use hybrid::accel::BackendConfig;
use hybrid::report::measure::on_threads;
use hybrid::scene::{collada, NormalMode};

fn main() {
    let path = std::env::args().nth(1).expect("a scene");
    let repeats: usize = std::env::args()
        .nth(2)
        .map_or(10, |r| r.parse().expect("a count"));
    // "cloud": the report's generated mesh of 1.31 M triangles.
    let scene = if path == "cloud" {
        hybrid::scene::generate::sphere_cloud(64, 5, 1)
    } else {
        collada::load(path.as_ref(), NormalMode::Smooth).expect("scene loads")
    };
    on_threads(1, || {
        let mut times = Vec::new();
        for _ in 0..repeats {
            let t = Instant::now();
            let config = if std::env::var_os("EMBREE").is_some() {
                BackendConfig::EMBREE.with_threads(1)
            } else {
                BackendConfig::NATIVE
            };
            std::hint::black_box(config.build(&scene).expect("builds"));
            times.push(t.elapsed().as_secs_f64() * 1e3);
        }
        times.sort_by(f64::total_cmp);
        println!(
            "{path}: median {:.2} ms over {repeats} builds",
            times[repeats / 2]
        );
    });
}
