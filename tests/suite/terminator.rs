//! The shadow terminator (Hanika 2021): a coarse mesh with smooth normals
//! lit by one light shows no staircase of dark facets where the shading
//! normal still faces the light, and keeps the shadows other objects cast.

use glam::Vec3;
use hybrid::accel::{config, Accel, TraceCounters};
use hybrid::choice::Choice;
use hybrid::render::integrator::DirectEstimator;
use hybrid::scene::builder::SceneBuilder;
use hybrid::scene::generate::icosphere;
use hybrid::scene::{Light, Material, NormalMode, Scene};

use crate::common;

/// The light's direction: from the right and a little above, so a
/// camera on +Z sees the terminator run down the middle of the sphere.
fn to_light() -> Vec3 {
    Vec3::new(1.0, 0.3, 0.1).normalize()
}

/// The occluder: a square of half-size `HALF` facing the light, hovering
/// over the lit side of the sphere between it and the light.
const HALF: f32 = 0.18;

fn occluder_frame() -> (Vec3, Vec3, Vec3) {
    let l = to_light();
    let on_sphere = (l + Vec3::new(0.0, -0.3, 0.8)).normalize();
    let centre = on_sphere + l * 0.3;
    let u = l.cross(Vec3::Y).normalize();
    let v = l.cross(u);
    (centre, u, v)
}

/// An 80-triangle icosphere of radius 1 (smooth normals) and the occluder,
/// lit by one directional light of irradiance 1.
fn coarse_sphere() -> Scene {
    let (unit, tris) = icosphere(1);
    let mut b = SceneBuilder::new("coarse sphere");
    let grey = b.material(Material::lambertian(Vec3::splat(0.5)));
    b.mesh(&unit, &tris, grey);
    let (c, u, v) = occluder_frame();
    let corners = [
        c - u * HALF - v * HALF,
        c + u * HALF - v * HALF,
        c + u * HALF + v * HALF,
        c - u * HALF + v * HALF,
    ];
    b.mesh(&corners, &[[0, 1, 2], [0, 2, 3]], grey);
    b.light(Light::Directional {
        to_light: to_light(),
        radiance: Vec3::ONE,
    });
    b.camera(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, 40.0, 40.0);
    b.finish(NormalMode::Smooth)
}

/// Where the ray from `p` towards the light crosses the occluder's plane,
/// in the square's coordinates (`None`: it moves away from the plane).
fn on_occluder(p: Vec3) -> Option<(f32, f32)> {
    let (c, u, v) = occluder_frame();
    let l = to_light();
    let t = (c - p).dot(l);
    if t <= 0.0 {
        return None;
    }
    let q = p + l * t - c;
    Some((q.dot(u), q.dot(v)))
}

#[test]
fn a_coarse_smooth_sphere_shows_no_terminator_staircase_and_keeps_cast_shadows() {
    let scene = coarse_sphere();
    let sphere_triangles = 80u32;
    let (w, h) = (160u32, 160u32);
    assert_eq!(w, h, "a square image");
    let l = to_light();
    for backend in config::compared() {
        for estimator in [DirectEstimator::Mis, DirectEstimator::LightSampling] {
            let accel = backend.build(&scene).expect("builds");
            let (film, camera) =
                common::direct_light_at_pixel_centres(&scene, &accel, estimator, w);
            let mut counters = TraceCounters::default();
            let (mut terminator, mut dark, mut lit, mut shadowed, mut leaks) = (0, 0, 0, 0, 0);
            for y in 0..h {
                for x in 0..w {
                    let ray = camera.ray(x as f32 + 0.5, y as f32 + 0.5);
                    let Some(hit) = accel.closest_hit(&ray, &mut counters) else {
                        continue;
                    };
                    if hit.prim >= sphere_triangles {
                        continue;
                    }
                    let sp = scene.surface_point(&ray, &hit);
                    let cosine = sp.shading_normal.dot(l);
                    let value = film.pixels[(y * w + x) as usize].x;
                    if cosine <= 0.1 {
                        continue;
                    }
                    // Shadow rays leave from the lifted point, so the
                    // shadow's edge may move by as much as the lift (which
                    // shrinks with the square of the facets' size).
                    let sag = scene
                        .shadow_lift(&hit, sp.position, sp.geometric_normal)
                        .length();
                    match on_occluder(sp.position) {
                        Some((s, t)) if s.abs().max(t.abs()) < HALF - sag => {
                            shadowed += 1;
                            if value > 0.0 {
                                leaks += 1;
                            }
                        }
                        Some((s, t)) if s.abs().max(t.abs()) < HALF + sag => {}
                        _ => {
                            lit += 1;
                            // The facet faces away, the smooth surface
                            // towards the light.
                            if sp.geometric_normal.dot(l) <= 0.0 {
                                terminator += 1;
                            }
                            let expected = 0.5 / std::f32::consts::PI * cosine;
                            if value < 0.8 * expected {
                                dark += 1;
                            }
                        }
                    }
                }
            }
            let label = format!("{} {}", backend.label(), estimator.name());
            println!(
                "{label}: {lit} lit pixels ({terminator} on facets facing away), {dark} dark; {shadowed} shadowed, {leaks} lit"
            );
            assert!(
                terminator > 30 && shadowed > 30,
                "{label}: the view misses the case ({terminator} terminator, {shadowed} shadowed pixels)"
            );
            assert_eq!(
                dark, 0,
                "{label}: {dark} of {lit} pixels facing the light by their shading normal are darker than it says"
            );
            assert_eq!(
                leaks, 0,
                "{label}: {leaks} of {shadowed} pixels in the occluder's shadow are lit"
            );
        }
    }
}
