//! Which opt-in tests can run here, decided when the tests are compiled, so that a test that
//! cannot run shows as ignored with its reason, never as passed (`cargo test` lists it):
//!
//! - `system_tests`: `WAAMTWIN_SYSTEM_TESTS=1`, the tests that bring up outside programs
//!   (PyPI's readers and the Python package, Slurm, Chromium, an OPC UA server, rerun);
//! - `validation_data`: the measured builds are here (`WAAMTWIN_DATA`, else
//!   `../shared/validation-data` beside the checkout).

use std::path::PathBuf;

fn main() {
    println!("cargo::rustc-check-cfg=cfg(system_tests)");
    println!("cargo::rustc-check-cfg=cfg(validation_data)");
    println!("cargo::rerun-if-env-changed=WAAMTWIN_SYSTEM_TESTS");
    println!("cargo::rerun-if-env-changed=WAAMTWIN_DATA");
    if std::env::var("WAAMTWIN_SYSTEM_TESTS").as_deref() == Ok("1") {
        println!("cargo::rustc-cfg=system_tests");
    }
    let manifest = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").unwrap_or_default());
    let data = std::env::var_os("WAAMTWIN_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| manifest.join("../../shared/validation-data"));
    if data.is_dir() {
        println!("cargo::rustc-cfg=validation_data");
    }
    // The tests read the data where this found it.
    println!("cargo::rustc-env=WAAMTWIN_TEST_DATA={}", data.display());
}
