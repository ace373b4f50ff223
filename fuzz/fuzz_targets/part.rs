//! Merge parts from arbitrary bytes (EXR headers, the `hybrid.part`
//! attribute, the channels): a part or one error, and a merge of what reads
//! back that neither panics nor allocates past the limit.
#![no_main]

use hybrid::render::part::{merge, read_part_bytes};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(part) = read_part_bytes(data) {
        let _ = merge(&[part], &["fuzz.exr".to_string()]);
    }
});
