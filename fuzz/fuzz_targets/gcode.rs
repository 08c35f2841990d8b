//! The G-code reader (G0/G1/G4 and a dialect's arc codes).
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        let d = sim::measured::gcode::Dialect {
            arc_on: "M101".into(),
            arc_off: "M103".into(),
            feed_scale: 1.0 / 60.0,
            travel_mm_s: None,
        };
        let _ = sim::measured::gcode::waypoints(text, "fuzz.gcode", &d);
    }
});
