//! The Python package (`python/`): installed from the checkout into a virtual environment
//! with pip (maturin and numpy come from PyPI), then its own tests run against the binary of
//! the same build (`python/tests/test_waamtwin.py`: the same plan to the byte, the GIL let go,
//! progress, errors, Ctrl-C). Opt-in ([`crate::SYSTEM_TESTS`]): it reaches PyPI.

use crate::root;
use std::path::Path;
use std::process::Command;

#[test]
#[cfg_attr(
    not(system_tests),
    ignore = "opt-in, WAAMTWIN_SYSTEM_TESTS=1: maturin and numpy from PyPI"
)]
fn the_package_passes_its_tests() {
    let target = Path::new(env!("CARGO_TARGET_TMPDIR")).parent().unwrap();
    let venv = target.join("python-venv");
    let ok = |c: &mut Command| c.status().is_ok_and(|s| s.success());
    assert!(ok(Command::new("python3").args(["-m", "venv"]).arg(&venv)));
    // The README's install command, into this build's target folder so that the engine's
    // crates are compiled once.
    assert!(
        ok(Command::new(venv.join("bin/pip"))
            .args([
                "install",
                "--quiet",
                "--disable-pip-version-check",
                "./python"
            ])
            .env("CARGO_TARGET_DIR", target)
            .current_dir(root())),
        "pip install ./python failed"
    );
    let out = Command::new(venv.join("bin/python"))
        .args(["-m", "unittest", "-v", "python/tests/test_waamtwin.py"])
        .env("WAAMTWIN_BIN", env!("CARGO_BIN_EXE_waamtwin"))
        .current_dir(root())
        .output()
        .expect("run python");
    let said = String::from_utf8_lossy(&out.stderr);
    eprintln!("{said}");
    assert!(out.status.success(), "the package's tests failed:\n{said}");
    assert!(said.contains("Ran 5 tests"), "{said}");
}
