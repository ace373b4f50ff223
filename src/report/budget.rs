//! How much work the report does (full or `--quick`) and on which scenes:
//! the sizes and the scene lists every section reads, in one place.

/// Sizes of the work, full or quick.
pub struct Budget {
    /// Rays per ray kind in the per-scene trace tables.
    pub rays: usize,
    pub repeats: usize,
    /// Time per frame: width, height, samples per pixel.
    pub frame: (u32, u32, u32),
    pub error_resolution: (u32, u32),
    pub reference_spp: u32,
    pub error_spp: Vec<u32>,
    pub adaptive_cap: u32,
    /// Triangle counts of the generated meshes of the scaling study.
    pub scaling: Vec<usize>,
    pub scaling_rays: usize,
    pub gallery: (u32, u32),
    pub gallery_spp: u32,
    pub spp_series: Vec<u32>,
    /// Adaptive gallery: batch, tolerance, cap.
    pub adaptive_gallery: (u32, f32, u32),
}

impl Budget {
    pub fn new(quick: bool) -> Budget {
        if quick {
            Budget {
                rays: 50_000,
                repeats: 3,
                frame: (120, 90, 4),
                error_resolution: (64, 48),
                reference_spp: 512,
                error_spp: vec![1, 2, 4, 8, 16, 32],
                adaptive_cap: 64,
                scaling: vec![1_000, 10_000, 100_000, 1_000_000],
                scaling_rays: 10_000,
                gallery: (80, 60),
                gallery_spp: 4,
                spp_series: vec![1, 4, 16, 64],
                adaptive_gallery: (16, 0.1, 256),
            }
        } else {
            Budget {
                rays: 200_000,
                repeats: 7,
                frame: (320, 240, 8),
                error_resolution: (160, 120),
                reference_spp: 8192,
                error_spp: vec![1, 2, 4, 8, 16, 32, 64, 128, 256],
                adaptive_cap: 1024,
                scaling: vec![1_000, 10_000, 100_000, 1_000_000, 2_000_000],
                scaling_rays: 100_000,
                gallery: (480, 360),
                gallery_spp: 64,
                spp_series: vec![1, 2, 4, 8, 16, 64, 256, 1024],
                adaptive_gallery: (64, 0.05, 2048),
            }
        }
    }
}

/// The shared scenes of the per-scene tables and the headline, with their
/// size class.
pub const SCENES: [(&str, &str); 3] = [
    ("small", "sky/CBspheres_lambertian.dae"),
    ("medium", "sky/CBbunny.dae"),
    ("large", "meshedit/maxplanck.dae"),
];

/// Small scenes for the "with and without acceleration" table.
pub const BRUTE_FORCE_SCENES: [&str; 4] = [
    "sky/CBempty.dae",
    "sky/CBspheres_lambertian.dae",
    "meshedit/teapot.dae",
    "keenan/banana.dae",
];

/// The scene of the speed-against-error study.
pub const ERROR_SCENE: &str = "sky/CBspheres_lambertian.dae";

/// The gallery's scenes: normal shading, and the course series.
pub const NORMALS_SCENES: [&str; 4] = [
    "sky/CBspheres_lambertian.dae",
    "sky/CBbunny.dae",
    "meshedit/maxplanck.dae",
    "keenan/banana.dae",
];
pub const SERIES_SCENE: &str = "sky/CBbunny.dae";
pub const SAMPLES_SCENE: &str = "sky/CBspheres_lambertian.dae";
