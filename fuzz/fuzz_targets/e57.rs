#![no_main]
//! E57.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = rig::e57::parse(bytes);
});
