#![no_main]
//! NumPy .npy arrays.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = rig::npy::parse(bytes);
});
