#![no_main]
//! JPEG camera frames (zune-jpeg under our truncation check).

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = rig::image::decode_jpeg(bytes);
});
