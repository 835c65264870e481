#![no_main]
//! Remesh constraint lines and per-face conductivity values.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = rig::remesh_inputs::parse_constraints(bytes);
    let _ = rig::remesh_inputs::parse_face_values(bytes, 16);
});
