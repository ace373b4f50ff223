//! The course's camera settings file on arbitrary text: a camera or one
//! error, never a panic.
#![no_main]

use hybrid::render::camera_file::CourseCamera;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = CourseCamera::parse(text, "fuzz.cam");
    }
});
