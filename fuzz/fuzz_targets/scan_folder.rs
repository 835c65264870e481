#![no_main]
//! The scan manifest (scan.json) and its progress journal.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    let _ = rig::Manifest::from_json(bytes);
    let _ = rig::scan_folder::parse_progress(bytes, 64);
});
