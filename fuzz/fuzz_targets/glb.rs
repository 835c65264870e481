#![no_main]
//! GLB.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = rig::glb::parse(bytes);
});
