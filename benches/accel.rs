//! Criterion benchmarks: every build variant of `accel::config` and the
//! compared backends' traces (the report's ray kinds; one thread; the same
//! pre-generated rays for every backend) on the report's scenes.
//! `cargo bench` (needs ../shared/scenes or HYBRID_SCENES).

use criterion::{criterion_group, criterion_main, BenchmarkId, Criterion, Throughput};

use hybrid::accel::config::{build_variants, compared, BackendConfig};
use hybrid::measure::{ray_sets, trace_all};
use hybrid::report::budget::SCENES;
use hybrid::scene::Scene;

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
        .map(|s| {
            (
                format!("{}:{}", s.size, s.name()),
                s.load(&dir).expect("report scene loads"),
            )
        })
        .collect()
}

fn builds(c: &mut Criterion) {
    let mut group = c.benchmark_group("build");
    group.sample_size(10);
    for (name, scene) in scenes() {
        group.throughput(Throughput::Elements(scene.primitive_count() as u64));
        for config in &build_variants() {
            let label = config.label().replace(' ', "-");
            group.bench_with_input(BenchmarkId::new(label, &name), &scene, |b, s| {
                b.iter(|| config.build(s).expect("builds"))
            });
        }
    }
    group.finish();
}

fn traces(c: &mut Criterion) {
    let mut group = c.benchmark_group("trace");
    group.sample_size(20);
    for (name, scene) in scenes() {
        let backends: Vec<_> = compared()
            .iter()
            .map(|c| (c.kind(), c.build(&scene).expect("builds")))
            .collect();
        let finder = BackendConfig::NATIVE.build(&scene).expect("builds");
        for set in ray_sets(&scene, &finder, 20_000) {
            group.throughput(Throughput::Elements(set.rays.len() as u64));
            for (kind, accel) in &backends {
                group.bench_function(
                    BenchmarkId::new(format!("{kind}-{}", set.kind), &name),
                    |b| b.iter(|| trace_all(accel, &set.rays, set.query, 1)),
                );
            }
        }
    }
    group.finish();
}

criterion_group!(benches, builds, traces);
criterion_main!(benches);
