//! Ray files from arbitrary bytes (`hybrid bench`'s input): a checked set
//! or one error, and every ray of a checked set traced as the bench traces
//! it, by native and by each Embree called as a plain C caller (Embree
//! asserts, and aborts the process, on a ray it does not accept).
#![no_main]

use std::path::Path;
use std::sync::OnceLock;

use hybrid::accel::{config::compared, Backend};
use hybrid::bench::{file, scene_of};
use hybrid::measure::Query;
use hybrid::scene::Scene;
use libfuzzer_sys::fuzz_target;

/// Two triangles across the origin, for the rays to meet.
fn scene() -> &'static Scene {
    static SCENE: OnceLock<Scene> = OnceLock::new();
    SCENE.get_or_init(|| {
        scene_of(
            &[
                [-1.0, -1.0, 0.0, 1.0, -1.0, 0.0, 1.0, 1.0, 0.0],
                [-1.0, -1.0, 0.0, 1.0, 1.0, 0.0, -1.0, 1.0, 0.0],
            ],
            "fuzz",
        )
    })
}

fn backends() -> &'static Vec<Backend<'static>> {
    static BACKENDS: OnceLock<Vec<Backend<'static>>> = OnceLock::new();
    BACKENDS.get_or_init(|| {
        compared()
            .iter()
            .map(|c| c.with_threads(1).build(scene()).expect("the backends build"))
            .collect()
    })
}

fuzz_target!(|data: &[u8]| {
    if let Ok((query, rays)) = file::parse_rays(data, Path::new("fuzz.rays")) {
        for backend in backends() {
            if let Some(library) = backend.plain_c() {
                let _ = library.trace(&rays, query == Query::Occluded);
            }
        }
    }
});
