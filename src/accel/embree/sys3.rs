//! Embree 3's functions: the table bindgen generates in `build.rs` from
//! `ffi/embree.h`, filled from `libembree3.so.3` at run time, as an
//! [`Api`] for the safe layer (`ffi.rs`).

use std::ffi::{c_char, c_void};
use std::sync::OnceLock;

use super::ffi::{value, Api, ErrorFunction, Handle, MemoryMonitor, RawRay};
use super::library::{self, RawHit, INVALID_GEOMETRY_ID};
use super::plain_c::{CFunctions, EmbreeMajor};

mod raw {
    #![allow(
        non_upper_case_globals,
        non_camel_case_types,
        non_snake_case,
        dead_code,
        unsafe_op_in_unsafe_fn,
        clippy::all,
        clippy::undocumented_unsafe_blocks
    )]
    include!(concat!(env!("OUT_DIR"), "/embree3_bindings.rs"));
}

// The enum values the safe layer passes are Embree 3's.
const _: () = {
    assert!(value::GEOMETRY_TRIANGLE == raw::RTC_GEOMETRY_TYPE_TRIANGLE);
    assert!(value::GEOMETRY_SPHERE_POINT == raw::RTC_GEOMETRY_TYPE_SPHERE_POINT);
    assert!(value::BUFFER_INDEX == raw::RTC_BUFFER_TYPE_INDEX);
    assert!(value::BUFFER_VERTEX == raw::RTC_BUFFER_TYPE_VERTEX);
    assert!(value::FORMAT_UINT3 == raw::RTC_FORMAT_UINT3);
    assert!(value::FORMAT_FLOAT3 == raw::RTC_FORMAT_FLOAT3);
    assert!(value::FORMAT_FLOAT4 == raw::RTC_FORMAT_FLOAT4);
    assert!(value::SCENE_FLAG_NONE == raw::RTC_SCENE_FLAG_NONE);
    assert!(value::SCENE_FLAG_ROBUST == raw::RTC_SCENE_FLAG_ROBUST);
    // The C driver's coherent hint for this version.
    assert!(super::plain_c::COHERENT3 == raw::RTC_INTERSECT_CONTEXT_FLAG_COHERENT);
    assert!(value::PROPERTY_VERSION_MAJOR == raw::RTC_DEVICE_PROPERTY_VERSION_MAJOR);
    assert!(value::PROPERTY_VERSION_MINOR == raw::RTC_DEVICE_PROPERTY_VERSION_MINOR);
    assert!(value::PROPERTY_VERSION_PATCH == raw::RTC_DEVICE_PROPERTY_VERSION_PATCH);
    assert!(
        value::PROPERTY_NATIVE_RAY8_SUPPORTED == raw::RTC_DEVICE_PROPERTY_NATIVE_RAY8_SUPPORTED
    );
    assert!(
        value::PROPERTY_NATIVE_RAY16_SUPPORTED == raw::RTC_DEVICE_PROPERTY_NATIVE_RAY16_SUPPORTED
    );
    assert!(raw::RTC_BUILD_QUALITY_LOW == 0 && raw::RTC_BUILD_QUALITY_HIGH == 2);
};

/// Embree 3's functions, loaded once per process.
pub struct Embree3(raw::Embree3);

/// Embree 3 in this process, or why it cannot be loaded.
pub fn api() -> Result<&'static Embree3, String> {
    static API: OnceLock<Result<Embree3, String>> = OnceLock::new();
    API.get_or_init(|| {
        let names = library::candidates("HYBRID_EMBREE3", "libembree3.so.3", None);
        let (lib, path) = library::open(&names).map_err(|e| {
            format!("Embree 3 is not installed ({e}); run `apt-get install -y libembree-dev` (Debian 12), or set HYBRID_EMBREE3 to a libembree3.so.3")
        })?;
        library::check_version(&lib, &path, 3, "rtcIntersect1M", "rtcForwardIntersect1")?;
        // SAFETY: the library is Embree 3 (found by its SONAME or named by
        // the user, and checked by its exports just above), whose exported
        // functions have the signatures of the headers the table was
        // generated from.
        let table = unsafe { raw::Embree3::from_library(lib) }
            .map_err(|e| format!("{path} is not Embree 3: {e}"))?;
        Ok(Embree3(table))
    })
    .as_ref()
    .map_err(Clone::clone)
}

fn make_ray((origin, dir, t_min, t_max): RawRay) -> raw::RTCRay {
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

fn make_rayhit(ray: RawRay) -> raw::RTCRayHit {
    raw::RTCRayHit {
        ray: make_ray(ray),
        hit: raw::RTCHit {
            geomID: INVALID_GEOMETRY_ID,
            primID: INVALID_GEOMETRY_ID,
            ..Default::default()
        },
    }
}

fn raw_hit(rh: &raw::RTCRayHit) -> Option<RawHit> {
    (rh.hit.geomID != INVALID_GEOMETRY_ID).then_some(RawHit {
        t: rh.ray.tfar,
        geometry: rh.hit.geomID,
        primitive: rh.hit.primID,
        u: rh.hit.u,
        v: rh.hit.v,
    })
}

/// What the inline `rtcInitIntersectContext` of `rtcore_ray.h` does.
fn context(flags: raw::RTCIntersectContextFlags) -> raw::RTCIntersectContext {
    raw::RTCIntersectContext {
        flags,
        filter: None,
        instID: [INVALID_GEOMETRY_ID; 1],
    }
}

// SAFETY: each method calls the Embree 3 function of its name, loaded from
// Embree 3 by `api`, and the values of `value` were checked against
// Embree 3's headers above.
unsafe impl Api for Embree3 {
    unsafe fn new_device(&self, config: *const c_char) -> Handle {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { self.0.rtcNewDevice(config) as Handle }
    }
    unsafe fn device_error(&self, device: Handle) -> u32 {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { self.0.rtcGetDeviceError(device as raw::RTCDevice) }
    }
    unsafe fn set_error_function(
        &self,
        device: Handle,
        f: Option<ErrorFunction>,
        user: *mut c_void,
    ) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe {
            self.0
                .rtcSetDeviceErrorFunction(device as raw::RTCDevice, f, user)
        }
    }
    unsafe fn set_memory_monitor(
        &self,
        device: Handle,
        f: Option<MemoryMonitor>,
        user: *mut c_void,
    ) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe {
            self.0
                .rtcSetDeviceMemoryMonitorFunction(device as raw::RTCDevice, f, user)
        }
    }
    unsafe fn device_property(&self, device: Handle, property: u32) -> isize {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe {
            self.0
                .rtcGetDeviceProperty(device as raw::RTCDevice, property)
        }
    }
    unsafe fn release_device(&self, device: Handle) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { self.0.rtcReleaseDevice(device as raw::RTCDevice) }
    }
    unsafe fn new_scene(&self, device: Handle) -> Handle {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { self.0.rtcNewScene(device as raw::RTCDevice) as Handle }
    }
    unsafe fn set_build_quality(&self, scene: Handle, quality: u32) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe {
            self.0
                .rtcSetSceneBuildQuality(scene as raw::RTCScene, quality)
        }
    }
    unsafe fn set_scene_flags(&self, scene: Handle, flags: u32) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { self.0.rtcSetSceneFlags(scene as raw::RTCScene, flags) }
    }
    unsafe fn commit_scene(&self, scene: Handle) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { self.0.rtcCommitScene(scene as raw::RTCScene) }
    }
    unsafe fn release_scene(&self, scene: Handle) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { self.0.rtcReleaseScene(scene as raw::RTCScene) }
    }
    unsafe fn new_geometry(&self, device: Handle, kind: u32) -> Handle {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { self.0.rtcNewGeometry(device as raw::RTCDevice, kind) as Handle }
    }
    unsafe fn set_shared_buffer(
        &self,
        geometry: Handle,
        kind: u32,
        format: u32,
        ptr: *const c_void,
        offset: usize,
        stride: usize,
        count: usize,
    ) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe {
            self.0.rtcSetSharedGeometryBuffer(
                geometry as raw::RTCGeometry,
                kind,
                0,
                format,
                ptr,
                offset,
                stride,
                count,
            )
        }
    }
    unsafe fn set_new_buffer(
        &self,
        geometry: Handle,
        kind: u32,
        format: u32,
        stride: usize,
        count: usize,
    ) -> *mut c_void {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe {
            self.0.rtcSetNewGeometryBuffer(
                geometry as raw::RTCGeometry,
                kind,
                0,
                format,
                stride,
                count,
            )
        }
    }
    unsafe fn commit_geometry(&self, geometry: Handle) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { self.0.rtcCommitGeometry(geometry as raw::RTCGeometry) }
    }
    unsafe fn attach_geometry(&self, scene: Handle, geometry: Handle) -> u32 {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe {
            self.0
                .rtcAttachGeometry(scene as raw::RTCScene, geometry as raw::RTCGeometry)
        }
    }
    unsafe fn release_geometry(&self, geometry: Handle) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { self.0.rtcReleaseGeometry(geometry as raw::RTCGeometry) }
    }

    #[inline(always)]
    unsafe fn intersect1(&self, scene: Handle, ray: RawRay) -> Option<RawHit> {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe {
            let mut rayhit = make_rayhit(ray);
            let mut ctx = context(raw::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT);
            // `rayhit` is a 16-byte aligned RTCRayHit (bindgen keeps the
            // header's alignment), initialised as the API requires.
            self.0
                .rtcIntersect1(scene as raw::RTCScene, &mut ctx, &mut rayhit);
            raw_hit(&rayhit)
        }
    }

    #[inline(always)]
    unsafe fn occluded1(&self, scene: Handle, ray: RawRay) -> bool {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe {
            let mut ray = make_ray(ray);
            let mut ctx = context(raw::RTC_INTERSECT_CONTEXT_FLAG_INCOHERENT);
            self.0
                .rtcOccluded1(scene as raw::RTCScene, &mut ctx, &mut ray);
            // Embree sets tfar to -inf on a hit.
            ray.tfar == f32::NEG_INFINITY
        }
    }

    fn c_functions(&self) -> CFunctions {
        CFunctions {
            version: EmbreeMajor::Three,
            intersect1: self.0.rtcIntersect1 as *const c_void,
            occluded1: self.0.rtcOccluded1 as *const c_void,
            intersect8: self.0.rtcIntersect8 as *const c_void,
            occluded8: self.0.rtcOccluded8 as *const c_void,
            intersect16: self.0.rtcIntersect16 as *const c_void,
            occluded16: self.0.rtcOccluded16 as *const c_void,
            intersect1m: self.0.rtcIntersect1M as *const c_void,
            occluded1m: self.0.rtcOccluded1M as *const c_void,
        }
    }
}
