#![no_main]
//! Simulator configuration TOML.

use libfuzzer_sys::fuzz_target;

fuzz_target!(|bytes: &[u8]| {
    if let Ok(text) = std::str::from_utf8(bytes) {
        let _ = sim::SimConfig::from_toml_str(text);
    }
});
