//! `[calibration] file` in a part's scenario (issue 29, item 1): `simulate` runs at the
//! calibrated values, manifest.json says what was carried and what not, and a study case keeps
//! the values it sets itself.

use crate::{root, scratch, waamtwin};
use std::path::Path;

const PART: &str = "[part]\nshape = \"cylinder\"\nradius_mm = 25.0\nheight_mm = 14.0\nedge_mm = 2.5\n\
    [planner]\nn_points = 40\n[thermal]\nplate_mm = [100.0, 100.0, 8.0]\n\
    [output]\nrerun = false\nmcap = false\nhdf5 = false\nreport = false\nplots = false\n";

/// What `calibrate` writes, cut to what a scenario reads: an arc's efficiency, a convection,
/// and a name this waamtwin does not know.
const CALIBRATION: &str = r#"{"parameters": [
    {"name": "efficiency", "value": 0.5, "low": 0.2, "high": 0.95, "ci95": [0.45, 0.55]},
    {"name": "convection_w_m2k", "value": 40.0, "low": 5.0, "high": 150.0, "ci95": [30.0, 50.0]},
    {"name": "wire_stickout_mm", "value": 12.0, "low": 5.0, "high": 20.0}],
  "covariance": [[0.0006, -0.05, 0.0], [-0.05, 26.0, 0.0], [0.0, 0.0, 1.0]],
  "heat_source": "arc"}"#;

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn simulate(dir: &Path, name: &str, scenario: &str) -> (serde_json::Value, serde_json::Value) {
    std::fs::write(dir.join(format!("{name}.toml")), scenario).unwrap();
    let out = dir.join(name);
    let o = waamtwin(&[
        "simulate",
        dir.join(format!("{name}.toml")).to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    (
        json(&out.join("thermal.json")),
        json(&out.join("manifest.json")),
    )
}

#[test]
fn simulate_runs_at_the_calibrated_values() {
    let dir = scratch("calibration_simulate");
    std::fs::write(dir.join("calibration.json"), CALIBRATION).unwrap();
    let (plain, _) = simulate(&dir, "plain", PART);
    let (cal, manifest) = simulate(
        &dir,
        "calibrated",
        &format!("{PART}[calibration]\nfile = \"calibration.json\"\n"),
    );
    // The same run as the values written into the scenario by hand, to the bit.
    let by_hand = PART.replace("[thermal]\n", "[thermal]\nconvection_w_m2k = 40.0\n");
    let (hand, _) = simulate(
        &dir,
        "by_hand",
        &format!("{by_hand}[process]\nefficiency = 0.5\n"),
    );
    for key in [
        "energy_in_j",
        "energy_lost_j",
        "max_preheat_c",
        "risky_revolutions",
    ] {
        assert_eq!(cal[key], hand[key], "{key}");
    }
    // And not the scenario's own: less heat in (η 0.5 against the default 0.85), cooler.
    assert!(cal["energy_in_j"].as_f64() < plain["energy_in_j"].as_f64());
    assert!(cal["max_preheat_c"].as_f64() < plain["max_preheat_c"].as_f64());
    let c = &manifest["scenario"]["calibration"];
    assert_eq!(manifest["scenario"]["process"]["efficiency"], 0.5);
    assert_eq!(manifest["scenario"]["thermal"]["convection_w_m2k"], 40.0);
    let applied: Vec<(&str, f64)> = c["applied"]
        .as_array()
        .unwrap()
        .iter()
        .map(|a| {
            (
                a["name"].as_str().unwrap(),
                a["scenario_value"].as_f64().unwrap(),
            )
        })
        .collect();
    assert_eq!(applied, [("efficiency", 0.85), ("convection_w_m2k", 15.0)]);
    let unused = c["calibration_unused"].as_array().unwrap();
    assert_eq!(unused.len(), 1, "{unused:?}");
    assert_eq!(unused[0]["name"], "wire_stickout_mm");
}

#[test]
fn a_study_case_keeps_what_it_sets() {
    let dir = scratch("calibration_study");
    std::fs::write(dir.join("calibration.json"), CALIBRATION).unwrap();
    std::fs::write(
        dir.join("base.toml"),
        format!("{PART}[calibration]\nfile = \"calibration.json\"\n"),
    )
    .unwrap();
    let study = dir.join("study.toml");
    std::fs::write(
        &study,
        "base = \"base.toml\"\ncommand = \"simulate\"\n[sweep]\n\"process.efficiency\" = [0.6, 0.7]\n",
    )
    .unwrap();
    let out = dir.join("out");
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_waamtwin"))
        .args([
            "study",
            study.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
        ])
        .current_dir(root())
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let cases: Vec<serde_json::Value> = ["0", "1"]
        .iter()
        .map(|id| {
            let d = std::fs::read_dir(out.join("cases"))
                .unwrap()
                .filter_map(|e| e.ok())
                .map(|e| e.path())
                .find(|p| p.file_name().unwrap().to_string_lossy().ends_with(id))
                .unwrap();
            json(&d.join("manifest.json"))
        })
        .collect();
    for (m, eta) in cases.iter().zip([0.6, 0.7]) {
        assert_eq!(m["scenario"]["process"]["efficiency"], eta, "{m}");
        assert_eq!(m["scenario"]["thermal"]["convection_w_m2k"], 40.0);
        let why: Vec<&str> = m["scenario"]["calibration"]["calibration_unused"]
            .as_array()
            .unwrap()
            .iter()
            .filter(|u| u["name"] == "efficiency")
            .map(|u| u["why"].as_str().unwrap())
            .collect();
        assert!(why.len() == 1 && why[0].contains("study case"), "{m}");
    }
}

/// `[dwell] confidence = 0.95` on a calibration with a spread: the plan at the mean breaks
/// under about half the fresh draws, the plan at 95 % under about one in twenty, and the design
/// point stands for each point's 95th percentile. 40 draws: a probability's standard error is
/// at most 0.08, 0.034 at 5 %; the bounds below are three of them.
#[test]
fn a_plan_at_95_percent_holds_under_fresh_draws() {
    let dir = scratch("calibration_confidence");
    std::fs::write(
        dir.join("calibration.json"),
        r#"{"parameters": [
            {"name": "efficiency", "value": 0.7, "low": 0.2, "high": 0.95, "ci95": [0.6, 0.8]},
            {"name": "convection_w_m2k", "value": 20.0, "low": 5.0, "high": 150.0}],
          "covariance": [[0.0026, -0.1], [-0.1, 26.0]], "heat_source": "arc"}"#,
    )
    .unwrap();
    let plain = format!("{PART}[calibration]\nfile = \"calibration.json\"\n");
    std::fs::write(dir.join("s.toml"), &plain).unwrap();
    let scenario = format!("{plain}[dwell]\nconfidence = 0.95\ncheck_draws = 40\n");
    std::fs::write(dir.join("s95.toml"), &scenario).unwrap();
    let out = dir.join("out");
    let o = waamtwin(&[
        "dwell",
        dir.join("s95.toml").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--no-baselines",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let d = json(&out.join("dwell.json"));
    let f = |k: &str| d[k].as_f64().unwrap_or_else(|| panic!("{k} in {d}"));
    assert_eq!(f("confidence"), 0.95);
    assert!(f("dwell_s") > f("dwell_s_at_mean"), "{d}");
    assert!(f("arc_stops") >= f("arc_stops_at_mean"));
    let (p, p_mean) = (
        f("violation_probability"),
        f("violation_probability_at_mean"),
    );
    assert!(p <= 0.05 + 3.0 * 0.034, "95 % plan violated under {p}");
    assert!(
        (0.5 - p_mean).abs() <= 3.0 * 0.08,
        "mean plan violated under {p_mean}"
    );
    let c = &d["confidence_detail"];
    // The design point is on the hot side: more heat in, less convection out.
    assert!(c["design_point"]["efficiency"].as_f64() > Some(0.7), "{c}");
    assert!(
        c["design_point"]["convection_w_m2k"].as_f64() < Some(20.0),
        "{c}"
    );
    // Against the mean preheat's spread of ~10 K (mean_preheat_sd_k), the design point's
    // preheats sit within a third of it of the draws' 95th percentiles.
    let spread = c["mean_preheat_sd_k"].as_f64().unwrap();
    let rms = c["quantile_check"]["rms_k"].as_f64().unwrap();
    assert!(spread > 3.0 && rms < spread / 3.0, "{c}");

    // Item 3: the plan's path.csv replayed as laid. At the design point it gives the dwell
    // run's own revolutions back (path.csv keeps dwells to the millisecond).
    let design = &c["design_point"];
    std::fs::copy(out.join("path.csv"), dir.join("plan95.csv")).unwrap();
    let at_design = PART.replace(
        "[thermal]\n",
        &format!(
            "[thermal]\nconvection_w_m2k = {}\n",
            design["convection_w_m2k"]
        ),
    ) + &format!(
        "[process]\nefficiency = {}\n[toolpath]\nfile = \"plan95.csv\"\nformat = \"path\"\n",
        design["efficiency"]
    );
    let replayed = replay(&dir, "design", &at_design);
    let layers = |d: &Path| crate::read_csv(&d.join("layers.csv")).1;
    let (mine, dwelled) = (layers(&replayed), layers(&out));
    assert_eq!(mine.len(), dwelled.len());
    for (a, b) in mine.iter().zip(&dwelled) {
        let (x, y): (f64, f64) = (a[3].parse().unwrap(), b[3].parse().unwrap());
        assert!(
            (x - y).abs() < 0.05,
            "preheat_max_c {x} against the dwell run's {y}"
        );
        assert_eq!(a[6], b[6], "risk");
    }
    // One standard deviation to the hot side on every parameter: the 95 % plan holds, the plan
    // at the mean (planned here without a confidence) breaks.
    let mean_plan = dir.join("mean");
    let o = waamtwin(&[
        "dwell",
        dir.join("s.toml").to_str().unwrap(),
        "-o",
        mean_plan.to_str().unwrap(),
        "--no-baselines",
    ]);
    assert!(o.status.success());
    std::fs::copy(mean_plan.join("path.csv"), dir.join("plan_mean.csv")).unwrap();
    let hot = |plan: &str| {
        format!(
            "{PART}[calibration]\nfile = \"calibration.json\"\nhot_side_sd = 1.0\n\
             [toolpath]\nfile = \"{plan}\"\nformat = \"path\"\n"
        )
    };
    let risky = |d: &Path| json(&d.join("thermal.json"))["risky_revolutions"].clone();
    let held = replay(&dir, "hot95", &hot("plan95.csv"));
    assert_eq!(
        risky(&held),
        serde_json::json!([]),
        "the 95 % plan, 1 sd hot"
    );
    let m = json(&held.join("manifest.json"));
    assert!(m["scenario"]["process"]["efficiency"].as_f64() > Some(0.7));
    let broke = replay(&dir, "hot_mean", &hot("plan_mean.csv"));
    assert_ne!(
        risky(&broke),
        serde_json::json!([]),
        "the mean plan, 1 sd hot"
    );

    // A path.csv that is not this part's plan is named, with the point and both places.
    let text = std::fs::read_to_string(dir.join("plan95.csv")).unwrap();
    let mut lines: Vec<String> = text.lines().map(String::from).collect();
    let mut f: Vec<String> = lines[3].split(',').map(String::from).collect();
    f[1] = format!("{:.4}", f[1].parse::<f64>().unwrap() + 0.5);
    lines[3] = f.join(",");
    std::fs::write(dir.join("moved.csv"), lines.join("\n") + "\n").unwrap();
    std::fs::write(dir.join("moved.toml"), hot("moved.csv")).unwrap();
    let o = waamtwin(&[
        "replay",
        dir.join("moved.toml").to_str().unwrap(),
        "-o",
        dir.join("moved").to_str().unwrap(),
    ]);
    crate::assert_input_error(&o, &["moved.csv line 4: point 2", "this scenario's plan"]);

    // Without a calibration, a confidence has nothing to stand on.
    std::fs::write(
        dir.join("bad.toml"),
        format!("{PART}[dwell]\nconfidence = 0.95\n"),
    )
    .unwrap();
    let o = waamtwin(&[
        "dwell",
        dir.join("bad.toml").to_str().unwrap(),
        "-o",
        dir.join("bad").to_str().unwrap(),
    ]);
    crate::assert_input_error(&o, &["dwell.confidence", "[calibration]"]);
}

/// `waamtwin replay` of `scenario` (written as NAME.toml in `dir`) into `dir/NAME`.
fn replay(dir: &Path, name: &str, scenario: &str) -> std::path::PathBuf {
    std::fs::write(dir.join(format!("{name}.toml")), scenario).unwrap();
    let out = dir.join(name);
    let o = waamtwin(&[
        "replay",
        dir.join(format!("{name}.toml")).to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    out
}
