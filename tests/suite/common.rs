//! Helpers shared by the tests.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use hybrid::scene::{builtin, collada, NormalMode, Scene};

/// The shared scenes folder, or `None` (with the reason printed) outside
/// CI when it is missing. Under CI a missing folder is a failure.
pub fn scenes_dir() -> Option<PathBuf> {
    let dir = hybrid::cli::shared_scenes_dir();
    if dir.is_dir() {
        return Some(dir);
    }
    if std::env::var_os("CI").is_some() {
        panic!(
            "shared scenes not found at {} (set HYBRID_SCENES); CI must have them",
            dir.display()
        );
    }
    eprintln!(
        "skipping: shared scenes not found at {} (set HYBRID_SCENES)",
        dir.display()
    );
    None
}

pub fn shared(rel: &str) -> Option<PathBuf> {
    let path = scenes_dir()?.join(rel);
    assert!(path.is_file(), "shared scene {} is missing", path.display());
    Some(path)
}

pub fn load(rel: &str) -> Option<Scene> {
    let path = shared(rel)?;
    Some(
        collada::load(&path, NormalMode::Smooth)
            .unwrap_or_else(|e| panic!("{rel} does not load: {e}")),
    )
}

/// The project's default scene.
pub fn default_scene() -> Scene {
    builtin::CORNELL
        .load(NormalMode::Smooth)
        .expect("default scene loads")
}

/// The project's glossy scene.
pub fn glossy_scene() -> Scene {
    builtin::GLOSSY
        .load(NormalMode::Smooth)
        .expect("glossy scene loads")
}

/// Loads a shared scene or returns from the test (skip outside CI).
macro_rules! scene_or_skip {
    ($rel:expr) => {
        match crate::common::load($rel) {
            Some(s) => s,
            None => return,
        }
    };
}
pub(crate) use scene_or_skip;

/// Root-mean-square difference of two equally sized radiance buffers.
pub fn rmse(a: &[glam::Vec3], b: &[glam::Vec3]) -> f64 {
    assert_eq!(a.len(), b.len());
    let sum: f64 = a
        .iter()
        .zip(b)
        .map(|(x, y)| (*x - *y).length_squared() as f64 / 3.0)
        .sum();
    (sum / a.len() as f64).sqrt()
}

/// A scratch directory unique to one test.
pub fn scratch(name: &str) -> PathBuf {
    let dir = std::env::temp_dir().join(format!("hybrid-test-{}-{name}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    std::fs::create_dir_all(&dir).expect("scratch dir");
    dir
}

/// Runs the `hybrid` binary with `args` in `dir`.
pub fn hybrid(args: &[&str], dir: &Path) -> Output {
    Command::new(env!("CARGO_BIN_EXE_hybrid"))
        .args(args)
        .current_dir(dir)
        .output()
        .expect("run hybrid")
}

/// `hybrid args` must succeed; its stderr is the failure message.
pub fn succeeds(args: &[&str], dir: &Path) {
    let o = hybrid(args, dir);
    assert!(
        o.status.success(),
        "hybrid {}: {}",
        args.join(" "),
        String::from_utf8_lossy(&o.stderr)
    );
}

/// `hybrid args` must fail with exit 2 and one `hybrid: error:` line
/// containing `expected`, and leave no new file in `dir`.
pub fn fails_in_one_line(args: &[&str], dir: &Path, expected: &str) {
    let files = || -> Vec<PathBuf> {
        let mut f: Vec<PathBuf> = std::fs::read_dir(dir)
            .unwrap()
            .flatten()
            .map(|e| e.path())
            .collect();
        f.sort();
        f
    };
    let before = files();
    let o = hybrid(args, dir);
    let stderr = String::from_utf8_lossy(&o.stderr);
    let what = format!("hybrid {}: {stderr}", args.join(" "));
    assert_eq!(o.status.code(), Some(2), "{what}");
    assert_eq!(stderr.lines().count(), 1, "not one line: {what}");
    assert!(stderr.starts_with("hybrid: error: "), "{what}");
    assert!(stderr.contains(expected), "'{expected}' not in: {what}");
    assert_eq!(files(), before, "a failed run left a file: {what}");
}

/// Direct light only (`-m 1`), one ray through each pixel's centre of a
/// `size` x `size` image from the scene's own camera node: for tests that
/// hold pixels against a closed form. Returns the film and the camera, so
/// that a test can trace the same rays itself.
pub fn direct_light_at_pixel_centres<A: hybrid::accel::Accel>(
    scene: &Scene,
    accel: &A,
    estimator: hybrid::render::integrator::DirectEstimator,
    size: u32,
) -> (hybrid::render::film::Film, hybrid::render::camera::Camera) {
    direct_light_sampled_at_pixel_centres(scene, accel, estimator, size, 1)
}

/// [`direct_light_at_pixel_centres`] with `light_samples` samples of
/// each area or ambient light (`-l`) per pixel.
pub fn direct_light_sampled_at_pixel_centres<A: hybrid::accel::Accel>(
    scene: &Scene,
    accel: &A,
    estimator: hybrid::render::integrator::DirectEstimator,
    size: u32,
    light_samples: u32,
) -> (hybrid::render::film::Film, hybrid::render::camera::Camera) {
    use hybrid::render::integrator::{PathSettings, Shading};
    use hybrid::render::{render, RenderSettings, Silent};
    let settings = RenderSettings {
        width: size,
        height: size,
        samples: 1,
        shading: Shading::Path(PathSettings {
            estimator,
            light_samples,
            max_bounces: 1,
            ..PathSettings::default()
        }),
        camera: hybrid::render::camera::CameraMode::Node,
        threads: 2,
        ..RenderSettings::default()
    };
    let film = render(scene, accel, &settings, &Silent).film;
    (film, settings.camera_for(scene))
}
