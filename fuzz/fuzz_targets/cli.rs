//! Arbitrary command lines: parsed and checked as `hybrid` does before any
//! work (a render's settings, a series' tiles and output names, an
//! export's memory and folder), one error or a valid plan, never a panic.
#![no_main]

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else {
        return;
    };
    let args: Vec<String> = text.split('\0').map(str::to_string).collect();
    let _ = hybrid::cli::check_command_line(&args);
});
