#![no_main]
//! STL.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = rig::stl::parse(bytes);
});
