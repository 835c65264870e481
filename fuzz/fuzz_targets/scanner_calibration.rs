#![no_main]
//! Other scanners' calibration files: FabScanPi's config.json and Horus' settings.json.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    if let Ok(text) = std::str::from_utf8(bytes) {
        let _ = rig::scanner_calibration::rig_from_fabscan(text);
        let _ = rig::scanner_calibration::rig_from_horus(text);
    }
});
