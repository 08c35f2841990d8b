//! Replay TOML: any text gives a checked replay scenario or one input error.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = sim::scenario::replay::ReplayScenario::parse(
            text,
            "fuzz.toml",
            std::path::Path::new("/nonexistent"),
        );
    }
});
