//! Arbitrary scenes through both Embree versions and the native packets:
//! load, build, trace one ray at a time and in batches. An Embree error
//! must come back as `Err`, never abort the process or unwind across the
//! FFI boundary; the batch queries must answer as single rays do.
#![no_main]

use hybrid::accel::{Accel, BackendConfig, Coherence, TraceCounters};
use hybrid::parity::rays;
use hybrid::scene::{collada, NormalMode};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(scene) = collada::load_str(text, "fuzz.dae", NormalMode::Smooth) else {
        return;
    };
    let mut set = rays::random_rays(&scene, 16, 1);
    set.extend(rays::camera_rays(&scene, 48, 2));
    for config in [BackendConfig::EMBREE, BackendConfig::EMBREE4, BackendConfig::NATIVE] {
        if config.available().is_err() {
            continue;
        }
        if let Ok(accel) = config.build(&scene) {
            let mut counters = TraceCounters::default();
            let mut hits = vec![None; set.len()];
            accel.closest_hits(&set, Coherence::Incoherent, &mut hits, &mut counters);
            let mut blocked = vec![false; set.len()];
            accel.occluded_all(&set, &mut blocked, &mut counters);
            // Native packets give each ray its single-ray answer; between
            // coincident triangles (arbitrary scenes have them) either may
            // be named, at the same distance.
            if matches!(config, BackendConfig::Native(_)) {
                for (i, ray) in set.iter().enumerate() {
                    let single = accel.closest_hit(ray, &mut counters);
                    assert_eq!(hits[i].map(|h| h.t.to_bits()), single.map(|h| h.t.to_bits()));
                    assert_eq!(blocked[i], accel.occluded(ray, &mut counters), "ray {i}");
                }
            }
        }
    }
});
