//! The probe (thermocouple) reader and the property-table reader.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let _ = sim::measured::probes::series(text, "fuzz.csv", 0, &[1, 2]);
        let _ = sim::measured::table::rows(text, "fuzz.csv");
    }
});
