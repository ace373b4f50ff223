//! Arbitrary scenes through both Embree versions: load, build, trace. An
//! Embree error must come back as `Err`, never abort the process or unwind
//! across the FFI boundary.
#![no_main]

use hybrid::accel::{Accel, BackendConfig};
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
    for config in [BackendConfig::EMBREE, BackendConfig::EMBREE4] {
        if config.available().is_err() {
            continue;
        }
        if let Ok(accel) = config.build(&scene) {
            let mut out = Vec::new();
            accel.closest_hits(&rays::random_rays(&scene, 16, 1), &mut out);
        }
    }
});
