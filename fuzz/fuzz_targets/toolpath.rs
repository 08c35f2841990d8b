//! The toolpath event-series reader.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = sim::measured::toolpath::event_series(text, "fuzz.csv");
    }
});
