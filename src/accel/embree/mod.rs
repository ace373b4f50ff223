//! The Embree backends: the scene's triangles and spheres in an Embree
//! scene, behind the same [`Accel`] trait as the native BVH, for Embree 3
//! and Embree 4 in one binary, each loaded at run time (`library.rs` says
//! why). [`EmbreeAccel`] is generic over the version's function table; the
//! safe layer over both is `ffi.rs`.
//!
//! Mapping to the trait's conventions:
//! - geometry 0 holds the triangles (primitive id = Embree's primID), a
//!   second geometry the spheres (primitive id = triangle count + primID);
//! - Embree's `u, v` are the weights of corners 1 and 2, as the trait's;
//! - Embree's `Ng` is not read: the normal is derived from the scene above
//!   the trait, so its convention (which Embree documents per version) does
//!   not matter.
//!
//! Spheres use Embree's own sphere-point geometry rather than a user
//! geometry: it keeps every query inside Embree (no Rust callback that could
//! unwind through C, nothing of ours measured as "Embree"), and it reports
//! the far root for origins inside the sphere, as the native test does.
//!
//! Threads: Embree builds with its own TBB worker pool, sized by `threads`
//! (the `-t` of the program); queries run on the calling (rayon) threads, so
//! the two pools never run at once.

mod ffi;
mod library;
mod plain_c;
#[cfg(hybrid_embree3)]
mod sys3;
#[cfg(not(hybrid_embree3))]
#[path = "sys3_missing.rs"]
mod sys3;
mod sys4;

use std::time::Instant;

use crate::choice::Choice;

use self::ffi::{Api, Device, Scene as EmbreeScene, SceneBuilder};
use self::library::{RawHit, INVALID_GEOMETRY_ID};
pub use self::plain_c::BatchMode;
use self::plain_c::{Answers, CHit};
pub use self::sys3::Embree3;
pub use self::sys4::Embree4;
use super::{Accel, AccelError, AccelStats, Coherence, TraceCounters};
use crate::geom::ray::FlatRay;
use crate::geom::{Hit, Ray};
use crate::scene::Scene;

/// Embree's build quality.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BuildQuality {
    Low,
    #[default]
    Medium,
    High,
}

crate::choice!(BuildQuality { Low => "low", Medium => "medium", High => "high" });

/// Which Embree: Debian 12's 3.13.5, or 4.x (Debian 13's, Intel's, or the
/// `embreex` wheel's that `scripts/setup.sh` installs on Debian 12).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum EmbreeVersion {
    #[default]
    V3,
    V4,
}

crate::choice!(EmbreeVersion { V3 => "embree3", V4 => "embree4" });

impl EmbreeVersion {
    /// `Ok` when this version's library loads here, else the line to show
    /// the user (what to install).
    pub fn available(self) -> Result<(), String> {
        match self {
            EmbreeVersion::V3 => sys3::api().map(|_| ()),
            EmbreeVersion::V4 => sys4::api().map(|_| ()),
        }
    }

    /// The newest version present (`--accel embree`): 4 when it loads,
    /// else 3.
    pub fn newest() -> EmbreeVersion {
        if EmbreeVersion::V4.available().is_ok() {
            EmbreeVersion::V4
        } else {
            EmbreeVersion::V3
        }
    }
}

/// Scene options.
#[derive(Clone, Copy, Debug, Default)]
pub struct SceneOptions {
    pub quality: BuildQuality,
    pub robust: bool,
}

/// Options of the Embree backend.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EmbreeOptions {
    pub version: EmbreeVersion,
    pub quality: BuildQuality,
    /// Embree's `RTC_SCENE_FLAG_ROBUST`: slower, avoids optimizations that
    /// reduce arithmetic accuracy.
    pub robust: bool,
    /// Embree's build threads; 0 means all cores.
    pub threads: usize,
}

impl EmbreeOptions {
    pub const DEFAULT: EmbreeOptions = EmbreeOptions {
        version: EmbreeVersion::V3,
        quality: BuildQuality::Medium,
        robust: false,
        threads: 0,
    };
}

impl Default for EmbreeOptions {
    fn default() -> Self {
        EmbreeOptions::DEFAULT
    }
}

/// One Embree version's table, as the backend is generic over it.
pub trait Version: Api + Sized {
    const VERSION: EmbreeVersion;
    fn api() -> Result<&'static Self, String>;
}

impl Version for Embree3 {
    const VERSION: EmbreeVersion = EmbreeVersion::V3;
    fn api() -> Result<&'static Self, String> {
        sys3::api()
    }
}

impl Version for Embree4 {
    const VERSION: EmbreeVersion = EmbreeVersion::V4;
    fn api() -> Result<&'static Self, String> {
        sys4::api()
    }
}

pub struct EmbreeAccel<'s, V: Version> {
    // Field order is drop order; Embree reference-counts, so any order is
    // safe, this one is merely tidy.
    scene: EmbreeScene<'s, V>,
    device: Device<V>,
    triangle_count: u32,
    sphere_geometry: u32,
    options: EmbreeOptions,
    build_ms: f64,
    primitives: usize,
    /// How the trait's batch queries trace: packets of the device's
    /// native width (16 with AVX-512, else 8), or `None` (4-wide SSE
    /// devices): single rays.
    batch: Option<BatchMode>,
}

impl<'s, V: Version> EmbreeAccel<'s, V> {
    pub fn build(
        scene: &'s Scene,
        options: &EmbreeOptions,
    ) -> Result<EmbreeAccel<'s, V>, AccelError> {
        let api = V::api().map_err(AccelError::Unavailable)?;
        let start = Instant::now();
        // `threads=N` from `-t`; `max_isa=...` when `HYBRID_ISA` caps the
        // instruction set, so Embree runs the kernels an older CPU runs.
        let config: Vec<String> = (options.threads > 0)
            .then(|| format!("threads={}", options.threads))
            .into_iter()
            .chain(crate::simd::cpu::Isa::embree_config())
            .collect();
        let config = config.join(",");
        let device = Device::new(api, &config).map_err(AccelError::Embree)?;
        let scene_options = SceneOptions {
            quality: options.quality,
            robust: options.robust,
        };
        let mut builder = SceneBuilder::new(&device, scene_options).map_err(AccelError::Embree)?;
        if !scene.mesh.is_empty() {
            let vertices: Vec<[f32; 3]> =
                scene.mesh.positions.iter().map(|p| p.to_array()).collect();
            builder
                .attach_triangles(&device, &vertices, &scene.mesh.indices)
                .map_err(AccelError::Embree)?;
        }
        let mut sphere_geometry = u32::MAX;
        if !scene.spheres.is_empty() {
            let spheres: Vec<[f32; 4]> = scene
                .spheres
                .iter()
                .map(|s| [s.center.x, s.center.y, s.center.z, s.radius])
                .collect();
            sphere_geometry = builder
                .attach_spheres(&device, &spheres)
                .map_err(AccelError::Embree)?;
        }
        let committed = builder.commit(&device).map_err(AccelError::Embree)?;
        let build_ms = start.elapsed().as_secs_f64() * 1e3;
        let batch = match device.native_packet_width() {
            16 => Some(BatchMode::Packet16),
            8 => Some(BatchMode::Packet8),
            _ => None,
        };
        Ok(EmbreeAccel {
            batch,
            scene: committed,
            device,
            triangle_count: scene.mesh.len() as u32,
            sphere_geometry,
            options: EmbreeOptions {
                version: V::VERSION,
                ..*options
            },
            build_ms,
            primitives: scene.primitive_count(),
        })
    }

    /// Embree's version and the ISA family it runs.
    pub fn description(&self) -> String {
        let width = self.device.native_packet_width();
        let family = match width {
            16 => "AVX-512",
            8 => "AVX/AVX2",
            _ => "SSE",
        };
        format!(
            "Embree {} ({family}, native packets of {width}), {:?} quality{}",
            self.device.version(),
            self.options.quality,
            if self.options.robust { ", robust" } else { "" }
        )
    }

    /// Embree's answer in the trait's conventions.
    #[inline]
    fn to_hit(&self, h: &RawHit) -> Hit {
        if h.geometry == self.sphere_geometry {
            return Hit {
                t: h.t,
                prim: self.triangle_count + h.primitive,
                u: 0.0,
                v: 0.0,
            };
        }
        Hit {
            t: h.t,
            prim: h.primitive,
            u: h.u,
            v: h.v,
        }
    }
}

/// A ray as Embree takes it; untraceable rays become an empty interval, so
/// that Embree reports a miss as every backend does.
#[inline]
fn raw_ray(r: &Ray) -> ffi::RawRay {
    if r.is_traceable() {
        (r.origin.to_array(), r.dir.to_array(), r.t_min, r.t_max)
    } else {
        ([0.0; 3], [0.0, 0.0, 1.0], 1.0, 0.0)
    }
}

/// Rays per call of the C driver from the trait's batch queries.
const CHUNK: usize = 64;

/// Up to [`CHUNK`] rays in the C driver's layout.
fn flat_rays(rays: &[Ray]) -> [FlatRay; CHUNK] {
    let mut flat = [[0.0f32; 8]; CHUNK];
    for (f, r) in flat.iter_mut().zip(rays) {
        let (o, d, t_min, t_max) = raw_ray(r);
        *f = [o[0], o[1], o[2], d[0], d[1], d[2], t_min, t_max];
    }
    flat
}

impl<V: Version> Accel for EmbreeAccel<'_, V> {
    #[inline]
    fn closest_hit(&self, ray: &Ray, counters: &mut TraceCounters) -> Option<Hit> {
        counters.rays += 1;
        if !ray.is_traceable() {
            return None;
        }
        let h = self.scene.intersect((
            ray.origin.to_array(),
            ray.dir.to_array(),
            ray.t_min,
            ray.t_max,
        ))?;
        Some(self.to_hit(&h))
    }

    #[inline]
    fn occluded(&self, ray: &Ray, counters: &mut TraceCounters) -> bool {
        counters.rays += 1;
        if !ray.is_traceable() {
            return false;
        }
        self.scene.occluded((
            ray.origin.to_array(),
            ray.dir.to_array(),
            ray.t_min,
            ray.t_max,
        ))
    }

    /// Packets of the device's native width, filled and called by the C
    /// driver, 64 rays per call from buffers on the stack, with the
    /// coherent hint where the caller says the rays are coherent (camera
    /// rays; on a wave's bounce rays the hint made Embree 4's CBbunny
    /// frame 1.34x as long).
    fn closest_hits(
        &self,
        rays: &[Ray],
        coherence: Coherence,
        out: &mut [Option<Hit>],
        counters: &mut TraceCounters,
    ) {
        debug_assert_eq!(rays.len(), out.len());
        let Some(mode) = self.batch else {
            for (ray, answer) in rays.iter().zip(out) {
                *answer = self.closest_hit(ray, counters);
            }
            return;
        };
        counters.rays += rays.len() as u64;
        for (rays, out) in rays.chunks(CHUNK).zip(out.chunks_mut(CHUNK)) {
            let n = rays.len();
            let flat = flat_rays(rays);
            let mut hits = [CHit::default(); CHUNK];
            let answers = Answers::Closest(&mut hits[..n]);
            let traced = self.scene.trace_batched(
                mode,
                coherence == Coherence::Coherent,
                &flat[..n],
                false,
                answers,
            );
            if traced.is_none() {
                // The device reported the width but the call was refused:
                // these rays alone (already counted).
                for (ray, answer) in rays.iter().zip(out) {
                    *answer = self.closest_hit(ray, &mut TraceCounters::default());
                }
                continue;
            }
            for (answer, h) in out.iter_mut().zip(&hits[..n]) {
                *answer = (h.geom != INVALID_GEOMETRY_ID).then(|| {
                    self.to_hit(&RawHit {
                        t: h.t,
                        geometry: h.geom,
                        primitive: h.prim,
                        u: h.u,
                        v: h.v,
                    })
                });
            }
        }
    }

    /// As [`Self::closest_hits`], with `rtcOccluded8/16`.
    fn occluded_all(&self, rays: &[Ray], out: &mut [bool], counters: &mut TraceCounters) {
        debug_assert_eq!(rays.len(), out.len());
        let Some(mode) = self.batch else {
            for (ray, answer) in rays.iter().zip(out) {
                *answer = self.occluded(ray, counters);
            }
            return;
        };
        counters.rays += rays.len() as u64;
        for (rays, out) in rays.chunks(CHUNK).zip(out.chunks_mut(CHUNK)) {
            let n = rays.len();
            let flat = flat_rays(rays);
            let mut blocked = [0u8; CHUNK];
            let answers = Answers::Blocked(&mut blocked[..n]);
            let traced = self
                .scene
                // No coherent hint: the renderer's shadow rays leave from
                // a row's hits, each to its own light sample (with the
                // hint Embree 3's frame on maxplanck ran 1.149x as long
                // with packets as without, 1.057x without it).
                .trace_batched(mode, false, &flat[..n], true, answers);
            if traced.is_none() {
                for (ray, answer) in rays.iter().zip(out) {
                    *answer = self.occluded(ray, &mut TraceCounters::default());
                }
                continue;
            }
            for (answer, &b) in out.iter_mut().zip(&blocked[..n]) {
                *answer = b != 0;
            }
        }
    }

    fn stats(&self) -> AccelStats {
        AccelStats {
            backend: V::VERSION.name().into(),
            primitives: self.primitives,
            build_ms: self.build_ms,
            memory_bytes: self.device.memory_bytes(),
            tree: None,
            batch_call: match self.batch {
                Some(BatchMode::Packet16) => {
                    "rtcIntersect16/rtcOccluded16 packets, coherent hint on camera rays"
                }
                Some(BatchMode::Packet8) => {
                    "rtcIntersect8/rtcOccluded8 packets, coherent hint on camera rays"
                }
                _ => "single-ray loop (no native packets)",
            },
            details: self.description(),
        }
    }
}

/// An Embree scene traced by the C driver (`csrc/embree_plain.c`) exactly
/// as a plain C program traces it: the baseline that the measurement layer
/// times hybrid against, so that no wrapper's cost is credited to the
/// native backend. Not a query the renderer asks; only a built Embree
/// backend has one ([`crate::accel::config::Backend::plain_c`]).
pub trait PlainC {
    /// One `rtcIntersect1` (or `rtcOccluded1`) per ray: the number of rays
    /// that hit (closest hit) or are blocked (`occluded`).
    fn trace(&self, rays: &[FlatRay], occluded: bool) -> usize;
    /// As [`PlainC::trace`], in the library's batched `mode` with the
    /// coherent hint or not; `None` where the library lacks the mode.
    fn trace_batched(
        &self,
        rays: &[FlatRay],
        occluded: bool,
        mode: BatchMode,
        coherent: bool,
    ) -> Option<usize>;
}

impl<V: Version> PlainC for EmbreeAccel<'_, V> {
    fn trace(&self, rays: &[FlatRay], occluded: bool) -> usize {
        self.scene.trace_as_c_caller(rays, occluded).0
    }

    fn trace_batched(
        &self,
        rays: &[FlatRay],
        occluded: bool,
        mode: BatchMode,
        coherent: bool,
    ) -> Option<usize> {
        let traced = self
            .scene
            .trace_batched(mode, coherent, rays, occluded, Answers::Count)?;
        Some(traced.0)
    }
}

/// Proves the error path: Embree is handed a misaligned shared buffer and
/// must answer with an error, which comes back here as a Rust `Err`
/// carrying Embree's message.
pub fn invalid_buffer_error(version: EmbreeVersion) -> Result<(), AccelError> {
    fn provoke<V: Version>() -> Result<(), AccelError> {
        let device = Device::new(V::api().map_err(AccelError::Unavailable)?, "")
            .map_err(AccelError::Embree)?;
        ffi::provoke_invalid_buffer(&device).map_err(AccelError::Embree)
    }
    match version {
        EmbreeVersion::V3 => provoke::<Embree3>(),
        EmbreeVersion::V4 => provoke::<Embree4>(),
    }
}
