//! Loader, native build and a 4x3 render (normals, then one path-traced
//! sample with two bounces) on arbitrary text: whatever loads must build
//! and render without a panic or a non-finite pixel.
#![no_main]

use hybrid::accel::BackendConfig;
use hybrid::render::integrator::{PathSettings, Shading};
use hybrid::render::{render, RenderSettings, Silent};
use hybrid::scene::{collada, NormalMode};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let Ok(scene) = collada::load_str(text, "fuzz.dae", NormalMode::Smooth) else {
        return;
    };
    let accel = BackendConfig::NATIVE
        .build(&scene)
        .expect("a loaded scene builds");
    for shading in [
        Shading::Normals,
        Shading::Path(PathSettings {
            max_bounces: 2,
            ..PathSettings::default()
        }),
    ] {
        let settings = RenderSettings {
            width: 4,
            height: 3,
            threads: 1,
            shading,
            ..RenderSettings::default()
        };
        let film = render(&scene, &accel, &settings, &Silent).film;
        assert!(
            film.pixels.iter().all(|p| p.is_finite()),
            "non-finite pixel: {:?}",
            film.pixels
        );
    }
});
