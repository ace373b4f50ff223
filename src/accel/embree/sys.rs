//! All of the FFI's `unsafe` code: Embree's C API (bindings generated
//! by bindgen in `build.rs` from `ffi/embree.h`) behind a small safe API.
//!
//! Ownership: [`Device`] and [`Scene`] own one Embree reference each and
//! release it on drop. Embree reference-counts internally (a scene keeps its
//! device alive), so Rust values may be dropped in any order.
//!
//! Errors: the device's error callback records Embree's message; every call
//! that can fail is followed by [`Device::check`], which turns the recorded
//! error into a Rust `Err`. The callback is a plain `extern "C"` function
//! that catches any panic, so no unwinding crosses the FFI boundary, and no
//! other Rust code is ever called by Embree.

#![allow(
    non_upper_case_globals,
    non_camel_case_types,
    non_snake_case,
    dead_code,
    clippy::all
)]

use std::ffi::{c_char, c_void, CStr, CString};
use std::marker::PhantomData;
use std::sync::atomic::{AtomicI64, Ordering};
use std::sync::Mutex;

mod raw {
    #![allow(
        non_upper_case_globals,
        non_camel_case_types,
        non_snake_case,
        dead_code,
        clippy::all
    )]
    include!(concat!(env!("OUT_DIR"), "/embree_bindings.rs"));
}

/// `RTC_INVALID_GEOMETRY_ID`, a cast macro bindgen does not translate.
const INVALID_GEOMETRY_ID: u32 = u32::MAX;

/// Embree's build quality.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
pub enum BuildQuality {
    Low,
    #[default]
    Medium,
    High,
}

crate::choice!(BuildQuality { Low => "low", Medium => "medium", High => "high" });

/// Where the last Embree error is kept until [`Device::check`] reads it.
struct ErrorSink {
    last: Mutex<Option<String>>,
    /// Bytes Embree has allocated on this device (memory monitor callback).
    bytes: AtomicI64,
}

/// Called by Embree on every allocation and release; only adds to an atomic
/// counter, so it cannot unwind. Returning true lets the allocation proceed.
unsafe extern "C" fn track_memory(user: *mut c_void, bytes: isize, _post: bool) -> bool {
    // SAFETY: `user` is the `ErrorSink` registered in `Device::new`, alive
    // until the callback is unregistered in `Device::drop`.
    let sink = unsafe { &*(user as *const ErrorSink) };
    sink.bytes.fetch_add(bytes as i64, Ordering::Relaxed);
    true
}

/// Called by Embree on errors. Never unwinds: the body runs under
/// `catch_unwind` and a poisoned lock is skipped.
unsafe extern "C" fn record_error(user: *mut c_void, code: raw::RTCError, message: *const c_char) {
    let _ = std::panic::catch_unwind(|| {
        // SAFETY: `user` is the `ErrorSink` registered in `Device::new`; the
        // callback is unregistered in `Device::drop` before the sink is
        // freed. `message` is a NUL-terminated string owned by Embree for
        // the duration of the call (or null).
        let sink = unsafe { &*(user as *const ErrorSink) };
        let text = if message.is_null() {
            String::new()
        } else {
            unsafe { CStr::from_ptr(message) }
                .to_string_lossy()
                .into_owned()
        };
        if let Ok(mut last) = sink.last.lock() {
            *last = Some(format!("{} ({})", text, error_name(code)));
        }
    });
}

fn error_name(code: raw::RTCError) -> &'static str {
    match code {
        raw::RTC_ERROR_NONE => "no error",
        raw::RTC_ERROR_INVALID_ARGUMENT => "invalid argument",
        raw::RTC_ERROR_INVALID_OPERATION => "invalid operation",
        raw::RTC_ERROR_OUT_OF_MEMORY => "out of memory",
        raw::RTC_ERROR_UNSUPPORTED_CPU => "unsupported CPU",
        raw::RTC_ERROR_CANCELLED => "cancelled",
        _ => "unknown error",
    }
}

/// An Embree device.
pub struct Device {
    raw: raw::RTCDevice,
    sink: Box<ErrorSink>,
}

// SAFETY: Embree's API documentation ("Thread safety") allows device calls
// from any thread; the error sink is behind a mutex.
unsafe impl Send for Device {}
unsafe impl Sync for Device {}

impl Device {
    /// A new device with Embree's configuration string (e.g. `threads=2`).
    pub fn new(config: &str) -> Result<Device, String> {
        let config =
            CString::new(config).map_err(|_| "configuration string contains NUL".to_string())?;
        // SAFETY: `config` is a valid C string for the duration of the call.
        let raw = unsafe { raw::rtcNewDevice(config.as_ptr()) };
        if raw.is_null() {
            // SAFETY: a null device is allowed here and reports the
            // thread-local error of the failed creation.
            let code = unsafe { raw::rtcGetDeviceError(std::ptr::null_mut()) };
            return Err(format!("cannot create a device: {}", error_name(code)));
        }
        let sink = Box::new(ErrorSink {
            last: Mutex::new(None),
            bytes: AtomicI64::new(0),
        });
        // SAFETY: the sink is heap-allocated and lives until `drop`, which
        // unregisters both callbacks first.
        unsafe {
            let user = &*sink as *const ErrorSink as *mut c_void;
            raw::rtcSetDeviceErrorFunction(raw, Some(record_error), user);
            raw::rtcSetDeviceMemoryMonitorFunction(raw, Some(track_memory), user);
        }
        Ok(Device { raw, sink })
    }

    /// `Err` with Embree's message if the last calls raised an error.
    pub fn check(&self) -> Result<(), String> {
        // SAFETY: `self.raw` is a live device; the call reads and clears its
        // error code.
        let code = unsafe { raw::rtcGetDeviceError(self.raw) };
        let message = self.sink.last.lock().ok().and_then(|mut m| m.take());
        match (code, message) {
            (raw::RTC_ERROR_NONE, None) => Ok(()),
            (_, Some(m)) => Err(m),
            (c, None) => Err(error_name(c).to_string()),
        }
    }

    fn property(&self, p: raw::RTCDeviceProperty) -> isize {
        // SAFETY: reading a documented property of a live device.
        unsafe { raw::rtcGetDeviceProperty(self.raw, p) as isize }
    }

    /// Bytes Embree currently holds on this device.
    pub fn memory_bytes(&self) -> usize {
        self.sink.bytes.load(Ordering::Relaxed).max(0) as usize
    }

    /// Embree's version, e.g. `3.13.5`.
    pub fn version(&self) -> String {
        format!(
            "{}.{}.{}",
            self.property(raw::RTC_DEVICE_PROPERTY_VERSION_MAJOR),
            self.property(raw::RTC_DEVICE_PROPERTY_VERSION_MINOR),
            self.property(raw::RTC_DEVICE_PROPERTY_VERSION_PATCH)
        )
    }

    /// Widest native packet the device supports (4, 8 or 16), which tells
    /// the ISA family Embree selected (SSE, AVX/AVX2, AVX-512).
    pub fn native_packet_width(&self) -> u32 {
        if self.property(raw::RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED) != 0 {
            16
        } else if self.property(raw::RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED) != 0 {
            8
        } else {
            4
        }
    }
}

impl Drop for Device {
    fn drop(&mut self) {
        // SAFETY: unregister the callback before the sink is freed, then
        // drop our reference; scenes still alive keep the device.
        unsafe {
            raw::rtcSetDeviceErrorFunction(self.raw, None, std::ptr::null_mut());
            raw::rtcSetDeviceMemoryMonitorFunction(self.raw, None, std::ptr::null_mut());
            raw::rtcReleaseDevice(self.raw);
        }
    }
}

/// Scene options.
#[derive(Clone, Copy, Debug, Default)]
pub struct SceneOptions {
    pub quality: BuildQuality,
    pub robust: bool,
}

/// A scene being built: geometry is attached, then [`SceneBuilder::commit`]
/// turns it into a [`Scene`] that answers queries. `'b` is the lifetime of
/// buffers shared with Embree.
pub struct SceneBuilder<'b> {
    raw: raw::RTCScene,
    _buffers: PhantomData<&'b [[u32; 3]]>,
}

/// A committed scene: read-only, queried from many threads.
pub struct Scene<'b> {
    raw: raw::RTCScene,
    _buffers: PhantomData<&'b [[u32; 3]]>,
}

// SAFETY: after rtcCommitScene, Embree allows rtcIntersect1/rtcOccluded1 on
// the scene from any number of threads at once (API docs, rtcCommitScene:
// "the scene can be used for ray queries ... from multiple threads"); the
// committed scene is never modified through this type.
unsafe impl Send for Scene<'_> {}
unsafe impl Sync for Scene<'_> {}

fn release_scene(scene: raw::RTCScene) {
    // SAFETY: the handle holds one reference, owned by the caller.
    unsafe { raw::rtcReleaseScene(scene) }
}

impl Drop for SceneBuilder<'_> {
    fn drop(&mut self) {
        release_scene(self.raw);
    }
}

impl Drop for Scene<'_> {
    fn drop(&mut self) {
        release_scene(self.raw);
    }
}

/// Owns a geometry until it is attached (the scene then holds it).
struct Geometry(raw::RTCGeometry);

impl Drop for Geometry {
    fn drop(&mut self) {
        // SAFETY: releases the reference created by rtcNewGeometry.
        unsafe { raw::rtcReleaseGeometry(self.0) }
    }
}

impl<'b> SceneBuilder<'b> {
    pub fn new(device: &Device, options: SceneOptions) -> Result<SceneBuilder<'b>, String> {
        // SAFETY: `device.raw` is live.
        let raw = unsafe { raw::rtcNewScene(device.raw) };
        device.check()?;
        if raw.is_null() {
            return Err("rtcNewScene returned null".into());
        }
        let builder = SceneBuilder {
            raw,
            _buffers: PhantomData,
        };
        let quality = match options.quality {
            BuildQuality::Low => raw::RTC_BUILD_QUALITY_LOW,
            BuildQuality::Medium => raw::RTC_BUILD_QUALITY_MEDIUM,
            BuildQuality::High => raw::RTC_BUILD_QUALITY_HIGH,
        };
        let flags = if options.robust {
            raw::RTC_SCENE_FLAG_ROBUST
        } else {
            raw::RTC_SCENE_FLAG_NONE
        };
        // SAFETY: plain setters on a live scene.
        unsafe {
            raw::rtcSetSceneBuildQuality(builder.raw, quality);
            raw::rtcSetSceneFlags(builder.raw, flags);
        }
        device.check()?;
        Ok(builder)
    }

    fn attach(&mut self, device: &Device, geometry: Geometry) -> Result<u32, String> {
        // SAFETY: the geometry is live; commit then attach, as the API
        // requires; the scene takes its own reference, ours is dropped.
        let id = unsafe {
            raw::rtcCommitGeometry(geometry.0);
            raw::rtcAttachGeometry(self.raw, geometry.0)
        };
        device.check()?;
        Ok(id)
    }

    /// Attaches a triangle mesh. The index triples are shared with Embree
    /// (no copy; they outlive the scene, `'b`). The vertices are copied once
    /// into a buffer Embree allocates: a shared vertex buffer must be padded
    /// so that the last vertex can be read with a 16-byte load (padding rule
    /// of `rtcSetSharedGeometryBuffer`), which the scene's tightly packed
    /// `Vec3` array is not.
    pub fn attach_triangles(
        &mut self,
        device: &Device,
        vertices: &[[f32; 3]],
        indices: &'b [[u32; 3]],
    ) -> Result<u32, String> {
        if let Some(bad) = indices
            .iter()
            .flatten()
            .find(|&&i| i as usize >= vertices.len())
        {
            return Err(format!(
                "triangle index {bad} is out of range for {} vertices",
                vertices.len()
            ));
        }
        // SAFETY: `device.raw` is live.
        let geometry =
            Geometry(unsafe { raw::rtcNewGeometry(device.raw, raw::RTC_GEOMETRY_TYPE_TRIANGLE) });
        device.check()?;
        fill_new_buffer(
            device,
            &geometry,
            raw::RTC_BUFFER_TYPE_VERTEX,
            raw::RTC_FORMAT_FLOAT3,
            vertices,
        )?;
        // SAFETY: the shared index slice is 4-byte aligned, holds
        // `indices.len()` UINT3 triples, outlives the scene ('b), and every
        // index was checked against the vertex count.
        unsafe {
            raw::rtcSetSharedGeometryBuffer(
                geometry.0,
                raw::RTC_BUFFER_TYPE_INDEX,
                0,
                raw::RTC_FORMAT_UINT3,
                indices.as_ptr() as *const c_void,
                0,
                12,
                indices.len(),
            );
        }
        device.check()?;
        self.attach(device, geometry)
    }

    /// Attaches spheres (`x, y, z, radius` each) as Embree sphere points,
    /// copied into a buffer Embree allocates.
    pub fn attach_spheres(&mut self, device: &Device, spheres: &[[f32; 4]]) -> Result<u32, String> {
        // SAFETY: `device.raw` is live.
        let geometry = Geometry(unsafe {
            raw::rtcNewGeometry(device.raw, raw::RTC_GEOMETRY_TYPE_SPHERE_POINT)
        });
        device.check()?;
        fill_new_buffer(
            device,
            &geometry,
            raw::RTC_BUFFER_TYPE_VERTEX,
            raw::RTC_FORMAT_FLOAT4,
            spheres,
        )?;
        self.attach(device, geometry)
    }

    /// Builds the acceleration structure.
    pub fn commit(self, device: &Device) -> Result<Scene<'b>, String> {
        // SAFETY: all attached geometry is committed; the scene is live.
        unsafe { raw::rtcCommitScene(self.raw) };
        device.check()?;
        let raw = self.raw;
        std::mem::forget(self);
        Ok(Scene {
            raw,
            _buffers: PhantomData,
        })
    }
}

/// Creates a geometry buffer that Embree allocates (with the padding its
/// loads need) and copies `data` into it: one element of `T` per item, `T`
/// laid out as `format` (`[f32; 3]` as FLOAT3, `[f32; 4]` as FLOAT4).
fn fill_new_buffer<T: Copy>(
    device: &Device,
    geometry: &Geometry,
    kind: raw::RTCBufferType,
    format: raw::RTCFormat,
    data: &[T],
) -> Result<(), String> {
    // SAFETY: Embree allocates `data.len()` elements of `size_of::<T>()`
    // bytes and returns a pointer to them (or null, checked), which we fill
    // with exactly that many elements before the geometry is committed.
    unsafe {
        let buffer = raw::rtcSetNewGeometryBuffer(
            geometry.0,
            kind,
            0,
            format,
            std::mem::size_of::<T>(),
            data.len(),
        ) as *mut T;
        device.check()?;
        if buffer.is_null() {
            return Err("rtcSetNewGeometryBuffer returned null".into());
        }
        std::ptr::copy_nonoverlapping(data.as_ptr(), buffer, data.len());
    }
    Ok(())
}

/// A hit as Embree reports it.
#[derive(Clone, Copy, Debug)]
pub struct RawHit {
    pub t: f32,
    pub geometry: u32,
    pub primitive: u32,
    pub u: f32,
    pub v: f32,
    /// Unnormalized geometric normal.
    pub ng: [f32; 3],
}

fn make_ray(origin: [f32; 3], dir: [f32; 3], t_min: f32, t_max: f32) -> raw::RTCRay {
    raw::RTCRay {
        org_x: origin[0],
        org_y: origin[1],
        org_z: origin[2],
        tnear: t_min,
        dir_x: dir[0],
        dir_y: dir[1],
        dir_z: dir[2],
        time: 0.0,
        tfar: t_max,
        mask: u32::MAX,
        id: 0,
        flags: 0,
    }
}

#[cfg(embree_major = "3")]
fn context() -> raw::RTCIntersectContext {
    context_with(raw::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT)
}

#[cfg(embree_major = "3")]
fn context_with(flags: raw::RTCIntersectContextFlags) -> raw::RTCIntersectContext {
    // What the inline rtcInitIntersectContext of rtcore_ray.h does.
    raw::RTCIntersectContext {
        flags,
        filter: None,
        instID: [INVALID_GEOMETRY_ID; 1],
    }
}

impl Scene<'_> {
    /// Closest hit of one ray (`rtcIntersect1`).
    #[inline]
    pub fn intersect(
        &self,
        origin: [f32; 3],
        dir: [f32; 3],
        t_min: f32,
        t_max: f32,
    ) -> Option<RawHit> {
        let mut rayhit = raw::RTCRayHit {
            ray: make_ray(origin, dir, t_min, t_max),
            hit: raw::RTCHit {
                geomID: INVALID_GEOMETRY_ID,
                primID: INVALID_GEOMETRY_ID,
                ..Default::default()
            },
        };
        // SAFETY: `rayhit` is a properly aligned (align 16, from bindgen)
        // RTCRayHit initialized as the API requires; the scene is committed.
        #[cfg(embree_major = "3")]
        unsafe {
            let mut ctx = context();
            raw::rtcIntersect1(self.raw, &mut ctx, &mut rayhit);
        }
        #[cfg(embree_major = "4")]
        unsafe {
            raw::rtcIntersect1(self.raw, &mut rayhit, std::ptr::null_mut());
        }
        (rayhit.hit.geomID != INVALID_GEOMETRY_ID).then(|| RawHit {
            t: rayhit.ray.tfar,
            geometry: rayhit.hit.geomID,
            primitive: rayhit.hit.primID,
            u: rayhit.hit.u,
            v: rayhit.hit.v,
            ng: [rayhit.hit.Ng_x, rayhit.hit.Ng_y, rayhit.hit.Ng_z],
        })
    }

    /// Closest hits of many rays at once: one `rtcIntersect1M` stream call
    /// with the coherent flag on Embree 3 (streams were removed in Embree 4,
    /// where this is a loop of `rtcIntersect1`). `rays` are
    /// `(origin, dir, t_min, t_max)`; `out` receives one answer per ray.
    pub fn intersect_stream(
        &self,
        rays: &[([f32; 3], [f32; 3], f32, f32)],
        out: &mut Vec<Option<RawHit>>,
    ) {
        out.clear();
        let mut batch: Vec<raw::RTCRayHit> = rays
            .iter()
            .map(|&(o, d, t0, t1)| raw::RTCRayHit {
                ray: make_ray(o, d, t0, t1),
                hit: raw::RTCHit {
                    geomID: INVALID_GEOMETRY_ID,
                    primID: INVALID_GEOMETRY_ID,
                    ..Default::default()
                },
            })
            .collect();
        #[cfg(embree_major = "3")]
        // SAFETY: `batch` holds `batch.len()` initialized, 16-byte aligned
        // RTCRayHit structs laid out with the stride given; the scene is
        // committed.
        unsafe {
            let mut ctx = context_with(raw::RTC_INTERSECT_CONTEXT_FLAG_COHERENT);
            raw::rtcIntersect1M(
                self.raw,
                &mut ctx,
                batch.as_mut_ptr(),
                batch.len() as u32,
                std::mem::size_of::<raw::RTCRayHit>(),
            );
        }
        #[cfg(embree_major = "4")]
        for rayhit in batch.iter_mut() {
            // SAFETY: as in `intersect`.
            unsafe { raw::rtcIntersect1(self.raw, rayhit, std::ptr::null_mut()) };
        }
        out.extend(batch.iter().map(|rh| {
            (rh.hit.geomID != INVALID_GEOMETRY_ID).then(|| RawHit {
                t: rh.ray.tfar,
                geometry: rh.hit.geomID,
                primitive: rh.hit.primID,
                u: rh.hit.u,
                v: rh.hit.v,
                ng: [rh.hit.Ng_x, rh.hit.Ng_y, rh.hit.Ng_z],
            })
        }));
    }

    /// Whether anything lies on the segment (`rtcOccluded1`).
    #[inline]
    pub fn occluded(&self, origin: [f32; 3], dir: [f32; 3], t_min: f32, t_max: f32) -> bool {
        let mut ray = make_ray(origin, dir, t_min, t_max);
        // SAFETY: as in `intersect`; Embree sets tfar to -inf on a hit.
        #[cfg(embree_major = "3")]
        unsafe {
            let mut ctx = context();
            raw::rtcOccluded1(self.raw, &mut ctx, &mut ray);
        }
        #[cfg(embree_major = "4")]
        unsafe {
            raw::rtcOccluded1(self.raw, &mut ray, std::ptr::null_mut());
        }
        ray.tfar == f32::NEG_INFINITY
    }
}

/// Test hook: hands Embree a buffer it must reject, to prove that Embree's
/// errors come back as Rust errors with Embree's message.
pub fn provoke_invalid_buffer(device: &Device) -> Result<(), String> {
    let mut builder = SceneBuilder::new(device, SceneOptions::default())?;
    // SAFETY: creating a geometry on a live device.
    let geometry =
        Geometry(unsafe { raw::rtcNewGeometry(device.raw, raw::RTC_GEOMETRY_TYPE_TRIANGLE) });
    device.check()?;
    let floats = [0.0f32; 16];
    // SAFETY: a misaligned pointer (offset 1 byte) is something Embree
    // checks and refuses before touching the memory; the slice outlives
    // the call.
    unsafe {
        raw::rtcSetSharedGeometryBuffer(
            geometry.0,
            raw::RTC_BUFFER_TYPE_VERTEX,
            0,
            raw::RTC_FORMAT_FLOAT3,
            floats.as_ptr() as *const c_void,
            1,
            12,
            3,
        );
    }
    device.check()?;
    builder.attach(device, geometry).map(|_| ())
}
