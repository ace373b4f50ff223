//! The rays of a real render's waves (issue 45): a small frame of the
//! scene rendered by the wavefront (`--mode wavefront`, one thread),
//! its extension rays after the camera's (bounces 1 to 4) and every shadow
//! ray of its direct lighting recorded in the order the renderer traces
//! them, so that `hybrid bench` and other programs replay what a wave
//! renderer hands a backend.

use std::sync::Mutex;

use glam::Vec3;

use crate::accel::{Accel, AccelStats, Backend, Coherence, TraceCounters};
use crate::geom::{Hit, Ray};
use crate::measure::Query;
use crate::render::integrator::{PathSettings, Shading};
use crate::render::{render, Mode, RenderSettings, Silent};
use crate::scene::Scene;

/// The kinds a wave export writes: the extension rays (closest hits) and
/// the shadow rays (any hit).
pub const WAVE_KINDS: [&str; 2] = ["wave bounce", "wave shadow"];

/// The recorded frame's size; its samples per pixel follow from the rays
/// wanted.
const FRAME: (u32, u32) = (80, 60);

/// A backend that answers as `inner` and keeps the first `cap` rays of
/// each batch kind it is asked, camera rays (those leaving `eye`) left
/// out.
struct Recorder<'a> {
    inner: &'a Backend<'a>,
    eye: Vec3,
    cap: usize,
    bounce: Mutex<Vec<Ray>>,
    shadow: Mutex<Vec<Ray>>,
}

impl Recorder<'_> {
    fn keep(&self, into: &Mutex<Vec<Ray>>, rays: impl Iterator<Item = Ray>) {
        let mut kept = into.lock().unwrap_or_else(|e| e.into_inner());
        let room = self.cap.saturating_sub(kept.len());
        kept.extend(rays.take(room));
    }
}

impl Accel for Recorder<'_> {
    fn closest_hit(&self, ray: &Ray, counters: &mut TraceCounters) -> Option<Hit> {
        self.inner.closest_hit(ray, counters)
    }
    fn occluded(&self, ray: &Ray, counters: &mut TraceCounters) -> bool {
        self.inner.occluded(ray, counters)
    }
    fn closest_hits(
        &self,
        rays: &[Ray],
        coherence: Coherence,
        out: &mut [Option<Hit>],
        counters: &mut TraceCounters,
    ) {
        self.keep(
            &self.bounce,
            rays.iter().filter(|r| r.origin != self.eye).copied(),
        );
        self.inner.closest_hits(rays, coherence, out, counters)
    }
    fn occluded_all(&self, rays: &[Ray], out: &mut [bool], counters: &mut TraceCounters) {
        self.keep(&self.shadow, rays.iter().copied());
        self.inner.occluded_all(rays, out, counters)
    }
    fn stats(&self) -> AccelStats {
        self.inner.stats()
    }
}

/// Up to `n` rays of each wave kind of `scene` traced through `finder`:
/// kind, query and rays.
pub fn wave_sets(
    scene: &Scene,
    finder: &Backend,
    n: usize,
) -> Vec<(&'static str, Query, Vec<Ray>)> {
    let (w, h) = FRAME;
    // At least one ray of each kind per path, most paths in a closed box
    // take several: enough samples that the caps fill.
    let samples = (2 * n).div_ceil((w * h) as usize).clamp(1, 4096) as u32;
    let settings = RenderSettings {
        width: w,
        height: h,
        samples,
        threads: 1,
        seed: 1,
        shading: Shading::Path(PathSettings {
            max_bounces: 5,
            ..PathSettings::default()
        }),
        mode: Some(Mode::Wavefront),
        ..RenderSettings::default()
    };
    let recorder = Recorder {
        inner: finder,
        eye: settings.camera_for(scene).position,
        cap: n,
        bounce: Mutex::default(),
        shadow: Mutex::default(),
    };
    render(scene, &recorder, &settings, &Silent);
    let take = |m: Mutex<Vec<Ray>>| m.into_inner().unwrap_or_else(|e| e.into_inner());
    vec![
        (WAVE_KINDS[0], Query::Closest, take(recorder.bounce)),
        (WAVE_KINDS[1], Query::Occluded, take(recorder.shadow)),
    ]
}
