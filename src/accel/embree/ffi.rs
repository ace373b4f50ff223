//! The safe API over Embree's C functions, written once for both versions:
//! [`Device`], [`SceneBuilder`] and [`Scene`] are generic over an [`Api`],
//! the table of one version's functions (`sys3.rs`, `sys4.rs`). Embree 3
//! and 4 share every call hybrid makes but the ray queries, and the same
//! values for every enum it passes, so only those queries differ per
//! version.
//!
//! Ownership: [`Device`] and [`Scene`] own one Embree reference each and
//! release it on drop. Embree reference-counts internally (a scene keeps its
//! device alive), so Rust values may be dropped in any order.
//!
//! Errors: the device's error callback records Embree's message; every call
//! that can fail is followed by [`Device::check`], which turns the recorded
//! error into a Rust `Err`. The callbacks ([`library::record_error`]) catch
//! any panic, so no unwinding crosses the FFI boundary.

use std::ffi::{c_char, c_void, CString};
use std::marker::PhantomData;

use super::library::{self, ErrorSink, RawHit};
use super::plain_c::{Answers, BatchMode, CFunctions};
use super::{BuildQuality, SceneOptions};
use crate::geom::ray::FlatRay;

/// An opaque Embree handle (`RTCDevice`, `RTCScene`, `RTCGeometry`).
pub type Handle = *mut c_void;

/// `RTCErrorFunction`, with the code as the `u32` it is in C.
pub type ErrorFunction = unsafe extern "C" fn(*mut c_void, u32, *const c_char);
/// `RTCMemoryMonitorFunction`.
pub type MemoryMonitor = unsafe extern "C" fn(*mut c_void, isize, bool) -> bool;

/// A ray as the queries take it: origin, direction, `t_min`, `t_max`.
pub type RawRay = ([f32; 3], [f32; 3], f32, f32);

/// Enum values hybrid passes (the same in Embree 3 and 4).
pub mod value {
    pub const GEOMETRY_TRIANGLE: u32 = 0;
    pub const GEOMETRY_SPHERE_POINT: u32 = 50;
    pub const BUFFER_INDEX: u32 = 0;
    pub const BUFFER_VERTEX: u32 = 1;
    pub const FORMAT_UINT3: u32 = 0x5003;
    pub const FORMAT_FLOAT3: u32 = 0x9003;
    pub const FORMAT_FLOAT4: u32 = 0x9004;
    pub const SCENE_FLAG_NONE: u32 = 0;
    pub const SCENE_FLAG_ROBUST: u32 = 1 << 2;
    pub const PROPERTY_VERSION_MAJOR: u32 = 1;
    pub const PROPERTY_VERSION_MINOR: u32 = 2;
    pub const PROPERTY_VERSION_PATCH: u32 = 3;
    pub const PROPERTY_NATIVE_RAY8_SUPPORTED: u32 = 33;
    pub const PROPERTY_NATIVE_RAY16_SUPPORTED: u32 = 34;
}

/// One Embree version's functions. Implementors guarantee that each method
/// calls the C function of that name with the arguments given, and that
/// the enum values of [`value`] mean the same to their library.
///
/// # Safety
/// Every method forwards to C; the callers below uphold the C API's
/// preconditions (live handles, valid pointers), stated at each call.
pub unsafe trait Api: Sync + 'static {
    unsafe fn new_device(&self, config: *const c_char) -> Handle;
    unsafe fn device_error(&self, device: Handle) -> u32;
    unsafe fn set_error_function(
        &self,
        device: Handle,
        f: Option<ErrorFunction>,
        user: *mut c_void,
    );
    unsafe fn set_memory_monitor(
        &self,
        device: Handle,
        f: Option<MemoryMonitor>,
        user: *mut c_void,
    );
    unsafe fn device_property(&self, device: Handle, property: u32) -> isize;
    unsafe fn release_device(&self, device: Handle);
    unsafe fn new_scene(&self, device: Handle) -> Handle;
    unsafe fn set_build_quality(&self, scene: Handle, quality: u32);
    unsafe fn set_scene_flags(&self, scene: Handle, flags: u32);
    unsafe fn commit_scene(&self, scene: Handle);
    unsafe fn release_scene(&self, scene: Handle);
    unsafe fn new_geometry(&self, device: Handle, kind: u32) -> Handle;
    #[allow(clippy::too_many_arguments)]
    unsafe fn set_shared_buffer(
        &self,
        geometry: Handle,
        kind: u32,
        format: u32,
        ptr: *const c_void,
        offset: usize,
        stride: usize,
        count: usize,
    );
    unsafe fn set_new_buffer(
        &self,
        geometry: Handle,
        kind: u32,
        format: u32,
        stride: usize,
        count: usize,
    ) -> *mut c_void;
    unsafe fn commit_geometry(&self, geometry: Handle);
    unsafe fn attach_geometry(&self, scene: Handle, geometry: Handle) -> u32;
    unsafe fn release_geometry(&self, geometry: Handle);
    /// `rtcIntersect1` on a committed scene, incoherent.
    unsafe fn intersect1(&self, scene: Handle, ray: RawRay) -> Option<RawHit>;
    /// `rtcOccluded1` on a committed scene, incoherent.
    unsafe fn occluded1(&self, scene: Handle, ray: RawRay) -> bool;
    /// The version's query functions (single rays, packets, stream) as
    /// plain C calls them, for the C driver (`plain_c.rs`).
    fn c_functions(&self) -> CFunctions;
}

/// An Embree device.
pub struct Device<A: Api> {
    api: &'static A,
    raw: Handle,
    sink: Box<ErrorSink>,
}

// SAFETY: Embree's API documentation ("Thread safety") allows device calls
// from any thread; the error sink is behind a mutex.
unsafe impl<A: Api> Send for Device<A> {}
// SAFETY: as for `Send`: shared references only make device calls, which
// Embree allows from any thread, and reach the sink through its mutex.
unsafe impl<A: Api> Sync for Device<A> {}

impl<A: Api> Device<A> {
    /// A new device with Embree's configuration string (e.g. `threads=2`).
    pub fn new(api: &'static A, config: &str) -> Result<Device<A>, String> {
        let config =
            CString::new(config).map_err(|_| "configuration string contains NUL".to_string())?;
        // SAFETY: `config` is a valid C string for the duration of the call.
        let raw = unsafe { api.new_device(config.as_ptr()) };
        if raw.is_null() {
            // SAFETY: a null device is allowed here and reports the
            // thread-local error of the failed creation.
            let code = unsafe { api.device_error(std::ptr::null_mut()) };
            return Err(format!(
                "cannot create a device: {}",
                library::error_name(code)
            ));
        }
        let sink = ErrorSink::new();
        // SAFETY: the sink is heap-allocated and lives until `drop`, which
        // unregisters both callbacks first.
        unsafe {
            let user = &*sink as *const ErrorSink as *mut c_void;
            api.set_error_function(raw, Some(library::record_error), user);
            api.set_memory_monitor(raw, Some(library::track_memory), user);
        }
        Ok(Device { api, raw, sink })
    }

    /// `Err` with Embree's message if the last calls raised an error.
    pub fn check(&self) -> Result<(), String> {
        // SAFETY: `self.raw` is a live device; the call reads and clears its
        // error code.
        let code = unsafe { self.api.device_error(self.raw) };
        library::check(code, &self.sink)
    }

    fn property(&self, p: u32) -> isize {
        // SAFETY: reading a documented property of a live device.
        unsafe { self.api.device_property(self.raw, p) }
    }

    /// Bytes Embree currently holds on this device.
    pub fn memory_bytes(&self) -> usize {
        self.sink.memory_bytes()
    }

    /// Embree's version, e.g. `3.13.5`.
    pub fn version(&self) -> String {
        format!(
            "{}.{}.{}",
            self.property(value::PROPERTY_VERSION_MAJOR),
            self.property(value::PROPERTY_VERSION_MINOR),
            self.property(value::PROPERTY_VERSION_PATCH)
        )
    }

    /// Widest native packet the device supports (4, 8 or 16), which tells
    /// the ISA family Embree selected (SSE, AVX/AVX2, AVX-512).
    pub fn native_packet_width(&self) -> u32 {
        if self.property(value::PROPERTY_NATIVE_RAY16_SUPPORTED) != 0 {
            16
        } else if self.property(value::PROPERTY_NATIVE_RAY8_SUPPORTED) != 0 {
            8
        } else {
            4
        }
    }
}

impl<A: Api> Drop for Device<A> {
    fn drop(&mut self) {
        // SAFETY: unregister the callbacks before the sink is freed, then
        // drop our reference; scenes still alive keep the device.
        unsafe {
            self.api
                .set_error_function(self.raw, None, std::ptr::null_mut());
            self.api
                .set_memory_monitor(self.raw, None, std::ptr::null_mut());
            self.api.release_device(self.raw);
        }
    }
}

/// A scene being built: geometry is attached, then [`SceneBuilder::commit`]
/// turns it into a [`Scene`] that answers queries. `'b` is the lifetime of
/// buffers shared with Embree.
pub struct SceneBuilder<'b, A: Api> {
    api: &'static A,
    raw: Handle,
    _buffers: PhantomData<&'b [[u32; 3]]>,
}

/// A committed scene: read-only, queried from many threads.
pub struct Scene<'b, A: Api> {
    api: &'static A,
    raw: Handle,
    _buffers: PhantomData<&'b [[u32; 3]]>,
}

// SAFETY: after rtcCommitScene, Embree allows ray queries on the scene from
// any number of threads at once (API docs, rtcCommitScene: "the scene can be
// used for ray queries ... from multiple threads"); the committed scene is
// never modified through this type.
unsafe impl<A: Api> Send for Scene<'_, A> {}
// SAFETY: as for `Send`: through a shared reference the committed scene
// only answers ray queries, which Embree allows from many threads at once.
unsafe impl<A: Api> Sync for Scene<'_, A> {}

impl<A: Api> Drop for SceneBuilder<'_, A> {
    fn drop(&mut self) {
        // SAFETY: the handle holds one reference, owned by this value.
        unsafe { self.api.release_scene(self.raw) }
    }
}

// SAFETY: a `Scene` exists only committed (`SceneBuilder::commit` makes
// it) and releases its handle only when dropped, so the handle lives while
// the scene is borrowed; `c_functions` is its own library's table.
unsafe impl<A: Api> super::plain_c::CommittedScene for Scene<'_, A> {
    fn c_calls(&self) -> (super::plain_c::CFunctions, Handle) {
        (self.api.c_functions(), self.raw)
    }
}

impl<A: Api> Drop for Scene<'_, A> {
    fn drop(&mut self) {
        // SAFETY: the handle holds one reference, owned by this value.
        unsafe { self.api.release_scene(self.raw) }
    }
}

/// Owns a geometry until it is attached (the scene then holds it).
struct Geometry<A: Api> {
    api: &'static A,
    raw: Handle,
}

impl<A: Api> Drop for Geometry<A> {
    fn drop(&mut self) {
        // SAFETY: releases the reference created by rtcNewGeometry.
        unsafe { self.api.release_geometry(self.raw) }
    }
}

impl<A: Api> Geometry<A> {
    fn new(device: &Device<A>, kind: u32) -> Result<Geometry<A>, String> {
        // SAFETY: `device.raw` is live.
        let raw = unsafe { device.api.new_geometry(device.raw, kind) };
        device.check()?;
        if raw.is_null() {
            return Err("rtcNewGeometry returned null".into());
        }
        Ok(Geometry {
            api: device.api,
            raw,
        })
    }

    /// Creates a buffer that Embree allocates (with the padding its loads
    /// need) and copies `data` into it: one element of `T` per item, `T`
    /// laid out as `format` (`[f32; 3]` as FLOAT3, `[f32; 4]` as FLOAT4).
    fn fill_new_buffer<T: Copy>(
        &self,
        device: &Device<A>,
        kind: u32,
        format: u32,
        data: &[T],
    ) -> Result<(), String> {
        // SAFETY: Embree allocates `data.len()` elements of `size_of::<T>()`
        // bytes and returns a pointer to them (or null, checked), which we
        // fill with exactly that many elements before the geometry is
        // committed.
        unsafe {
            let buffer = self.api.set_new_buffer(
                self.raw,
                kind,
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
}

impl<'b, A: Api> SceneBuilder<'b, A> {
    pub fn new(device: &Device<A>, options: SceneOptions) -> Result<SceneBuilder<'b, A>, String> {
        // SAFETY: `device.raw` is live.
        let raw = unsafe { device.api.new_scene(device.raw) };
        device.check()?;
        if raw.is_null() {
            return Err("rtcNewScene returned null".into());
        }
        let builder = SceneBuilder {
            api: device.api,
            raw,
            _buffers: PhantomData,
        };
        // RTC_BUILD_QUALITY_LOW, _MEDIUM, _HIGH.
        let quality = match options.quality {
            BuildQuality::Low => 0,
            BuildQuality::Medium => 1,
            BuildQuality::High => 2,
        };
        let flags = if options.robust {
            value::SCENE_FLAG_ROBUST
        } else {
            value::SCENE_FLAG_NONE
        };
        // SAFETY: plain setters on a live scene.
        unsafe {
            device.api.set_build_quality(builder.raw, quality);
            device.api.set_scene_flags(builder.raw, flags);
        }
        device.check()?;
        Ok(builder)
    }

    fn attach(&mut self, device: &Device<A>, geometry: Geometry<A>) -> Result<u32, String> {
        // SAFETY: the geometry is live; commit then attach, as the API
        // requires; the scene takes its own reference, ours is dropped.
        let id = unsafe {
            self.api.commit_geometry(geometry.raw);
            self.api.attach_geometry(self.raw, geometry.raw)
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
        device: &Device<A>,
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
        let geometry = Geometry::new(device, value::GEOMETRY_TRIANGLE)?;
        geometry.fill_new_buffer(device, value::BUFFER_VERTEX, value::FORMAT_FLOAT3, vertices)?;
        // SAFETY: the shared index slice is 4-byte aligned, holds
        // `indices.len()` UINT3 triples, outlives the scene ('b), and every
        // index was checked against the vertex count.
        unsafe {
            self.api.set_shared_buffer(
                geometry.raw,
                value::BUFFER_INDEX,
                value::FORMAT_UINT3,
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
    pub fn attach_spheres(
        &mut self,
        device: &Device<A>,
        spheres: &[[f32; 4]],
    ) -> Result<u32, String> {
        let geometry = Geometry::new(device, value::GEOMETRY_SPHERE_POINT)?;
        geometry.fill_new_buffer(device, value::BUFFER_VERTEX, value::FORMAT_FLOAT4, spheres)?;
        self.attach(device, geometry)
    }

    /// Builds the acceleration structure.
    pub fn commit(self, device: &Device<A>) -> Result<Scene<'b, A>, String> {
        // SAFETY: all attached geometry is committed; the scene is live.
        unsafe { self.api.commit_scene(self.raw) };
        device.check()?;
        let (api, raw) = (self.api, self.raw);
        std::mem::forget(self);
        Ok(Scene {
            api,
            raw,
            _buffers: PhantomData,
        })
    }
}

impl<A: Api> Scene<'_, A> {
    /// Closest hit of one ray.
    #[inline]
    pub fn intersect(&self, ray: RawRay) -> Option<RawHit> {
        // SAFETY: the scene is committed and alive as long as `self`.
        unsafe { self.api.intersect1(self.raw, ray) }
    }

    /// Whether anything lies on the segment.
    #[inline]
    pub fn occluded(&self, ray: RawRay) -> bool {
        // SAFETY: as in `intersect`.
        unsafe { self.api.occluded1(self.raw, ray) }
    }

    /// `rays` traced by the C driver, one `rtcIntersect1` (or
    /// `rtcOccluded1`) per ray as a C program makes them: the number of
    /// rays that hit and the sum of the hit primitive ids.
    pub fn trace_as_c_caller(&self, rays: &[FlatRay], occluded: bool) -> (usize, u64) {
        super::plain_c::trace(self, rays, occluded)
    }

    /// `rays` traced by the C driver in one of Embree's batched modes, as
    /// a C program calls it (`plain_c::trace_batched`).
    pub fn trace_batched(
        &self,
        mode: BatchMode,
        coherent: bool,
        rays: &[FlatRay],
        occluded: bool,
        answers: Answers,
    ) -> Option<(usize, u64)> {
        super::plain_c::trace_batched(self, mode, coherent, rays, occluded, answers)
    }
}

/// Test hook: hands Embree a buffer it must reject, to prove that Embree's
/// errors come back as Rust errors with Embree's message.
pub fn provoke_invalid_buffer<A: Api>(device: &Device<A>) -> Result<(), String> {
    let mut builder = SceneBuilder::new(device, SceneOptions::default())?;
    let geometry = Geometry::new(device, value::GEOMETRY_TRIANGLE)?;
    let floats = [0.0f32; 16];
    // SAFETY: a misaligned pointer (offset 1 byte) is something Embree
    // checks and refuses before touching the memory; the slice outlives
    // the call.
    unsafe {
        device.api.set_shared_buffer(
            geometry.raw,
            value::BUFFER_VERTEX,
            value::FORMAT_FLOAT3,
            floats.as_ptr() as *const c_void,
            1,
            12,
            3,
        );
    }
    device.check()?;
    builder.attach(device, geometry).map(|_| ())
}
