//! How much work the report does (full or `--quick`) and on which scenes:
//! the sizes and the scene lists every section reads, in one place.

use std::path::Path;

use crate::measure::Settle;
use crate::scene::generate::sphere_cloud;
use crate::scene::Scene;

/// Sizes of the work, full or quick.
pub struct Budget {
    /// Rays per ray kind in the per-scene trace tables.
    pub rays: usize,
    pub repeats: usize,
    /// When the one-thread trace figures stop repeating.
    pub settle: Settle,
    /// Time per frame: width, height, samples per pixel.
    pub frame: (u32, u32, u32),
    /// Repeats of each backend's frame. More than the traces': a frame is
    /// short and runs on every core, so one busy moment of the shared
    /// machine moves a median of five by 10% or more.
    pub frame_repeats: usize,
    pub error_resolution: (u32, u32),
    pub reference_spp: u32,
    pub error_spp: Vec<u32>,
    pub adaptive_cap: u32,
    /// The scaling study: how many times the scanned mesh is subdivided
    /// (one scene per level from 0), and the copies of each cloud of it.
    pub scaling_subdivisions: u32,
    pub scaling_clouds: Vec<u32>,
    pub scaling_rays: usize,
    /// Rays per kind and mesh in the corpus section.
    pub corpus_rays: usize,
    pub gallery: (u32, u32),
    pub gallery_spp: u32,
    pub spp_series: Vec<u32>,
    /// Adaptive gallery: batch, tolerance, cap.
    pub adaptive_gallery: (u32, f32, u32),
    /// Estimator gallery: spp on the glossy scene, spp on the default one.
    pub estimator_gallery: (u32, u32),
    /// Adaptive against uniform: resolution, reference spp, batch,
    /// tolerance, cap.
    pub adaptive_study: ((u32, u32), u32, u32, f32, u32),
    /// Environment light study: resolution, sample counts, reference spp.
    pub environment_resolution: (u32, u32),
    pub environment_spp: Vec<u32>,
    pub environment_reference_spp: u32,
}

impl Budget {
    pub fn new(quick: bool) -> Budget {
        if quick {
            Budget {
                // Fewer scenes, not fewer rays: the quick ratios are the
                // full report's on the scenes it keeps.
                rays: 1_000_000,
                repeats: 3,
                settle: Settle {
                    min: 5,
                    max: 15,
                    within: 0.03,
                },
                // Frames of a tenth of a second, fifteen of each: at
                // 120x90 and three repeats (10 ms frames) the ratio with
                // and without packets read anywhere from 0.88 to 1.5, and
                // nine pairs bound its median only by their first and
                // eighth (the interval of `paired_ratio`).
                frame: (240, 180, 8),
                frame_repeats: 15,
                error_resolution: (64, 48),
                reference_spp: 512,
                error_spp: vec![1, 2, 4, 8, 16, 32],
                adaptive_cap: 64,
                scaling_subdivisions: 3,
                scaling_clouds: vec![2, 8, 32],
                scaling_rays: 10_000,
                corpus_rays: 20_000,
                // Tiles large enough to read and samples enough that a
                // single bounce's dim image shows (80x60 at 4 spp was a
                // sheet of noise); about ten seconds on two cores.
                gallery: (160, 120),
                gallery_spp: 16,
                spp_series: vec![1, 4, 16, 64],
                adaptive_gallery: (16, 0.1, 256),
                estimator_gallery: (64, 16),
                adaptive_study: ((64, 48), 1024, 16, 0.1, 512),
                environment_resolution: (64, 48),
                environment_spp: vec![4, 16, 64],
                environment_reference_spp: 256,
            }
        } else {
            Budget {
                rays: 1_000_000,
                repeats: 5,
                settle: Settle {
                    min: 5,
                    max: 25,
                    within: 0.03,
                },
                frame: (320, 240, 8),
                frame_repeats: 15,
                error_resolution: (160, 120),
                reference_spp: 8192,
                error_spp: vec![1, 2, 4, 8, 16, 32, 64, 128, 256],
                adaptive_cap: 1024,
                scaling_subdivisions: 4,
                scaling_clouds: vec![2, 8, 32, 128],
                scaling_rays: 100_000,
                corpus_rays: 200_000,
                gallery: (480, 360),
                gallery_spp: 64,
                spp_series: vec![1, 2, 4, 8, 16, 64, 256, 1024],
                adaptive_gallery: (64, 0.05, 2048),
                estimator_gallery: (1024, 128),
                adaptive_study: ((160, 120), 4096, 32, 0.05, 1024),
                environment_resolution: (160, 120),
                environment_spp: vec![1, 4, 16, 64, 256],
                environment_reference_spp: 4096,
            }
        }
    }
}

/// Where a scene of the report comes from.
#[derive(Clone, Copy, Debug)]
pub enum Source {
    /// A file of the shared scenes folder.
    Shared(&'static str),
    /// [`sphere_cloud`]: `count` icospheres of `level` (fixed seed).
    SphereCloud { count: u32, level: u32 },
}

/// A scene of the per-scene tables and the headline.
#[derive(Clone, Copy, Debug)]
pub struct ReportScene {
    /// Size class: small, medium, large, generated.
    pub size: &'static str,
    pub source: Source,
}

impl ReportScene {
    /// The scene's name in tables.
    pub fn name(&self) -> String {
        match self.source {
            Source::Shared(rel) => rel.to_string(),
            Source::SphereCloud { count, level } => {
                format!(
                    "generated ({count} icospheres, {} triangles)",
                    (count as usize * 20) << (2 * level)
                )
            }
        }
    }

    pub fn load(&self, dir: &Path) -> Result<Scene, String> {
        match self.source {
            Source::Shared(rel) => super::load(dir, rel),
            Source::SphereCloud { count, level } => Ok(sphere_cloud(count, level, 1)),
        }
    }
}

/// The scenes of the per-scene tables and the headline: the small Cornell
/// box, every shared mesh of 10^4+ triangles, and a generated one of about
/// 10^6.
pub const SCENES: [ReportScene; 5] = [
    ReportScene {
        size: "small",
        source: Source::Shared("sky/CBspheres_lambertian.dae"),
    },
    ReportScene {
        size: "medium",
        source: Source::Shared("sky/CBbunny.dae"),
    },
    ReportScene {
        size: "medium",
        source: Source::Shared("sky/bunny.dae"),
    },
    ReportScene {
        size: "large",
        source: Source::Shared("meshedit/maxplanck.dae"),
    },
    ReportScene {
        size: "generated",
        source: Source::SphereCloud {
            count: 64,
            level: 5,
        },
    },
];

/// The scenes `--quick` keeps: the two course meshes of 10^4+ triangles
/// that every table of the full report has too.
pub const QUICK_SCENES: [&str; 2] = ["sky/CBbunny.dae", "meshedit/maxplanck.dae"];

/// The per-scene tables' scenes: all of [`SCENES`], or with `quick` the
/// [`QUICK_SCENES`].
pub fn report_scenes(quick: bool) -> Vec<ReportScene> {
    SCENES
        .iter()
        .filter(|s| {
            !quick || matches!(s.source, Source::Shared(rel) if QUICK_SCENES.contains(&rel))
        })
        .copied()
        .collect()
}

/// Every shared scene the report reads (`quick` or not), each once: they
/// are all loaded before any measuring, so a missing or broken one ends
/// the run at once rather than after minutes of work.
pub fn shared_scenes(quick: bool) -> Vec<&'static str> {
    let mut all: Vec<&'static str> = report_scenes(quick)
        .iter()
        .filter_map(|s| match s.source {
            Source::Shared(rel) => Some(rel),
            Source::SphereCloud { .. } => None,
        })
        .collect();
    all.extend(BRUTE_FORCE_SCENES);
    all.extend(NORMALS_SCENES);
    all.extend([SERIES_SCENE, SAMPLES_SCENE, SCANNED]);
    all.extend(super::sampler::SCENES);
    all.extend(crate::bench::corpus::SHARED);
    all.sort_unstable();
    all.dedup();
    all
}

/// Above this many primitives only the compared backends' builds are
/// timed (a high-quality Embree build of 10^6 triangles takes seconds).
pub const ALL_BUILDS_UP_TO: usize = 200_000;

/// Small scenes for the "with and without acceleration" table.
pub const BRUTE_FORCE_SCENES: [&str; 4] = [
    "sky/CBempty.dae",
    "sky/CBspheres_lambertian.dae",
    "meshedit/teapot.dae",
    "keenan/banana.dae",
];

/// The gallery's scenes: normal shading, and the course series.
pub const NORMALS_SCENES: [&str; 4] = [
    "sky/CBspheres_lambertian.dae",
    "sky/CBbunny.dae",
    "meshedit/maxplanck.dae",
    "keenan/banana.dae",
];
pub const SERIES_SCENE: &str = "sky/CBbunny.dae";
/// The scanned mesh every scaling scene is made of.
pub const SCANNED: &str = "sky/bunny.dae";
pub const SAMPLES_SCENE: &str = "sky/CBspheres_lambertian.dae";
