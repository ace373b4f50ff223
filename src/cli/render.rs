//! `hybrid render`: load, build the chosen backend, render, write, report.

use crate::simd::cpu::Isa;
use std::path::{Path, PathBuf};
use std::time::Instant;

use clap::Args;

use super::choice;
use super::progress::Bar;
use crate::accel::config::BackendKind;
use crate::accel::embree::{BuildQuality, EmbreeOptions};
use crate::accel::native::build::BuildMethod;
use crate::accel::native::triangle::TriangleMode;
use crate::accel::native::NativeOptions;
use crate::accel::{Accel, BackendConfig, OneByOne};
use crate::choice::Choice;
use crate::render::camera::CameraMode;
use crate::render::film::{check_writable, rate_path, write_files, Exposure, Film, ToneMap};
use crate::render::integrator::{Background, BounceView, DirectEstimator};
use crate::render::{render, Mode, RenderOutput, RenderSettings, Sampler};
use crate::scene::environment::{EnvSampling, Environment};
use crate::scene::{NormalMode, Scene};

#[derive(Args, Debug, Clone)]
pub struct RenderArgs {
    #[command(flatten)]
    pub input: super::SceneInput,
    /// Acceleration backend (`embree`: the newest present, 4 when it
    /// loads, else 3; `none`: brute force); its options come from its own
    /// flags.
    #[arg(long, value_parser = choice::<BackendKind>(), default_value = BackendKind::Native.name())]
    pub accel: BackendKind,
    /// Colour by the shading normal (n * 0.5 + 0.5) instead of path tracing.
    #[arg(long)]
    pub normals: bool,
    /// Shade with flat (geometric) normals instead of smooth ones.
    #[arg(long)]
    pub flat: bool,
    /// Smooth normals stop at edges sharper than this many degrees (faces
    /// meeting at more keep their own normals); default: no crease.
    #[arg(long, value_name = "DEG")]
    pub crease: Option<f32>,
    /// Camera placement: the reference framing, or the camera node's own.
    #[arg(long, value_parser = choice::<CameraMode>(), default_value = CameraMode::default().name())]
    pub camera: CameraMode,
    /// Camera settings file in the course framework's format (overrides
    /// --camera; its lens is used unless -b is given).
    #[arg(short = 'c', value_name = "FILE")]
    pub camera_file: Option<PathBuf>,
    /// Write the camera this render uses to FILE in the course's format.
    #[arg(long, value_name = "FILE")]
    pub save_camera: Option<PathBuf>,
    /// Also write this render as a Mitsuba 3 scene in DIR (new or empty):
    /// scene.xml and its meshes, same camera, samples and depth
    /// (`tools/mitsuba_render.py DIR` renders it and compares).
    #[arg(long, value_name = "DIR")]
    pub mitsuba: Option<PathBuf>,
    /// Thin lens: lens radius in scene units (depth of field; 0: pinhole).
    #[arg(short = 'b', value_name = "RADIUS")]
    pub lens_radius: Option<f32>,
    /// Thin lens: distance in focus along the view axis (default: the
    /// distance to the framed scene's centre).
    #[arg(short = 'd', value_name = "DISTANCE")]
    pub focal_distance: Option<f32>,
    /// Environment light: an equirectangular map (EXR radiance; +Y up, the
    /// course's layout), seen by escaped rays and sampled by luminance.
    #[arg(short = 'e', value_name = "FILE.exr")]
    pub environment: Option<PathBuf>,
    /// Sample the environment map uniformly over the sphere instead of by
    /// luminance (to compare the two).
    #[arg(long, requires = "environment")]
    pub env_uniform: bool,
    /// What camera rays that miss the scene see: the sky (the ambient
    /// light and -e map, physical) or black, as in the course's gallery.
    #[arg(long, value_parser = choice::<Background>(), default_value = Background::default().name())]
    pub background: Background,
    /// Resolution.
    #[arg(short = 'r', num_args = 2, value_names = ["W", "H"], default_values_t = [480u32, 360])]
    pub resolution: Vec<u32>,
    /// Camera rays per pixel (the cap with -a) [default: 1; 256 for the
    /// default scene].
    #[arg(short = 's')]
    pub samples: Option<u32>,
    /// Threads (default: all cores).
    #[arg(short = 't', default_value_t = 0)]
    pub threads: usize,
    /// Seed: the same seed gives the same image for any thread count.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Which numbers camera samples draw: `sobol`, every dimension from an
    /// Owen-scrambled Sobol sequence per pixel, or `independent`, R2 pixel
    /// positions (the course's) and independent numbers elsewhere.
    #[arg(long, value_parser = choice::<Sampler>(), default_value = Sampler::default().name())]
    pub sampler: Sampler,
    /// How paths advance: `reference`, each path alone from its first hit
    /// (renders everything, on any CPU), or `wavefront`, a wave's paths
    /// together bounce by bounce, their state stepped sixteen at a time.
    /// The image is the same; by default the wavefront where its lanes
    /// take the scene's vertices, else the reference (`hybrid render`
    /// says which and why).
    #[arg(long, value_parser = choice::<Mode>())]
    pub mode: Option<Mode>,
    /// Answer every batch query one ray at a time, camera rays too (the
    /// image is the same; for timing batched queries against single rays).
    #[arg(long)]
    pub no_packets: bool,
    /// Output image: .png (tone-mapped) or .exr (raw radiance).
    #[arg(short = 'f')]
    pub output: Option<PathBuf>,
    /// Render one cell of the image only; the output holds just the cell.
    #[arg(short = 'p', num_args = 4, value_names = ["X", "Y", "DX", "DY"])]
    pub cell: Option<Vec<u32>>,
    /// Render band K of N equal bands of rows (K from 0): the task of a
    /// job array; write .exr parts and combine them with `hybrid merge`.
    #[arg(long = "part", value_name = "K/N", conflicts_with = "cell")]
    pub part: Option<String>,
    /// Render only samples A..B-1 of every pixel (of -s N): write .exr
    /// parts and combine them with `hybrid merge`.
    #[arg(long = "samples", value_name = "A..B")]
    pub sample_range: Option<String>,
    /// Direct lighting by uniform hemisphere sampling (`--estimator hemisphere`).
    #[arg(short = 'H', conflicts_with = "estimator")]
    pub hemisphere: bool,
    /// Direct lighting: multiple importance sampling of lights and BSDF,
    /// light sampling only, or uniform hemisphere sampling.
    /// [default: mis]
    #[arg(long, value_parser = choice::<DirectEstimator>())]
    pub estimator: Option<DirectEstimator>,
    /// Samples per area light (or hemisphere samples with -H).
    #[arg(short = 'l', default_value_t = 1)]
    pub light_samples: u32,
    /// Maximum bounces (0: emitted light only, 1: direct lighting)
    /// [default: 1; 8 for the default scene].
    #[arg(short = 'm')]
    pub max_bounces: Option<u32>,
    /// 1: accumulate bounces 0..=M; 0: only bounce M.
    #[arg(short = 'o', default_value_t = 1, value_parser = clap::value_parser!(u8).range(0..=1))]
    pub accumulate: u8,
    /// Show only direct or only indirect light.
    #[arg(long, value_parser = choice::<BounceView>(), default_value = BounceView::default().name())]
    pub only: BounceView,
    /// Russian roulette with this continuation probability (0, 1]
    /// [default: off; 0.8 for the default scene].
    #[arg(long = "rr", value_name = "P")]
    pub russian_roulette: Option<f32>,
    /// Adaptive sampling: batches of BATCH samples until the 95% interval
    /// is within TOL of the mean.
    #[arg(short = 'a', num_args = 2, value_names = ["BATCH", "TOL"], allow_negative_numbers = true)]
    pub adaptive: Option<Vec<f64>>,
    /// Native backend: ray/triangle test.
    #[arg(long, value_parser = choice::<TriangleMode>(), default_value = TriangleMode::default().name())]
    pub triangle: TriangleMode,
    /// Native backend: build method.
    #[arg(long, value_parser = choice::<BuildMethod>(), default_value = BuildMethod::default().name())]
    pub build: BuildMethod,
    /// Native backend: largest leaf (0: four triangles, eight from 2^19
    /// triangles on).
    #[arg(long, default_value_t = NativeOptions::DEFAULT.max_leaf)]
    pub leaf: usize,
    /// Embree backend: build quality.
    #[arg(long, value_parser = choice::<BuildQuality>(), default_value = BuildQuality::default().name())]
    pub quality: BuildQuality,
    /// Embree backend: robust scene flag.
    #[arg(long)]
    pub robust: bool,
    /// Native backend: the portable scalar traversal even where the CPU
    /// runs the AVX2 one.
    #[arg(long)]
    pub scalar: bool,
    /// Exposure of the PNG (and a series' tiles) in stops, radiance times
    /// 2^EV before the tone map, or `auto`: each image's mean brought to
    /// mid grey (the EV is printed, and shown under a series' tiles). EXR
    /// keeps the radiance as it is.
    #[arg(long, value_name = "EV|auto", allow_hyphen_values = true, value_parser = exposure_arg)]
    pub exposure: Option<ExposureArg>,
}

/// `--exposure`: fixed stops, or by each image's mean.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ExposureArg {
    Stops(Exposure),
    Auto,
}

fn exposure_arg(text: &str) -> Result<ExposureArg, String> {
    if text == "auto" {
        return Ok(ExposureArg::Auto);
    }
    text.parse::<f64>()
        .ok()
        .and_then(Exposure::stops)
        .map(ExposureArg::Stops)
        .ok_or_else(|| {
            format!(
                "expected a number of stops within ±{} or 'auto'",
                Exposure::LIMIT
            )
        })
}

/// What `hybrid render` with no scene renders unless told otherwise: the
/// default scene converged in about ten seconds on two cores (-s, -m,
/// --rr). With a scene file the course's defaults (1 sample, 1 bounce, no
/// roulette) hold.
pub const PRESET: Preset = Preset {
    samples: 256,
    max_bounces: 8,
    russian_roulette: 0.8,
};

/// Path-tracing settings the default scene gets when they are not given.
pub struct Preset {
    pub samples: u32,
    pub max_bounces: u32,
    pub russian_roulette: f32,
}

impl RenderArgs {
    /// Whether the [`PRESET`] fills in what was not given: no scene file
    /// and path tracing.
    pub fn uses_preset(&self) -> bool {
        self.input.scene.is_none() && !self.normals
    }

    /// `given`, else the preset's `value` when the preset applies.
    fn or_preset<T>(&self, given: Option<T>, value: T) -> Option<T> {
        given.or_else(|| self.uses_preset().then_some(value))
    }

    /// `-s`: given, the preset's, or the course's 1.
    pub fn samples(&self) -> u32 {
        self.or_preset(self.samples, PRESET.samples).unwrap_or(1)
    }

    /// `-m`: given, the preset's, or the course's 1.
    pub fn max_bounces(&self) -> u32 {
        self.or_preset(self.max_bounces, PRESET.max_bounces)
            .unwrap_or(1)
    }

    /// `--rr`: given, the preset's, or none.
    pub fn russian_roulette(&self) -> Option<f32> {
        self.or_preset(self.russian_roulette, PRESET.russian_roulette)
    }

    /// The preset options this run takes, as they would be typed (empty
    /// when the preset does not apply or every one was given).
    pub fn preset_options(&self) -> String {
        if !self.uses_preset() {
            return String::new();
        }
        let mut options = Vec::new();
        if self.samples.is_none() {
            options.push(format!("-s {}", PRESET.samples));
        }
        if self.max_bounces.is_none() {
            options.push(format!("-m {}", PRESET.max_bounces));
        }
        if self.russian_roulette.is_none() {
            options.push(format!("--rr {}", PRESET.russian_roulette));
        }
        options.join(" ")
    }

    /// The backend `--accel` chose, with its own flags; native's batches
    /// in packets of [`render_packet_lanes`].
    pub fn backend(&self) -> BackendConfig {
        let native = NativeOptions {
            triangle: self.triangle,
            method: self.build,
            max_leaf: self.leaf,
            simd: !self.scalar,
            packet_lanes: render_packet_lanes(),
        };
        let embree = EmbreeOptions {
            quality: self.quality,
            robust: self.robust,
            threads: self.threads,
            ..EmbreeOptions::DEFAULT
        };
        self.accel.configure(native, embree)
    }

    /// PNG tone map of `film`: the reference renders', exposed as
    /// `--exposure` says, for radiance; none for normals.
    pub fn tone_map(&self, film: &Film) -> ToneMap {
        if self.normals {
            return ToneMap::Identity;
        }
        ToneMap::Reference(match self.exposure {
            None => Exposure::NONE,
            Some(ExposureArg::Stops(e)) => e,
            Some(ExposureArg::Auto) => Exposure::by_mean(&film.pixels),
        })
    }

    fn output_path(&self) -> PathBuf {
        if let Some(f) = &self.output {
            return f.clone();
        }
        let stem = self
            .input
            .scene
            .as_ref()
            .and_then(|s| s.file_stem())
            .and_then(|s| s.to_str())
            .unwrap_or("cornell");
        PathBuf::from(format!("{stem}.png"))
    }
}

pub fn run(args: &RenderArgs) -> Result<(), String> {
    let settings = args.settings()?;
    for warning in args.warnings() {
        super::report_line("warning", &warning);
    }
    if let Some(note) = args.course_note() {
        say!("{note}");
    }
    let output = args.output_path();
    Film::check_image_name(&output).map_err(|e| e.to_string())?;
    // A missing or read-only folder fails now, not after the render.
    check_writable(&output).map_err(|e| e.to_string())?;
    if settings.adaptive.is_some() {
        check_writable(&rate_path(&output)).map_err(|e| e.to_string())?;
    }
    if let Some(camera) = &args.save_camera {
        check_writable(camera).map_err(|e| format!("--save-camera: {e}"))?;
    }
    outputs_spare_inputs(args, &output, settings.adaptive.is_some())?;
    if let Some(dir) = &args.mitsuba {
        crate::render::mitsuba::check_settings(&settings)?;
        check_mitsuba_dir(dir)?;
    }
    let preset = args.preset_options();
    if !preset.is_empty() {
        // The same render named in full, as it works from any folder: the
        // scene's file by its absolute path while it is there.
        let file = crate::scene::builtin::CORNELL
            .file_on_disk()
            .map(|p| {
                let p = p.display().to_string();
                if p.contains(char::is_whitespace) {
                    format!("'{p}' ")
                } else {
                    format!("{p} ")
                }
            })
            .unwrap_or_default();
        say!(
            "the default scene with converged settings: {preset} (the same as `hybrid render {file}{preset}`; a scene file gets the course's defaults)"
        );
    }
    let result = render_with(args, &settings)?.output;
    let map = args.tone_map(&result.film);
    if let (Some(ExposureArg::Auto), ToneMap::Reference(e)) = (args.exposure, map) {
        say!("exposure by the image's mean: {}", e.label());
    }
    let image = result.film.file(&output, map).map_err(|e| e.to_string())?;
    let c = result.counters;
    let frame = match settings.cell {
        Some(cell) => format!(
            "the {}x{} cell at ({}, {}) of {}x{}",
            cell.width, cell.height, cell.x, cell.y, settings.width, settings.height
        ),
        None => format!("{}x{}", settings.width, settings.height),
    };
    let samples = match (settings.sample_range, settings.adaptive) {
        (Some((a, b)), _) => format!("samples {a}..{b} of {} spp", settings.samples),
        (None, Some(_)) => format!(
            "{:.1} spp on average (adaptive, at most {})",
            result.mean_samples(),
            settings.samples
        ),
        (None, None) => format!("{} spp", settings.samples),
    };
    let mut line = format!(
        "rendered {frame} at {samples} in {}: {} rays, {:.2} Mrays/s",
        super::duration(result.seconds),
        c.rays,
        result.mrays_per_second()
    );
    // Backends that count tests (not Embree) report them.
    if c.box_tests + c.prim_tests > 0 {
        line += &format!(
            ", {:.1} box tests and {:.1} primitive tests per ray",
            c.box_tests as f64 / c.rays as f64,
            c.prim_tests as f64 / c.rays as f64
        );
    }
    say!("{line}");
    let waves = result.wave_times;
    if waves.total() > 0.0 {
        let [closest, occluded, paths] = waves.shares().map(|s| 100.0 * s);
        say!(
            "waves: {closest:.0}% in extension-ray batches, {occluded:.0}% in shadow-ray batches, {paths:.0}% stepping paths (shading, sampling, gathering rays) of {:.2} thread-seconds; at most {:.0} KiB of paths and rays a thread",
            waves.total(),
            waves.peak_bytes as f64 / 1024.0
        );
        if let Some([arrive, light, leave]) = waves.steps.shares().map(|s| s.map(|s| 100.0 * s)) {
            let t = waves.steps;
            say!(
                "stepping: {:.3} s ({arrive:.0}%) taking the hits, {:.3} s ({light:.0}%) sampling the lights, {:.3} s ({leave:.0}%) summing light and leaving",
                t.arrive,
                t.light,
                t.leave
            );
        }
    }
    // The image and its sample-rate companion are written together or
    // not at all.
    if settings.adaptive.is_some() {
        let rate = rate_path(&output);
        let rate_image = result.film.rate_file();
        write_files(&[(&output, image), (&rate, rate_image)]).map_err(|e| e.to_string())?;
        say!("wrote the sample-rate image {}", rate.display());
    } else {
        write_files(&[(&output, image)]).map_err(|e| e.to_string())?;
    }
    say!("wrote {}", output.display());
    Ok(())
}

/// A render and the work before it: what a series' captions and tables
/// show.
pub struct Rendered {
    pub output: RenderOutput,
    /// The acceleration structure's build, wall clock.
    pub build_seconds: f64,
    pub triangles: usize,
}

/// Loads the scene, builds the backend and renders as `args` and
/// `settings` say, printing the scene summary, the build and a progress
/// bar; writes nothing but the camera file (`--save-camera`).
pub fn render_with(args: &RenderArgs, settings: &RenderSettings) -> Result<Rendered, String> {
    let normal_mode = if args.flat {
        NormalMode::Flat
    } else {
        NormalMode::Smooth
    };

    let start = Instant::now();
    let mut scene = args.input.load(normal_mode)?;
    if let Some(degrees) = args.crease.filter(|_| !args.flat) {
        scene.mesh.crease(degrees);
    }
    if let Some(path) = &args.environment {
        let mut env = Environment::load(path).map_err(|e| e.to_string())?;
        if args.env_uniform {
            env.sampling = EnvSampling::Uniform;
        }
        scene.environment = Some(std::sync::Arc::new(env));
    }
    say!("{}", scene.summary());
    say!(
        "collected {} primitives in {:.1} ms",
        scene.primitive_count(),
        start.elapsed().as_secs_f64() * 1e3
    );
    if let Some(path) = &args.save_camera {
        let text = settings.camera_for(&scene).to_course().text();
        // Written as images are: under a temporary name, then renamed.
        write_files(&[(path.as_path(), crate::render::film::ImageFile::Text(&text))])
            .map_err(|e| format!("--save-camera: {e}"))?;
        say!("wrote the camera to {}", path.display());
    }

    if let Some(dir) = &args.mitsuba {
        write_mitsuba(dir, &scene, settings)?;
    }

    if let Some(cap) = Isa::cap_note() {
        say!("{cap}");
    }
    let backend = args.backend();
    let accel = backend.build(&scene).map_err(|e| e.to_string())?;
    let stats = accel.stats();
    say!("{}", stats.describe());
    let (mode, why) = Mode::choose(settings.mode, &scene, settings.shading);
    let lanes = match mode {
        Mode::Wavefront => format!(
            ", stepped in {} lanes",
            crate::simd::lanes::Vectors::widest().name()
        ),
        Mode::Reference => String::new(),
    };
    say!("mode: {}{lanes} ({why})", mode.name());
    let settings = &RenderSettings {
        mode: Some(mode),
        ..settings.clone()
    };
    if args.no_packets {
        say!("batch queries: one ray at a time (--no-packets)");
    } else {
        say!("batch queries: {}", stats.batch_call);
    }
    if !backend.suits(&scene) {
        super::report_line(
            "warning",
            &format!(
                "{}: {} primitives without an acceleration structure will be slow",
                backend.kind(),
                stats.primitives
            ),
        );
    }

    let bar = Bar::new(settings);
    let output = if args.no_packets {
        render(&scene, &OneByOne(&accel), settings, &bar)
    } else {
        render(&scene, &accel, settings, &bar)
    };
    bar.finish();

    Ok(Rendered {
        output,
        build_seconds: stats.build_ms / 1e3,
        triangles: scene.triangle_count(),
    })
}

/// `Err` when an output of the run (`-f`, its rate image, `--save-camera`)
/// names one of its inputs (the scene, `-e`, `-c`) or another output:
/// `--save-camera my.dae`, the flag taken for a switch, wrote camera text
/// over the scene (issue 46, class 6).
fn outputs_spare_inputs(args: &RenderArgs, output: &Path, adaptive: bool) -> Result<(), String> {
    let mut outputs = vec![("-f", output.to_path_buf())];
    if adaptive {
        outputs.push(("the rate image", rate_path(output)));
    }
    if let Some(camera) = &args.save_camera {
        outputs.push(("--save-camera", camera.clone()));
    }
    let inputs = [
        ("the scene", args.input.scene.as_ref()),
        ("-e", args.environment.as_ref()),
        ("-c", args.camera_file.as_ref()),
    ];
    for (k, (flag, out)) in outputs.iter().enumerate() {
        for (name, input) in inputs.iter().filter_map(|(n, i)| Some((n, (*i)?))) {
            if same_file(out, input) {
                return Err(format!(
                    "{flag} {} names {name} of this run; it would be overwritten",
                    out.display()
                ));
            }
        }
        for (other, earlier) in &outputs[..k] {
            if std::path::absolute(out).ok() == std::path::absolute(earlier).ok() {
                return Err(format!(
                    "{flag} {} is also {other}: give each output its own name",
                    out.display()
                ));
            }
        }
    }
    Ok(())
}

/// `Err` unless `dir` can take a Mitsuba scene without touching a file:
/// it does not exist yet (its parent does) or is an empty folder.
fn check_mitsuba_dir(dir: &Path) -> Result<(), String> {
    let fail = |why: &str| Err(format!("--mitsuba {}: {why}", dir.display()));
    match std::fs::symlink_metadata(dir) {
        Ok(meta) if !meta.is_dir() => fail("is not a folder"),
        Ok(_) => match std::fs::read_dir(dir).map(|mut e| e.next().is_none()) {
            Ok(true) => Ok(()),
            Ok(false) => fail("is not empty; give a new or empty folder"),
            Err(e) => fail(&e.to_string()),
        },
        Err(_) => {
            let parent = dir.parent().filter(|p| !p.as_os_str().is_empty());
            match parent {
                Some(p) if !p.is_dir() => fail("its parent folder does not exist"),
                _ => Ok(()),
            }
        }
    }
}

/// Writes the Mitsuba scene of this render into `dir` (checked by
/// [`check_mitsuba_dir`]), every file or none.
fn write_mitsuba(dir: &Path, scene: &Scene, settings: &RenderSettings) -> Result<(), String> {
    use crate::render::film::ImageFile;
    use crate::render::mitsuba;
    let exported = mitsuba::export(scene, settings)?;
    let created = !dir.exists();
    if created {
        std::fs::create_dir(dir).map_err(|e| format!("--mitsuba {}: {e}", dir.display()))?;
    }
    let xml_path = dir.join(mitsuba::SCENE_FILE);
    let paths: Vec<PathBuf> = exported.files.iter().map(|(n, _)| dir.join(n)).collect();
    let mut files = vec![(xml_path.as_path(), ImageFile::Text(&exported.xml))];
    for (path, (_, bytes)) in paths.iter().zip(&exported.files) {
        files.push((path.as_path(), ImageFile::Bytes(bytes)));
    }
    if let Err(e) = write_files(&files) {
        if created {
            let _ = std::fs::remove_dir(dir);
        }
        return Err(format!("--mitsuba: {e}"));
    }
    say!(
        "wrote the Mitsuba 3 scene {} and the {} files it names; render it with tools/mitsuba_render.py {}",
        xml_path.display(),
        exported.files.len(),
        dir.display()
    );
    Ok(())
}

/// Whether `a` and `b` are the same existing file (device and inode).
pub(super) fn same_file(a: &Path, b: &Path) -> bool {
    use std::os::unix::fs::MetadataExt;
    match (std::fs::metadata(a), std::fs::metadata(b)) {
        (Ok(x), Ok(y)) => x.dev() == y.dev() && x.ino() == y.ino(),
        _ => false,
    }
}

/// Rays per native packet in the renderer: sixteen, in AVX-512 lanes or
/// two AVX2 registers a value. Packets give every ray the single-ray
/// kernel's answer at either width, so the image does not depend on this
/// choice. On Zen 4 (four alternating rounds, minimum seconds, 8 -> 16):
/// CBempty 1.02 -> 0.903, maxplanck 0.707 -> 0.663, CBbunny 1.38 ->
/// 1.33. On an Intel Xeon (model 207), one thread pinned, `render -t 1
/// -r 160 120 -s 128 -m 5 -l 1 --seed 3`, median of 15-25 alternating
/// pairs, time with 16 over time with 8: CBempty 0.84, maxplanck 0.85,
/// sky/bunny 0.93, banana 0.94, the default scene 0.95, CBbunny 0.97,
/// CBspheres 0.96, CBspheres_lambertian 0.99 (docs/experiments.md).
pub fn render_packet_lanes() -> usize {
    16
}
