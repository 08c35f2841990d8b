//! The dwell planner through `waamtwin dwell` on a small closed dome.

use crate::{read_csv as csv, scratch, waamtwin};

fn column(h: &[String], rows: &[Vec<String>], name: &str) -> Vec<f64> {
    let k = h
        .iter()
        .position(|x| x == name)
        .unwrap_or_else(|| panic!("no column {name}"));
    rows.iter().map(|r| r[k].parse().unwrap()).collect()
}

#[test]
fn planned_dwells_keep_a_closed_dome_under_the_limit() {
    let dir = scratch("dwell_dome");
    std::fs::write(
        dir.join("s.toml"),
        "[part]\nshape = \"hemisphere\"\nradius_mm = 40.0\nedge_mm = 2.5\n[planner]\nn_points = 60\n[thermal]\nplate_mm = [150.0, 150.0, 10.0]\n",
    )
    .unwrap();
    let out = dir.join("out");
    let o = waamtwin(&[
        "dwell",
        dir.join("s.toml").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let d: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("dwell.json")).unwrap()).unwrap();
    eprintln!("dwell: {}", serde_json::to_string(&d).unwrap());
    // Without dwells the closing zone overheats, and the run says so.
    assert!(d["first_risk_before"]["i"].is_u64());
    // With the planned dwells, a fresh simulation of the dwelled path has every point a dwell
    // can act on safe; the points laid on metal just laid at the closing point stay at risk, and
    // dwell.json, thermal.json and layers.csv all say so.
    only_the_closing_point_left(&d);
    assert_eq!(d["unresolved_points"], 0);
    let t: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("thermal.json")).unwrap()).unwrap();
    let left = d["risky_after"].as_array().unwrap();
    assert_eq!(
        t["first_overheat"],
        left.first()
            .map_or(serde_json::Value::Null, |p| p["i"].clone())
    );
    let (lh, lrows) = csv(&out.join("layers.csv"));
    let risky_layers: Vec<u64> = lrows
        .iter()
        .filter(|r| !r[lh.iter().position(|h| h == "risk").unwrap()].is_empty())
        .map(|r| r[0].parse().unwrap())
        .collect();
    let mut said: Vec<u64> = left.iter().map(|p| p["layer"].as_u64().unwrap()).collect();
    said.dedup();
    assert_eq!(
        risky_layers, said,
        "layers.csv and dwell.json agree on what is at risk"
    );
    let total = d["total_dwell_s"].as_f64().unwrap();
    let count = d["dwell_count"].as_u64().unwrap() as usize;
    assert!(total > 0.0 && count > 0);
    // The files agree with each other.
    let (dh, drows) = csv(&out.join("dwells.csv"));
    assert_eq!(dh[..5].join(","), "i,layer,t_s,dwell_s,reason");
    assert_eq!(drows.len(), count);
    let sum = |v: Vec<f64>| v.iter().sum::<f64>();
    assert!((sum(column(&dh, &drows, "dwell_s")) - total).abs() < 0.01 * count as f64);
    // No dwell shorter than `[dwell] min_dwell_s` (5 s): each is an arc stop and a restart.
    assert_eq!(d["arc_stops"], count);
    let shortest = column(&dh, &drows, "dwell_s")
        .into_iter()
        .fold(f64::INFINITY, f64::min);
    assert!(shortest >= 5.0 - 1e-3, "a dwell of {shortest} s");
    let (ph, prows) = csv(&out.join("path.csv"));
    assert!((sum(column(&ph, &prows, "dwell_s")) - total).abs() < 1e-3 * count as f64 + 1e-6);
    let (lh, lrows) = csv(&out.join("layers.csv"));
    assert!((sum(column(&lh, &lrows, "dwell_s")) - total).abs() < 1e-3 * count as f64 + 1e-6);
    let (before, after) = (
        d["build_time_s"]["before"].as_f64().unwrap(),
        d["build_time_s"]["after"].as_f64().unwrap(),
    );
    assert!(
        (after - before - total).abs() < 1e-6 * after,
        "{before} + {total} vs {after}"
    );
    // The baselines. The same dwell before every revolution keeps the dome safe only up to the
    // revolution where one revolution's own heat breaks the limit; there the planned dwells
    // take at most 0.7 of the smallest safe uniform dwell.
    let b = &d["baselines"];
    let uniform = &b["uniform"];
    let ratio = uniform["ratio"]
        .as_f64()
        .expect("a uniform dwell keeps the first revolutions safe");
    assert!(ratio <= 0.7, "planned / uniform = {ratio}");
    assert!(uniform["judged_before_point"].as_u64().unwrap() > 0);
    // "Wait until the last layer is below the limit" is not safe here (the layer beneath cools,
    // the revolution being laid heats it again): it is reported with its first risky point.
    let w = &b["wait_until_cool"];
    assert_eq!(w["safe"], false);
    assert!(w["first_risk"]["i"].is_u64() && w["its_dwell_before_that_s"].is_f64());
}

/// `model = "voxel"`: the dwells are searched on the voxel model itself (the heat-model
/// contract), and a fresh voxel simulation of the dwelled path is safe wherever a dwell can
/// act. Near the closing point revolutions are a few millimetres round and the arc reheats the
/// ring beneath within a second: there the voxel model finds points no dwell (up to 600 s)
/// keeps under the limit; they are reported, in the closing zone, as unresolved (the closing
/// strategy is its own issue).
#[test]
fn dwells_planned_on_the_voxel_model_keep_a_small_dome_safe_outside_its_closing_zone() {
    let out = crate::run_scenario(
        "dwell_voxel_dome",
        "dwell",
        "[part]\nshape = \"hemisphere\"\nradius_mm = 25.0\nedge_mm = 2.5\n[planner]\nn_points = 48\n\
         [thermal]\nmodel = \"voxel\"\nplate_mm = [90.0, 90.0, 8.0]\n[output]\nrerun = false\nmcap = false\nhdf5 = false\nplots = false\n",
    );
    let d: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("dwell.json")).unwrap()).unwrap();
    let t: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("thermal.json")).unwrap()).unwrap();
    eprintln!("voxel dwell: {}", serde_json::to_string(&d).unwrap());
    assert_eq!(d["model"], "voxel");
    assert_eq!(t["model"], "voxel");
    assert!(t["voxels"].as_u64().unwrap() > 10_000);
    // Overheating without dwells, dwells planned, their search cost in voxel builds.
    assert!(d["first_risk_before"]["i"].is_u64());
    assert!(d["dwell_count"].as_u64().unwrap() > 10);
    assert!(d["search_cost_in_builds"].as_f64().unwrap() > 1.0);
    // Every point a dwell can act on is safe but a few the planner reports unresolved; what is
    // left lies in the closing zone.
    only_the_closing_point_left(&d);
    let left = d["risky_after"].as_array().unwrap();
    let dwell_could = left.iter().filter(|p| p["dwell_can_help"] == true).count();
    assert!(dwell_could <= 5, "{left:?}");
    assert!(d["unresolved_points"].as_u64().unwrap() >= dwell_could as u64);
}

/// What a fresh simulation of the dwelled path leaves at risk lies in the closing zone, and
/// those points no dwell can help are counted apart (no closing strategy is built).
fn only_the_closing_point_left(d: &serde_json::Value) {
    assert_eq!(d["risky_points_after_outside_closing_zone"], 0, "{d}");
    let left = d["risky_after"].as_array().unwrap();
    assert!(left.iter().all(|p| p["closing_zone"] == true), "{left:?}");
    // risky_after lists the first 50; the count covers them all.
    let beyond = left.iter().filter(|p| p["dwell_can_help"] == false).count() as u64;
    let counted = d["risky_points_after_no_dwell_can_help"].as_u64().unwrap();
    assert!(counted >= beyond && counted <= d["risky_points_after"].as_u64().unwrap());
    assert!(d["closing_strategy"].is_null());
}

/// `[dwell] max_arc_stops` and `--pareto` on a small dome: the plans at six weights of an arc
/// stop are real plans (pareto.csv, pareto.png, dwell.json `pareto`), the front is the plans
/// nothing beats on both counts, and the plan kept is the lightest weight within the budget, or,
/// where no weight meets it, the one with the fewest stops, said to miss it.
#[test]
fn an_arc_stop_budget_and_its_front() {
    let dir = scratch("dwell_budget");
    std::fs::write(
        dir.join("s.toml"),
        "[part]\nshape = \"hemisphere\"\nradius_mm = 25.0\nedge_mm = 2.5\n[planner]\nn_points = 48\n\
         [thermal]\nplate_mm = [90.0, 90.0, 10.0]\n[dwell]\nmax_arc_stops = 10\n",
    )
    .unwrap();
    let out = dir.join("out");
    let o = waamtwin(&[
        "dwell",
        dir.join("s.toml").to_str().unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--no-baselines",
        "--pareto",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let d: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("dwell.json")).unwrap()).unwrap();
    let budget = &d["arc_stop_budget"];
    eprintln!("budget: {budget}\nfront: {}", d["pareto"]);
    let stops = d["arc_stops"].as_u64().unwrap();
    assert_eq!(budget["met"], stops <= 10, "{budget}");
    only_the_closing_point_left(&d);
    let (h, rows) = csv(&out.join("pareto.csv"));
    assert_eq!(
        h.join(","),
        "weight_s,arc_stops,total_dwell_s,build_time_s,on_front"
    );
    assert_eq!(rows.len(), 6);
    let plans: Vec<(f64, f64, bool)> = rows
        .iter()
        .map(|r| (r[1].parse().unwrap(), r[3].parse().unwrap(), r[4] == "1"))
        .collect();
    for &(s, t, on) in &plans {
        let beaten = plans
            .iter()
            .any(|&(s2, t2, _)| (s2 <= s && t2 < t - 1e-6) || (s2 < s && t2 <= t + 1e-6));
        assert_eq!(on, !beaten, "{plans:?}");
    }
    // The plan kept is one of the front's, with its stops and dwell.
    let kept_weight = budget["weight_s_per_stop"].as_f64().unwrap();
    let kept = rows
        .iter()
        .find(|r| r[0].parse::<f64>().unwrap() == kept_weight)
        .expect("the kept plan is on the list");
    assert_eq!(kept[1].parse::<u64>().unwrap(), stops);
    let total = d["total_dwell_s"].as_f64().unwrap();
    assert!((kept[2].parse::<f64>().unwrap() - total).abs() < 1e-3 * total.max(1.0));
    // Weighing a stop heavier never buys more stops for less build time than the lightest.
    let fewest = plans.iter().map(|p| p.0).fold(f64::INFINITY, f64::min);
    assert!(fewest <= plans[0].0, "{plans:?}");
    assert!(out.join("pareto.png").is_file());
}
