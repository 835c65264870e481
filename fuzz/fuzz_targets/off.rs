#![no_main]
//! OFF.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = rig::off::parse(bytes);
});
