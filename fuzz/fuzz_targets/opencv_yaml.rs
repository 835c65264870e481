#![no_main]
//! OpenCV camera YAML (its own small YAML subset).

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = rig::opencv_yaml::parse(bytes);
    let _ = rig::opencv_yaml::camera_from_bytes(bytes);
});
