//! The inspection outputs (run.rrd, run.mcap, fields.h5, PNG plots): read back here in Rust, and
//! by the reference readers of each format (tests/readers/check_outputs.py), which this test
//! installs from PyPI into target/readers-venv on first use (opt-in: `crate::SYSTEM_TESTS`).

use crate::{readers, root, scratch, waamtwin};
use std::path::{Path, PathBuf};
use std::process::Command;

const DOME: &str = "[part]\nshape = \"hemisphere\"\nradius_mm = 40.0\nedge_mm = 2.5\n[planner]\nn_points = 60\n[thermal]\nplate_mm = [150.0, 150.0, 10.0]\n[output]\nframes = 40\n";

fn run_dome(name: &str, extra: &str) -> PathBuf {
    let dir = scratch(name);
    std::fs::write(dir.join("s.toml"), format!("{DOME}{extra}")).unwrap();
    let out = dir.join("out");
    let o = waamtwin(&[
        "dwell",
        dir.join("s.toml").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--no-baselines",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}

/// RFC 4648 base64, as MCAP's JSON encoding writes `bytes` fields.
fn base64_decode(text: &str) -> Vec<u8> {
    let value = |c: u8| match c {
        b'A'..=b'Z' => c - b'A',
        b'a'..=b'z' => c - b'a' + 26,
        b'0'..=b'9' => c - b'0' + 52,
        b'+' => 62,
        b'/' => 63,
        _ => panic!("not base64: {c}"),
    };
    let digits: Vec<u8> = text.bytes().filter(|&c| c != b'=').map(value).collect();
    let mut out = Vec::with_capacity(digits.len() * 3 / 4);
    for chunk in digits.chunks(4) {
        let n = chunk
            .iter()
            .enumerate()
            .fold(0u32, |acc, (k, &d)| acc | (u32::from(d) << (18 - 6 * k)));
        out.extend(n.to_be_bytes()[1..chunk.len()].iter());
    }
    out
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).unwrap()).unwrap()
}

/// Every value a run wrote for the wall is physical: in every frame of fields.h5 and every
/// `/wall/temperature` cloud of run.mcap, a laid point lies between ambient (20 °C, less 1 K)
/// and the highest peak of any point, and the laid count never falls. (The thin wall's lagged
/// heat capacity once put points of the R 40 dome at −273 °C in three of its 40 frames.)
pub fn assert_physical(out: &Path) {
    let (ph, rows) = crate::read_csv(&out.join("path.csv"));
    let peak_col = ph.iter().position(|c| c == "peak_c").unwrap();
    let peak = rows
        .iter()
        .map(|r| r[peak_col].parse::<f64>().unwrap())
        .fold(f64::NEG_INFINITY, f64::max);
    assert!(peak.is_finite() && peak > 1000.0, "peak {peak} °C");
    let inside = |c: f64| (19.0..=peak + 0.01).contains(&c);

    let h5 = hdf5_pure::File::from_bytes(std::fs::read(out.join("fields.h5")).unwrap()).unwrap();
    let read = |name: &str| h5.dataset(&format!("VTKHDF/{name}")).unwrap();
    let n = read("NumberOfPoints").read_i64().unwrap()[0] as usize;
    let t = read("PointData/temperature_c").read_f32().unwrap();
    let laid = read("PointData/laid").read_u8().unwrap();
    assert_eq!(t.len() % n, 0);
    let mut laid_before = 0;
    for (step, (temps, laid)) in t.chunks(n).zip(laid.chunks(n)).enumerate() {
        let count = laid.iter().filter(|&&l| l == 1).count();
        assert!(
            count >= laid_before,
            "fields.h5 step {step}: {count} laid after {laid_before}"
        );
        laid_before = count;
        for (i, (&c, &l)) in temps.iter().zip(laid).enumerate() {
            assert!(
                l == 0 || inside(c as f64),
                "fields.h5 step {step}, point {i}: {c} °C outside [19, {peak}]"
            );
        }
    }

    let bytes = std::fs::read(out.join("run.mcap")).unwrap();
    let mut cloud_before = 0;
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        if m.channel.topic != "/wall/temperature" {
            continue;
        }
        let v: serde_json::Value = serde_json::from_slice(&m.data).unwrap();
        assert_eq!(v["point_stride"], 16);
        let data = base64_decode(v["data"].as_str().unwrap());
        let points = data.len() / 16;
        assert!(
            points >= cloud_before,
            "run.mcap: {points} points after {cloud_before}"
        );
        cloud_before = points;
        for (i, p) in data.chunks_exact(16).enumerate() {
            let c = f32::from_le_bytes(p[12..16].try_into().unwrap()) as f64;
            assert!(
                inside(c),
                "run.mcap at {} ns, point {i}: {c} °C outside [19, {peak}]",
                m.log_time
            );
        }
    }
    assert!(cloud_before > 0, "no /wall/temperature cloud in run.mcap");
}

/// A small dome on the voxel model, its field kept at 30 times.
const VOXEL_DOME: &str = "[part]\nshape = \"hemisphere\"\nradius_mm = 25.0\nedge_mm = 2.5\n\
    [planner]\nn_points = 48\n[thermal]\nmodel = \"voxel\"\nplate_mm = [90.0, 90.0, 8.0]\n\
    [output]\nplots = false\nframes = 30\n";

/// The same bounds on a voxel run: its field is one temperature per deposit, the mean of its
/// metal.
#[test]
fn voxel_outputs_are_physical() {
    let out = crate::run_scenario("outputs_voxel", "simulate", VOXEL_DOME);
    assert_eq!(json(&out.join("thermal.json"))["model"], "voxel");
    assert_physical(&out);
}

/// The voxel run's files opened by the reference readers of each format.
#[test]
#[cfg_attr(
    not(system_tests),
    ignore = "opt-in, WAAMTWIN_SYSTEM_TESTS=1: the reference readers from PyPI"
)]
fn voxel_outputs_open_in_their_readers() {
    let out = crate::run_scenario("outputs_voxel_readers", "simulate", VOXEL_DOME);
    open_in_readers(&out);
}

#[test]
fn outputs_open_in_their_readers() {
    let out = run_dome("outputs_dome", "");
    let manifest = json(&out.join("manifest.json"));
    let files: Vec<&str> = manifest["files"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| f.as_str().unwrap())
        .collect();
    for f in [
        "run.rrd",
        "run.mcap",
        "fields.h5",
        "preheat.png",
        "deposits.png",
        "temperature_history.png",
        "dwells.png",
    ] {
        assert!(files.contains(&f), "{f} not in the manifest: {files:?}");
        assert!(out.join(f).is_file(), "{f} missing");
    }
    // PNGs are PNGs.
    let png = std::fs::read(out.join("preheat.png")).unwrap();
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");

    // fields.h5 read back by the pure-Rust reader: the probe's temperature.
    let probe = json(&out.join("thermal.json"))["probe"].clone();
    let h5 = hdf5_pure::File::from_bytes(std::fs::read(out.join("fields.h5")).unwrap()).unwrap();
    let n = h5
        .dataset("VTKHDF/NumberOfPoints")
        .unwrap()
        .read_i64()
        .unwrap()[0] as usize;
    let t = h5
        .dataset("VTKHDF/PointData/temperature_c")
        .unwrap()
        .read_f32()
        .unwrap();
    let k =
        probe["frame"].as_u64().unwrap() as usize * n + probe["point"].as_u64().unwrap() as usize;
    let want = probe["temperature_c"].as_f64().unwrap();
    assert!((t[k] as f64 - want).abs() < 1e-3, "{} vs {want}", t[k]);
    assert_physical(&out);

    // run.mcap through the mcap crate's reader: every message in log-time order.
    let bytes = std::fs::read(out.join("run.mcap")).unwrap();
    let mut last = 0;
    let mut topics = std::collections::BTreeSet::new();
    for m in mcap::MessageStream::new(&bytes).unwrap() {
        let m = m.unwrap();
        assert!(m.log_time >= last, "{} out of order", m.channel.topic);
        last = m.log_time;
        serde_json::from_slice::<serde_json::Value>(&m.data).unwrap();
        topics.insert(m.channel.topic.clone());
    }
    assert!(
        topics.contains("/wall/temperature") && topics.contains("/tf"),
        "{topics:?}"
    );

    // report.html: the verdict, and every plot inlined.
    let report = std::fs::read_to_string(out.join("report.html")).unwrap();
    assert!(report.contains("id=\"verdict\""), "no verdict");
    // Every point is judged, none exempt: the dome's closing zone, where no dwell can help, is
    // laid as drops, and the verdict is safe and says how.
    assert!(report.contains("Safe: "), "the verdict");
    assert!(report.contains("is laid as") && report.contains("drops, each struck after a wait"));
    let pngs = [
        "preheat.png",
        "deposits.png",
        "temperature_history.png",
        "dwells.png",
    ];
    assert_eq!(
        report.matches("src=\"data:image/png;base64,").count(),
        pngs.len()
    );
    assert!(files.contains(&"report.html"));

    // And by the reference readers (where they can be installed: the voxel test above shows
    // as ignored where they cannot).
    #[cfg(system_tests)]
    open_in_readers(&out);
}

/// The reference readers of each format (tests/readers/check_outputs.py) open the run's files,
/// and every value run.rrd shows for the wall is physical. Opt-in (the callers' `system_tests`
/// cfg): it installs the readers from PyPI.
pub fn open_in_readers(out: &Path) {
    let venv = readers();
    let check = Command::new(venv.join("bin/python"))
        .arg(root().join("tests/readers/check_outputs.py"))
        .arg(out)
        .arg(venv.join("bin/rerun"))
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&check.stdout);
    eprintln!("{text}{}", String::from_utf8_lossy(&check.stderr));
    assert!(check.status.success(), "reference readers failed:\n{text}");
}

#[test]
fn each_sink_switches_off() {
    let out = run_dome(
        "outputs_off",
        "rerun = false\nmcap = false\nhdf5 = false\nplots = false\n",
    );
    for f in ["run.rrd", "run.mcap", "fields.h5", "preheat.png"] {
        assert!(!out.join(f).exists(), "{f} written though switched off");
    }
    assert!(out.join("thermal.json").is_file());
}

/// report.html as a person opens it: headless Chromium (Debian's package, installed by
/// tests/chromium/install.sh) renders it, every inlined plot decodes (the page's own check), and
/// a screenshot is taken. Opt-in (`crate::SYSTEM_TESTS`): it installs a browser as root.
#[test]
#[cfg_attr(
    not(system_tests),
    ignore = "opt-in, WAAMTWIN_SYSTEM_TESTS=1: installs Chromium as root"
)]
fn report_renders_in_a_browser() {
    let install = Command::new("bash")
        .arg(root().join("tests/chromium/install.sh"))
        .output()
        .unwrap();
    assert!(
        install.status.success(),
        "Chromium did not install: {}",
        String::from_utf8_lossy(&install.stderr)
    );
    let browser = String::from_utf8_lossy(&install.stdout).trim().to_string();
    let out = run_dome("report_dome", "");
    let page = format!("file://{}", out.join("report.html").display());
    let profile = out.parent().unwrap().join("chromium-profile");
    let chromium = |extra: &[&str]| {
        Command::new(&browser)
            .args([
                "--headless",
                "--no-sandbox",
                "--disable-gpu",
                "--no-first-run",
                "--disable-background-networking",
                "--disable-component-update",
                "--disable-sync",
                "--virtual-time-budget=5000",
            ])
            .arg(format!("--user-data-dir={}", profile.display()))
            .args(extra)
            .arg(&page)
            .output()
            .unwrap()
    };
    let dom = chromium(&["--dump-dom"]);
    let text = String::from_utf8_lossy(&dom.stdout);
    assert!(
        text.contains("data-images=\"ok\""),
        "the plots did not all decode: {}",
        String::from_utf8_lossy(&dom.stderr)
    );
    let shot = out.parent().unwrap().join("report.png");
    let _ = std::fs::remove_file(&shot);
    let s = chromium(&[
        &format!("--screenshot={}", shot.display()),
        "--window-size=1100,2600",
    ]);
    let png = std::fs::read(&shot).unwrap_or_else(|e| {
        panic!(
            "no screenshot ({e}): {}",
            String::from_utf8_lossy(&s.stderr)
        )
    });
    assert_eq!(&png[..8], b"\x89PNG\r\n\x1a\n");
    // A page of four plots is far from blank: a blank 1100 × 2600 page compresses to a few kB.
    assert!(png.len() > 100_000, "screenshot of {} bytes", png.len());
}

/// A plan whose points ask for deposits outside the process window away from its closing zone
/// is said on stderr and in thermal.json (`plan_infeasible`): the R 8 quarter torus, whose
/// layers cross its converging generators (docs/PHYSICS.md "Eq.6 on a bent tube"). An R 20
/// hemisphere, whose two violations lie in its closing zone (as a closed part's last
/// revolutions have them), is not.
#[test]
fn a_plan_outside_the_window_away_from_its_closing_zone_is_said() {
    let off = "[output]\nrerun = false\nmcap = false\nhdf5 = false\nplots = false\n";
    let run = |name: &str, part: &str| {
        let dir = scratch(name);
        std::fs::write(dir.join("s.toml"), format!("{part}{off}")).unwrap();
        let out = dir.join("out");
        let o = waamtwin(&[
            "simulate",
            dir.join("s.toml").to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ]);
        let err = String::from_utf8_lossy(&o.stderr).to_string();
        assert!(o.status.success(), "{err}");
        let kinds: Vec<String> = json(&out.join("thermal.json"))["warnings"]
            .as_array()
            .unwrap()
            .iter()
            .map(|w| w["kind"].as_str().unwrap().to_string())
            .collect();
        let violations = json(&out.join("plan.json"))["violations_total"]
            .as_u64()
            .unwrap();
        (err, kinds, violations)
    };
    let torus = "[part]\nshape = \"quarter_torus\"\nbend_radius_mm = 100.0\n\
                 tube_radius_mm = 8.0\nedge_mm = 1.0\n";
    let (err, kinds, violations) = run("plan_infeasible_torus", torus);
    assert_eq!(kinds, ["plan_infeasible"]);
    let said = format!("warning: the plan is not feasible (CTPP Eq.6): {violations} of its");
    assert!(err.contains(&said), "{err}");
    let dome = "[part]\nshape = \"hemisphere\"\nradius_mm = 20.0\nedge_mm = 2.5\n\
                [planner]\nn_points = 40\n";
    let (err, kinds, violations) = run("plan_infeasible_dome", dome);
    assert!(violations > 0, "no violation to keep quiet about");
    assert!(kinds.is_empty(), "{kinds:?}");
    assert!(!err.contains("not feasible"), "{err}");
}
