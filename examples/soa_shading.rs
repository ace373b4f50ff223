//! Developer tool: the bet of shading many paths at once, measured on one
//! kernel before any integrator is rewritten (issue 45, point b). The
//! surface points of real hits (camera rays and their first diffuse
//! bounce on a scene) are computed one hit at a time by
//! [`Scene::surface_point`], as the per-path renderer does, and eight
//! hits at a time by [`hybrid::render::lanes::surface_points`], as the
//! wave renderer does (each lane gathers its triangle's corners and
//! normals, then every step runs across the eight lanes). Both must give
//! the same bits; the tool checks that, then prints ns per hit, best of
//! `PASSES` passes, on the calling thread.
//!
//! ```text
//! taskset -c 1 cargo run --release --example soa_shading -- SCENE.dae [PASSES]
//! ```

use std::process::ExitCode;
use std::time::Instant;

use hybrid::accel::native::cpu::Avx2;
use hybrid::accel::{Accel, BackendConfig};
use hybrid::geom::{Hit, Ray};
use hybrid::render::lanes::surface_points;
use hybrid::scene::{collada, NormalMode, Scene, SurfacePoint};

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let Some(path) = args.first() else {
        eprintln!("usage: soa_shading SCENE.dae [PASSES]");
        return ExitCode::from(2);
    };
    let passes: usize = args.get(1).and_then(|p| p.parse().ok()).unwrap_or(7);
    let scene = match collada::load(std::path::Path::new(path), NormalMode::Smooth) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("soa_shading: {e}");
            return ExitCode::from(2);
        }
    };
    let Some(avx2) = Avx2::detect() else {
        eprintln!("soa_shading: needs AVX2");
        return ExitCode::from(2);
    };
    let accel = BackendConfig::NATIVE.build(&scene).expect("native build");
    let (rays, hits): (Vec<Ray>, Vec<Option<Hit>>) = real_hits(&scene, &accel)
        .into_iter()
        .map(|(r, h)| (r, Some(h)))
        .unzip();
    println!(
        "{}: {} hits (camera rays and first bounces)",
        scene.name,
        hits.len()
    );

    let mut scalar = vec![SurfacePoint::NONE; hits.len()];
    let mut lanes = Vec::new();
    let (mut best_scalar, mut best_soa) = (f64::INFINITY, f64::INFINITY);
    for _ in 0..passes {
        let t = Instant::now();
        for (out, (ray, hit)) in scalar.iter_mut().zip(rays.iter().zip(&hits)) {
            *out = std::hint::black_box(scene.surface_point(ray, &hit.expect("a hit")));
        }
        best_scalar = best_scalar.min(t.elapsed().as_secs_f64());
        let t = Instant::now();
        surface_points(&scene, Some(avx2), &rays, &hits, &mut lanes);
        std::hint::black_box(&lanes);
        best_soa = best_soa.min(t.elapsed().as_secs_f64());
    }
    let bits = |p: &SurfacePoint| {
        [p.position, p.error, p.geometric_normal, p.shading_normal]
            .map(|v| v.to_array().map(f32::to_bits))
    };
    let differ = scalar
        .iter()
        .zip(&lanes)
        .filter(|(a, b)| bits(a) != bits(b))
        .count();
    let ns = |s: f64| s * 1e9 / hits.len() as f64;
    println!(
        "one at a time {:.2} ns per hit, eight lanes {:.2} ns per hit: {:.2}x; {differ} of {} hits differ in some bit",
        ns(best_scalar),
        ns(best_soa),
        best_scalar / best_soa,
        hits.len()
    );
    ExitCode::SUCCESS
}

/// Camera rays through a 320 x 240 image, 4 per pixel, and one cosine
/// bounce from each hit: the hits the renderer's first two vertices see.
fn real_hits<A: Accel>(scene: &Scene, accel: &A) -> Vec<(Ray, Hit)> {
    use hybrid::render::camera::{Camera, CameraMode};
    let camera = Camera::new(scene, CameraMode::Canonical, 320, 240);
    let mut rng = hybrid::geom::sampling::Rng::new(7, 0);
    let mut out = Vec::new();
    let mut counters = hybrid::accel::TraceCounters::default();
    for y in 0..240 {
        for x in 0..320 {
            for _ in 0..4 {
                let ray = camera.ray(x as f32 + rng.next_f32(), y as f32 + rng.next_f32());
                let Some(hit) = accel.closest_hit(&ray, &mut counters) else {
                    continue;
                };
                out.push((ray, hit));
                let sp = scene.surface_point(&ray, &hit);
                let n = if sp.geometric_normal.dot(ray.dir) > 0.0 {
                    -sp.geometric_normal
                } else {
                    sp.geometric_normal
                };
                let (u, v) = (rng.next_f32(), rng.next_f32());
                let local = hybrid::geom::sampling::cosine_hemisphere(u, v);
                let frame = hybrid::geom::sampling::Frame::new(n);
                let bounce = Ray::spawn(&sp.spawn_point(), frame.to_world(local), f32::INFINITY);
                if let Some(h) = accel.closest_hit(&bounce, &mut counters) {
                    out.push((bounce, h));
                }
            }
        }
    }
    out
}
