//! Scenario TOML: any text gives a checked scenario or one input error, never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ =
            sim::scenario::Scenario::parse(text, "fuzz.toml", std::path::Path::new("/nonexistent"));
    }
});
