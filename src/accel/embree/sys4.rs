//! Embree 4's functions, loaded at run time from `libembree4.so.4`, with
//! the ABI types of the `embree4-sys` crate (bindgen on Embree 4.2's
//! headers), as an [`Api`] for the safe layer (`ffi.rs`).
//!
//! Two layouts grew after 4.2, and a 4.3+ library writes or reads past the
//! 4.2 structs: `RTCHit` gained `instPrimID` (instance arrays, on in the
//! wheel's 4.4.0 and in Debian 13's 4.3: a plain C caller compiled against
//! 4.2 headers gets four bytes written after its `RTCRayHit`, checked), and
//! `RTCIntersectArguments` may end in `minWidthDistanceFactor`. Every
//! struct handed over here carries a zeroed tail covering both.

use std::ffi::{c_char, c_void};
use std::sync::OnceLock;

use embree4_sys as e4;
use libloading::os::unix::Library;

use super::ffi::{value, Api, ErrorFunction, Handle, MemoryMonitor, RawRay};
use super::library::{self, RawHit, INVALID_GEOMETRY_ID};
use super::plain_c::{CFunctions, EmbreeMajor};

// The enum values the safe layer passes are Embree 4's.
const _: () = {
    assert!(value::GEOMETRY_TRIANGLE == e4::RTCGeometryType::TRIANGLE as u32);
    assert!(value::GEOMETRY_SPHERE_POINT == e4::RTCGeometryType::SPHERE_POINT as u32);
    assert!(value::BUFFER_INDEX == e4::RTCBufferType::INDEX as u32);
    assert!(value::BUFFER_VERTEX == e4::RTCBufferType::VERTEX as u32);
    assert!(value::FORMAT_UINT3 == e4::RTCFormat::UINT3 as u32);
    assert!(value::FORMAT_FLOAT3 == e4::RTCFormat::FLOAT3 as u32);
    assert!(value::FORMAT_FLOAT4 == e4::RTCFormat::FLOAT4 as u32);
    assert!(value::SCENE_FLAG_NONE == e4::RTCSceneFlags::NONE.0);
    assert!(value::SCENE_FLAG_ROBUST == e4::RTCSceneFlags::ROBUST.0);
    assert!(value::PROPERTY_VERSION_MAJOR == e4::RTCDeviceProperty::VERSION_MAJOR as u32);
    assert!(value::PROPERTY_VERSION_MINOR == e4::RTCDeviceProperty::VERSION_MINOR as u32);
    assert!(value::PROPERTY_VERSION_PATCH == e4::RTCDeviceProperty::VERSION_PATCH as u32);
    assert!(
        value::PROPERTY_NATIVE_RAY8_SUPPORTED
            == e4::RTCDeviceProperty::NATIVE_RAY8_SUPPORTED as u32
    );
    assert!(
        value::PROPERTY_NATIVE_RAY16_SUPPORTED
            == e4::RTCDeviceProperty::NATIVE_RAY16_SUPPORTED as u32
    );
    assert!(e4::RTCBuildQuality::LOW as u32 == 0 && e4::RTCBuildQuality::HIGH as u32 == 2);
    // The C driver's coherent hint for this version.
    assert!(super::plain_c::COHERENT4 == e4::RTCRayQueryFlags::COHERENT.0);
    // The 4.2 layouts the tails below extend.
    assert!(std::mem::size_of::<e4::RTCRayHit>() == 80);
    assert!(std::mem::size_of::<e4::RTCIntersectArguments>() == 32);
};

/// Declares the table: each field a C function read from the library by
/// its own name. Enum arguments and results are the `u32`s they are in C.
macro_rules! table {
    ($($name:ident: fn($($arg:ty),*) $(-> $ret:ty)?;)*) => {
        #[allow(non_snake_case)]
        struct Table {
            _library: Library,
            $($name: unsafe extern "C" fn($($arg),*) $(-> $ret)?,)*
        }

        impl Table {
            /// # Safety
            /// `library` must be Embree 4, whose functions have these
            /// signatures.
            #[allow(non_snake_case)]
            unsafe fn load(library: Library) -> Result<Table, libloading::Error> {
                $(let $name = *unsafe {
                    // SAFETY: the caller's contract: this is Embree 4, and
                    // the symbol has the signature the table gives it.
                    library.get::<unsafe extern "C" fn($($arg),*) $(-> $ret)?>(
                        concat!(stringify!($name), "\0").as_bytes(),
                    )
                }?;)*
                Ok(Table { _library: library, $($name),* })
            }
        }
    };
}

table! {
    rtcNewDevice: fn(*const c_char) -> Handle;
    rtcGetDeviceError: fn(Handle) -> u32;
    rtcSetDeviceErrorFunction: fn(Handle, Option<ErrorFunction>, *mut c_void);
    rtcSetDeviceMemoryMonitorFunction: fn(Handle, Option<MemoryMonitor>, *mut c_void);
    rtcGetDeviceProperty: fn(Handle, u32) -> isize;
    rtcReleaseDevice: fn(Handle);
    rtcNewScene: fn(Handle) -> Handle;
    rtcSetSceneBuildQuality: fn(Handle, u32);
    rtcSetSceneFlags: fn(Handle, u32);
    rtcCommitScene: fn(Handle);
    rtcReleaseScene: fn(Handle);
    rtcNewGeometry: fn(Handle, u32) -> Handle;
    rtcSetSharedGeometryBuffer: fn(Handle, u32, u32, u32, *const c_void, usize, usize, usize);
    rtcSetNewGeometryBuffer: fn(Handle, u32, u32, u32, usize, usize) -> *mut c_void;
    rtcCommitGeometry: fn(Handle);
    rtcAttachGeometry: fn(Handle, Handle) -> u32;
    rtcReleaseGeometry: fn(Handle);
    rtcIntersect1: fn(Handle, *mut RayHit, *mut IntersectArguments);
    rtcOccluded1: fn(Handle, *mut e4::RTCRay, *mut OccludedArguments);
    // Packets: only ever called by the C driver, which fills them.
    rtcIntersect8: fn(*const i32, Handle, *mut c_void, *mut c_void);
    rtcOccluded8: fn(*const i32, Handle, *mut c_void, *mut c_void);
    rtcIntersect16: fn(*const i32, Handle, *mut c_void, *mut c_void);
    rtcOccluded16: fn(*const i32, Handle, *mut c_void, *mut c_void);
}

/// `RTCRayHit` with room for the hit fields 4.3+ appends (`instPrimID`).
#[repr(C, align(16))]
struct RayHit {
    rayhit: e4::RTCRayHit,
    _tail: [u32; 4],
}

/// `RTCIntersectArguments` with room for `minWidthDistanceFactor`.
#[repr(C)]
struct IntersectArguments {
    args: e4::RTCIntersectArguments,
    _tail: [u32; 2],
}

/// `RTCOccludedArguments` with room for `minWidthDistanceFactor`.
#[repr(C)]
struct OccludedArguments {
    args: e4::RTCOccludedArguments,
    _tail: [u32; 2],
}

/// The features hybrid's scenes use: triangles and sphere points. Embree 4's
/// API documentation describes the mask as a way to specialise its SYCL
/// (GPU) traversal kernels at compile time; the CPU kernels hybrid runs
/// always support every feature, so it is set for what it states, not for
/// speed.
const FEATURES: e4::RTCFeatureFlags = e4::RTCFeatureFlags(
    e4::RTCFeatureFlags::RTC_FEATURE_FLAG_TRIANGLE.0
        | e4::RTCFeatureFlags::RTC_FEATURE_FLAG_SPHERE_POINT.0,
);

/// What the inline `rtcInitIntersectArguments` does, with our flags.
fn intersect_arguments(flags: e4::RTCRayQueryFlags) -> IntersectArguments {
    IntersectArguments {
        args: e4::RTCIntersectArguments {
            flags,
            feature_mask: FEATURES,
            context: std::ptr::null_mut(),
            filter: None,
            intersect: None,
        },
        _tail: [0; 2],
    }
}

fn occluded_arguments(flags: e4::RTCRayQueryFlags) -> OccludedArguments {
    OccludedArguments {
        args: e4::RTCOccludedArguments {
            flags,
            feature_mask: FEATURES,
            context: std::ptr::null_mut(),
            filter: None,
            occluded: None,
        },
        _tail: [0; 2],
    }
}

/// Embree 4's functions, loaded once per process.
pub struct Embree4 {
    table: Table,
}

/// The library file's name as the system, Intel's release and Debian 13
/// install it, and as `scripts/setup.sh` links the wheel's copy.
pub const SONAME: &str = "libembree4.so.4";

/// Embree 4 in this process, or why it cannot be loaded.
pub fn api() -> Result<&'static Embree4, String> {
    static API: OnceLock<Result<Embree4, String>> = OnceLock::new();
    API.get_or_init(|| {
        let names = library::candidates("HYBRID_EMBREE4", SONAME, Some(library::EMBREE4_USER_DIR));
        let (lib, path) = library::open(&names).map_err(|e| {
            format!("Embree 4 is not installed ({e}); run `bash scripts/setup.sh` or set HYBRID_EMBREE4 to a libembree4.so.4")
        })?;
        library::check_version(&lib, &path, 4, "rtcForwardIntersect1", "rtcIntersect1M")?;
        // SAFETY: the library is Embree 4 (found by its SONAME or named by
        // the user, and checked by its exports just above); the table's
        // signatures are its headers' with enums as u32 and the structs
        // widened as described above.
        let table =
            unsafe { Table::load(lib) }.map_err(|e| format!("{path} is not Embree 4: {e}"))?;
        Ok(Embree4 { table })
    })
    .as_ref()
    .map_err(Clone::clone)
}

fn make_ray((origin, dir, t_min, t_max): RawRay) -> e4::RTCRay {
    e4::RTCRay {
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

fn make_rayhit(ray: RawRay) -> RayHit {
    RayHit {
        rayhit: e4::RTCRayHit {
            ray: make_ray(ray),
            hit: e4::RTCHit {
                Ng_x: 0.0,
                Ng_y: 0.0,
                Ng_z: 0.0,
                u: 0.0,
                v: 0.0,
                primID: INVALID_GEOMETRY_ID,
                geomID: INVALID_GEOMETRY_ID,
                instID: [INVALID_GEOMETRY_ID; 1],
            },
        },
        _tail: [INVALID_GEOMETRY_ID; 4],
    }
}

fn raw_hit(rh: &RayHit) -> Option<RawHit> {
    let (ray, hit) = (&rh.rayhit.ray, &rh.rayhit.hit);
    (hit.geomID != INVALID_GEOMETRY_ID).then_some(RawHit {
        t: ray.tfar,
        geometry: hit.geomID,
        primitive: hit.primID,
        u: hit.u,
        v: hit.v,
    })
}

// SAFETY: each method calls the Embree 4 function of its name, loaded from
// Embree 4 by `api`, and the values of `value` were checked against
// Embree 4's headers above.
unsafe impl Api for Embree4 {
    unsafe fn new_device(&self, config: *const c_char) -> Handle {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { (self.table.rtcNewDevice)(config) }
    }
    unsafe fn device_error(&self, device: Handle) -> u32 {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { (self.table.rtcGetDeviceError)(device) }
    }
    unsafe fn set_error_function(
        &self,
        device: Handle,
        f: Option<ErrorFunction>,
        user: *mut c_void,
    ) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { (self.table.rtcSetDeviceErrorFunction)(device, f, user) }
    }
    unsafe fn set_memory_monitor(
        &self,
        device: Handle,
        f: Option<MemoryMonitor>,
        user: *mut c_void,
    ) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { (self.table.rtcSetDeviceMemoryMonitorFunction)(device, f, user) }
    }
    unsafe fn device_property(&self, device: Handle, property: u32) -> isize {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { (self.table.rtcGetDeviceProperty)(device, property) }
    }
    unsafe fn release_device(&self, device: Handle) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { (self.table.rtcReleaseDevice)(device) }
    }
    unsafe fn new_scene(&self, device: Handle) -> Handle {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { (self.table.rtcNewScene)(device) }
    }
    unsafe fn set_build_quality(&self, scene: Handle, quality: u32) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { (self.table.rtcSetSceneBuildQuality)(scene, quality) }
    }
    unsafe fn set_scene_flags(&self, scene: Handle, flags: u32) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { (self.table.rtcSetSceneFlags)(scene, flags) }
    }
    unsafe fn commit_scene(&self, scene: Handle) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { (self.table.rtcCommitScene)(scene) }
    }
    unsafe fn release_scene(&self, scene: Handle) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { (self.table.rtcReleaseScene)(scene) }
    }
    unsafe fn new_geometry(&self, device: Handle, kind: u32) -> Handle {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { (self.table.rtcNewGeometry)(device, kind) }
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
            (self.table.rtcSetSharedGeometryBuffer)(
                geometry, kind, 0, format, ptr, offset, stride, count,
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
        unsafe { (self.table.rtcSetNewGeometryBuffer)(geometry, kind, 0, format, stride, count) }
    }
    unsafe fn commit_geometry(&self, geometry: Handle) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { (self.table.rtcCommitGeometry)(geometry) }
    }
    unsafe fn attach_geometry(&self, scene: Handle, geometry: Handle) -> u32 {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { (self.table.rtcAttachGeometry)(scene, geometry) }
    }
    unsafe fn release_geometry(&self, geometry: Handle) {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe { (self.table.rtcReleaseGeometry)(geometry) }
    }

    #[inline(always)]
    unsafe fn intersect1(&self, scene: Handle, ray: RawRay) -> Option<RawHit> {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe {
            let mut rayhit = make_rayhit(ray);
            let mut args = intersect_arguments(e4::RTCRayQueryFlags::INCOHERENT);
            (self.table.rtcIntersect1)(scene, &mut rayhit, &mut args);
            raw_hit(&rayhit)
        }
    }

    #[inline(always)]
    unsafe fn occluded1(&self, scene: Handle, ray: RawRay) -> bool {
        // SAFETY: the `Api` contract: live handles of this library, valid pointers.
        unsafe {
            let mut ray = make_ray(ray);
            let mut args = occluded_arguments(e4::RTCRayQueryFlags::INCOHERENT);
            (self.table.rtcOccluded1)(scene, &mut ray, &mut args);
            // Embree sets tfar to -inf on a hit.
            ray.tfar == f32::NEG_INFINITY
        }
    }

    fn c_functions(&self) -> CFunctions {
        CFunctions {
            version: EmbreeMajor::Four,
            intersect1: self.table.rtcIntersect1 as *const c_void,
            occluded1: self.table.rtcOccluded1 as *const c_void,
            intersect8: self.table.rtcIntersect8 as *const c_void,
            occluded8: self.table.rtcOccluded8 as *const c_void,
            intersect16: self.table.rtcIntersect16 as *const c_void,
            occluded16: self.table.rtcOccluded16 as *const c_void,
            // Embree 4 removed the stream calls.
            intersect1m: std::ptr::null(),
            occluded1m: std::ptr::null(),
        }
    }
}
