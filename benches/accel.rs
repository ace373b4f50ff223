//! Criterion benchmarks: BVH builds (native variants, Embree build
//! qualities) and traces (camera, shadow, bounce rays; one thread; the same
//! pre-generated rays for every backend) on a small, a medium and a large
//! shared scene. `cargo bench` (needs ../shared/scenes or HYBRID_SCENES).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

use hybrid::accel::embree::{BuildQuality, EmbreeAccel, EmbreeOptions};
use hybrid::accel::native::bvh::BuildMethod;
use hybrid::accel::native::triangle::TriangleMode;
use hybrid::accel::native::{NativeBvh, NativeOptions};
use hybrid::parity::rays;
use hybrid::report::measure::{trace_all, Query};
use hybrid::report::SCENES;
use hybrid::scene::{collada, NormalMode, Scene};

fn scenes() -> Vec<(String, Scene)> {
    let dir = hybrid::cli::shared_scenes_dir();
    if !dir.is_dir() {
        eprintln!(
            "benches: no shared scenes at {} (set HYBRID_SCENES); nothing to measure",
            dir.display()
        );
        return Vec::new();
    }
    SCENES
        .iter()
        .map(|(size, rel)| {
            (
                format!("{size}:{rel}"),
                collada::load(&dir.join(rel), NormalMode::Smooth).expect("shared scene loads"),
            )
        })
        .collect()
}

fn builds(c: &mut Criterion) {
    let mut group = c.benchmark_group("build");
    group.sample_size(10);
    for (name, scene) in scenes() {
        group.throughput(Throughput::Elements(scene.primitive_count() as u64));
        for (label, method, triangle) in [
            ("native-sah", BuildMethod::Sah, TriangleMode::MollerTrumbore),
            (
                "native-sah-watertight",
                BuildMethod::Sah,
                TriangleMode::Watertight,
            ),
            (
                "native-median",
                BuildMethod::Median,
                TriangleMode::MollerTrumbore,
            ),
        ] {
            let opts = NativeOptions {
                method,
                triangle,
                ..NativeOptions::default()
            };
            group.bench_with_input(BenchmarkId::new(label, &name), &scene, |b, s| {
                b.iter(|| NativeBvh::build(s, &opts))
            });
        }
        for quality in [BuildQuality::Low, BuildQuality::Medium, BuildQuality::High] {
            let opts = EmbreeOptions {
                quality,
                ..EmbreeOptions::default()
            };
            group.bench_with_input(
                BenchmarkId::new(format!("embree-{quality:?}"), &name),
                &scene,
                |b, s| b.iter(|| EmbreeAccel::build(s, &opts).expect("embree builds")),
            );
        }
    }
    group.finish();
}

fn traces(c: &mut Criterion) {
    let mut group = c.benchmark_group("trace");
    group.sample_size(20);
    for (name, scene) in scenes() {
        let native = NativeBvh::build(&scene, &NativeOptions::default());
        let embree = EmbreeAccel::build(&scene, &EmbreeOptions::default()).expect("embree builds");
        let sets = [
            (
                "camera",
                Query::Closest,
                rays::camera_rays(&scene, 20_000, 1),
            ),
            (
                "shadow",
                Query::Occluded,
                rays::shadow_rays(&scene, &native, 20_000, 2),
            ),
            (
                "bounce",
                Query::Closest,
                rays::bounce_rays(&scene, &native, 20_000, 3),
            ),
        ];
        for (kind, query, set) in &sets {
            group.throughput(Throughput::Elements(set.len() as u64));
            group.bench_function(BenchmarkId::new(format!("native-{kind}"), &name), |b| {
                b.iter(|| trace_all(&native, set, *query, 1))
            });
            group.bench_function(BenchmarkId::new(format!("embree-{kind}"), &name), |b| {
                b.iter(|| trace_all(&embree, set, *query, 1))
            });
        }
    }
    group.finish();
}

criterion_group!(benches, builds, traces);
criterion_main!(benches);
