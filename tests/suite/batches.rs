//! The batch queries (native packets, Embree's `rtcIntersect8/16` and
//! `rtcOccluded8/16` through the C driver) answer as the same backend's
//! single-ray queries, ray for ray, on every kind of ray the renderer and
//! the report send: native bit for bit; Embree, whose packet kernels are
//! other code than its single-ray ones, within the bound the parity suite
//! states (`parity::BATCH_T_RELATIVE`).

use std::sync::atomic::{AtomicU64, Ordering};

use hybrid::accel::native::cpu::Avx2;
use hybrid::accel::native::NativeOptions;
use hybrid::accel::{Accel, BackendConfig, Coherence, TraceCounters};
use hybrid::geom::{Hit, Ray};
use hybrid::measure::coherence_of;
use hybrid::parity::batch_agrees;
use hybrid::parity::rays::{
    bounce_rays, camera_rays, incoherent_rays, occlusion_rays, shadow_rays,
};
use hybrid::render::camera::ThinLens;
use hybrid::render::integrator::{
    arrays_take, Background, BounceView, DirectEstimator, Integrator, PathSettings, Shading,
};
use hybrid::render::{render, Adaptive, Batching, RenderSettings, Silent, WAVE_PATHS};
use hybrid::scene::Scene;

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
    hybrid::accel::native::cpu::Avx2::detect().is_some()
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

/// Renders `scene` through `accel` with rays batched as `batching` says.
fn frame(
    scene: &Scene,
    accel: &impl Accel,
    settings: &RenderSettings,
    batching: Batching,
    threads: usize,
) -> (Vec<glam::DVec3>, Vec<u32>, u64) {
    let settings = RenderSettings {
        batching,
        threads,
        ..settings.clone()
    };
    let out = render(scene, accel, &settings, &Silent);
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
/// same bits alone, with camera rays batched and in waves (path tracing
/// with each direct-lighting estimator, Russian roulette, `-o 0`, normals,
/// adaptive sampling, a lens, any thread count) and traces as many rays;
/// Embree, whose packet kernels may round `t` differently in the last
/// bits, the same image within a hair.
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
        let alone = frame(&scene, &native, settings, Batching::Alone, 1);
        for batching in [Batching::Camera, Batching::Waves] {
            for threads in [1, 3] {
                let batched = frame(&scene, &native, settings, batching, threads);
                let what = format!("variant {v}, {batching:?}, {threads} threads");
                assert!(alone.0 == batched.0, "{what}: sums differ");
                assert_eq!(alone.1, batched.1, "{what}: samples per pixel differ");
                assert_eq!(alone.2, batched.2, "{what}: rays traced differ");
            }
        }
    }
    // The rays went through the batch queries: every camera ray, and in
    // waves every ray of every bounce, none alone.
    for estimator in [DirectEstimator::Mis, DirectEstimator::LightSampling] {
        let count = |settings: &RenderSettings, batching| {
            let counting = Batches {
                inner: &native,
                counts: Default::default(),
            };
            frame(&scene, &counting, settings, batching, 2);
            counting.counts.map(AtomicU64::into_inner)
        };
        let pixels = u64::from(base.width * base.height * base.samples);
        let deep = with_path(PathSettings {
            estimator,
            max_bounces: 4,
            ..PathSettings::default()
        });
        let [camera, alone] = [Batching::Camera, Batching::Alone].map(|b| count(&deep, b));
        // [closest_hits, occluded_all, occluded, closest_hit] rays.
        assert_eq!(alone[..2], [0, 0], "{estimator:?}: alone");
        assert_eq!(camera[0], pixels, "{estimator:?}: camera rays");
        assert_eq!(
            [camera[1], camera[2], camera[3] + pixels],
            [0, alone[2], alone[3]],
            "{estimator:?}: camera batches"
        );
        let waves = count(&deep, Batching::Waves);
        assert!(alone[3] > pixels + pixels / 4, "{estimator:?}: {alone:?}");
        assert_eq!(waves, [alone[3], alone[2], 0, 0], "{estimator:?}: waves");
    }
    // Adaptive sampling did stop some pixels early, so the check above
    // covered pixels leaving the waves.
    let adaptive = frame(&scene, &native, &variants[2], Batching::Waves, 1);
    assert!(adaptive.1.iter().any(|&n| n < 32) && adaptive.1.contains(&32));
    for config in [BackendConfig::EMBREE, BackendConfig::EMBREE4] {
        let embree = config.build(&scene).expect("embree builds");
        let alone = frame(&scene, &embree, &base, Batching::Alone, 1);
        for batching in [Batching::Camera, Batching::Waves] {
            let batched = frame(&scene, &embree, &base, batching, 2);
            let what = format!("{} {batching:?}", config.label());
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

/// A wave in arrays (its paths' state in lists, stepped eight paths at a
/// time: `render::integrator::ArrayWave`) gives the bits of the paths
/// walked alone, and traces as many rays: smoothly shaded triangles and
/// spheres of Lambertian and emitting materials lit by an area light
/// (CBbunny), a point light (CBempty) and a directional one (maxplanck);
/// with a mirror and a glass sphere (CBspheres) and a rough conductor
/// (the default and glossy scenes), whose vertices the arrays step path
/// by path among the lanes' ones; a sphere and a mesh under the sky's
/// ambient light and a directional light (sphere_diffuse, banana); under
/// MIS, light sampling
/// and hemisphere sampling (whose vertices all go path by path), several
/// light samples, Russian roulette, `-o 0`, direct light only, a black
/// background and adaptive sampling, on one thread and three. Where the
/// CPU runs AVX2 the arrays do take these frames, in lanes but for
/// hemisphere sampling.
#[test]
fn waves_in_arrays_give_the_bits_of_paths_alone() {
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
        with_path(PathSettings {
            estimator: DirectEstimator::Hemisphere,
            max_bounces: 3,
            ..PathSettings::default()
        }),
    ];
    for (name, scene) in &scenes {
        let native = BackendConfig::NATIVE.build(scene).expect("native builds");
        for (v, settings) in variants.iter().enumerate() {
            if Avx2::detect().is_some() {
                let integrator = Integrator::new(scene, &native, settings.shading);
                assert!(
                    integrator.array_plan(Avx2::detect()).is_some(),
                    "{name}, variant {v}: the arrays refused it"
                );
                let hemisphere = v == variants.len() - 1;
                assert_eq!(
                    arrays_take(scene, settings.shading),
                    !hemisphere,
                    "{name}, variant {v}: in lanes or not"
                );
            }
            let alone = frame(scene, &native, settings, Batching::Alone, 1);
            for threads in [1, 3] {
                let waves = frame(scene, &native, settings, Batching::Waves, threads);
                let what = format!("{name}, variant {v}, {threads} threads");
                assert!(alone.0 == waves.0, "{what}: sums differ");
                assert_eq!(alone.1, waves.1, "{what}: samples per pixel differ");
                assert_eq!(alone.2, waves.2, "{what}: rays traced differ");
            }
        }
    }
    // Normals go through the paths' states, as does everything on a CPU
    // without AVX2.
    let scene = &scenes[0].1;
    let native = BackendConfig::NATIVE.build(scene).expect("native builds");
    let normals = Integrator::new(scene, &native, Shading::Normals);
    assert!(normals.array_plan(Avx2::detect()).is_none());
    let path = Integrator::new(scene, &native, Shading::Path(PathSettings::default()));
    assert!(path.array_plan(None).is_none());
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
            batching: Batching::Waves,
            ..settings.clone()
        },
        &Silent,
    );
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
    // In arrays, the stepping is broken down by step, and the steps make
    // up all of it; otherwise there is no breakdown.
    let s = t.steps;
    if arrays_take(&scene, settings.shading) {
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
    } else {
        assert_eq!(s.shares(), None, "{s:?}");
    }
    for batching in [Batching::Camera, Batching::Alone] {
        let out = render(
            &scene,
            &native,
            &RenderSettings {
                batching,
                ..settings.clone()
            },
            &Silent,
        );
        assert_eq!(out.wave_times, Default::default(), "{batching:?}");
    }
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
        batching: Batching::Waves,
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
    let pieces = 160usize.div_ceil(WAVE_PATHS / 16);
    let paths = 160usize.div_ceil(pieces) * 16;
    let bound = WAVE_PATHS * 1024;
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
        // The wave's passes in lanes, each compiled for AVX2 and AVX-512:
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
        "wide::F16",
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
    let frame = |flag: &str| {
        let out = dir.join(format!("frame{flag}.exr"));
        let (out_arg, scene_arg) = (out.to_string_lossy(), path.to_string_lossy());
        let mut args = vec![
            "render", "-t", "2", "-r", "160", "120", "-s", "64", "-m", "5",
        ];
        args.extend(["-l", "1", "--seed", "3", "-f", &out_arg, &scene_arg]);
        if !flag.is_empty() {
            args.push(flag);
        }
        let o = crate::common::hybrid(&args, &dir);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        std::fs::read(&out).unwrap()
    };
    let alone = frame("--no-packets");
    assert!(
        frame("") == alone,
        "camera batches and rays alone give other frames"
    );
    assert!(
        frame("--waves") == alone,
        "waves and rays alone give other frames"
    );
}
