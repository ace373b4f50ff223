//! The ray sets the parity suite sends through every backend. All are
//! deterministic for a seed, so every backend sees exactly the same rays.

use glam::Vec3;

use crate::accel::{Accel, TraceCounters};
use crate::geom::ray::SpawnPoint;
pub use crate::geom::sampling::uniform_sphere;
use crate::geom::sampling::{cosine_hemisphere, Frame, Rng};
use crate::geom::Ray;
use crate::render::camera::{Camera, CameraMode};
use crate::render::light::{sample_li, Facing};
use crate::scene::Scene;

/// The order camera rays come in.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum CameraOrder {
    /// 8x8-pixel tiles, as the renderer traces them.
    Tiles,
    /// Scanline rows, top to bottom.
    Rows,
}

/// Camera rays in the order a renderer sends them: 8x8-pixel tiles of a
/// 4:3 image of about `n` pixels, one jittered ray per pixel.
pub fn camera_rays(scene: &Scene, n: usize, seed: u64) -> Vec<Ray> {
    camera_rays_in(scene, n, seed, CameraOrder::Tiles)
}

/// The same rays as [`camera_rays`] (the jitter of each pixel is the
/// same), in `order`.
pub fn camera_rays_in(scene: &Scene, n: usize, seed: u64, order: CameraOrder) -> Vec<Ray> {
    let h = (((n as f64) * 3.0 / 4.0).sqrt().ceil() as u32).max(1);
    let w = ((n as u32).div_ceil(h)).max(1);
    let camera = Camera::new(scene, CameraMode::Canonical, w, h);
    let mut rng = Rng::new(seed, 1);
    let mut tiled = Vec::with_capacity((w * h) as usize);
    for ty in (0..h).step_by(8) {
        for tx in (0..w).step_by(8) {
            for y in ty..(ty + 8).min(h) {
                for x in tx..(tx + 8).min(w) {
                    let ray = camera.ray(x as f32 + rng.next_f32(), y as f32 + rng.next_f32());
                    tiled.push((y * w + x, ray));
                }
            }
        }
    }
    // The first n pixels of the tile order, in either order.
    tiled.truncate(n);
    if order == CameraOrder::Rows {
        tiled.sort_by_key(|&(pixel, _)| pixel);
    }
    tiled.into_iter().map(|(_, r)| r).collect()
}

/// Rays from random points inside the scene's bounds (grown by 10% of the
/// largest extent on every side, so flat scenes get a volume) in uniformly
/// random directions.
pub fn random_rays(scene: &Scene, n: usize, seed: u64) -> Vec<Ray> {
    let b = scene.bounds();
    let pad = Vec3::splat(b.extent().max_element() * 0.1);
    let (lo, size) = (b.min - pad, b.extent() + 2.0 * pad);
    let mut rng = Rng::new(seed, 2);
    (0..n)
        .map(|_| {
            let o = lo + size * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let (u, v) = rng.next_2d();
            Ray::new(o, uniform_sphere(u, v))
        })
        .collect()
}

/// Incoherent rays, as the comparison headline defines them: origins
/// uniform inside the scene's bounds, directions uniform on the sphere.
pub fn incoherent_rays(scene: &Scene, n: usize, seed: u64) -> Vec<Ray> {
    let b = scene.bounds();
    let mut rng = Rng::new(seed, 6);
    (0..n)
        .map(|_| {
            let o = b.min + b.extent() * Vec3::new(rng.next_f32(), rng.next_f32(), rng.next_f32());
            let (u, v) = rng.next_2d();
            Ray::new(o, uniform_sphere(u, v))
        })
        .collect()
}

/// The headline's shadow rays: the incoherent rays as occlusion queries
/// reaching half the diagonal of the scene's bounds.
pub fn occlusion_rays(scene: &Scene, n: usize, seed: u64) -> Vec<Ray> {
    let reach = 0.5 * scene.bounds().extent().length();
    incoherent_rays(scene, n, seed)
        .into_iter()
        .map(|r| Ray { t_max: reach, ..r })
        .collect()
}

/// Real hit points of camera rays, found with `reference`, as the renderer
/// sees them (geometric normal facing the camera).
fn surface_points<A: Accel>(scene: &Scene, reference: &A, n: usize, seed: u64) -> Vec<SpawnPoint> {
    let mut counters = TraceCounters::default();
    let mut out = Vec::with_capacity(n);
    let mut attempt = 0;
    while out.len() < n && attempt < 20 {
        for ray in camera_rays(scene, n, seed.wrapping_add(attempt)) {
            if let Some(hit) = reference.closest_hit(&ray, &mut counters) {
                let mut at = scene.surface_point(&ray, &hit).spawn_point();
                if at.ng.dot(ray.dir) > 0.0 {
                    at.ng = -at.ng;
                }
                out.push(at);
                if out.len() == n {
                    break;
                }
            }
        }
        attempt += 1;
    }
    out
}

/// Cosine-distributed rays leaving real hit points with the project's spawn
/// rule.
pub fn bounce_rays<A: Accel>(scene: &Scene, reference: &A, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed, 3);
    surface_points(scene, reference, n, seed)
        .into_iter()
        .map(|at| {
            let (u, v) = rng.next_2d();
            let dir = Frame::new(at.ng).to_world(cosine_hemisphere(u, v));
            Ray::spawn(&at, dir, f32::INFINITY)
        })
        .collect()
}

/// Shadow rays from real hit points towards light samples, with `t_max`
/// stopping short of the light (as the integrator sends them).
pub fn shadow_rays<A: Accel>(scene: &Scene, reference: &A, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed, 4);
    if scene.lights.is_empty() {
        return Vec::new();
    }
    surface_points(scene, reference, n, seed)
        .into_iter()
        .filter_map(|at| {
            let light = &scene.lights[(rng.next_u32() as usize) % scene.lights.len()];
            let ls = sample_li(light, at.p, Facing::geometric(at.ng), &mut rng)?;
            // Only lights above the surface get a shadow ray, as in the
            // integrator.
            (ls.wi.dot(at.ng) > 0.0).then(|| Ray::shadow(&at, ls.wi, ls.distance))
        })
        .collect()
}

/// Rays that skim surfaces: from just above a real hit point, nearly
/// parallel to the surface (within 0.5 degrees).
pub fn grazing_rays<A: Accel>(scene: &Scene, reference: &A, n: usize, seed: u64) -> Vec<Ray> {
    let mut rng = Rng::new(seed, 5);
    surface_points(scene, reference, n, seed)
        .into_iter()
        .map(|SpawnPoint { p, ng, .. }| {
            let frame = Frame::new(ng);
            let phi = 2.0 * std::f32::consts::PI * rng.next_f32();
            let elevation = (rng.next_f32() - 0.5) * 0.5f32.to_radians() * 2.0;
            let local = Vec3::new(
                phi.cos() * elevation.cos(),
                phi.sin() * elevation.cos(),
                elevation.sin(),
            );
            // Start back along the skim direction so the ray crosses p.
            let dir = frame.to_world(local);
            let back = scene.bounds().extent().length() * 0.05;
            Ray::new(p - dir * back + ng * 1e-4 * back, dir)
        })
        .collect()
}
