//! Environment maps from arbitrary bytes: a map (with its sampling tables)
//! or one error, never a panic or an allocation sized from a header.
#![no_main]

use hybrid::scene::environment::Environment;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // The loader reads files (it checks they are regular first).
    let path = std::env::temp_dir().join(format!("hybrid-fuzz-map-{}.exr", std::process::id()));
    if std::fs::write(&path, data).is_ok() {
        let _ = Environment::load(&path);
    }
});
