//! End-to-end tests: the `waamtwin` binary on scenarios and meshes, one module per area.

mod bead;
mod calibration;
mod cli;
mod ctpp;
mod determinism;
mod dwell;
mod export;
mod family;
mod follow;
mod follow_opcua;
mod inspect;
mod outputs;
mod python;
mod replay;
mod resume;
mod scenarios;
mod skeleton;
mod study;
mod thermal;

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// The workspace root (this file is `tests/e2e/main.rs`).
pub fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR"))
        .parent()
        .unwrap()
        .to_path_buf()
}

pub fn waamtwin(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_waamtwin"))
        .args(args)
        .current_dir(root())
        .output()
        .expect("run waamtwin")
}

/// `waamtwin ARGS` as [`waamtwin`], killed past `limit`: a refusal that regresses into a run
/// (weeks of cooling) fails the test instead of hanging it. stdout and stderr go to files, so
/// that a long run cannot fill a pipe while it is waited on.
pub fn waamtwin_within(args: &[&str], limit: std::time::Duration) -> Output {
    static CALLS: std::sync::atomic::AtomicUsize = std::sync::atomic::AtomicUsize::new(0);
    let call = CALLS.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
    let dir = scratch(&format!("within_{call}"));
    let out_file = |name: &str| std::fs::File::create(dir.join(name)).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_waamtwin"))
        .args(args)
        .current_dir(root())
        .stdout(out_file("stdout"))
        .stderr(out_file("stderr"))
        .spawn()
        .expect("run waamtwin");
    let start = std::time::Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait().unwrap() {
            break status;
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let _ = child.wait();
            panic!("waamtwin {args:?} still running after {limit:?}");
        }
        std::thread::sleep(std::time::Duration::from_millis(50));
    };
    let read = |name: &str| std::fs::read(dir.join(name)).unwrap();
    Output {
        status,
        stdout: read("stdout"),
        stderr: read("stderr"),
    }
}

/// The tests that bring up outside programs (the reference readers and the Python package from
/// PyPI, a real single-node Slurm and Chromium installed as root, an OPC UA server, rerun) are
/// compiled as ignored, with their reason, unless this variable was 1 when they were built
/// (`sim/build.rs` sets the `system_tests` cfg). `.ci/run` sets it; a plain `cargo test` touches
/// nothing outside the checkout and `target/`, and lists them as ignored.
pub const SYSTEM_TESTS: &str = "WAAMTWIN_SYSTEM_TESTS";

/// The measured builds (the ORNL pad, the GAMMA wall): the folder `sim/build.rs` found when
/// the tests were built, `WAAMTWIN_DATA` or `../shared/validation-data` beside the checkout.
/// The tests that read it are ignored, with that reason, where it was absent
/// (`validation_data` cfg); where it was there, a file missing from it fails them.
pub fn data() -> PathBuf {
    PathBuf::from(env!("WAAMTWIN_TEST_DATA"))
}

/// A virtual environment with the pinned readers, made once per target directory.
pub fn readers() -> PathBuf {
    // Tests run in parallel: one installs, the others wait for it.
    static INSTALL: std::sync::Mutex<()> = std::sync::Mutex::new(());
    let _one = INSTALL.lock().unwrap_or_else(|e| e.into_inner());
    let venv = Path::new(env!("CARGO_TARGET_TMPDIR"))
        .parent()
        .unwrap()
        .join("readers-venv");
    let requirements = root().join("tests/readers/requirements.txt");
    let wanted = std::fs::read_to_string(&requirements).unwrap();
    let marker = venv.join("installed-requirements.txt");
    if std::fs::read_to_string(&marker).ok().as_deref() != Some(wanted.as_str()) {
        let ok = |c: &mut Command| c.status().is_ok_and(|s| s.success());
        assert!(
            ok(Command::new("python3").args(["-m", "venv"]).arg(&venv)),
            "python3 -m venv {} failed",
            venv.display()
        );
        assert!(
            ok(Command::new(venv.join("bin/pip"))
                .args(["install", "--quiet", "--disable-pip-version-check", "-r"])
                .arg(&requirements)),
            "pip install -r {} failed (the readers come from PyPI)",
            requirements.display()
        );
        std::fs::write(&marker, wanted).unwrap();
    }
    venv
}

/// A fresh scratch folder under the target directory.
pub fn scratch(name: &str) -> PathBuf {
    let d = Path::new(env!("CARGO_TARGET_TMPDIR")).join(name);
    let _ = std::fs::remove_dir_all(&d);
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Asserts a bad-input failure: exit 2, one line on stderr containing every `needle`, no panic.
pub fn assert_input_error(out: &Output, needles: &[&str]) {
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "expected exit 2, stderr: {err}");
    assert!(!err.contains("panicked"), "panic: {err}");
    assert_eq!(
        err.trim_end().lines().count(),
        1,
        "one line expected: {err}"
    );
    for n in needles {
        assert!(err.contains(n), "stderr lacks {n:?}: {err}");
    }
}

/// A CSV file's header and rows, split on commas.
pub fn read_csv(path: &Path) -> (Vec<String>, Vec<Vec<String>>) {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let mut lines = text.lines();
    let header = lines
        .next()
        .unwrap_or_default()
        .split(',')
        .map(String::from)
        .collect();
    (
        header,
        lines
            .map(|l| l.split(',').map(String::from).collect())
            .collect(),
    )
}

/// Write `scenario` as `s.toml` in a fresh folder, run `waamtwin COMMAND s.toml -o out`, insist
/// that it succeeds, and return the output folder.
pub fn run_scenario(name: &str, command: &str, scenario: &str) -> PathBuf {
    let dir = scratch(name);
    std::fs::write(dir.join("s.toml"), scenario).unwrap();
    let out = waamtwin(&[
        command,
        dir.join("s.toml").to_str().unwrap(),
        "-o",
        dir.join("out").to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    dir.join("out")
}

/// A closed cap with two humps: its level sets split into two loops near the top (a
/// multi-branch part).
pub fn two_humps() -> planner::mesh::TriMesh {
    let mut m = planner::shapes::Shape::Disk { radius_mm: 60.0 }.mesh(2.0);
    m.map_positions(|p| {
        let bump = |cx: f64| (-((p.x - cx).powi(2) + p.y * p.y) / 300.0).exp();
        let rim = 1.0 - (p.x * p.x + p.y * p.y) / 3600.0;
        planner::nalgebra::Point3::new(
            p.x,
            p.y,
            60.0 * (bump(-25.0) + bump(25.0)) * rim + 20.0 * rim,
        )
    });
    m
}

/// JSON with the wall-clock fields taken out: keys naming `wall_s`, and the search cost, a
/// ratio of two wall-clock times.
pub fn without_clock(v: &mut serde_json::Value) {
    if let Some(m) = v.as_object_mut() {
        m.retain(|k, _| !k.contains("wall_s") && k != "search_cost_in_builds");
        m.values_mut().for_each(without_clock);
    }
}

/// run.mcap's messages in order (topic, log time, payload): its summary section lists schemas
/// and channels in the writer's hash order, which changes from process to process.
pub fn mcap_messages(path: &Path) -> Vec<(String, u64, Vec<u8>)> {
    let bytes = std::fs::read(path).unwrap();
    mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| {
            let m = m.unwrap();
            (m.channel.topic.clone(), m.log_time, m.data.into_owned())
        })
        .collect()
}

/// Every file of run directory `one` is in `two` with the same content, wall-clock fields
/// aside (the manifest, a rerun recording's ids and times, JSON keys naming `wall_s`, run.mcap's
/// summary order); the file names compared.
pub fn assert_same_outputs(one: &Path, two: &Path, how: &str) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(one)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    for name in &names {
        let (a, b) = (one.join(name), two.join(name));
        match name.as_str() {
            // The manifest is a record of the run itself: its id, start and duration.
            "manifest.json" => {}
            // A rerun recording carries a random recording id and wall-clock times.
            "run.rrd" => assert!(b.is_file()),
            "run.mcap" => assert_eq!(mcap_messages(&a), mcap_messages(&b), "{name} {how}"),
            n if n.ends_with(".json") => {
                let read = |p: &Path| {
                    let mut v: serde_json::Value =
                        serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap();
                    without_clock(&mut v);
                    v
                };
                assert_eq!(read(&a), read(&b), "{name} {how}");
            }
            _ => assert!(
                std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(),
                "{name} differs {how}"
            ),
        }
    }
    names
}
