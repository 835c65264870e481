#![no_main]
//! PNG camera frames.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = rig::image::decode_png(bytes);
});
