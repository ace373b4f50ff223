//! The Embree backends (Embree 3 and Embree 4, both in one process) behind
//! the same trait: hit-level agreement with the native BVH, the same
//! images, and Embree's errors as Rust errors.

use hybrid::accel::embree::{invalid_buffer_error, BuildQuality, EmbreeOptions, EmbreeVersion};
use hybrid::accel::native::{NativeBvh, NativeOptions};
use hybrid::accel::BackendConfig;
use hybrid::accel::{Accel, AccelError, Coherence, TraceCounters};
use hybrid::choice::Choice;
use hybrid::geom::Ray;
use hybrid::parity::rays;
use hybrid::render::integrator::{PathSettings, Shading};
use hybrid::render::{render, RenderSettings, Silent};

use crate::bvh::assert_agree;
use crate::common::{self, scene_or_skip};

const SCENES: &[&str] = &[
    "basic/plane1024.dae",
    "basic/plane64.dae",
    "basic/sphere_diffuse.dae",
    "basic/trigs5.dae",
    "keenan/banana.dae",
    "meshedit/cow.dae",
    "meshedit/maxplanck.dae",
    "meshedit/teapot.dae",
    "sky/CBbunny.dae",
    "sky/CBempty.dae",
    "sky/CBspheres.dae",
    "sky/CBspheres_lambertian.dae",
    "sky/bunny.dae",
];

/// The Embree versions this machine has. Under CI (`CI` set) both must
/// load: a missing one fails there rather than shortening the tests.
fn versions() -> Vec<EmbreeVersion> {
    EmbreeVersion::ALL
        .iter()
        .copied()
        .filter(|v| match v.available() {
            Ok(()) => true,
            Err(why) if std::env::var_os("CI").is_some() => {
                panic!("{} is required under CI: {why}", v.name())
            }
            Err(why) => {
                println!("skipping {}: {why}", v.name());
                false
            }
        })
        .collect()
}

fn embree(
    version: EmbreeVersion,
    quality: BuildQuality,
    robust: bool,
    threads: usize,
) -> BackendConfig {
    BackendConfig::Embree(EmbreeOptions {
        version,
        quality,
        robust,
        threads,
    })
}

#[test]
fn both_embree_versions_load_side_by_side_and_report_their_version() {
    let scene = common::default_scene();
    let present = versions();
    let built: Vec<_> = present
        .iter()
        .map(|&v| {
            embree(v, BuildQuality::Medium, false, 0)
                .build(&scene)
                .expect("builds")
        })
        .collect();
    for (v, accel) in present.iter().zip(&built) {
        let details = accel.stats().details;
        println!("{}: {details}", v.name());
        let major = match v {
            EmbreeVersion::V3 => "Embree 3.",
            EmbreeVersion::V4 => "Embree 4.",
        };
        assert!(details.starts_with(major), "{} reports {details}", v.name());
        assert_eq!(accel.stats().backend, v.name());
    }
}

#[test]
fn embree_agrees_with_native_on_random_rays_in_every_shared_scene() {
    for rel in SCENES {
        let scene = scene_or_skip!(rel);
        let native = NativeBvh::build(&scene, &NativeOptions::default()).expect("native builds");
        for (version, quality) in versions()
            .into_iter()
            .flat_map(|v| [(v, BuildQuality::Low), (v, BuildQuality::High)])
        {
            let embree = embree(version, quality, false, 0)
                .build(&scene)
                .expect("embree builds");
            let rays = rays::random_rays(&scene, 10_000, 21);
            let a = |r: &Ray| native.closest_hit(r, &mut TraceCounters::default());
            let b = |r: &Ray| embree.closest_hit(r, &mut TraceCounters::default());
            assert_agree(
                &format!("{rel}: native vs {} ({quality:?})", version.name()),
                &a,
                &b,
                &rays,
                1e-4,
                0.0005,
            );
            // The normals derived from each backend's hits agree where the
            // same primitive was hit (a sphere's depends on the hit's t).
            let mut worst = 0.0f32;
            for r in &rays {
                if let (Some(x), Some(y)) = (a(r), b(r)) {
                    if x.prim == y.prim {
                        let (nx, ny) =
                            (scene.geometric_normal(r, &x), scene.geometric_normal(r, &y));
                        worst = worst.max(nx.angle_between(ny).to_degrees());
                    }
                }
            }
            println!("{rel}: worst geometric-normal angle {worst:.4} degrees");
            assert!(
                worst < 0.1,
                "{rel}: geometric normals differ by up to {worst} degrees"
            );
            let occluded = rays
                .iter()
                .filter(|r| embree.occluded(r, &mut TraceCounters::default()) != b(r).is_some())
                .count();
            assert_eq!(
                occluded, 0,
                "{rel}: embree occluded() and closest_hit() disagree on {occluded} rays"
            );
        }
    }
}

fn same_image(rel: &str, shading: Shading, spp: u32, max_rmse: f64) {
    let scene = scene_or_skip!(rel);
    let native = NativeBvh::build(&scene, &NativeOptions::default()).expect("native builds");
    for version in versions() {
        let embree = embree(version, BuildQuality::Medium, false, 0)
            .build(&scene)
            .expect("embree builds");
        same_image_on(rel, version, &native, &embree, shading, spp, max_rmse);
    }
}

fn same_image_on(
    rel: &str,
    version: EmbreeVersion,
    native: &NativeBvh,
    embree: &hybrid::accel::Backend,
    shading: Shading,
    spp: u32,
    max_rmse: f64,
) {
    let scene = scene_or_skip!(rel);
    let settings = RenderSettings {
        width: 64,
        height: 48,
        samples: spp,
        seed: 3,
        threads: 2,
        shading,
        ..RenderSettings::default()
    };
    let a = render(&scene, native, &settings, &Silent).film;
    let b = render(&scene, embree, &settings, &Silent).film;
    let rmse = common::rmse(&a.pixels, &b.pixels);
    let same_byte = a
        .to_rgb8(hybrid::render::film::ToneMap::REFERENCE)
        .iter()
        .zip(b.to_rgb8(hybrid::render::film::ToneMap::REFERENCE))
        .filter(|(x, y)| (**x as i32 - *y as i32).abs() <= 1)
        .count() as f64
        / (a.pixels.len() * 3) as f64;
    let v = version.name();
    println!(
        "{rel} {shading:?} native vs {v}: RMSE {rmse:.5}, {:.2}% of channels within 1/255",
        same_byte * 100.0
    );
    assert!(
        rmse <= max_rmse,
        "{rel}: native and {v} images differ by RMSE {rmse:.5} > {max_rmse}"
    );
    assert!(
        same_byte >= 0.99,
        "{rel}: native vs {v}: only {:.2}% of channels within 1/255",
        same_byte * 100.0
    );
}

#[test]
fn native_and_embree_render_the_same_normal_images() {
    same_image("sky/CBspheres_lambertian.dae", Shading::Normals, 4, 0.01);
    same_image("sky/CBbunny.dae", Shading::Normals, 4, 0.01);
}

#[test]
fn native_and_embree_render_the_same_path_traced_images() {
    let pt = Shading::Path(PathSettings {
        max_bounces: 3,
        light_samples: 2,
        ..PathSettings::default()
    });
    same_image("sky/CBspheres_lambertian.dae", pt, 8, 0.02);
    same_image("sky/CBbunny.dae", pt, 8, 0.02);
}

#[test]
fn embree_errors_come_back_as_rust_errors_with_embrees_message() {
    for version in versions() {
        match invalid_buffer_error(version) {
            Err(AccelError::Embree(message)) => {
                println!("{} said: {message}", version.name());
                assert!(
                    message.contains("invalid argument") || message.contains("aligned"),
                    "unexpected message: {message}"
                );
            }
            Err(other) => panic!("not an Embree error: {other}"),
            Ok(()) => panic!("a misaligned buffer was accepted by {}", version.name()),
        }
    }
}

#[test]
fn backends_can_be_dropped_in_any_order() {
    let scene = common::default_scene();
    let present = versions();
    // Each version with each, the other's scenes alive or not.
    for &first in &present {
        for &second in &present {
            let a = embree(first, BuildQuality::Medium, true, 0)
                .build(&scene)
                .unwrap();
            let b = embree(second, BuildQuality::High, false, 1)
                .build(&scene)
                .unwrap();
            // Straight into the default box's back wall.
            let ray = Ray::new(glam::Vec3::new(0.0, 1.0, 3.0), -glam::Vec3::Z);
            assert!(a.closest_hit(&ray, &mut TraceCounters::default()).is_some());
            drop(a);
            assert!(
                b.closest_hit(&ray, &mut TraceCounters::default()).is_some(),
                "dropping a {} scene broke a {} one",
                first.name(),
                second.name()
            );
            drop(b);
        }
    }
}

#[test]
fn embree_batch_calls_answer_like_single_rays() {
    for version in versions() {
        batch_answers_like_single_rays(version);
    }
}

fn batch_answers_like_single_rays(version: EmbreeVersion) {
    let scene = scene_or_skip!("sky/CBspheres_lambertian.dae");
    let embree = embree(version, BuildQuality::Medium, false, 0)
        .build(&scene)
        .unwrap();
    let mut set = rays::camera_rays(&scene, 5_000, 4);
    set.push(Ray::new(glam::Vec3::splat(f32::NAN), glam::Vec3::Z));
    let mut stream = vec![None; set.len()];
    embree.closest_hits(
        &set,
        Coherence::Coherent,
        &mut stream,
        &mut TraceCounters::default(),
    );
    assert_eq!(stream.len(), set.len());
    // Embree's packet path runs other kernels than rtcIntersect1,
    // so t may differ in the last bits; answers must agree as the parity
    // suite defines it.
    let scene_size = scene.bounds().extent().max_element();
    let mut exact = 0;
    for (r, s) in set.iter().zip(&stream) {
        let single = embree.closest_hit(r, &mut TraceCounters::default());
        assert!(
            hybrid::parity::batch_agrees(single, *s, false, scene_size),
            "packet {s:?} and single {single:?} disagree beyond the parity bound for {r:?}"
        );
        exact += (single == *s) as usize;
    }
    println!(
        "{}: batch vs single: {exact} of {} answers bit-identical",
        version.name(),
        set.len()
    );
}

/// The default render (480 x 360, 1 sample, direct light) on every
/// compared backend and triangle test: no pixel is black on one and lit on
/// another. Such pixels lined the floor-wall junctions on native
/// (Möller-Trumbore camera rays through the shared edge, shadow rays
/// starting behind the neighbouring wall) before hit points were rebuilt
/// from barycentrics and spawned past their error bounds.
#[test]
fn the_default_render_has_no_junction_pixels_only_one_backend_darkens() {
    let scene = common::default_scene();
    let settings = RenderSettings {
        shading: Shading::Path(PathSettings::default()),
        ..RenderSettings::default()
    };
    let images: Vec<(String, Vec<[u8; 3]>)> = hybrid::accel::config::parity_candidates()
        .iter()
        .chain([&hybrid::accel::BackendConfig::NATIVE_WATERTIGHT])
        .map(|config| {
            let accel = config.build(&scene).expect("builds");
            let film = render(&scene, &accel, &settings, &Silent).film;
            let rgb = film.to_rgb8(hybrid::render::film::ToneMap::REFERENCE);
            (
                config.label(),
                rgb.chunks(3).map(|p| [p[0], p[1], p[2]]).collect(),
            )
        })
        .collect();
    let black = |p: &[u8; 3]| *p == [0, 0, 0];
    let lit = |p: &[u8; 3]| p.iter().any(|&c| c > 30);
    for (a, pa) in &images {
        for (b, pb) in &images {
            let odd: Vec<usize> = (0..pa.len())
                .filter(|&i| black(&pa[i]) && lit(&pb[i]))
                .collect();
            let at: Vec<(usize, usize)> = odd.iter().take(8).map(|i| (i % 480, i / 480)).collect();
            assert!(
                odd.is_empty(),
                "{} pixels black on {a} but lit on {b}, e.g. {at:?}",
                odd.len()
            );
        }
    }
}

#[test]
fn embree_called_as_a_plain_c_program_gives_the_wrappers_answers() {
    let scene = scene_or_skip!("sky/CBbunny.dae");
    let camera = rays::camera_rays(&scene, 20_000, 1);
    let incoherent = rays::occlusion_rays(&scene, 20_000, 5);
    for version in versions() {
        let embree = embree(version, BuildQuality::Medium, false, 0)
            .build(&scene)
            .expect("embree builds");
        let flat = |rays: &[Ray]| rays.iter().map(Ray::flat).collect::<Vec<_>>();
        let hits = camera
            .iter()
            .filter(|r| {
                embree
                    .closest_hit(r, &mut TraceCounters::default())
                    .is_some()
            })
            .count();
        let blocked = incoherent
            .iter()
            .filter(|r| embree.occluded(r, &mut TraceCounters::default()))
            .count();
        assert!(
            hits > 1000 && blocked > 1000,
            "{hits} hits, {blocked} blocked"
        );
        assert_eq!(
            embree.plain_c().map(|c| c.trace(&flat(&camera), false)),
            Some(hits),
            "{}: closest hits",
            version.name()
        );
        assert_eq!(
            embree.plain_c().map(|c| c.trace(&flat(&incoherent), true)),
            Some(blocked),
            "{}: occluded rays",
            version.name()
        );
    }
    let native = BackendConfig::NATIVE.build(&scene).expect("native builds");
    assert!(native.plain_c().is_none(), "native is not a C library");
}
