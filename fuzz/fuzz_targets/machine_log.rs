//! The machine-log reader (a logger's CSV), with its default columns.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let c = sim::measured::machine_log::Columns::default();
        let _ = sim::measured::machine_log::waypoints(text, "fuzz.csv", &c);
    }
});
