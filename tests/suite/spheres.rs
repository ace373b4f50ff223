//! Are analytic spheres lit as they should be? A sphere's hit is rebuilt by
//! projection and its rays leave past a rounding bound (the spawn rule);
//! either could darken a sphere by a fraction of a percent (an independent
//! renderer read the left sphere of CBspheres_lambertian 0.26% darker than
//! the rest agreed). Two checks that would show such a bias: the sphere
//! against a fine tessellation of itself under the same random numbers
//! (the difference has far less noise than either image), and direct light
//! on a lone sphere against its closed form, pixel by pixel.

use glam::Vec3;
use hybrid::accel::{Accel, BackendConfig, TraceCounters};
use hybrid::render::camera::CameraMode;
use hybrid::render::integrator::{DirectEstimator, PathSettings, Shading};
use hybrid::render::{render, RenderSettings, Silent};
use hybrid::scene::generate::icosphere;
use hybrid::scene::{NormalMode, Scene};

use crate::common::scene_or_skip;

/// `scene` with every sphere replaced by an icosphere of `level` (20 *
/// 4^level triangles) through the same centre, radius and material.
fn tessellated(scene: &Scene, level: u32) -> Scene {
    let mut out = scene.clone();
    let (unit, tris) = icosphere(level);
    for s in std::mem::take(&mut out.spheres) {
        let base = out.mesh.positions.len() as u32;
        out.mesh
            .positions
            .extend(unit.iter().map(|p| s.center + *p * s.radius));
        out.mesh
            .indices
            .extend(tris.iter().map(|t| t.map(|i| i + base)));
        out.mesh.materials.extend(tris.iter().map(|_| s.material));
    }
    assert_eq!(out.normal_mode, NormalMode::Smooth);
    out.mesh.compute_smooth_normals();
    out
}

/// Pixels whose centre ray hits the sphere at `centre` of `radius` in
/// `scene`, well inside its silhouette.
fn sphere_pixels(
    scene: &Scene,
    settings: &RenderSettings,
    centre: Vec3,
    radius: f32,
) -> Vec<usize> {
    let accel = BackendConfig::NATIVE.build(scene).expect("builds");
    let camera = settings.camera_for(scene);
    let mut counters = TraceCounters::default();
    let mut out = Vec::new();
    for y in 0..settings.height {
        for x in 0..settings.width {
            let ray = camera.ray(x as f32 + 0.5, y as f32 + 0.5);
            if let Some(hit) = accel.closest_hit(&ray, &mut counters) {
                let p = ray.at(hit.t);
                // Well inside the silhouette, so both versions hit it.
                let inside = (p - centre).length() < radius * 1.001
                    && ray.dir.dot((p - centre).normalize()) < -0.3;
                if inside {
                    out.push((y * settings.width + x) as usize);
                }
            }
        }
    }
    out
}

#[test]
fn an_analytic_sphere_renders_as_its_fine_tessellation_does() {
    let scene = scene_or_skip!("sky/CBspheres_lambertian.dae");
    let mesh = tessellated(&scene, 6);
    let settings = RenderSettings {
        width: 64,
        height: 48,
        samples: 256,
        seed: 5,
        shading: Shading::Path(PathSettings {
            estimator: DirectEstimator::Mis,
            max_bounces: 5,
            ..PathSettings::default()
        }),
        camera: CameraMode::Canonical,
        threads: 2,
        ..RenderSettings::default()
    };
    let film_of = |s: &Scene| {
        let accel = BackendConfig::NATIVE.build(s).expect("builds");
        render(s, &accel, &settings, &Silent).film
    };
    let (analytic, tess) = (film_of(&scene), film_of(&mesh));
    for (k, s) in scene.spheres.iter().enumerate() {
        let pixels = sphere_pixels(&scene, &settings, s.center, s.radius);
        let sum = |film: &hybrid::render::film::Film| -> f64 {
            pixels
                .iter()
                .map(|&i| (film.pixels[i].x + film.pixels[i].y + film.pixels[i].z) as f64)
                .sum()
        };
        let (a, t) = (sum(&analytic), sum(&tess));
        // Per-pixel ratios' spread gives the uncertainty of the mean ratio.
        let ratios: Vec<f64> = pixels
            .iter()
            .map(|&i| {
                let a = analytic.pixels[i].element_sum() as f64;
                let t = tess.pixels[i].element_sum() as f64;
                a / t.max(1e-9)
            })
            .collect();
        let n = ratios.len() as f64;
        let mean = ratios.iter().sum::<f64>() / n;
        let sd = (ratios.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt();
        let error = sd / n.sqrt();
        println!(
            "sphere {k}: {} pixels, analytic / tessellated {:.5} (pixel ratios {mean:.5} ± {error:.5})",
            pixels.len(),
            a / t,
        );
        assert!(
            pixels.len() > 30,
            "sphere {k}: only {} pixels",
            pixels.len()
        );
        // The tessellation's own error (its faces lie up to 4e-5 of the
        // radius inside the sphere) is far below 0.1%; a bias of 0.26%
        // would be many standard errors.
        assert!(
            (mean - 1.0).abs() < 4.0 * error + 1e-3,
            "sphere {k}: the analytic sphere reads {mean:.5} ± {error:.5} of its tessellation"
        );
    }
}

/// A lone diffuse sphere under a directional light, one ray through each
/// pixel's centre: each pixel is `albedo / pi * E * cos`, with the cosine
/// of the exact (double-precision) normal, on every backend, near the
/// origin and far from it. A shadow ray that found its own sphere would
/// leave a black pixel; an imprecise hit a wrong shade.
#[test]
fn a_lone_sphere_under_a_directional_light_is_shaded_exactly() {
    use hybrid::scene::builder::SceneBuilder;
    use hybrid::scene::{Light, Material};
    let l = Vec3::new(0.6, 0.5, 0.62).normalize();
    for offset in [0.0f32, 1e3, 1e5] {
        let centre = Vec3::new(offset, -0.5 * offset, 0.25 * offset);
        let mut b = SceneBuilder::new("lone sphere");
        let grey = b.material(Material::lambertian(Vec3::splat(0.5)));
        b.sphere(centre, 1.0, grey);
        b.light(Light::Directional {
            to_light: l,
            radiance: Vec3::ONE,
        });
        b.camera(centre + Vec3::new(0.3, 0.2, 3.5), centre, 45.0, 45.0);
        let scene = b.finish(NormalMode::Smooth);
        for backend in hybrid::accel::config::compared() {
            let accel = backend.build(&scene).expect("builds");
            let (film, camera) = crate::common::direct_light_at_pixel_centres(
                &scene,
                &accel,
                DirectEstimator::LightSampling,
                96,
            );
            let (mut checked, mut worst, mut black) = (0, 0.0f64, 0);
            for y in 0..96u32 {
                for x in 0..96u32 {
                    let ray = camera.ray(x as f32 + 0.5, y as f32 + 0.5);
                    // The exact hit, in double precision.
                    let (o, d) = (ray.origin.as_dvec3(), ray.dir.as_dvec3().normalize());
                    let oc = o - centre.as_dvec3();
                    let half_b = oc.dot(d);
                    let disc = half_b * half_b - (oc.length_squared() - 1.0);
                    if disc <= 1e-3 {
                        continue;
                    }
                    let n = (oc + d * (-half_b - disc.sqrt())).normalize();
                    let cosine = n.dot(l.as_dvec3());
                    let value = film.pixels[(y * 96 + x) as usize].x as f64;
                    if cosine > 1e-3 && value == 0.0 {
                        black += 1;
                    }
                    if cosine > 0.02 {
                        let expected = 0.5 / std::f64::consts::PI * cosine;
                        worst = worst.max((value / expected - 1.0).abs());
                        checked += 1;
                    }
                }
            }
            let label = format!("{} at {offset}", backend.label());
            println!(
                "{label}: {checked} lit pixels, worst relative error {worst:.2e}, {black} black"
            );
            assert!(checked > 1500, "{label}: only {checked} lit pixels");
            assert_eq!(
                black, 0,
                "{label}: {black} lit pixels are black (self-shadowing)"
            );
            assert!(worst < 1e-4, "{label}: a pixel is off by {worst:.2e}");
        }
    }
}
