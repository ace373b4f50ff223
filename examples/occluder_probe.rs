//! Developer tool: the bet of an occluder cache, measured on exported rays
//! before any traversal is changed (docs/experiments.md). A
//! cache would test the triangle that blocked the batch's last shadow ray
//! (or one of its last four) before the tree; it can only pay where rays
//! are blocked and neighbours are blocked by the same triangle. For each
//! ray of a set, the probe finds a blocker (the closest hit within the
//! ray's interval) and counts how often the last blocker, or one of the
//! last four, blocks the ray too:
//!
//! ```text
//! hybrid rays export /tmp/rays-bunny ../shared/scenes/sky/CBbunny.dae
//! cargo run --release --example occluder_probe -- /tmp/rays-bunny wave_shadow.rays
//! ```

use std::path::Path;
use std::process::ExitCode;

use hybrid::accel::native::triangle::{MollerTrumbore, TriangleTest};
use hybrid::accel::{Accel, BackendConfig, TraceCounters};
use hybrid::bench::{file, scene_of};
use hybrid::geom::Ray;

/// Blockers the cache remembers.
const REMEMBERED: usize = 4;

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let (Some(dir), Some(set)) = (args.first(), args.get(1)) else {
        eprintln!("usage: occluder_probe RAYS_DIR SET.rays");
        return ExitCode::from(2);
    };
    let dir = Path::new(dir);
    let loaded = file::read_triangles(&dir.join("triangles.bin"))
        .and_then(|triangles| file::read_rays(&dir.join(set)).map(|(_, rays)| (triangles, rays)));
    let (triangles, flat) = match loaded {
        Ok(loaded) => loaded,
        Err(e) => {
            eprintln!("occluder_probe: {e}");
            return ExitCode::from(2);
        }
    };
    let scene = scene_of(&triangles, &dir.display().to_string());
    let native = match BackendConfig::NATIVE.with_threads(1).build(&scene) {
        Ok(native) => native,
        Err(e) => {
            eprintln!("occluder_probe: {e}");
            return ExitCode::from(2);
        }
    };
    let rays: Vec<Ray> = flat.iter().map(Ray::from_flat).collect();
    let mut counters = TraceCounters::default();
    let (mut blocked, mut by_last, mut by_recent) = (0usize, 0usize, 0usize);
    let mut recent: Vec<u32> = Vec::with_capacity(REMEMBERED + 1);
    for ray in &rays {
        let Some(hit) = native.closest_hit(ray, &mut counters) else {
            continue;
        };
        blocked += 1;
        let blocks = |p: &u32| {
            let [a, b, c] = scene.mesh.corners(*p as usize);
            let triangle = MollerTrumbore::prepare(a, b, c);
            MollerTrumbore::intersect(&triangle, ray, ray.t_min, ray.t_max).is_some()
        };
        by_last += usize::from(recent.first().is_some_and(blocks));
        by_recent += usize::from(recent.iter().any(blocks));
        recent.retain(|&p| p != hit.prim);
        recent.insert(0, hit.prim);
        recent.truncate(REMEMBERED);
    }
    let share = |n: usize, of: usize| 100.0 * n as f64 / of.max(1) as f64;
    println!(
        "{} rays, {:.1}% blocked; of those, the last blocker blocks {:.1}%, one of the last {REMEMBERED} {:.1}%",
        rays.len(),
        share(blocked, rays.len()),
        share(by_last, blocked),
        share(by_recent, blocked)
    );
    ExitCode::SUCCESS
}
