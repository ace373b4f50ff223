//! The COLLADA loader on arbitrary text: it must return a scene or one
//! error, never panic, overflow its stack or allocate from a count.
#![no_main]

use hybrid::scene::{collada, NormalMode};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = collada::load_str(text, "fuzz.dae", NormalMode::Smooth);
    }
});
