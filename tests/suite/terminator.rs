//! The shadow terminator (Hanika 2021): a coarse mesh with smooth normals
//! lit by one light shows no staircase of dark facets where the shading
//! normal still faces the light, and keeps the shadows other objects cast.

use glam::Vec3;
use hybrid::accel::{config, Accel, TraceCounters};
use hybrid::choice::Choice;
use hybrid::render::integrator::DirectEstimator;
use hybrid::scene::builder::SceneBuilder;
use hybrid::scene::generate::{icosphere, quad_ball};
use hybrid::scene::{AreaLight, Light, Material, NormalMode, Scene};

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

/// The four kinds of light a course scene has, each placed so that a
/// camera on +Z sees its terminator cross the ball.
fn grazing_lights() -> [(&'static str, Light); 4] {
    let side = Vec3::new(1.0, -0.5, 0.15).normalize();
    let distance = 4.0;
    let centre = side * distance;
    // A square of side 0.3 facing the ball: from the ball it spans about
    // 0.04 radians, so its terminator is as sharp as a point light's.
    let u = side.cross(Vec3::Y).normalize() * 0.3;
    let v = side.cross(u).normalize() * 0.3;
    let area = Light::Area(AreaLight {
        origin: centre - (u + v) * 0.5,
        edge_u: u,
        edge_v: v,
        triangle: false,
        normal: -side,
        radiance: Vec3::splat(distance * distance / 0.09),
        area: 0.09,
        surface: AreaLight::NO_SURFACE,
    });
    [
        (
            "directional",
            Light::Directional {
                to_light: side,
                radiance: Vec3::ONE,
            },
        ),
        (
            "point",
            Light::Point {
                position: centre,
                intensity: Vec3::splat(distance * distance),
            },
        ),
        ("area", area),
        (
            "ambient",
            Light::Ambient {
                radiance: Vec3::ONE,
            },
        ),
    ]
}

/// What a smooth ball of albedo 0.5 reflects at `p` with unit normal `n`
/// under `light` alone, unshadowed: the closed form the coarse mesh's
/// smooth normals stand for. For the area light, its square seen as a
/// point (it is small and far); for the ambient light, the sky's share of
/// the hemisphere above `n`, `(1 + n_y) / 2`.
fn smooth_ball_radiance(light: &Light, p: Vec3, n: Vec3) -> f32 {
    let albedo = 0.5;
    let towards = |q: Vec3, intensity: f32| {
        let d = q - p;
        intensity * n.dot(d.normalize()).max(0.0) / d.length_squared()
    };
    let irradiance = match light {
        Light::Directional { to_light, radiance } => radiance.x * n.dot(*to_light).max(0.0),
        Light::Point {
            position,
            intensity,
        } => towards(*position, intensity.x),
        Light::Area(a) => {
            let centre = a.origin + (a.edge_u + a.edge_v) * 0.5;
            let facing = a.normal.dot((p - centre).normalize()).max(0.0);
            towards(centre, a.radiance.x * a.area * facing)
        }
        Light::Ambient { radiance } => {
            return albedo * radiance.x * (1.0 + n.y) / 2.0;
        }
        Light::Sphere { .. } => unreachable!("not among the lights tested"),
    };
    albedo / std::f32::consts::PI * irradiance
}

/// The cosine of the smooth normal with the direction light arrives from
/// (for the ambient light, the share of the sky above it, in `[0, 1]`).
fn facing_light(light: &Light, p: Vec3, n: Vec3) -> f32 {
    match light {
        Light::Directional { to_light, .. } => n.dot(*to_light),
        Light::Point { position, .. } => n.dot((*position - p).normalize()),
        Light::Area(a) => n.dot((a.origin + (a.edge_u + a.edge_v) * 0.5 - p).normalize()),
        Light::Ambient { .. } => (1.0 + n.y) / 2.0,
        Light::Sphere { .. } => unreachable!("not among the lights tested"),
    }
}

/// A coarse ball of smooth triangles (an 80-triangle icosphere, and a
/// 96-triangle ball of quads whose triangles differ in shape), lit by each
/// kind of light with its terminator across the view: every pixel where
/// the smooth normal faces the light is as bright as the smooth ball's
/// closed form says (within its noise), and every pixel where it faces
/// away is black. Lighting the facets beyond the smooth terminator (the
/// light's direction in front of the facet but behind the shading normal)
/// drew a staircase of lit triangles along it.
#[test]
fn a_coarse_ball_under_each_light_kind_ends_its_light_at_the_smooth_terminator() {
    let size = 120u32;
    for (mesh, (unit, tris)) in [("icosphere", icosphere(1)), ("quad ball", quad_ball(2))] {
        for (kind, light) in grazing_lights() {
            let mut b = SceneBuilder::new("coarse ball");
            let grey = b.material(Material::lambertian(Vec3::splat(0.5)));
            b.mesh(&unit, &tris, grey);
            b.light(light);
            b.camera(Vec3::new(0.0, 0.0, 4.0), Vec3::ZERO, 40.0, 40.0);
            let scene = b.finish(NormalMode::Smooth);
            // Delta lights need one sample; the others enough that a
            // pixel's noise stays well inside the bound.
            let (light_samples, lit_from) = match light {
                Light::Area(_) => (16, 0.1),
                Light::Ambient { .. } => (512, 0.6),
                _ => (1, 0.1),
            };
            for backend in config::compared() {
                let accel = backend.build(&scene).expect("builds");
                for estimator in [DirectEstimator::Mis, DirectEstimator::LightSampling] {
                    let (film, camera) = common::direct_light_sampled_at_pixel_centres(
                        &scene,
                        &accel,
                        estimator,
                        size,
                        light_samples,
                    );
                    let mut counters = TraceCounters::default();
                    let (mut lit, mut dark, mut beyond, mut leaks) = (0, 0, 0, 0);
                    for y in 0..size {
                        for x in 0..size {
                            let ray = camera.ray(x as f32 + 0.5, y as f32 + 0.5);
                            let Some(hit) = accel.closest_hit(&ray, &mut counters) else {
                                continue;
                            };
                            let sp = scene.surface_point(&ray, &hit);
                            let n = sp.shading_normal;
                            let value = film.pixels[(y * size + x) as usize].x;
                            let facing = facing_light(&light, sp.position, n);
                            if facing >= lit_from {
                                lit += 1;
                                if value < 0.8 * smooth_ball_radiance(&light, sp.position, n) {
                                    dark += 1;
                                }
                            } else if facing <= -0.05 && !matches!(light, Light::Ambient { .. }) {
                                beyond += 1;
                                if value > 0.0 {
                                    leaks += 1;
                                }
                            }
                        }
                    }
                    let label = format!(
                        "{mesh}, {kind} light, {} {}",
                        backend.label(),
                        estimator.name()
                    );
                    println!("{label}: {lit} lit pixels, {dark} dark; {beyond} beyond the terminator, {leaks} lit");
                    assert!(
                        lit > 500,
                        "{label}: the view misses the lit side ({lit} pixels)"
                    );
                    assert_eq!(dark, 0, "{label}: {dark} of {lit} pixels facing the light are darker than the smooth ball");
                    if !matches!(light, Light::Ambient { .. }) {
                        assert!(
                            beyond > 500,
                            "{label}: the view misses the dark side ({beyond} pixels)"
                        );
                    }
                    assert_eq!(
                        leaks, 0,
                        "{label}: {leaks} of {beyond} pixels facing away from the light are lit"
                    );
                }
            }
        }
    }
}
