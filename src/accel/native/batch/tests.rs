use super::*;
use crate::accel::native::cpu::Avx2;
use crate::accel::native::NativeOptions;
use crate::accel::Accel;
use crate::parity::rays::{occlusion_rays, shadow_rays};
use crate::scene::builtin::CORNELL;
use crate::scene::NormalMode;
use glam::Vec3;

/// Occlusion streams answer as single rays do, ray for ray: full
/// streams of random rays, short ones (walked alone from the root), the
/// renderer's light rays, and rays that cannot be traced at all.
#[test]
fn occlusion_streams_answer_as_single_rays() {
    if Avx2::detect().is_none() {
        return;
    }
    let scene = CORNELL
        .load(NormalMode::Smooth)
        .expect("the default scene loads");
    let bvh = NativeBvh::build(&scene, &NativeOptions::DEFAULT).expect("native builds");
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
