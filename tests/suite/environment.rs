//! The environment light (`-e`): an analytic furnace, equivalence with the
//! ambient light, agreement of every estimator and backend, importance
//! against uniform sampling, and bad maps.

use std::sync::Arc;

use glam::Vec3;
use hybrid::accel::BackendConfig;
use hybrid::render::camera::CameraMode;
use hybrid::render::film::Film;
use hybrid::render::integrator::{DirectEstimator, PathSettings, Shading};
use hybrid::scene::builder::SceneBuilder;
use hybrid::scene::environment::{EnvSampling, Environment};
use hybrid::scene::generate::{demo_sky, spheres_on_a_plate, sun_and_sky};
use hybrid::scene::{Light, Material, NormalMode, Scene};

use crate::common::{fails_in_one_line, hybrid, rmse, scratch, succeeds};
use crate::integrators::{estimators_agree_on, path, run_on};

fn with_environment(mut scene: Scene, env: Environment) -> Scene {
    scene.environment = Some(Arc::new(env));
    scene
}

/// A map of `colour` over the whole sphere (or only above the horizon:
/// fine enough that the lookup's blend across the horizon, half a row
/// each way, is a fraction of a degree).
fn constant_map(colour: Vec3, above_horizon_only: bool) -> Environment {
    let (w, h) = (512u32, 256u32);
    let texels = (0..w * h)
        .map(|i| {
            if above_horizon_only && i / w >= h / 2 {
                Vec3::ZERO
            } else {
                colour
            }
        })
        .collect();
    Environment::new("constant", w, h, texels)
}

/// Mean and standard error of the red channel over the pixels `keep` picks.
fn mean_where(film: &Film, keep: impl Fn(u32, u32) -> bool) -> (f64, f64) {
    let v: Vec<f64> = (0..film.height)
        .flat_map(|y| (0..film.width).map(move |x| (x, y)))
        .filter(|&(x, y)| keep(x, y))
        .map(|(x, y)| film.pixels[(y * film.width + x) as usize].x as f64)
        .collect();
    let n = v.len() as f64;
    let mean = v.iter().sum::<f64>() / n;
    let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (n - 1.0);
    (mean, (var / n).sqrt())
}

#[test]
fn a_constant_map_lights_a_convex_diffuse_sphere_to_albedo_times_its_radiance() {
    // A convex surface sees only the sky, so with a constant map of
    // radiance c every point reflects albedo * c, at any bounce count;
    // camera rays that miss see c.
    let (albedo, c) = (0.6f64, 0.8f64);
    let mut b = SceneBuilder::new("sphere under a constant sky");
    let m = b.material(Material::lambertian(Vec3::splat(albedo as f32)));
    b.sphere(Vec3::ZERO, 1.0, m);
    b.camera(Vec3::new(0.0, 0.0, 3.0), Vec3::ZERO, 40.0, 40.0);
    let mut scene = with_environment(
        b.finish(NormalMode::Smooth),
        constant_map(Vec3::splat(c as f32), false),
    );
    let (w, h) = (24u32, 24u32);
    // The central third is sphere; the corners are sky.
    let centre =
        |x: u32, y: u32| (w / 3..2 * w / 3).contains(&x) && (h / 3..2 * h / 3).contains(&y);
    let corner = |x: u32, y: u32| (x < 2 || x >= w - 2) && (y < 2 || y >= h - 2);
    for sampling in [EnvSampling::Importance, EnvSampling::Uniform] {
        let mut env = constant_map(Vec3::splat(c as f32), false);
        env.sampling = sampling;
        scene.environment = Some(Arc::new(env));
        for (estimator, backend) in [
            (DirectEstimator::Hemisphere, BackendConfig::NATIVE),
            (DirectEstimator::LightSampling, BackendConfig::NATIVE),
            (DirectEstimator::Mis, BackendConfig::NATIVE),
            (DirectEstimator::Mis, BackendConfig::EMBREE),
        ] {
            for m in [1, 3] {
                let film = run_on(
                    backend,
                    &scene,
                    w,
                    h,
                    16,
                    5,
                    Shading::Path(path(estimator, m)),
                    CameraMode::Node,
                )
                .film;
                let (sphere, se) = mean_where(&film, centre);
                let (sky, _) = mean_where(&film, corner);
                let on = backend.label();
                println!(
                    "{sampling:?} {estimator:?} on {on} -m {m}: sphere {sphere:.4} ± {se:.4} (analytic {:.4}), sky {sky:.4}",
                    albedo * c
                );
                assert!(
                    (sphere - albedo * c).abs() <= 4.0 * se + 1e-4,
                    "{sampling:?} {estimator:?} on {on} -m {m}: sphere {sphere:.4} ± {se:.4}, analytic {:.4}",
                    albedo * c
                );
                assert!(
                    (sky - c).abs() < 1e-6,
                    "camera rays that miss see {sky}, not {c}"
                );
            }
        }
    }
}

#[test]
fn a_map_constant_above_the_horizon_renders_as_the_ambient_light_does() {
    // The ambient light is uniform radiance from the +Y hemisphere
    // (scene-format.md), so a map of that colour above the horizon and
    // black below is the same light, sampled differently.
    let colour = Vec3::new(0.9, 0.7, 0.5);
    let mut ambient = spheres_on_a_plate();
    ambient.lights.push(Light::Ambient { radiance: colour });
    let mapped = with_environment(spheres_on_a_plate(), constant_map(colour, true));
    let (w, h, seeds) = (32u32, 24u32, 12u64);
    let settings = Shading::Path(path(DirectEstimator::Mis, 3));
    let regions = |scene: &Scene| -> Vec<(f64, f64)> {
        let per_seed: Vec<Vec<f64>> = (0..seeds)
            .map(|s| {
                let film = run_on(
                    BackendConfig::NATIVE,
                    scene,
                    w,
                    h,
                    8,
                    40 + s,
                    settings,
                    CameraMode::Node,
                )
                .film;
                let mut out = vec![0.0; 12];
                for y in 0..h {
                    for x in 0..w {
                        let p = film.pixels[(y * w + x) as usize];
                        out[((y * 3 / h) * 4 + x * 4 / w) as usize] += (p.x + p.y + p.z) as f64;
                    }
                }
                out
            })
            .collect();
        (0..12)
            .map(|r| {
                let v: Vec<f64> = per_seed.iter().map(|s| s[r]).collect();
                let mean = v.iter().sum::<f64>() / seeds as f64;
                let var = v.iter().map(|x| (x - mean).powi(2)).sum::<f64>() / (seeds as f64 - 1.0);
                (mean, (var / seeds as f64).sqrt())
            })
            .collect()
    };
    let (a, e) = (regions(&ambient), regions(&mapped));
    for r in 0..12 {
        let se = (a[r].1.powi(2) + e[r].1.powi(2)).sqrt();
        println!(
            "region {r}: ambient {:.3} ± {:.3}, map {:.3} ± {:.3}",
            a[r].0, a[r].1, e[r].0, e[r].1
        );
        assert!(
            (a[r].0 - e[r].0).abs() <= 4.0 * se + 1e-3 * a[r].0,
            "region {r}: ambient {:.3} vs map {:.3} (± {se:.3})",
            a[r].0,
            e[r].0
        );
    }
    assert!(
        a.iter().all(|r| r.0 > 0.0),
        "the ambient scene is black somewhere: {a:?}"
    );
}

#[test]
fn every_estimator_and_backend_agree_under_a_sun_and_sky() {
    // A sun of 10 degrees, large enough for uniform hemisphere sampling to
    // converge in the test's budget.
    let sky = sun_and_sky(
        64,
        32,
        Vec3::new(1.0, 1.5, 0.5),
        10.0,
        Vec3::splat(20.0),
        Vec3::new(0.3, 0.4, 0.6),
    );
    let scene = with_environment(spheres_on_a_plate(), sky);
    estimators_agree_on("spheres on a plate under a sun", &scene, 24);
}

#[test]
fn importance_sampling_the_map_beats_uniform_sampling_at_equal_samples() {
    // Direct light only: with more bounces, the sun's caustics off the
    // polished sphere (found by BSDF sampling alone, whatever the map's
    // strategy) add the same error to both.
    let scene = with_environment(spheres_on_a_plate(), demo_sky());
    let (w, h) = (48u32, 36u32);
    let settings = Shading::Path(PathSettings {
        light_samples: 1,
        ..path(DirectEstimator::Mis, 1)
    });
    let render = |scene: &Scene, spp: u32, seed: u64| {
        run_on(
            BackendConfig::NATIVE,
            scene,
            w,
            h,
            spp,
            seed,
            settings,
            CameraMode::Node,
        )
        .film
        .pixels
    };
    let reference = render(&scene, 1024, 99);
    let mut uniform_scene = scene.clone();
    let mut uniform = demo_sky();
    uniform.sampling = EnvSampling::Uniform;
    uniform_scene.environment = Some(Arc::new(uniform));
    for seed in [1, 2] {
        let importance = rmse(&render(&scene, 16, seed), &reference);
        let uniform = rmse(&render(&uniform_scene, 16, seed), &reference);
        println!("16 spp, seed {seed}: RMSE importance {importance:.4}, uniform {uniform:.4}");
        assert!(
            importance < 0.5 * uniform,
            "seed {seed}: importance sampling RMSE {importance:.4} is not below half of uniform's {uniform:.4}"
        );
    }
}

#[test]
fn render_with_a_map_from_the_command_line_and_refuse_bad_maps() {
    let dir = scratch("environment-cli");
    demo_sky()
        .save(&dir.join("sky.exr"))
        .expect("write the map");
    for accel in ["native", "embree"] {
        succeeds(
            &[
                "render", "-e", "sky.exr", "--accel", accel, "-r", "32", "24", "-s", "2", "-f",
                "out.png",
            ],
            &dir,
        );
    }
    let o = hybrid(
        &[
            "render",
            "-e",
            "sky.exr",
            "--env-uniform",
            "-r",
            "8",
            "6",
            "-f",
            "u.png",
        ],
        &dir,
    );
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("sampled uniformly"),
        "--env-uniform is not reported: {}",
        String::from_utf8_lossy(&o.stdout)
    );

    fails_in_one_line(
        &["render", "-e", "missing.exr", "-f", "x.png"],
        &dir,
        "missing.exr: cannot read the environment map",
    );
    let mut bad = image::Rgb32FImage::new(4, 2);
    bad.put_pixel(3, 1, image::Rgb([1.0, f32::NAN, 0.0]));
    bad.save(dir.join("nan.exr")).unwrap();
    fails_in_one_line(
        &["render", "-e", "nan.exr", "-f", "x.png"],
        &dir,
        "nan.exr: texel (3, 1)",
    );
    std::fs::write(dir.join("text.exr"), "not an image").unwrap();
    fails_in_one_line(
        &["render", "-e", "text.exr", "-f", "x.png"],
        &dir,
        "text.exr: not an image",
    );
    fails_in_one_line(&["render", "--env-uniform", "-f", "x.png"], &dir, "-e");
}

#[test]
fn a_black_background_hides_the_sky_from_camera_rays_but_keeps_its_light() {
    let dir = scratch("environment-background");
    demo_sky()
        .save(&dir.join("sky.exr"))
        .expect("write the map");
    let corner_and_mean = |background: &str| {
        let out = format!("{background}-render.exr");
        succeeds(
            &[
                "render",
                "-e",
                "sky.exr",
                "--background",
                background,
                "-r",
                "32",
                "24",
                "-s",
                "4",
                "-f",
                &out,
            ],
            &dir,
        );
        let img = image::open(dir.join(&out)).unwrap().to_rgb32f();
        let mean: f32 = img.pixels().map(|p| p.0[0]).sum::<f32>() / (32.0 * 24.0);
        // The default scene's box is open towards the camera: its top-left
        // corner sees past it.
        (img.get_pixel(0, 0).0[0], mean)
    };
    let (sky_corner, sky_mean) = corner_and_mean("sky");
    let (black_corner, black_mean) = corner_and_mean("black");
    println!("corner: sky {sky_corner}, black {black_corner}; mean: {sky_mean} vs {black_mean}");
    assert!(sky_corner > 0.0, "the sky is not seen past the box");
    assert_eq!(black_corner, 0.0, "--background black still shows the sky");
    assert!(
        black_mean > 0.0 && black_mean < sky_mean,
        "the sky no longer lights the box"
    );
}
