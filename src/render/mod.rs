//! Rendering: camera rays through the accelerator, integrated per pixel.
//!
//! - [`camera`]: ray generation and framing;
//! - [`material`], [`light`]: scattering and light sampling;
//! - [`integrator`]: normal shading and the path tracer, one path at a
//!   time: the reference every other mode matches bit for bit;
//! - [`wavefront`]: the same path tracer for a wave of paths at once,
//!   their state in lists, stepped sixteen at a time;
//! - [`schedule`]: which of the two a render runs ([`Mode`]), and the
//!   lists a thread's waves reuse;
//! - [`sampler`]: which numbers a camera sample draws;
//! - [`times`]: where a render's time and memory went;
//! - [`film`], [`part`]: the image, its files, and parts merged;
//! - [`mitsuba`]: the same render as a Mitsuba 3 scene.
//!
//! Rows are rendered in parallel on a rayon pool of `threads` threads. Every
//! camera sample has its own random sequence (seed, pixel, sample index), so
//! the image is the same for any thread count.

pub mod camera;
pub mod camera_file;
pub mod film;
pub mod integrator;
pub mod light;
pub mod material;
pub mod mitsuba;
pub mod part;
pub mod sampler;
pub mod schedule;
pub mod times;
pub mod wavefront;

use std::sync::Mutex;
use std::time::Instant;

use glam::{DVec3, Vec3};
use rayon::prelude::*;

use self::camera::{Camera, CameraMode, ThinLens};
use self::camera_file::CourseCamera;
use self::film::Film;
use self::film::Origin;
use self::integrator::{Integrator, Shading};
pub use self::sampler::Sampler;
pub use self::schedule::Mode;
use self::schedule::{WaveLists, SIDE_BY_SIDE};
pub use self::times::WaveTimes;
use self::wavefront::Plan;
use crate::accel::{Accel, TraceCounters};
use crate::geom::sampling::{luminance, Rng};
use crate::geom::Ray;
use crate::scene::Scene;

/// Adaptive sampling (`-a BATCH TOL`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Adaptive {
    pub batch: u32,
    pub tolerance: f32,
}

/// A rectangle of pixels: `x, y, width, height`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cell {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
}

#[derive(Clone, Debug)]
pub struct RenderSettings {
    pub width: u32,
    pub height: u32,
    /// Samples per pixel (the cap, with adaptive sampling).
    pub samples: u32,
    /// Worker threads; 0 means all cores.
    pub threads: usize,
    pub seed: u64,
    pub camera: CameraMode,
    pub shading: Shading,
    pub adaptive: Option<Adaptive>,
    /// Render only this cell: the film then holds just the cell's pixels.
    pub cell: Option<Cell>,
    /// Render only samples `start..end` of every pixel (of `samples`):
    /// parts of one frame that `hybrid merge` combines.
    pub sample_range: Option<(u32, u32)>,
    /// Depth of field (`-b`, `-d`); `None`: a pinhole (or the camera
    /// file's lens).
    pub lens: Option<ThinLens>,
    /// A camera file's camera (`-c`), instead of `camera`'s placement.
    pub course_camera: Option<CourseCamera>,
    /// Which numbers the camera samples draw.
    pub sampler: Sampler,
    /// How paths advance: one at a time or in a wavefront; `None`: as
    /// [`Mode::choose`] picks for the scene. The image is the same either
    /// way.
    pub mode: Option<Mode>,
}

impl RenderSettings {
    /// The camera these settings render through: the camera file's or the
    /// placement `camera` names, with the lens of `-b`/`-d` if given
    /// (else the file's, if it has one).
    pub fn camera_for(&self, scene: &Scene) -> Camera {
        let (w, h) = (self.width, self.height);
        let camera = match &self.course_camera {
            Some(c) => Camera::from_course(c, w, h),
            None => Camera::new(scene, self.camera, w, h),
        };
        if self.lens.is_some() {
            camera.with_lens(self.lens)
        } else {
            camera
        }
    }
}

impl Default for RenderSettings {
    fn default() -> Self {
        RenderSettings {
            width: 480,
            height: 360,
            samples: 1,
            threads: 0,
            seed: 0,
            camera: CameraMode::Canonical,
            shading: Shading::Normals,
            adaptive: None,
            cell: None,
            sample_range: None,
            lens: None,
            course_camera: None,
            sampler: Sampler::default(),
            mode: None,
        }
    }
}

/// A finished render and what it cost.
pub struct RenderOutput {
    pub film: Film,
    pub counters: TraceCounters,
    pub seconds: f64,
    /// The mode it ran in.
    pub mode: Mode,
    /// Where the wavefront's time went (zero in the reference mode).
    pub wave_times: WaveTimes,
}

impl RenderOutput {
    pub fn mrays_per_second(&self) -> f64 {
        self.counters.rays as f64 / self.seconds.max(1e-9) / 1e6
    }

    pub fn mean_samples(&self) -> f64 {
        self.film.mean_samples()
    }
}

/// Progress reporting, called once per finished row (never per ray) with
/// the camera samples the row took. Rows are rendered in a scattered
/// order, so the rows done so far are a fair sample of the frame's cost and
/// an estimate from them is not fooled by a band of empty background.
pub trait Progress: Sync {
    fn row_done(&self, samples: u64);
}

/// No progress output.
pub struct Silent;

impl Progress for Silent {
    fn row_done(&self, _samples: u64) {}
}

/// The order rows are rendered in: sorted by a hash of the row index, a
/// fixed scattering (the image does not depend on it, only the progress
/// estimate does).
fn scattered(row: u32) -> u64 {
    crate::geom::sampling::mix(u64::from(row))
}

/// Renders `scene` through `accel`.
pub fn render<A: Accel>(
    scene: &Scene,
    accel: &A,
    settings: &RenderSettings,
    progress: &dyn Progress,
) -> RenderOutput {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(settings.threads)
        .build();
    let run = || render_rows(scene, accel, settings, progress);
    match pool {
        Ok(pool) => pool.install(run),
        // Could not start a pool of that size: use the global one.
        Err(_) => run(),
    }
}

fn render_rows<A: Accel>(
    scene: &Scene,
    accel: &A,
    settings: &RenderSettings,
    progress: &dyn Progress,
) -> RenderOutput {
    let start = Instant::now();
    let (w, h) = (settings.width, settings.height);
    let camera = settings.camera_for(scene);
    let integrator = Integrator::new(scene, accel, settings.shading);
    let (mode, _) = Mode::choose(settings.mode, scene, settings.shading);
    let plan = match mode {
        Mode::Wavefront => Plan::new(&integrator),
        Mode::Reference => None,
    };
    let cell = settings.cell.unwrap_or(Cell {
        x: 0,
        y: 0,
        width: w,
        height: h,
    });
    // Only the cell's pixels are allocated: one pixel of a 32768^2 frame
    // costs one pixel.
    let mut film = Film::new(cell.width, cell.height);
    let cap = settings.samples.max(1);
    film.origin = Origin {
        frame: (w, h),
        cell,
        samples: settings.sample_range.unwrap_or((0, cap)),
        total: cap,
        seed: settings.seed,
        adaptive: settings.adaptive.map(|a| a.batch.max(1)),
    };
    let width = cell.width as usize;
    let mut rows: Vec<_> = film
        .pixels
        .chunks_mut(width)
        .zip(film.samples.chunks_mut(width))
        .zip(film.sums.chunks_mut(width))
        .enumerate()
        .collect();
    rows.sort_unstable_by_key(|(row_index, _)| scattered(*row_index as u32));
    // The lists of a row's waves, handed from row to row: allocated and
    // first touched once per thread rather than once per row.
    let spare: Mutex<Vec<WaveLists>> = Mutex::new(Vec::new());
    // One row per job: rayon would otherwise cut the rows into a few
    // pieces per thread, and the thread whose pieces cost less idles at
    // the end of the frame.
    let (totals, wave_times) = rows
        .into_par_iter()
        .with_max_len(1)
        .map(|(row_index, ((row, counts), sums))| {
            let y = cell.y + row_index as u32;
            let mut counters = TraceCounters::default();
            let columns = cell.x..cell.x + cell.width;
            let mut lists = spare
                .lock()
                .unwrap_or_else(|e| e.into_inner())
                .pop()
                .unwrap_or_default();
            let part = Row {
                columns,
                y,
                sums: &mut *sums,
                counts: &mut *counts,
            };
            let times = render_row(
                &integrator,
                plan.as_ref(),
                &camera,
                settings,
                part,
                &mut counters,
                &mut lists,
            );
            spare.lock().unwrap_or_else(|e| e.into_inner()).push(lists);
            for ((value, sum), &n) in row.iter_mut().zip(sums.iter()).zip(counts.iter()) {
                // The one division both a single render and a merge do.
                *value = if n == 0 {
                    Vec3::ZERO
                } else {
                    (*sum / f64::from(n)).as_vec3()
                };
            }
            progress.row_done(counts.iter().map(|&n| u64::from(n)).sum());
            (counters, times)
        })
        .reduce(Default::default, |(mut a, mut x), (b, y)| {
            a += b;
            x += y;
            (a, x)
        });
    RenderOutput {
        film,
        counters: totals,
        seconds: start.elapsed().as_secs_f64(),
        mode: plan.as_ref().map_or(Mode::Reference, |_| Mode::Wavefront),
        wave_times,
    }
}

/// The camera ray of sample `i` of pixel `(x, y)`, written into `ray`,
/// and the sample's random stream after it, into `stream` (the lens
/// sample comes first from the stream, and only with a lens: pinhole
/// images keep their random numbers). Field by field: a ray built whole
/// and copied went through the stack, its direction stored in two parts
/// and reloaded in one (a stalled store forwarding, 1-6% of a frame).
#[inline(always)]
fn camera_sample(
    camera: &Camera,
    settings: &RenderSettings,
    (x, y, i): (u32, u32, u32),
    ray: &mut Ray,
    stream: &mut Rng,
) {
    let samples = settings.samples.max(1);
    let ((dx, dy), mut rng) = settings.sampler.start(settings.seed, (x, y, i), samples);
    let lens = camera.has_lens().then(|| rng.next_2d());
    let (origin, dir) = camera.origin_and_dir(x as f32 + dx, y as f32 + dy, lens);
    ray.origin = origin;
    ray.dir = dir;
    ray.t_min = 0.0;
    ray.t_max = f32::INFINITY;
    *stream = rng;
}

/// Whether a pixel's adaptive sampling may stop after `n` samples of
/// luminance sum `s1` and square sum `s2`.
fn converged(a: &Adaptive, n: u32, s1: f64, s2: f64) -> bool {
    if n < 2 {
        return false;
    }
    let nf = f64::from(n);
    let mean = s1 / nf;
    let variance = ((s2 - s1 * s1 / nf) / (nf - 1.0)).max(0.0);
    let interval = 1.96 * variance.sqrt() / nf.sqrt();
    interval <= a.tolerance as f64 * mean
}

/// One row's part of a frame: its pixels' columns, and their sums and
/// sample counts.
struct Row<'f> {
    columns: std::ops::Range<u32>,
    y: u32,
    sums: &'f mut [DVec3],
    counts: &'f mut [u32],
}

/// Row `y`'s pixels in `columns`: the sums of their samples (all of them,
/// or the settings' sample range) in double precision into `sums`, and the
/// number each took into `counts`. The paths of the row's unfinished
/// pixels, for as many consecutive sample indices as fit in a wave
/// ([`Mode::wave_paths`]), are traced as one wave, a pixel's samples side
/// by side: walked alone (the reference) or as a wavefront, as `plan`
/// says. Each pixel takes its samples in order from its own random
/// streams, its sums add them in sample order, and each path takes the
/// same steps either way, so the sums do not depend on the mode. Returns
/// where the row's waves spent their time.
fn render_row<A: Accel>(
    integrator: &Integrator<'_, A>,
    plan: Option<&Plan>,
    camera: &Camera,
    settings: &RenderSettings,
    row: Row<'_>,
    counters: &mut TraceCounters,
    lists: &mut WaveLists,
) -> WaveTimes {
    let Row {
        columns,
        y,
        sums,
        counts,
    } = row;
    let cap = settings.samples.max(1);
    let (first, last) = settings.sample_range.unwrap_or((0, cap));
    let batch = settings.adaptive.map_or(cap, |a| a.batch.max(1));
    let width = columns.len();
    sums.fill(DVec3::ZERO);
    counts.fill(0);
    let mut luminance_sums = vec![(0.0f64, 0.0f64); width];
    let mut active: Vec<usize> = (0..width).collect();
    let mut times = WaveTimes::default();
    let mode = plan.map_or(Mode::Reference, |_| Mode::Wavefront);
    let wave_paths = mode.wave_paths();
    let mut done = first;
    while done < last && !active.is_empty() {
        let end = done.saturating_add(batch).min(last);
        let per_wave = (wave_paths / active.len()).max(1) as u32;
        let mut i = done;
        while i < end {
            // A wave holds each of its pixels' next samples side by side,
            // at least SIDE_BY_SIDE of them where the batch has them: a
            // row too wide for that goes in even pieces of fewer pixels.
            let block = per_wave.max(SIDE_BY_SIDE).min(end - i);
            let pieces = active.len().div_ceil((wave_paths / block as usize).max(1));
            for pixels in active.chunks(active.len().div_ceil(pieces)) {
                // Pixel by pixel: the paths next to each other in a wave
                // start in one pixel, so that their camera rays and the
                // shadow rays of their first hits form tight packets.
                let paths = pixels.len() * block as usize;
                lists.rays.resize(paths, Ray::new(Vec3::ZERO, Vec3::Z));
                lists.streams.resize(paths, Rng::new(0, 0));
                let per_pixel = lists
                    .rays
                    .chunks_mut(block as usize)
                    .zip(lists.streams.chunks_mut(block as usize));
                for (&p, (rays, streams)) in pixels.iter().zip(per_pixel) {
                    let x = columns.start + p as u32;
                    for ((ray, stream), sample) in rays.iter_mut().zip(streams).zip(i..) {
                        camera_sample(camera, settings, (x, y, sample), ray, stream);
                    }
                }
                lists.radiance(integrator, plan, counters, &mut times);
                for (pixel_values, &p) in lists.values.chunks(block as usize).zip(pixels) {
                    for &value in pixel_values {
                        sums[p] += value.as_dvec3();
                        let l = luminance(value) as f64;
                        luminance_sums[p].0 += l;
                        luminance_sums[p].1 += l * l;
                    }
                }
            }
            i += block;
        }
        done = end;
        for &p in &active {
            counts[p] = done - first;
        }
        if let Some(a) = settings.adaptive {
            if done < last {
                active.retain(|&p| {
                    let (s1, s2) = luminance_sums[p];
                    !converged(&a, done - first, s1, s2)
                });
            }
        }
    }
    if mode == Mode::Wavefront {
        times.peak_bytes = lists.held_bytes() + times::held(&luminance_sums) + times::held(&active);
    }
    times
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The first tenth of the rows rendered reaches every quarter of the
    /// frame, so an estimate from them sees background and content alike.
    #[test]
    fn rows_are_taken_in_an_order_spread_over_the_frame() {
        let height = 360u32;
        let mut order: Vec<u32> = (0..height).collect();
        order.sort_unstable_by_key(|&r| scattered(r));
        let mut quarters = [0usize; 4];
        for &row in &order[..36] {
            quarters[(row * 4 / height) as usize] += 1;
        }
        assert!(
            quarters.iter().all(|&n| n >= 4),
            "first rows by quarter: {quarters:?}"
        );
        order.sort_unstable();
        assert_eq!(order, (0..height).collect::<Vec<_>>(), "every row once");
    }
}
