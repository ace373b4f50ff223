//! Stands in for `sys3.rs` when the build found no Embree 3 headers
//! (`build.rs`): the type exists so that the backend union is the same on
//! every build, but no value of it can, and asking for it says why.

use std::ffi::{c_char, c_void};

use super::ffi::{Api, ErrorFunction, Handle, MemoryMonitor, RawRay};
use super::library::RawHit;
use super::plain_c::CFunctions;

/// Embree 3, absent from this build: an empty type, never constructed.
pub enum Embree3 {}

pub fn api() -> Result<&'static Embree3, String> {
    Err("this hybrid was built without Embree 3 (no /usr/include/embree3 at build time); install libembree-dev (Debian 12) and rebuild".into())
}

// SAFETY: no value of `Embree3` exists, so no method can be called.
#[allow(clippy::too_many_arguments)]
unsafe impl Api for Embree3 {
    unsafe fn new_device(&self, _: *const c_char) -> Handle {
        match *self {}
    }
    unsafe fn device_error(&self, _: Handle) -> u32 {
        match *self {}
    }
    unsafe fn set_error_function(&self, _: Handle, _: Option<ErrorFunction>, _: *mut c_void) {
        match *self {}
    }
    unsafe fn set_memory_monitor(&self, _: Handle, _: Option<MemoryMonitor>, _: *mut c_void) {
        match *self {}
    }
    unsafe fn device_property(&self, _: Handle, _: u32) -> isize {
        match *self {}
    }
    unsafe fn release_device(&self, _: Handle) {
        match *self {}
    }
    unsafe fn new_scene(&self, _: Handle) -> Handle {
        match *self {}
    }
    unsafe fn set_build_quality(&self, _: Handle, _: u32) {
        match *self {}
    }
    unsafe fn set_scene_flags(&self, _: Handle, _: u32) {
        match *self {}
    }
    unsafe fn commit_scene(&self, _: Handle) {
        match *self {}
    }
    unsafe fn release_scene(&self, _: Handle) {
        match *self {}
    }
    unsafe fn new_geometry(&self, _: Handle, _: u32) -> Handle {
        match *self {}
    }
    unsafe fn set_shared_buffer(
        &self,
        _: Handle,
        _: u32,
        _: u32,
        _: *const c_void,
        _: usize,
        _: usize,
        _: usize,
    ) {
        match *self {}
    }
    unsafe fn set_new_buffer(&self, _: Handle, _: u32, _: u32, _: usize, _: usize) -> *mut c_void {
        match *self {}
    }
    unsafe fn commit_geometry(&self, _: Handle) {
        match *self {}
    }
    unsafe fn attach_geometry(&self, _: Handle, _: Handle) -> u32 {
        match *self {}
    }
    unsafe fn release_geometry(&self, _: Handle) {
        match *self {}
    }
    unsafe fn intersect1(&self, _: Handle, _: RawRay) -> Option<RawHit> {
        match *self {}
    }
    unsafe fn occluded1(&self, _: Handle, _: RawRay) -> bool {
        match *self {}
    }
    unsafe fn intersect_coherent(&self, _: Handle, _: &[RawRay], _: &mut Vec<Option<RawHit>>) {
        match *self {}
    }
    fn c_functions(&self) -> CFunctions {
        match *self {}
    }
}
