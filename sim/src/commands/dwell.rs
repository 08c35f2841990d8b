//! `waamtwin dwell SCENARIO -o DIR [--no-baselines]`: plan, simulate, plan the cooling dwells,
//! check them in a fresh simulation of the dwelled path, and compare with the baselines.

use super::simulate::{Simulation, record, simulate, write_thermal};
use crate::beads::beads;
use crate::deposition::{schedule, wall_settings};
use crate::dwell::{dwell_points, first_risk, plan_dwells, uniform_baseline, wait_until_cool};
use crate::error::{Error, Result};
use crate::output::RunDir;
use crate::part::load_part;
use crate::progress::Stage;
use crate::risk::judge;
use crate::scenario::Scenario;
use serde_json::{Value, json};
use std::fmt::Write;
use std::path::Path;
use std::time::Instant;

pub fn run(scenario: &Path, out: &Path, baselines: bool) -> Result<String> {
    let s = Scenario::load(scenario)?;
    let mut dir = RunDir::create(out)?;
    let line = plan_and_dwell(&s, &mut dir, baselines)?;
    dir.finish("dwell", s.to_json())?;
    Ok(line)
}

/// Plan, simulate, plan the dwells and simulate the dwelled path, writing every file of the
/// dwell command into `dir` (all but the manifest).
pub fn plan_and_dwell(s: &Scenario, dir: &mut RunDir, baselines: bool) -> Result<String> {
    let part = load_part(&s.part)?;
    let pl = super::plan::plan_part(s, &part)?;
    let b = beads(s, &pl);
    let deps = schedule(s, &pl, &b, &[]);
    let settings = wall_settings(s, &deps, Vec::new());
    let fail = |e: String| Error::input(format!("thermal: {e}"));

    let before = simulate(s, &pl, &[], 0)?;
    let clock = Instant::now();
    let plan = {
        let _stage = Stage::start("planning the dwells");
        plan_dwells(s, &pl, &deps, &settings).map_err(fail)?
    };
    let search_s = clock.elapsed().as_secs_f64();
    let after = simulate(s, &pl, &plan.dwell_s, s.output.frames)?;
    let risky_after: Vec<usize> = (0..pl.points.len())
        .filter(|&i| judge(s, &after.result.points[i], after.support[i], 0.0).is_some())
        .collect();

    let total = plan.dwell_s.iter().sum::<f64>();
    let count = plan.dwell_s.iter().filter(|&&d| d > 0.0).count();
    let build = |sim: &Simulation| sim.deposits.last().map_or(0.0, |d| d.time);
    let mut summary = json!({
        "policy": "revolution",
        "criteria": {
            "interpass_max_c": s.dwell.interpass_max_k - 273.15,
            "interpass": s.dwell.interpass,
            "strength_loss_c": s.dwell.strength_loss_k.map(|k| k - 273.15),
            "humping": s.dwell.humping,
            "bond": s.dwell.bond,
        },
        "total_dwell_s": total,
        "dwell_count": count,
        "cost_s": total + s.dwell.count_weight_s * count as f64,
        "build_time_s": {"before": build(&before), "after": build(&after)},
        "first_risk_before": first_risk_json(s, &before),
        "risky_points_after": risky_after.len(),
        "risky_after": risky_after.iter().take(50).map(|&i| json!({"i": i, "layer": pl.points[i].layer,
            "reason": judge(s, &after.result.points[i], after.support[i], 0.0).map(|r| r.as_str()),
            "preheat_c": after.result.points[i].preheat - 273.15, "pool_length_mm": after.result.points[i].pool_length * 1e3})).collect::<Vec<_>>(),
        "unresolved_points": plan.unresolved.len(),
        "search_deposits_in_builds": plan.cost_builds,
        "search_wall_s": search_s,
        "single_build_wall_s": before.wall_s,
        "search_cost_in_builds": search_s / before.wall_s.max(1e-9),
    });
    if baselines {
        let _stage = Stage::start("baselines: uniform dwell, wait until cool");
        let uniform = uniform_baseline(s, &pl, &deps, &settings).map_err(fail)?;
        // Where the uniform policy stops working (a dome's closing zone), both are compared on
        // the points before.
        let until = uniform.until;
        let slots = dwell_points(&pl, &deps, settings.lead)
            .into_iter()
            .filter(|&i| i < until)
            .count();
        let planned_there: f64 = plan.dwell_s[..until].iter().sum();
        let waits = wait_until_cool(s, &pl, &deps, &settings).map_err(fail)?;
        let wait_total: f64 = waits.iter().sum();
        let n = deps.len();
        let wait_risk = first_risk(s, &deps, &settings, &waits, n).map_err(fail)?;
        let wait_safe_until = wait_risk.map_or(n, |(i, _)| i);
        summary["baselines"] = json!({
            "none": {"total_dwell_s": 0.0, "first_risk": first_risk_json(s, &before)},
            "uniform": {
                "dwell_per_revolution_s": uniform.dwell_s,
                "judged_before_point": until,
                "policy_fails_from_layer": (until < n).then(|| pl.points[until].layer),
                "total_dwell_s": uniform.dwell_s.map(|d| d * slots as f64),
                "dwell_count": slots,
                "planned_dwell_there_s": planned_there,
                "ratio": uniform.dwell_s.map(|d| planned_there / (d * slots as f64).max(1e-9)),
            },
            "wait_until_cool": {"total_dwell_s": wait_total, "dwell_count": waits.iter().filter(|&&d| d > 0.0).count(),
                "safe": wait_risk.is_none(),
                "first_risk": wait_risk.map(|(i, r)| json!({"i": i, "layer": pl.points[i].layer, "reason": r.as_str()})),
                "its_dwell_before_that_s": waits[..wait_safe_until].iter().sum::<f64>(),
                "planned_dwell_before_that_s": plan.dwell_s[..wait_safe_until].iter().sum::<f64>()},
        });
        if let Some(d) = uniform.dwell_s {
            summary["ratio_to_uniform"] = json!(planned_there / (d * slots as f64).max(1e-9));
        }
        summary["ratio_to_wait_until_cool"] = json!(total / wait_total.max(1e-9));
    }
    super::plan::write_plan(dir, s, &pl)?;
    write_thermal(dir, s, &pl, &after, &plan.dwell_s)?;
    record(dir, s, &part, &pl, &after, &plan.dwell_s, Some(&before))?;
    let mut csv = String::from("i,layer,t_s,dwell_s,reason,x_mm,y_mm,z_mm\n");
    for (i, &d) in plan.dwell_s.iter().enumerate() {
        if d > 0.0 {
            let q = &pl.points[i];
            let reason = plan.reason[i].map_or("", |r| r.as_str());
            let _ = writeln!(
                csv,
                "{i},{},{:.3},{d:.3},{reason},{:.3},{:.3},{:.3}",
                q.layer,
                after.deposits[i].arc_start() - d,
                q.position.x,
                q.position.y,
                q.position.z
            );
        }
    }
    dir.write("dwells.csv", csv.as_bytes())?;
    dir.write_json("dwell.json", &summary)?;
    Ok(format!(
        "{count} dwells, {total:.0} s in all; build {:.0} s → {:.0} s; {} points still at risk; search {:.1} builds of wall time",
        build(&before),
        build(&after),
        risky_after.len(),
        search_s / before.wall_s.max(1e-9)
    ))
}

fn first_risk_json(s: &Scenario, sim: &Simulation) -> Value {
    (0..sim.result.points.len())
        .find_map(|i| {
            judge(s, &sim.result.points[i], sim.support[i], 0.0)
                .map(|r| json!({"i": i, "reason": r.as_str()}))
        })
        .unwrap_or(Value::Null)
}
