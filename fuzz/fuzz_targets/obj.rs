#![no_main]
//! Wavefront OBJ.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = rig::obj::parse(bytes);
});
