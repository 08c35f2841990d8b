//! The Python package (`python/`): installed from the checkout into a virtual environment
//! with pip (maturin and numpy come from PyPI), then its own tests run against the binary of
//! the same build (`python/tests/test_waamtwin.py`: the same plan to the byte, the GIL let go,
//! progress, errors, Ctrl-C), and the example notebooks are executed as a reader would
//! (`examples/run.py`: nbclient, a fresh kernel each), their own checks holding and their plots
//! written. Opt-in ([`crate::SYSTEM_TESTS`]): it reaches PyPI.

use crate::{root, scratch};
use std::path::Path;
use std::process::{Command, ExitStatus};

/// `program` under coreutils' `timeout`: ended after `seconds` (and killed 10 s later).
fn bounded(seconds: u32, program: &Path) -> Command {
    let mut c = Command::new("timeout");
    c.args(["--kill-after=10", &seconds.to_string()])
        .arg(program);
    c
}

/// `c` without the variables `cargo test` sets for this crate's test binary (CARGO_MANIFEST_DIR,
/// CARGO_PKG_NAME, …). The pip install below runs cargo again in the same target folder, and
/// `ring`'s build script reads those names through `rerun-if-env-changed`: seen with this
/// crate's values there, they made `ring` and the 20 crates above it (rustls, tonic, rerun's)
/// stale, built again for some 250 s of the test's time (and once more by the workspace's
/// next build outside the test). Variables that configure cargo itself (CARGO_HOME,
/// CARGO_NET_*, …) are kept.
fn without_this_crates_cargo_vars(c: &mut Command) -> &mut Command {
    for (name, _) in std::env::vars_os() {
        let Some(name) = name.to_str() else { continue };
        let per_crate = matches!(
            name,
            "CARGO_MANIFEST_DIR"
                | "CARGO_MANIFEST_PATH"
                | "CARGO_MANIFEST_LINKS"
                | "CARGO_CRATE_NAME"
                | "CARGO_BIN_NAME"
                | "CARGO_PRIMARY_PACKAGE"
                | "CARGO_TARGET_TMPDIR"
                | "OUT_DIR"
        ) || name.starts_with("CARGO_PKG_")
            || name.starts_with("CARGO_CFG_");
        if per_crate {
            c.env_remove(name);
        }
    }
    c
}

/// What a run ended by `bounded`'s limit says of it.
fn timed_out(status: &ExitStatus) -> &'static str {
    match status.code() {
        Some(124) | Some(137) => " (timed out)",
        _ => "",
    }
}

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
        ok(
            without_this_crates_cargo_vars(&mut Command::new(venv.join("bin/pip")))
                .args([
                    "install",
                    "--quiet",
                    "--disable-pip-version-check",
                    "./python"
                ])
                .env("CARGO_TARGET_DIR", target)
                .current_dir(root())
        ),
        "pip install ./python failed"
    );
    // Bounded: a run that hangs (a lost Ctrl-C once left `follow` waiting for data) fails
    // here rather than holding CI to its limit. They take about 16 s alone.
    let out = bounded(600, &venv.join("bin/python"))
        .args(["-m", "unittest", "-v", "python/tests/test_waamtwin.py"])
        .env("WAAMTWIN_BIN", env!("CARGO_BIN_EXE_waamtwin"))
        .current_dir(root())
        .output()
        .expect("run python");
    let said = String::from_utf8_lossy(&out.stderr);
    eprintln!("{said}");
    assert!(
        out.status.success(),
        "the package's tests failed{}:\n{said}",
        timed_out(&out.status)
    );
    assert!(said.contains("Ran 8 tests"), "{said}");

    // The notebooks: the GAMMA wall calibrated (it reads the measured builds) and a dome
    // dwelled. Each asserts what it shows; a failing cell fails run.py.
    assert!(
        ok(Command::new(venv.join("bin/pip"))
            .args(["install", "--quiet", "--disable-pip-version-check", "-r"])
            .arg(root().join("examples/requirements.txt"))),
        "pip install -r examples/requirements.txt failed"
    );
    let out = scratch("notebooks");
    let run = bounded(1200, &venv.join("bin/python"))
        .arg(root().join("examples/run.py"))
        .arg(&out)
        .env("WAAMTWIN_DATA", crate::data())
        .current_dir(root())
        .output()
        .expect("run the notebooks");
    let said =
        String::from_utf8_lossy(&run.stdout).to_string() + &String::from_utf8_lossy(&run.stderr);
    assert!(
        run.status.success(),
        "the notebooks failed{}:\n{said}",
        timed_out(&run.status)
    );
    for (notebook, plot) in [
        ("gamma_wall_calibrated.ipynb", "gamma_calibrated.png"),
        ("dome_planned_and_dwelled.ipynb", "dome_dwelled.png"),
    ] {
        let text = std::fs::read_to_string(out.join(notebook)).unwrap();
        assert!(
            !text.contains("\"output_type\": \"error\""),
            "{notebook} shows an error"
        );
        let png = std::fs::read(out.join(plot)).unwrap();
        assert!(
            png.starts_with(b"\x89PNG") && png.len() > 20_000,
            "{plot}: {} bytes",
            png.len()
        );
    }
}
