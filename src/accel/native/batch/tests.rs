use super::*;
use crate::accel::native::NativeOptions;
use crate::accel::native::MIXED_PACKET_NODES;
use crate::accel::Accel;
use crate::parity::rays::{occlusion_rays, shadow_rays};
use crate::scene::builtin::CORNELL;
use crate::scene::NormalMode;
use crate::simd::cpu::Avx2;
use glam::Vec3;

/// The default scene and its tree with the default options, where the CPU
/// runs the stream and packet kernels (AVX2); else nothing to test.
fn cornell_where_streams_run() -> Option<(crate::scene::Scene, NativeBvh)> {
    Avx2::detect()?;
    let scene = CORNELL
        .load(NormalMode::Smooth)
        .expect("the default scene loads");
    let bvh = NativeBvh::build(&scene, &NativeOptions::DEFAULT).expect("native builds");
    Some((scene, bvh))
}

/// Occlusion streams answer as single rays do, ray for ray: full
/// streams of random rays, short ones (down to one ray a node), the
/// renderer's light rays, and rays that cannot be traced at all.
#[test]
fn occlusion_streams_answer_as_single_rays() {
    let Some((scene, bvh)) = cornell_where_streams_run() else {
        return;
    };
    let TriangleStore::Blocks(blocks) = &bvh.triangle_store else {
        panic!("the default options store triangle blocks");
    };
    let mut rays = occlusion_rays(&scene, 3_000, 7);
    rays.extend(shadow_rays(&scene, &bvh, 3_000, 8));
    rays[5].dir = Vec3::ZERO;
    rays[70].origin.y = f32::NAN;
    let mut alone = TraceCounters::default();
    let single: Vec<bool> = rays.iter().map(|r| bvh.occluded(r, &mut alone)).collect();
    assert!(single.iter().any(|&b| b) && single.iter().any(|&b| !b));
    for size in [traverse::STREAM, 37, 3] {
        let mut out = vec![false; rays.len()];
        let mut streams = TraceCounters::default();
        for start in (0..rays.len()).step_by(size) {
            let which: Vec<u32> = (start..rays.len().min(start + size))
                .map(|i| i as u32)
                .collect();
            Occluded::rest(&bvh, blocks, &rays, &which, &mut out, &mut streams);
        }
        assert_eq!(out, single, "streams of {size} rays");
        // Each ray meets the nodes and leaves of its single-ray walk,
        // in the same order, up to the same leaf: the same counts.
        assert_eq!(
            (streams.box_tests, streams.prim_tests),
            (alone.box_tests, alone.prim_tests),
            "streams of {size} rays: node and leaf tests"
        );
    }
}

/// Occlusion rays to infinity that share a direction (a directional
/// light's) from points scattered over the scene form no packets, and go
/// as streams (the node tests of single rays); leaving points side by side
/// or along one line (spread along the rays, not across), or reaching a
/// finite distance, they form packets (far fewer node tests counted: one
/// per packet's node). Same answers throughout.
#[test]
fn scattered_parallel_shadow_rays_form_no_packets() {
    let Some((scene, bvh)) = cornell_where_streams_run() else {
        return;
    };
    let toward = Vec3::new(0.3, 0.9, 0.2).normalize();
    let parallel = |origin: Vec3| Ray {
        origin,
        dir: toward,
        t_min: 1e-4,
        t_max: f32::INFINITY,
    };
    let scattered: Vec<Ray> = occlusion_rays(&scene, 2_048, 9)
        .iter()
        .map(|r| parallel(r.origin))
        .collect();
    let size = scene.bounds().extent().max_element();
    let (start, step) = (scattered[0].origin, size * 1e-4);
    let side_by_side: Vec<Ray> = (0..2_048)
        .map(|i| parallel(start + Vec3::new((i % 16) as f32, (i / 16 % 16) as f32, 0.0) * step))
        .collect();
    let along: Vec<Ray> = (0..2_048)
        .map(|i| parallel(start + toward * (size * 0.2 * (i % 16) as f32 / 16.0)))
        .collect();
    let reaching: Vec<Ray> = scattered
        .iter()
        .map(|r| Ray {
            t_max: 2.0 * size,
            ..*r
        })
        .collect();
    for (name, rays, packets) in [
        ("scattered", &scattered, false),
        ("side by side", &side_by_side, true),
        ("along one line", &along, true),
        ("scattered, reaching a finite distance", &reaching, true),
    ] {
        let mut alone = TraceCounters::default();
        let single: Vec<bool> = rays.iter().map(|r| bvh.occluded(r, &mut alone)).collect();
        let mut batch = TraceCounters::default();
        let mut out = vec![false; rays.len()];
        bvh.occluded_all(rays, &mut out, &mut batch);
        assert_eq!(out, single, "{name}: answers");
        if packets {
            assert!(
                batch.box_tests * 2 < alone.box_tests,
                "{name}: no packets ({} node tests, {} alone)",
                batch.box_tests,
                alone.box_tests
            );
        } else {
            assert_eq!(batch.box_tests, alone.box_tests, "{name}: packets formed");
        }
    }
}

/// Rays of every octant from points side by side (ambient occlusion's,
/// a diffuse bounce's, shadow rays from points under an area light) form
/// no packet of one octant. In a tree of a root and one level below it
/// they go as packets of mixed octants: far fewer node tests (one per
/// packet's node). In a deep tree, or beside spheres, they go as
/// streams, about the node tests of single rays. The same answers
/// everywhere.
#[test]
fn rays_of_mixed_octants_form_packets_in_small_trees() {
    let Some((cornell, with_spheres)) = cornell_where_streams_run() else {
        return;
    };
    let build = |scene: &crate::scene::Scene| {
        NativeBvh::build(scene, &NativeOptions::DEFAULT).expect("native builds")
    };
    let (few, cloud) = (
        crate::scene::generate::sphere_cloud(4, 0, 5),
        crate::scene::generate::sphere_cloud(64, 2, 5),
    );
    let (small, deep) = (build(&few), build(&cloud));
    assert!(small.triangles.nodes().len() <= MIXED_PACKET_NODES);
    assert!(deep.triangles.nodes().len() > 100);
    assert!(with_spheres.triangles.nodes().len() <= MIXED_PACKET_NODES);
    for (name, scene, bvh, packets) in [
        ("four icospheres", &few, &small, true),
        ("64 icospheres", &cloud, &deep, false),
        // Each lane's sphere walk would rebuild its ray's box constants.
        (
            "the Cornell box, with spheres",
            &cornell,
            &with_spheres,
            false,
        ),
    ] {
        let size = scene.bounds().extent().max_element();
        let random = occlusion_rays(scene, 4_096, 11);
        let base = random[0].origin;
        let rays: Vec<Ray> = random
            .iter()
            .enumerate()
            .map(|(i, r)| Ray {
                origin: base + Vec3::new((i % 4) as f32, (i / 4 % 4) as f32, 0.0) * size * 1e-3,
                t_max: 0.3 * size,
                ..*r
            })
            .collect();
        let one_octant = rays
            .chunks(8)
            .filter(|g| packet::packet_can_form(g, min_packet(8)))
            .count();
        assert!(
            one_octant * 20 < rays.len() / 8,
            "{name}: {one_octant} groups of one octant"
        );
        let mut alone = TraceCounters::default();
        let single: Vec<bool> = rays.iter().map(|r| bvh.occluded(r, &mut alone)).collect();
        assert!(
            single.iter().any(|&b| b) && single.iter().any(|&b| !b),
            "{name}"
        );
        let mut batch = TraceCounters::default();
        let mut out = vec![false; rays.len()];
        bvh.occluded_all(&rays, &mut out, &mut batch);
        assert_eq!(out, single, "{name}: occlusion");
        let (any_alone, any_batch) = (alone.box_tests, batch.box_tests);
        let mut alone = TraceCounters::default();
        let single: Vec<_> = rays
            .iter()
            .map(|r| bvh.closest_hit(r, &mut alone))
            .collect();
        assert!(single.iter().any(|h| h.is_some()), "{name}: nothing hit");
        let mut batch = TraceCounters::default();
        let mut hits = vec![None; rays.len()];
        bvh.closest_hits(
            &rays,
            crate::accel::Coherence::Incoherent,
            &mut hits,
            &mut batch,
        );
        assert_eq!(hits, single, "{name}: closest hits");
        for (query, alone, batch) in [
            ("occlusion", any_alone, any_batch),
            ("closest hits", alone.box_tests, batch.box_tests),
        ] {
            if packets {
                assert!(
                    batch * 2 < alone,
                    "{name} {query}: {batch} node tests, {alone} alone"
                );
            } else {
                // Streams test each ray's nodes (closest hits in another
                // order, so their counts differ a little).
                assert!(
                    batch * 10 > alone * 9,
                    "{name} {query}: packets formed ({batch} node tests, {alone} alone)"
                );
            }
        }
    }
}
