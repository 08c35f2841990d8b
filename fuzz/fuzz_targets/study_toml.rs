//! Study TOML: any text gives a checked study (every case a scenario) or one input error, never
//! a panic, and never a product of sweeps past `MAX_CASES` built. The base scenario is a real
//! file, written once.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::PathBuf;
use std::sync::OnceLock;

fn dir() -> &'static PathBuf {
    static DIR: OnceLock<PathBuf> = OnceLock::new();
    DIR.get_or_init(|| {
        let d = std::env::temp_dir().join(format!("waamtwin-fuzz-study-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(
            d.join("base.toml"),
            "[part]\nshape = \"cylinder\"\nradius_mm = 25.0\nheight_mm = 14.0\n",
        )
        .unwrap();
        d
    })
}

fuzz_target!(|data: &[u8]| {
    if let Ok(text) = std::str::from_utf8(data) {
        if let Ok(study) = sim::commands::study::parse(text, "fuzz.toml", dir()) {
            assert!(study.cases.len() <= sim::commands::study::MAX_CASES);
        }
    }
});
