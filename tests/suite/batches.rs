//! The batch queries (native packets, Embree's `rtcIntersect8/16` and
//! `rtcOccluded8/16` through the C driver) answer as the same backend's
//! single-ray queries, ray for ray, on every kind of ray the renderer and
//! the report send: native bit for bit; Embree, whose packet kernels are
//! other code than its single-ray ones, within the bound the parity suite
//! states (`parity::BATCH_T_RELATIVE`).

use std::sync::atomic::{AtomicU64, Ordering};

use hybrid::accel::native::NativeOptions;
use hybrid::accel::OneByOne;
use hybrid::accel::{Accel, BackendConfig, Coherence, TraceCounters};
use hybrid::geom::{Hit, Ray};
use hybrid::measure::coherence_of;
use hybrid::parity::batch_agrees;
use hybrid::parity::rays::{
    bounce_rays, camera_rays, incoherent_rays, occlusion_rays, shadow_rays,
};
use hybrid::render::camera::ThinLens;
use hybrid::render::integrator::{
    Background, BounceView, DirectEstimator, Integrator, PathSettings, Shading,
};
use hybrid::render::wavefront::{lanes_take, Plan};
use hybrid::render::{render, Adaptive, Mode, RenderSettings, Sampler, Silent};
use hybrid::scene::Scene;
use hybrid::simd::lanes::Vectors;

use crate::common::scene_or_skip;

/// Ray sets of every kind, with a few odd ones mixed in: untraceable rays
/// (NaN, zero direction, empty interval) and a group that is not a whole
/// packet.
fn ray_sets(scene: &Scene, reference: &impl Accel) -> Vec<(&'static str, Vec<Ray>)> {
    let n = 4_003;
    let mut odd = camera_rays(scene, 61, 9);
    odd[3].dir = glam::Vec3::ZERO;
    odd[10].origin.x = f32::NAN;
    odd[17].t_max = -1.0;
    vec![
        ("camera", camera_rays(scene, n, 1)),
        ("incoherent", incoherent_rays(scene, n, 2)),
        ("bounce", bounce_rays(scene, reference, n, 3)),
        ("light", shadow_rays(scene, reference, n, 4)),
        ("occlusion", occlusion_rays(scene, n, 5)),
        ("odd", odd),
    ]
}

/// Every ray's batch answers against its single-ray answers: closest hit
/// and occlusion; also checks the batch counts every ray.
fn check(scene_name: &str, config: BackendConfig, scene: &Scene) {
    let reference = BackendConfig::NATIVE.build(scene).expect("native builds");
    let accel = match config.build(scene) {
        Ok(a) => a,
        Err(e) => panic!("{}: {e}", config.label()),
    };
    let exact = matches!(config, BackendConfig::Native(_));
    let scene_size = scene.bounds().extent().max_element();
    for (kind, rays) in ray_sets(scene, &reference) {
        assert!(!rays.is_empty(), "{scene_name} {kind}: no rays");
        let mut counters = TraceCounters::default();
        let single: Vec<Option<Hit>> = rays
            .iter()
            .map(|r| accel.closest_hit(r, &mut counters))
            .collect();
        let blocked: Vec<bool> = rays
            .iter()
            .map(|r| accel.occluded(r, &mut counters))
            .collect();
        let mut batch_counters = TraceCounters::default();
        let mut hits = vec![None; rays.len()];
        accel.closest_hits(&rays, coherence_of(kind), &mut hits, &mut batch_counters);
        // The hint picks kernels (Embree's coherent path), never answers.
        let other = match coherence_of(kind) {
            Coherence::Coherent => Coherence::Incoherent,
            Coherence::Incoherent => Coherence::Coherent,
        };
        let mut hinted = vec![None; rays.len()];
        accel.closest_hits(&rays, other, &mut hinted, &mut TraceCounters::default());
        let hint_differs = (0..rays.len())
            .filter(|&i| !batch_agrees(single[i], hinted[i], exact, scene_size))
            .count();
        assert_eq!(
            hint_differs,
            0,
            "{scene_name} {kind} {}: with the {other:?} hint {hint_differs} closest hits differ",
            config.label()
        );
        // Camera rays go as packets (one interval test per node for eight
        // rays), and so do the light rays' occlusion queries towards a
        // light at a finite distance (one light, origins side by side):
        // the node tests counted fall well below single rays'. A
        // directional light's rays from this small frame's hits are
        // parallel from points too far apart to share nodes, and go as
        // streams (the lib's scattered_parallel_shadow_rays_form_no_packets).
        let converge = rays.iter().all(|r| r.t_max.is_finite());
        let packets_expected = kind == "camera" || (kind == "light" && converge);
        if config == BackendConfig::NATIVE && packets_expected && simd() {
            let (alone, packets) = box_tests(&accel, &rays, kind == "light");
            assert!(
                packets * 4 < alone * 3,
                "{scene_name}: {kind} rays not traced as packets ({packets} box tests against {alone} alone)"
            );
        }
        let mut occluded = vec![false; rays.len()];
        accel.occluded_all(&rays, &mut occluded, &mut batch_counters);
        assert_eq!(
            batch_counters.rays,
            2 * rays.len() as u64,
            "{kind}: rays counted"
        );
        let differ: Vec<usize> = (0..rays.len())
            .filter(|&i| !batch_agrees(single[i], hits[i], exact, scene_size))
            .collect();
        assert!(
            differ.is_empty(),
            "{scene_name} {kind} {}: {} of {} closest hits differ, first ray {:?}: single {:?}, batch {:?}",
            config.label(),
            differ.len(),
            rays.len(),
            rays[differ[0]],
            single[differ[0]],
            hits[differ[0]]
        );
        let blocked_differ = (0..rays.len())
            .filter(|&i| blocked[i] != occluded[i])
            .count();
        assert_eq!(
            blocked_differ,
            0,
            "{scene_name} {kind} {}: occlusion differs on {blocked_differ} of {} rays",
            config.label(),
            rays.len()
        );
        // The sets must exercise both answers.
        assert!(
            hits.iter().any(|h| h.is_some()),
            "{scene_name} {kind}: nothing hit"
        );
    }
}

/// Box tests counted for `rays` one at a time and as one batch query,
/// closest hits or (`occlusion`) any hits.
fn box_tests(accel: &impl Accel, rays: &[Ray], occlusion: bool) -> (u64, u64) {
    let (mut alone, mut batch) = (TraceCounters::default(), TraceCounters::default());
    if occlusion {
        for r in rays {
            accel.occluded(r, &mut alone);
        }
        accel.occluded_all(rays, &mut vec![false; rays.len()], &mut batch);
    } else {
        for r in rays {
            accel.closest_hit(r, &mut alone);
        }
        accel.closest_hits(
            rays,
            Coherence::Coherent,
            &mut vec![None; rays.len()],
            &mut batch,
        );
    }
    (alone.box_tests, batch.box_tests)
}

/// Whether the native packet kernels run here (the CPU has AVX2 and
/// `HYBRID_ISA` allows it).
fn simd() -> bool {
    hybrid::simd::cpu::Avx2::detect().is_some()
}

#[test]
fn batch_queries_answer_as_single_rays_on_every_backend() {
    for rel in [
        "sky/CBbunny.dae",
        "sky/CBspheres.dae",
        "meshedit/maxplanck.dae",
    ] {
        let scene = scene_or_skip!(rel);
        for config in [
            BackendConfig::NATIVE,
            BackendConfig::NATIVE_PACKETS8,
            // Under HYBRID_ISA=avx2 (CI's ISA run): two AVX2 registers per
            // value.
            BackendConfig::NATIVE_PACKETS16,
            // No SIMD: the batch queries loop over single rays.
            BackendConfig::Native(NativeOptions {
                simd: false,
                ..NativeOptions::DEFAULT
            }),
            BackendConfig::NATIVE_WATERTIGHT,
            BackendConfig::EMBREE,
            BackendConfig::EMBREE4,
        ] {
            check(rel, config, &scene);
        }
    }
}

/// The ways a frame is rendered that must give the same image: the
/// reference mode, the same with every batch query answered one ray at a
/// time, and the wavefront.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Way {
    Reference,
    OneByOne,
    Wavefront,
}

/// Renders `scene` through `accel` the `way` given: its sums, samples per
/// pixel and rays traced.
fn frame<A: Accel>(
    scene: &Scene,
    accel: &A,
    settings: &RenderSettings,
    way: Way,
    threads: usize,
) -> (Vec<glam::DVec3>, Vec<u32>, u64) {
    let settings = RenderSettings {
        mode: Some(match way {
            Way::Wavefront => Mode::Wavefront,
            Way::Reference | Way::OneByOne => Mode::Reference,
        }),
        threads,
        ..settings.clone()
    };
    let out = if way == Way::OneByOne {
        render(scene, &OneByOne(accel), &settings, &Silent)
    } else {
        render(scene, accel, &settings, &Silent)
    };
    (out.film.sums, out.film.samples, out.counters.rays)
}

/// A backend that counts the rays reaching each of its queries (and
/// passes everything on to `inner`).
struct Batches<'a, A> {
    inner: &'a A,
    /// Rays through `closest_hits`, `occluded_all`, `occluded` and
    /// `closest_hit`.
    counts: [AtomicU64; 4],
}

impl<A: Accel> Accel for Batches<'_, A> {
    fn closest_hit(&self, ray: &Ray, counters: &mut TraceCounters) -> Option<Hit> {
        self.counts[3].fetch_add(1, Ordering::Relaxed);
        self.inner.closest_hit(ray, counters)
    }
    fn occluded(&self, ray: &Ray, counters: &mut TraceCounters) -> bool {
        self.counts[2].fetch_add(1, Ordering::Relaxed);
        self.inner.occluded(ray, counters)
    }
    fn closest_hits(
        &self,
        rays: &[Ray],
        coherence: Coherence,
        out: &mut [Option<Hit>],
        counters: &mut TraceCounters,
    ) {
        self.counts[0].fetch_add(rays.len() as u64, Ordering::Relaxed);
        self.inner.closest_hits(rays, coherence, out, counters)
    }
    fn occluded_all(&self, rays: &[Ray], out: &mut [bool], counters: &mut TraceCounters) {
        self.counts[1].fetch_add(rays.len() as u64, Ordering::Relaxed);
        self.inner.occluded_all(rays, out, counters)
    }
    fn stats(&self) -> hybrid::accel::AccelStats {
        self.inner.stats()
    }
}

/// How the renderer batches its rays changes nothing: native gives the
/// same bits one ray at a time, in the reference mode (camera rays
/// batched) and in the wavefront (path tracing with each direct-lighting
/// estimator, Russian roulette, `-o 0`, adaptive sampling, a lens, any
/// thread count; normals in the reference mode, which alone renders them)
/// and traces as many rays; Embree, whose packet kernels may round `t`
/// differently in the last bits, the same image within a hair.
#[test]
fn batching_leaves_the_image_unchanged() {
    let scene = crate::common::default_scene();
    let path = Shading::Path(PathSettings {
        light_samples: 1,
        max_bounces: 3,
        ..PathSettings::default()
    });
    let base = RenderSettings {
        width: 61,
        height: 37,
        samples: 4,
        seed: 7,
        shading: path,
        ..RenderSettings::default()
    };
    let with_path = |p: PathSettings| RenderSettings {
        shading: Shading::Path(p),
        ..base.clone()
    };
    let variants = [
        base.clone(),
        RenderSettings {
            shading: Shading::Normals,
            ..base.clone()
        },
        RenderSettings {
            samples: 32,
            adaptive: Some(Adaptive {
                batch: 4,
                tolerance: 0.2,
            }),
            ..base.clone()
        },
        RenderSettings {
            lens: Some(ThinLens {
                radius: 0.05,
                focal_distance: 3.0,
            }),
            ..base.clone()
        },
        with_path(PathSettings {
            estimator: DirectEstimator::LightSampling,
            light_samples: 3,
            max_bounces: 2,
            ..PathSettings::default()
        }),
        with_path(PathSettings {
            estimator: DirectEstimator::Hemisphere,
            light_samples: 2,
            max_bounces: 2,
            ..PathSettings::default()
        }),
        with_path(PathSettings {
            max_bounces: 6,
            russian_roulette: Some(0.7),
            ..PathSettings::default()
        }),
        with_path(PathSettings {
            max_bounces: 3,
            accumulate: false,
            ..PathSettings::default()
        }),
    ];
    let native = BackendConfig::NATIVE.build(&scene).expect("native builds");
    for (v, settings) in variants.iter().enumerate() {
        let alone = frame(&scene, &native, settings, Way::OneByOne, 1);
        for way in [Way::Reference, Way::Wavefront] {
            for threads in [1, 3] {
                let batched = frame(&scene, &native, settings, way, threads);
                let what = format!("variant {v}, {way:?}, {threads} threads");
                assert!(alone.0 == batched.0, "{what}: sums differ");
                assert_eq!(alone.1, batched.1, "{what}: samples per pixel differ");
                assert_eq!(alone.2, batched.2, "{what}: rays traced differ");
            }
        }
    }
    // The rays went through the batch queries: every camera ray, and in
    // the wavefront every ray of every bounce, none alone.
    for estimator in [DirectEstimator::Mis, DirectEstimator::LightSampling] {
        let count = |settings: &RenderSettings, way| {
            let counting = Batches {
                inner: &native,
                counts: Default::default(),
            };
            frame(&scene, &counting, settings, way, 2);
            counting.counts.map(AtomicU64::into_inner)
        };
        let pixels = u64::from(base.width * base.height * base.samples);
        let deep = with_path(PathSettings {
            estimator,
            max_bounces: 4,
            ..PathSettings::default()
        });
        let [camera, alone] = [Way::Reference, Way::OneByOne].map(|w| count(&deep, w));
        // [closest_hits, occluded_all, occluded, closest_hit] rays.
        assert_eq!(alone[..2], [0, 0], "{estimator:?}: alone");
        assert_eq!(camera[0], pixels, "{estimator:?}: camera rays");
        assert_eq!(
            [camera[1], camera[2], camera[3] + pixels],
            [0, alone[2], alone[3]],
            "{estimator:?}: camera batches"
        );
        let waves = count(&deep, Way::Wavefront);
        assert!(alone[3] > pixels + pixels / 4, "{estimator:?}: {alone:?}");
        assert_eq!(waves, [alone[3], alone[2], 0, 0], "{estimator:?}: waves");
    }
    // Adaptive sampling did stop some pixels early, so the check above
    // covered pixels leaving the waves.
    let adaptive = frame(&scene, &native, &variants[2], Way::Wavefront, 1);
    assert!(adaptive.1.iter().any(|&n| n < 32) && adaptive.1.contains(&32));
    for config in [BackendConfig::EMBREE, BackendConfig::EMBREE4] {
        let embree = config.build(&scene).expect("embree builds");
        let alone = frame(&scene, &embree, &base, Way::OneByOne, 1);
        for way in [Way::Reference, Way::Wavefront] {
            let batched = frame(&scene, &embree, &base, way, 2);
            let what = format!("{} {way:?}", config.label());
            assert_eq!(alone.2, batched.2, "{what}: rays traced differ");
            let (mut diff, mut total) = (0.0, 0.0);
            for (a, b) in alone.0.iter().zip(&batched.0) {
                diff += (*a - *b).abs().element_sum();
                total += a.element_sum();
            }
            assert!(
                diff <= 1e-4 * total,
                "{what}: batching moved the image by {}",
                diff / total
            );
        }
    }
}

/// The three ways to render a frame give the same bits and trace as many
/// rays: the reference mode (each path walked alone from its batched
/// camera rays), the same with every batch query answered one ray at a
/// time, and the wavefront (its paths' state in lists, stepped sixteen at
/// a time in AVX-512, AVX2 or the scalar twin, as the CPU and
/// `HYBRID_ISA` allow: CI runs this under each). Smoothly shaded triangles and
/// spheres of Lambertian and emitting materials lit by an area light
/// (CBbunny), a point light (CBempty) and a directional one (maxplanck);
/// with a mirror and a glass sphere (CBspheres) and a rough conductor
/// (the default and glossy scenes), whose vertices the arrays step path
/// by path among the lanes' ones; a sphere and a mesh under the sky's
/// ambient light and a directional light (sphere_diffuse, banana); under
/// MIS, light sampling
/// and hemisphere sampling (whose vertices all go path by path), several
/// light samples, Russian roulette, `-o 0`, direct light only, a black
/// background and adaptive sampling, the Sobol sampler (the default) and
/// independent numbers, on one thread and three; normals in
/// the two reference ways. The wavefront's lanes take these frames but
/// for hemisphere sampling, whose vertices all go path by path.
#[test]
fn the_modes_give_the_same_bits() {
    let mut scenes = Vec::new();
    for name in [
        "sky/CBbunny.dae",
        "sky/CBempty.dae",
        "sky/CBspheres.dae",
        "meshedit/maxplanck.dae",
        "basic/sphere_diffuse.dae",
        "keenan/banana.dae",
    ] {
        scenes.push((name, scene_or_skip!(name)));
    }
    scenes.push(("the default scene", crate::common::default_scene()));
    scenes.push(("the glossy scene", crate::common::glossy_scene()));
    let base = RenderSettings {
        width: 40,
        height: 30,
        samples: 6,
        seed: 11,
        ..RenderSettings::default()
    };
    let with_path = |p: PathSettings| RenderSettings {
        shading: Shading::Path(p),
        ..base.clone()
    };
    let variants = [
        with_path(PathSettings {
            max_bounces: 5,
            ..PathSettings::default()
        }),
        with_path(PathSettings {
            estimator: DirectEstimator::LightSampling,
            light_samples: 3,
            max_bounces: 3,
            ..PathSettings::default()
        }),
        with_path(PathSettings {
            max_bounces: 7,
            russian_roulette: Some(0.6),
            ..PathSettings::default()
        }),
        with_path(PathSettings {
            max_bounces: 3,
            accumulate: false,
            ..PathSettings::default()
        }),
        with_path(PathSettings {
            max_bounces: 4,
            view: BounceView::Direct,
            background: Background::Black,
            ..PathSettings::default()
        }),
        RenderSettings {
            samples: 24,
            adaptive: Some(Adaptive {
                batch: 4,
                tolerance: 0.3,
            }),
            ..with_path(PathSettings {
                max_bounces: 4,
                ..PathSettings::default()
            })
        },
        RenderSettings {
            sampler: Sampler::Independent,
            ..with_path(PathSettings {
                max_bounces: 5,
                russian_roulette: Some(0.8),
                ..PathSettings::default()
            })
        },
        with_path(PathSettings {
            estimator: DirectEstimator::Hemisphere,
            max_bounces: 3,
            ..PathSettings::default()
        }),
    ];
    for (name, scene) in &scenes {
        let native = BackendConfig::NATIVE.build(scene).expect("native builds");
        for (v, settings) in variants.iter().enumerate() {
            let integrator = Integrator::new(scene, &native, settings.shading);
            let plan = Plan::new(&integrator).expect("the wavefront plans path tracing");
            let hemisphere = v == variants.len() - 1;
            assert_eq!(plan.in_lanes(), !hemisphere, "{name}, variant {v}");
            assert_eq!(lanes_take(scene, settings.shading), !hemisphere);
            let chosen = Mode::choose(None, scene, settings.shading).0;
            let default = if hemisphere {
                Mode::Reference
            } else {
                Mode::Wavefront
            };
            assert_eq!(chosen, default, "{name}, variant {v}: the default mode");
            let reference = frame(scene, &native, settings, Way::Reference, 1);
            let ways = [(Way::OneByOne, 1), (Way::Wavefront, 1), (Way::Wavefront, 3)];
            for (way, threads) in ways {
                let other = frame(scene, &native, settings, way, threads);
                let what = format!("{name}, variant {v}, {way:?} on {threads} threads");
                assert!(reference.0 == other.0, "{what}: sums differ");
                assert_eq!(reference.1, other.1, "{what}: samples per pixel differ");
                assert_eq!(reference.2, other.2, "{what}: rays traced differ");
            }
        }
    }
    eprintln!("wavefront lanes: {}", Vectors::widest().name());
    // Normals: the reference mode alone renders them, whatever is asked.
    let scene = &scenes[0].1;
    let native = BackendConfig::NATIVE.build(scene).expect("native builds");
    let normals = Integrator::new(scene, &native, Shading::Normals);
    assert!(Plan::new(&normals).is_none());
    for asked in [None, Some(Mode::Wavefront)] {
        assert_eq!(
            Mode::choose(asked, scene, Shading::Normals).0,
            Mode::Reference
        );
    }
    let settings = RenderSettings {
        shading: Shading::Normals,
        ..base.clone()
    };
    let reference = frame(scene, &native, &settings, Way::Reference, 2);
    assert_eq!(
        reference,
        frame(scene, &native, &settings, Way::OneByOne, 1)
    );
}

/// A wave renderer says where its time went: each phase (extension-ray
/// batches, shadow-ray batches, stepping paths) took some, together no
/// more than the frame on one thread (each is timed inside it); the other
/// modes time nothing.
#[test]
fn waves_say_where_their_time_went() {
    let scene = crate::common::default_scene();
    let native = BackendConfig::NATIVE.build(&scene).expect("native builds");
    let settings = RenderSettings {
        width: 40,
        height: 30,
        samples: 4,
        seed: 3,
        threads: 1,
        shading: Shading::Path(PathSettings {
            light_samples: 1,
            max_bounces: 3,
            ..PathSettings::default()
        }),
        ..RenderSettings::default()
    };
    let waves = render(
        &scene,
        &native,
        &RenderSettings {
            mode: Some(Mode::Wavefront),
            ..settings.clone()
        },
        &Silent,
    );
    assert_eq!(waves.mode, Mode::Wavefront);
    let t = waves.wave_times;
    assert!(
        t.closest > 0.0 && t.occluded > 0.0 && t.paths > 0.0,
        "a phase took no time: {t:?}"
    );
    assert!(t.total() <= waves.seconds, "{t:?} in {} s", waves.seconds);
    let shares = t.shares();
    assert!(
        (shares.iter().sum::<f64>() - 1.0).abs() < 1e-9,
        "{shares:?}"
    );
    // The stepping is broken down by step, and the steps make up all of
    // it.
    let s = t.steps;
    assert!(
        s.arrive > 0.0 && s.light > 0.0 && s.leave > 0.0,
        "a step took no time: {s:?}"
    );
    let sum = s.arrive + s.light + s.leave;
    assert!(
        (sum - t.paths).abs() <= 1e-9 * t.paths,
        "{s:?} of {}",
        t.paths
    );
    let reference = RenderSettings {
        mode: Some(Mode::Reference),
        ..settings.clone()
    };
    let out = render(&scene, &native, &reference, &Silent);
    assert_eq!(out.mode, Mode::Reference);
    assert_eq!(out.wave_times, Default::default());
    let out = render(&scene, &OneByOne(&native), &reference, &Silent);
    assert_eq!(out.wave_times, Default::default());
}

/// A wave renderer says the most memory one thread's wave held (its
/// paths, rays, hits and shadow tape, docs/design.md: up to about 0.85 KB
/// a path, 1.7 MB for waves of 2048 paths): some, within 1 KiB a path of a
/// full wave however wide the row, on one thread as on three (a thread's
/// lists pass from row to row, so what they grew to depends on the rows
/// it took before: within the same bound).
#[test]
fn waves_say_how_much_memory_a_thread_held() {
    let scene = crate::common::default_scene();
    let native = BackendConfig::NATIVE.build(&scene).expect("native builds");
    let settings = |threads| RenderSettings {
        width: 160,
        height: 12,
        samples: 16,
        seed: 3,
        threads,
        mode: Some(Mode::Wavefront),
        shading: Shading::Path(PathSettings {
            light_samples: 1,
            max_bounces: 5,
            ..PathSettings::default()
        }),
        ..RenderSettings::default()
    };
    let one = render(&scene, &native, &settings(1), &Silent)
        .wave_times
        .peak_bytes;
    let three = render(&scene, &native, &settings(3), &Silent)
        .wave_times
        .peak_bytes;
    // A wave holds the 16 samples of an even piece of the row's 160
    // pixels, as many as fit, each path its state and at least a camera
    // ray.
    let wave_paths = Mode::Wavefront.wave_paths();
    let pieces = 160usize.div_ceil(wave_paths / 16);
    let paths = 160usize.div_ceil(pieces) * 16;
    let bound = wave_paths * 1024;
    for (threads, held) in [(1, one), (3, three)] {
        assert!(held > paths * 32, "{held} bytes, {threads} threads");
        assert!(held <= bound, "{held} bytes a thread, {threads} threads");
    }
    // A row three times as wide as a wave goes in pieces: the same bound.
    let wide = RenderSettings {
        width: 3000,
        height: 2,
        samples: 8,
        ..settings(1)
    };
    let wide = render(&scene, &native, &wide, &Silent)
        .wave_times
        .peak_bytes;
    assert!(wide <= bound, "{wide} bytes a thread for a 3000-pixel row");
}

/// Every SIMD intrinsic is inlined into the `#[target_feature]` kernel that
/// calls it. One reached through code without the features (a closure run
/// by `array::map`, issue 49) stays a function call that passes vectors
/// through memory: eight-ray packets then ran at a quarter of single rays.
/// Such a call leaves the intrinsic as a symbol of its own, or has the
/// kernel call the library function that runs the closure (`map`'s
/// `try_map`, `from_fn`'s `try_from_fn`). So: no x86 intrinsic stands as a
/// function in the binary (CPU detection's `cpuid` and `xgetbv` aside),
/// and the packet and AVX2 kernels call no array builder.
#[test]
fn simd_intrinsics_are_inlined_into_their_kernels() {
    let binary = env!("CARGO_BIN_EXE_hybrid");
    let run = |tool: &str, args: &[&str]| {
        let out = std::process::Command::new(tool)
            .args(args)
            .arg(binary)
            .output()
            .unwrap_or_else(|e| panic!("{tool} (binutils) reads the binary: {e}"));
        assert!(out.status.success(), "{tool} {binary}: {out:?}");
        String::from_utf8_lossy(&out.stdout).into_owned()
    };
    let symbols = run("nm", &["--defined-only", "-C"]);
    let detection = ["cpuid", "xgetbv"];
    let mut wrong: Vec<String> = symbols
        .lines()
        .filter(|l| l.contains("core_arch::x86") && !detection.iter().any(|d| l.contains(d)))
        .map(|l| format!("out of line: {l}"))
        .collect();
    let kernels = [
        "NativeBvh::group_avx2",
        "NativeBvh::group16",
        "traverse::avx2::",
        // The wavefront's passes in lanes, each compiled for AVX2 and AVX-512:
        // a closure or lane operation left out of line there runs without
        // the pass's vectors.
        "_pass::avx2",
        "_pass::avx512",
    ];
    let builders = [
        "try_map",
        "try_from_fn",
        "core_arch::x86",
        "{{closure}}",
        "lanes::F16",
    ];
    let mut kernel = None;
    let mut kernels_seen = 0;
    let mut passes_seen = 0;
    for line in run("objdump", &["-d", "--no-show-raw-insn", "-C"]).lines() {
        if let Some(name) = line.strip_suffix(">:").and_then(|l| l.split_once(" <")) {
            let name = name.1.to_string();
            passes_seen += usize::from(name.contains("_pass::avx"));
            kernel = kernels.iter().any(|k| name.contains(k)).then_some(name);
            kernels_seen += usize::from(kernel.is_some());
        } else if let Some(name) = &kernel {
            if line.contains("call") && builders.iter().any(|b| line.contains(b)) {
                wrong.push(format!("{name} calls {}", line.trim()));
            }
        }
    }
    assert!(
        kernels_seen >= 3,
        "found {kernels_seen} kernels in {binary}"
    );
    assert!(
        passes_seen >= 14,
        "found {passes_seen} of the seven passes' two versions in {binary}"
    );
    assert!(
        wrong.is_empty(),
        "{} calls where SIMD code should be inlined:\n{}",
        wrong.len(),
        wrong.join("\n")
    );
}

/// Two ways packets once answered otherwise than single rays, each found
/// in a CBbunny frame that differed in one pixel with `--no-packets`: a
/// camera ray through the edge two triangles share, at exactly the same
/// distance (the walk's order picked the triangle), and a camera ray whose
/// only hit the triangle test's edge slack puts just outside the root box
/// (the ray alone tests the root box; the packet did not). Each ray goes
/// in a packet of eight with its neighbours, as in the frame, and the
/// frame itself must come out the same, bit for bit.
#[test]
fn packets_meet_ties_and_the_root_box_as_single_rays() {
    let Some(path) = crate::common::shared("sky/CBbunny.dae") else {
        return;
    };
    let scene = scene_or_skip!("sky/CBbunny.dae");
    let accel = BackendConfig::NATIVE_PACKETS8
        .build(&scene)
        .expect("native builds");
    let origin = glam::Vec3::new(0.0, 0.75, f32::from_bits(0xc099_accd));
    for (dir, what) in [
        (
            [0x3cb8_1616, 0xbe0e_c853, 0x3f7d_6f13],
            "a tie between two triangles",
        ),
        (
            [0x3dfb_ba66, 0xbe44_a903, 0x3f79_419b],
            "a hit just outside the root box",
        ),
    ] {
        let dir = glam::Vec3::from_array(dir.map(f32::from_bits));
        // The ray and seven neighbours a pixel's width apart.
        let rays: Vec<Ray> = (0..8)
            .map(|k| Ray::new(origin, dir + glam::Vec3::new(0.002 * k as f32, 0.0, 0.0)))
            .collect();
        let single: Vec<Option<Hit>> = rays
            .iter()
            .map(|r| accel.closest_hit(r, &mut TraceCounters::default()))
            .collect();
        let mut batch = vec![None; rays.len()];
        accel.closest_hits(
            &rays,
            Coherence::Coherent,
            &mut batch,
            &mut TraceCounters::default(),
        );
        for k in 0..rays.len() {
            assert!(
                batch_agrees(single[k], batch[k], true, 1.0),
                "{what}, ray {k}: single {:?}, packet {:?}",
                single[k],
                batch[k]
            );
        }
    }
    let dir = crate::common::scratch("packets-frame");
    let frame_in = |flags: &[&str]| {
        let out = dir.join(format!("frame{}.exr", flags.join("")));
        let (out_arg, scene_arg) = (out.to_string_lossy(), path.to_string_lossy());
        let mut args = vec![
            "render", "-t", "2", "-r", "160", "120", "-s", "64", "-m", "5",
        ];
        args.extend(["-l", "1", "--seed", "3", "-f", &out_arg, &scene_arg]);
        args.extend(flags);
        let o = crate::common::hybrid(&args, &dir);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(&out).unwrap()
    };
    let alone = frame_in(&["--no-packets"]);
    assert!(
        frame_in(&[]) == alone,
        "camera batches and rays alone give other frames"
    );
    for mode in ["reference", "wavefront"] {
        assert!(
            frame_in(&["--mode", mode]) == alone,
            "{mode} and rays alone give other frames"
        );
    }
}
