//! The Embree backend: the scene's triangles and spheres in an Embree scene,
//! behind the same [`Accel`] trait as the native BVH.
//!
//! Mapping to the trait's conventions:
//! - geometry 0 holds the triangles (primitive id = Embree's primID), a
//!   second geometry the spheres (primitive id = triangle count + primID);
//! - Embree's `u, v` are the weights of corners 1 and 2, as the trait's;
//! - Embree's unnormalized `Ng` for triangles is `(v1 - v0) x (v2 - v0)` up
//!   to sign (checked at build, see [`EmbreeAccel::build`]) and is
//!   normalized; for spheres it points outward.
//!
//! Spheres use Embree's own sphere-point geometry rather than a user
//! geometry: it keeps every query inside Embree (no Rust callback that could
//! unwind through C, nothing of ours measured as "Embree"), and it reports
//! the far root for origins inside the sphere, as the native test does.
//!
//! Threads: Embree builds with its own TBB worker pool, sized by `threads`
//! (the `-t` of the program); queries run on the calling (rayon) threads, so
//! the two pools never run at once.

mod sys;

use std::time::Instant;

use glam::Vec3;

pub use self::sys::BuildQuality;
use super::{Accel, AccelError, AccelStats, Hit, Ray, TraceCounters};
use crate::scene::{unit, Scene};

/// Options of the Embree backend.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct EmbreeOptions {
    pub quality: BuildQuality,
    /// Embree's `RTC_SCENE_FLAG_ROBUST`: slower, avoids optimizations that
    /// reduce arithmetic accuracy.
    pub robust: bool,
    /// Embree's build threads; 0 means all cores.
    pub threads: usize,
}

impl EmbreeOptions {
    pub const DEFAULT: EmbreeOptions = EmbreeOptions {
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

pub struct EmbreeAccel<'s> {
    // Field order is drop order; Embree reference-counts, so any order is
    // safe, this one is merely tidy.
    scene: sys::Scene<'s>,
    device: sys::Device,
    triangle_count: u32,
    sphere_geometry: u32,
    /// -1 when Embree's triangle normal is `(v2 - v0) x (v1 - v0)`.
    normal_sign: f32,
    options: EmbreeOptions,
    build_ms: f64,
    primitives: usize,
}

impl<'s> EmbreeAccel<'s> {
    pub fn build(scene: &'s Scene, options: &EmbreeOptions) -> Result<EmbreeAccel<'s>, AccelError> {
        let start = Instant::now();
        let config = if options.threads > 0 {
            format!("threads={}", options.threads)
        } else {
            String::new()
        };
        let device = sys::Device::new(&config).map_err(AccelError::Embree)?;
        let scene_options = sys::SceneOptions {
            quality: options.quality,
            robust: options.robust,
        };
        let mut builder =
            sys::SceneBuilder::new(&device, scene_options).map_err(AccelError::Embree)?;
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
        let mut accel = EmbreeAccel {
            scene: committed,
            device,
            triangle_count: scene.mesh.len() as u32,
            sphere_geometry,
            normal_sign: 1.0,
            options: *options,
            build_ms,
            primitives: scene.primitive_count(),
        };
        accel.normal_sign = accel.probe_normal_sign(scene);
        Ok(accel)
    }

    /// Embree documents its triangle normal convention per version; rather
    /// than trust one, shoot one ray at the first triangle the backend can
    /// hit and compare with the scene's `(v1 - v0) x (v2 - v0)`.
    fn probe_normal_sign(&self, scene: &Scene) -> f32 {
        for i in 0..scene.mesh.len().min(64) {
            let [a, b, c] = scene.mesh.corners(i);
            let n = (b - a).cross(c - a);
            if n.length_squared() == 0.0 {
                continue;
            }
            let centroid = (a + b + c) / 3.0;
            let n = unit(n);
            let origin = centroid + n * 1e-3 * (b - a).length().max(1e-6);
            if let Some(hit) =
                self.scene
                    .intersect(origin.to_array(), (-n).to_array(), 0.0, f32::INFINITY)
            {
                if hit.primitive == i as u32 && hit.geometry == 0 {
                    return if Vec3::from(hit.ng).dot(n) < 0.0 {
                        -1.0
                    } else {
                        1.0
                    };
                }
            }
        }
        1.0
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
}

impl EmbreeAccel<'_> {
    /// Closest hits of a batch of rays through one Embree stream call
    /// (measured against single-ray calls in the report). Untraceable rays
    /// are misses, as in [`Accel::closest_hit`].
    pub fn closest_hits(&self, rays: &[Ray], out: &mut Vec<Option<Hit>>) {
        let batch: Vec<([f32; 3], [f32; 3], f32, f32)> = rays
            .iter()
            .map(|r| {
                if r.is_traceable() {
                    (r.origin.to_array(), r.dir.to_array(), r.t_min, r.t_max)
                } else {
                    // An empty interval: Embree reports no hit.
                    ([0.0; 3], [0.0, 0.0, 1.0], 1.0, 0.0)
                }
            })
            .collect();
        let mut raw = Vec::with_capacity(rays.len());
        self.scene.intersect_stream(&batch, &mut raw);
        out.clear();
        out.extend(raw.iter().map(|h| h.as_ref().map(|h| self.to_hit(h))));
    }

    /// Embree's answer in the trait's conventions.
    #[inline]
    fn to_hit(&self, h: &sys::RawHit) -> Hit {
        let ng = Vec3::from(h.ng);
        if h.geometry == self.sphere_geometry {
            return Hit {
                t: h.t,
                prim: self.triangle_count + h.primitive,
                u: 0.0,
                v: 0.0,
                normal: unit(ng),
            };
        }
        Hit {
            t: h.t,
            prim: h.primitive,
            u: h.u,
            v: h.v,
            normal: unit(ng * self.normal_sign),
        }
    }
}

impl Accel for EmbreeAccel<'_> {
    #[inline]
    fn closest_hit(&self, ray: &Ray, counters: &mut TraceCounters) -> Option<Hit> {
        counters.rays += 1;
        if !ray.is_traceable() {
            return None;
        }
        let h = self.scene.intersect(
            ray.origin.to_array(),
            ray.dir.to_array(),
            ray.t_min,
            ray.t_max,
        )?;
        Some(self.to_hit(&h))
    }

    #[inline]
    fn occluded(&self, ray: &Ray, counters: &mut TraceCounters) -> bool {
        counters.rays += 1;
        if !ray.is_traceable() {
            return false;
        }
        self.scene.occluded(
            ray.origin.to_array(),
            ray.dir.to_array(),
            ray.t_min,
            ray.t_max,
        )
    }

    fn stats(&self) -> AccelStats {
        AccelStats {
            backend: "embree".into(),
            primitives: self.primitives,
            build_ms: self.build_ms,
            memory_bytes: self.device.memory_bytes(),
            details: self.description(),
            ..AccelStats::default()
        }
    }
}

/// Proves the error path: Embree is handed a misaligned shared buffer and
/// must answer with an error, which comes back here as a Rust `Err`
/// carrying Embree's message.
pub fn invalid_buffer_error() -> Result<(), AccelError> {
    let device = sys::Device::new("").map_err(AccelError::Embree)?;
    sys::provoke_invalid_buffer(&device).map_err(AccelError::Embree)
}
