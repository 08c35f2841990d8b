//! `waamtwin dwell SCENARIO -o DIR [--no-baselines]`: plan, simulate, plan the cooling dwells,
//! check them in a fresh simulation of the dwelled path, and compare with the baselines.

use super::checkpoint;
use super::simulate::{record, write_thermal};
use crate::error::Result;
use crate::output::RunDir;
use crate::pipeline::checkpoint::Checkpoints;
use crate::pipeline::dwell::DwellPlan;
use crate::pipeline::dwelled::{self, AtMean, Dwelled};
use crate::pipeline::params::ThermalModel;
use crate::pipeline::{Build, Simulation};
use crate::pipeline::{arc_stops, risk};
use crate::progress::Terminal;
use crate::scenario::Scenario;
use serde_json::{Value, json};
use std::fmt::Write;
use std::path::Path;
use thermal::celsius;

/// What the dwell command does beyond the plan: the baselines, and the arc-stop front.
#[derive(Debug, Clone, Copy, Default)]
pub struct Extras {
    pub baselines: bool,
    pub pareto: bool,
}

pub fn run(
    scenario: &Path,
    out: &Path,
    extras: Extras,
    resume: checkpoint::Options,
) -> Result<String> {
    let s = Scenario::load(scenario)?;
    let file = scenario.display().to_string();
    super::cost::check_plate(&file, &s.thermal, &s.material, keeps(&s, extras))?;
    let mut dir = RunDir::create(out)?;
    let line = plan_and_dwell(&s, &file, &mut dir, extras, Some(resume))?;
    dir.finish("dwell", s.to_json())?;
    Ok(line)
}

/// The report's and the recordings' sentence: the design point, both plans' violation
/// probabilities, and what the confidence cost (this plan's `dwell_s`, arc stops).
fn how_sure(
    m: &AtMean,
    c: &crate::pipeline::confidence::Settings,
    check: &crate::pipeline::confidence::Check,
    check_mean: &crate::pipeline::confidence::Check,
    (dwell_s, stops): (f64, usize),
) -> String {
    let at: Vec<String> = m
        .uncertainty
        .parameters
        .iter()
        .zip(&m.design.x)
        .map(|(p, x)| format!("{} {x:.4}", p.key()))
        .collect();
    format!(
        "planned at {:.0} % of the calibration's uncertainty (at {}): some point breaks a \
         criterion under {:.0} % of {} fresh parameter draws; the plan at the mean under {:.0} % \
         ({:.0} s of dwell and {} arc stops, this plan {dwell_s:.0} s and {stops})",
        100.0 * c.confidence,
        at.join(", "),
        100.0 * check.violation_probability(),
        check.draws,
        100.0 * check_mean.violation_probability(),
        m.plan.cooling.total_dwell_s(),
        m.plan.cooling.arc_stops(),
    )
}

/// dwell.json's `confidence_detail`: the design point, and how well it stands for the quantile.
fn confidence_json(
    m: &AtMean,
    c: &crate::pipeline::confidence::Settings,
    check: &crate::pipeline::confidence::Check,
    check_mean: &crate::pipeline::confidence::Check,
    after: &Simulation,
) -> Value {
    let u = &m.uncertainty;
    let names: Vec<&str> = u.parameters.iter().map(|p| p.key()).collect();
    // Each point's preheat at θ* against its empirical q-quantile over the draws.
    let diff: Vec<f64> = after
        .result
        .points
        .iter()
        .zip(&check.preheat_quantile_k)
        .map(|(p, q)| p.preheat - q)
        .collect();
    let n = diff.len().max(1) as f64;
    json!({
        "method": "design point (first-order reliability), checked on fresh draws",
        "parameters": names,
        "mean": u.mean,
        "sd": u.sd(),
        "covariance": u.covariance,
        "design_point": u.parameters.iter().zip(&m.design.x).map(|(p, x)| (p.key().to_string(), json!(x))).collect::<serde_json::Map<_, _>>(),
        "z": m.design.z,
        "mean_preheat_gradient_k_per_unit": m.design.gradient_k,
        "mean_preheat_sd_k": m.design.preheat_sd_k,
        "check_draws": check.draws,
        "check_seed": c.seed,
        "violated_draws": check.violated,
        "violated_draws_at_mean": check_mean.violated,
        "quantile_check": {
            "what": "per point: preheat at the design point less the empirical quantile over the draws",
            "mean_k": diff.iter().sum::<f64>() / n,
            "rms_k": (diff.iter().map(|d| d * d).sum::<f64>() / n).sqrt(),
            "max_abs_k": diff.iter().fold(0.0_f64, |a, d| a.max(d.abs())),
        },
    })
}

/// A dwell command's heat runs in one-build times (`simulate`'s estimate of the run), each
/// model as measured (docs/PERFORMANCE.md "Cost estimates"): the run without dwells (1), the
/// search (dwells tried and the runs from their checkpoints), the arc-stop bound (each deposit
/// laid about once and a stretch's last few again from its copy, `pipeline::bound`: 1.13
/// builds laid on the demo dome), the revolution-dwell yardstick (each revolution's shortest
/// safe dwell found by trying dwells through it) and the run with the dwells; and the
/// baselines where they are made (`--no-baselines` leaves them out): the uniform dwell's halving
/// search (a run at the longest dwell, then some eight runs each to its first point at risk)
/// and wait-until-cool's three runs (`pipeline::dwelled::baselines`); and `--pareto`'s front
/// where it is asked for (a search at each weight of an arc stop the search did not try,
/// `pipeline::arc_stops::front`).
struct Builds {
    yardstick: f64,
    search: f64,
    bound: f64,
    dwelled: f64,
    baselines: f64,
    front: f64,
}

/// On the thin wall, one thread (2026-11-28, `RAYON_NUM_THREADS=1`, the R 50 dome, the demo
/// dome, the vase and the cone: 8.0 to 9.3 builds in all, the yardstick 3.2 to 3.8 of them by
/// what the rest leaves): with local steps a node's cost is its deposits', not the build's
/// seconds, so the dwelled run costs about what the build does (1.17 to 1.25).
///
/// The baselines made one after the other 8.8, 9.8 and 11.3 builds (the demo dome, the vase,
/// the cone; 2026-11-29, dwell.json's `baselines.wall_s` over its `single_build_wall_s`),
/// uncounted before, so that `dwell` with them said "about 36 s" for 58 s and "1.1 min" for
/// 145 s; made side by side on two threads 6.1, 6.7 and 8.3 ([`BASELINES_BESIDE_SHARE`]).
/// `--pareto`'s front 35.4 and 37.6 builds (the demo dome, the vase, with `--no-baselines`: the
/// command's wall time with the front less without, 2026-11-29), some 17.5 times the search:
/// five searches at the heavier weights, each longer than the unweighted one; uncounted before
/// ("about 36 s" for 160 s on the demo).
const THIN_WALL: Builds = Builds {
    yardstick: 3.5,
    search: 2.5,
    bound: 1.2,
    dwelled: 1.3,
    baselines: 11.0,
    front: 38.0,
};

/// The voxel model steps the build's seconds, and every dwell tried costs the seconds it
/// cools: measured on the closed domes R 50 and R 100 (2026-11-28, plate coarsened, two
/// threads; in `simulate` estimates of 2.5 and 14.0 s), the search took 15.6 and 12.4 of them,
/// the dwelled run 2.3 and 2.1, the yardstick, the bound and the run without dwells 21.9 and
/// 11.0; fitted to the R 50 dome (the longer in builds), 1.6 times long at R 100. Before, 15.7
/// builds in all (a yardstick of 9), which put the estimate at 0.39 and 0.64 of the command.
///
/// The baselines on the R 50 dome 7.2 builds made one after the other, 6.0 side by side
/// (2026-11-29; its runs share the threads, so the second is counted). The front not measured on
/// it: reckoned as the thin wall's, 17.5 times the search.
const VOXEL: Builds = Builds {
    yardstick: 20.0,
    search: 16.0,
    bound: 1.2,
    dwelled: 2.5,
    baselines: 6.0,
    front: 280.0,
};

/// On the thin wall with a second thread the yardstick is made beside the rest
/// ([`dwelled::dwell`]), which saved 16–17 % (the vase, the cone) to 41–42 % (the R 50 dome,
/// the demo) of one thread's time (2026-11-28): the least saving is counted.
const BESIDE_SHARE: f64 = 0.85;

/// On the thin wall with a second thread wait-until-cool's runs are made beside the uniform
/// dwell's search, which took the baselines to 0.65, 0.70 and 0.77 of their time one after the
/// other (the demo dome, the vase, the cone; 2026-11-29): the least saving is counted.
const BASELINES_BESIDE_SHARE: f64 = 0.77;

/// The runs a dwell command makes on `model`, in builds.
fn builds(model: ThermalModel) -> Builds {
    match model {
        ThermalModel::ThinWall => THIN_WALL,
        ThermalModel::Voxel => VOXEL,
    }
}

/// What a study's dwell case keeps and runs (`Build::case`): the search alone, which restarts
/// from checkpoints (about four models at once), and the run with its dwells; no yardstick, bound
/// or baselines.
pub(crate) fn search_keeps(s: &Scenario) -> super::cost::Keeps {
    let b = builds(s.thermal.model);
    super::cost::Keeps {
        copies: 4.0,
        runs: b.search + b.dwelled,
        ..super::cost::Keeps::ONE_RUN
    }
}

/// What a dwell command keeps and runs: the search restarts from checkpoints (a run kept with
/// the cache's cooled copies: about four models at once) and, beside it, the revolution-dwell
/// yardstick (its run, the revolution's start and a try: three more, and the cooled states its
/// tries go on from, those between a failing and a passing try, not counted here; the peak
/// measured no higher for them at R 400, 1.46 GB, and 6 % higher at R 100). Its runs are
/// [`Builds`], the baselines and the front among them where `extras` makes them.
pub(crate) fn keeps(s: &Scenario, extras: Extras) -> super::cost::Keeps {
    let b = builds(s.thermal.model);
    let all = 1.0 + b.search + b.bound + b.yardstick + b.dwelled;
    let baselines = match extras.baselines {
        true => b.baselines,
        false => 0.0,
    };
    // The front's searches one after another, beside nothing.
    let front = match extras.pareto {
        true => b.front,
        false => 0.0,
    };
    // The thin wall steps on one thread; the voxel model's runs share the threads.
    let beside = s.thermal.model == ThermalModel::ThinWall && rayon::current_num_threads() > 1;
    let together = front
        + match beside {
            true => all * BESIDE_SHARE + baselines * BASELINES_BESIDE_SHARE,
            false => all + baselines,
        };
    super::cost::Keeps {
        copies: 7.0,
        frames: s.output.frames,
        // At a confidence: the plan at the mean too, a run per parameter for the design point,
        // and both plans under every fresh draw.
        runs: together
            + s.confidence.as_ref().map_or(0.0, |c| {
                4.5 + (c.uncertainty.mean.len() + 2) as f64 + 4.0 * c.check_draws as f64
            }),
        recorded: s.output.records(),
        ..super::cost::Keeps::ONE_RUN
    }
}

/// Plan, simulate, plan the dwells and simulate the dwelled path ([`dwelled::dwell`]),
/// writing every file of the dwell command into `dir` (all but the manifest). With `resume`,
/// each stage is kept in the run's checkpoint folder and taken from there by `--resume`.
pub fn plan_and_dwell(
    s: &Scenario,
    file: &str,
    dir: &mut RunDir,
    extras: Extras,
    resume: Option<checkpoint::Options>,
) -> Result<String> {
    let part = super::cost::part_to_plan(file, &s.part)?;
    let b = super::plan::build(s, &part)?;
    let mut folder = match resume {
        Some(o) => {
            let print = checkpoint::of_run("dwell", &s.to_json(), b.deposits());
            Some(checkpoint::Folder::open(dir.path(), "dwell", print, o)?)
        }
        None => None,
    };
    super::cost::check(
        file,
        &b.params.thermal,
        &s.material,
        b.deposits(),
        b.deposits().last().map_or(0.0, |d| d.time),
        super::cost::Keeps {
            planned: part.mesh.n_vertices(),
            ..keeps(s, extras)
        },
    )?;
    let mut ck = match folder.as_mut() {
        Some(f) => Checkpoints::to(f),
        None => Checkpoints::off(),
    };
    let options = dwelled::Options {
        confidence: s.confidence.clone(),
        baselines: extras.baselines,
        pareto: extras.pareto,
        frames: s.output.frames,
        traces: match s.output.frames {
            0 => Vec::new(),
            _ => crate::record::history_points(b.plan.points.len()).to_vec(),
        },
    };
    let d = dwelled::dwell(b, &options, &mut ck, &mut Terminal::default())?;
    let line = write(dir, s, &part, &d)?;
    if let Some(folder) = folder {
        folder.close()?;
    }
    Ok(line)
}

/// dwell.json, dwells.csv, pareto.csv, the plan's and the heat's files and the recordings of
/// a dwell run; its summary line.
fn write(
    dir: &mut RunDir,
    s: &Scenario,
    part: &planner::mesh::Part,
    d: &Dwelled,
) -> Result<String> {
    let (b, before, after) = (&d.build, &d.before, &d.after);
    let dwelled::Searched {
        plan,
        budget,
        search_s,
        revolution,
        searched,
        searched_build_s,
        kept,
    } = &d.searched;
    let (search_s, bound) = (*search_s, &d.bound);
    let (pl, dw) = (&b.plan, &b.params.dwell);
    let risks_after = after.risks(&b.criteria);
    let zone = b.closing_zone(after);
    let risky_after: Vec<usize> = (0..pl.points.len())
        .filter(|&i| risks_after[i].is_some())
        .collect();
    // Where the risk is one a dwell could act on (the planner's judgement): the others lie on
    // metal laid while their preheat was read, near a closing point, and need a closing strategy.
    let r = &after.result;
    let dwell_can_help =
        |i: usize| risk::judge_for_dwell(&b.criteria, &r.points[i], r.support[i], 0.0).is_some();
    let beyond_dwells = risky_after.iter().filter(|&&i| !dwell_can_help(i)).count();

    let c = &plan.cooling;
    let total = c.total_dwell_s();
    let count = (0..c.dwell_s.len())
        .filter(|&i| c.dwell_s[i] > 0.0 && c.drop[i].is_none())
        .count();
    let stops = c.arc_stops();
    let mut summary = json!({
        "policy": "revolution",
        "model": after.model,
        "criteria": {
            "interpass_max_c": celsius(dw.interpass_max_k),
            "interpass": dw.interpass,
            "strength_loss_c": dw.strength_loss_k.map(celsius),
            "humping": dw.humping,
            "bond": dw.bond,
        },
        "total_dwell_s": total,
        // Dwells with the arc off, drops' waits apart.
        "dwell_count": count,
        // Every arc start after the first: each dwell and each drop.
        "arc_stops": stops,
        "shortest_dwell_s": (0..c.dwell_s.len())
            .filter(|&i| c.dwell_s[i] > 0.0 && c.drop[i].is_none())
            .map(|i| c.dwell_s[i])
            .reduce(f64::min),
        "min_dwell_s": dw.min_dwell_s,
        "cost_s": total + dw.count_weight_s * stops as f64,
        "arc_stops_lower_bound": bound.stops,
        "kept": kept.name(),
        "search_plan": {"arc_stops": searched, "build_time_s": searched_build_s},
        "revolution_dwell": revolution_json(b, revolution),
        "arc_stops_bound": bound_json(bound, stops),
        "build_time_s": {"before": before.build_time_s(), "after": after.build_time_s()},
        "slow_down": slow_down_json(b, after),
        "closing_strategy": closing_json(b, plan, after),
        "first_risk_before": first_risk_json(b, before),
        "risky_points_after": risky_after.len(),
        "risky_points_after_outside_closing_zone": risky_after.iter().filter(|&&i| !zone[i]).count(),
        "risky_points_after_no_dwell_can_help": beyond_dwells,
        "risky_after": risky_after.iter().take(50).map(|&i| json!({"i": i, "layer": pl.points[i].layer,
            "closing_zone": zone[i], "reason": risks_after[i].map(|r| r.as_str()),
            "dwell_can_help": dwell_can_help(i), "laid_on": support_name(r.support[i]),
            "preheat_c": celsius(after.result.points[i].preheat), "pool_length_mm": after.result.points[i].pool_length * 1e3})).collect::<Vec<_>>(),
        "unresolved_points": plan.unresolved.len(),
        "search_deposits_in_builds": plan.cost_builds,
        "search_wall_s": search_s,
        "single_build_wall_s": before.wall_clock_s,
        "search_cost_in_builds": search_s / before.wall_clock_s.max(1e-9),
    });
    // How sure the plan is, in one sentence for the report and the recordings.
    let mut sure = None;
    if let (Some(sr), Some(c)) = (&d.sure, &s.confidence) {
        let m = &sr.at_mean;
        summary["confidence"] = json!(c.confidence);
        summary["dwell_s"] = json!(total);
        summary["dwell_s_at_mean"] = json!(m.plan.cooling.total_dwell_s());
        summary["arc_stops_at_mean"] = json!(m.plan.cooling.arc_stops());
        summary["violation_probability"] = json!(sr.check.violation_probability());
        summary["violation_probability_at_mean"] = json!(sr.check_at_mean.violation_probability());
        summary["confidence_detail"] = confidence_json(m, c, &sr.check, &sr.check_at_mean, after);
        sure = Some(how_sure(m, c, &sr.check, &sr.check_at_mean, (total, stops)));
    }
    if let Some((max, r)) = budget {
        summary["arc_stop_budget"] = json!({
            "max_arc_stops": max,
            "met": r.met,
            "arc_stops_lower_bound": r.bound.stops,
            "why_not_met": (!r.met).then(|| if *max < r.bound.stops {
                format!("the budget is under the lower bound: no plan can make fewer than {} arc stops", r.bound.stops)
            } else {
                format!("the heaviest weight of an arc stop tried ({} s) still stops the arc {} times", r.tried.iter().map(|t| t.weight_s).fold(0.0, f64::max), r.plan.cooling.arc_stops())
            }),
            "weight_s_per_stop": r.weight_s,
            "tried": r.tried.iter().map(tried_json).collect::<Vec<_>>(),
        });
    }
    if let Some(plans) = &d.front {
        let mut csv = String::from(
            "weight_s,arc_stops,total_dwell_s,build_time_s,on_front,slowed_points,drops\n",
        );
        for t in plans {
            let _ = writeln!(
                csv,
                "{},{},{:.3},{:.3},{},{},{}",
                t.weight_s,
                t.arc_stops,
                t.total_dwell_s,
                t.build_time_s,
                u8::from(arc_stops::on_front(t, plans)),
                t.slowed_points,
                t.drops
            );
        }
        dir.write("pareto.csv", csv.as_bytes())?;
        summary["pareto"] = plans.iter().map(tried_json).collect::<Vec<_>>().into();
        #[cfg(feature = "recording")]
        crate::record::pareto_plot(
            dir,
            "dwell plans",
            plans,
            budget.as_ref().map(|b| b.0),
            bound.stops,
        )?;
    }
    if let Some(bl) = &d.baselines {
        let n = b.deposits().len();
        let (uniform, until, slots) = (&bl.uniform, bl.uniform.until, bl.slots);
        let planned_there = bl.planned_there_s;
        let wait_total: f64 = bl.waits.iter().sum();
        let wait_safe_until = bl.wait_risk.map_or(n, |(i, _)| i);
        let wait_failing: std::collections::BTreeMap<usize, std::collections::BTreeSet<&str>> = (0
            ..n)
            .filter_map(|i| bl.wait_risks[i].map(|r| (pl.points[i].layer, r.as_str())))
            .fold(Default::default(), |mut m, (layer, r)| {
                m.entry(layer).or_default().insert(r);
                m
            });
        summary["baselines"] = json!({
            // What they cost this command, s (`--no-baselines` saves it).
            "wall_s": bl.wall_s,
            "none": {"total_dwell_s": 0.0, "first_risk": first_risk_json(b, before)},
            "uniform": {
                "dwell_per_revolution_s": uniform.dwell_s,
                "judged_before_point": until,
                "policy_fails_from_layer": (until < n).then(|| pl.points[until].layer),
                "total_dwell_s": uniform.dwell_s.map(|d| d * slots as f64),
                "dwell_count": slots,
                "planned_dwell_there_s": planned_there,
                "ratio": uniform.dwell_s.map(|d| planned_there / (d * slots as f64).max(1e-9)),
            },
            "wait_until_cool": {"total_dwell_s": wait_total, "dwell_count": bl.waits.iter().filter(|&&d| d > 0.0).count(),
                "safe": bl.wait_risk.is_none(),
                "first_risk": bl.wait_risk.map(|(i, r)| json!({"i": i, "layer": pl.points[i].layer, "reason": r.as_str()})),
                "its_dwell_before_that_s": bl.waits[..wait_safe_until].iter().sum::<f64>(),
                "risky_points": bl.wait_risks.iter().filter(|r| r.is_some()).count(),
                "risky_layers": wait_failing.iter().map(|(l, c)| json!({"layer": l, "criteria": c})).collect::<Vec<_>>(),
                "planned_dwell_before_that_s": plan.dwell_s()[..wait_safe_until].iter().sum::<f64>()},
        });
        if let Some(d) = uniform.dwell_s {
            summary["ratio_to_uniform"] = json!(planned_there / (d * slots as f64).max(1e-9));
        }
        summary["ratio_to_wait_until_cool"] = json!(total / wait_total.max(1e-9));
    }
    // The pools the search planned against, where the voxel grid may have made them.
    let for_pools = (0..pl.points.len())
        .filter(|&i| c.dwell_s[i] > 0.0 && c.drop[i].is_none())
        .filter(|&i| matches!(plan.reason[i], Some(risk::Risk::Humping | risk::Risk::Bond)))
        .count();
    let run = " of the run without dwells";
    let pools = super::simulate::coarse_pool(b, before, run, Some((for_pools, count)));
    summary["warnings"] = json!(super::simulate::warnings_json(&[], pools.as_slice()));
    super::plan::write_plan(dir, s, b)?;
    for w in pools.iter().chain(&write_thermal(dir, b, after)?) {
        eprintln!("{}", w.line);
    }
    let dwelled = super::simulate::Dwelled {
        before,
        arc_stops_lower_bound: bound.stops,
        confidence: sure,
    };
    record(dir, s, part, b, after, Some(dwelled))?;
    let mut csv = String::from("i,layer,t_s,dwell_s,reason,x_mm,y_mm,z_mm\n");
    for (i, &d) in plan.dwell_s().iter().enumerate() {
        if c.strikes(i) {
            let q = &pl.points[i];
            let reason = match (c.drop[i], plan.reason[i]) {
                (Some(_), _) => "drop",
                (None, r) => r.map_or("", |r| r.as_str()),
            };
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
        "{count} dwells, {total:.0} s in all, {} points slowed, closed by {}: {stops} arc stops; build {:.0} s → {:.0} s; {} points still at risk; search {:.1} {} builds of wall time",
        c.slowed(),
        plan.closing.name(),
        before.build_time_s(),
        after.build_time_s(),
        risky_after.len(),
        search_s / before.wall_clock_s.max(1e-9),
        after.model
    ))
}

/// The revolution-dwell policy's plan: one dwell before each revolution, the closing zone as the
/// search closes it; whether it is safe, and where no dwell before a revolution cures it.
fn revolution_json(b: &Build, p: &DwellPlan) -> Value {
    let c = &p.cooling;
    json!({
        "safe": p.unresolved.is_empty(),
        "arc_stops": c.arc_stops(),
        "total_dwell_s": c.total_dwell_s(),
        "build_time_s": arc_stops::build_time_s(b, p),
        "closing_strategy": p.closing.name(),
        "uncured_revolutions": p.uncured.iter().map(|(layer, r)| json!({"layer": layer, "criterion": r.as_str()})).collect::<Vec<_>>(),
        "unresolved_points": p.unresolved.len(),
    })
}

/// The lower bound on arc stops (`pipeline::bound`), what it rests on and how far the plan is.
fn bound_json(bound: &crate::pipeline::bound::StopsBound, stops: usize) -> Value {
    json!({
        "stops": bound.stops,
        "plan_over_bound": (bound.stops > 0).then(|| stops as f64 / bound.stops as f64),
        "rests_on": "stretches laid without a break from the part cooled to ambient (a comparison principle), at the paces listed, drops no longer than 1.5 bead widths and only in the closing zone; docs/PHYSICS.md",
        "paces": bound.paces,
        "greedy_stops_before_points": bound.at.iter().take(50).collect::<Vec<_>>(),
        "incurable_points": bound.incurable.len(),
        "cost_builds": bound.cost_builds,
    })
}

fn support_name(s: thermal::Support) -> &'static str {
    match s {
        thermal::Support::Plate => "plate",
        thermal::Support::Deposit => "earlier_revolution",
        thermal::Support::JustLaid => "metal_just_laid",
    }
}

fn tried_json(t: &arc_stops::Tried) -> Value {
    json!({"weight_s_per_stop": t.weight_s, "arc_stops": t.arc_stops,
        "total_dwell_s": t.total_dwell_s, "build_time_s": t.build_time_s,
        "slowed_points": t.slowed_points, "drops": t.drops, "closing_strategy": t.closing})
}

/// What slowing down did: how many points, how slow, the least power.
fn slow_down_json(b: &Build, sim: &Simulation) -> Value {
    let slowed: Vec<usize> = (0..sim.pace.len())
        .filter(|&i| sim.pace[i] != 1.0 && sim.drop[i].is_none())
        .collect();
    let layers: std::collections::BTreeSet<usize> =
        slowed.iter().map(|&i| b.plan.points[i].layer).collect();
    let extra_s: f64 = slowed
        .iter()
        .map(|&i| sim.deposits[i].arc_time * (1.0 - 1.0 / sim.pace[i]))
        .fold(0.0, |a, b| a + b);
    json!({
        "points": slowed.len(),
        "revolutions": layers.len(),
        "pace_max": slowed.iter().map(|&i| sim.pace[i]).reduce(f64::max),
        "power_w_min": slowed.iter().map(|&i| b.bead_as_laid(sim, i).power_w).reduce(f64::min),
        "power_w_planned_there_max": slowed.iter().map(|&i| b.beads.beads[i].power_w).reduce(f64::max),
        "extra_arc_time_s": extra_s,
    })
}

/// The closing strategy and how it did: where it starts, and the points still at risk there.
fn closing_json(b: &Build, plan: &DwellPlan, sim: &Simulation) -> Value {
    use crate::pipeline::dwell::Closing;
    let from = match plan.closing {
        Closing::NotNeeded => None,
        Closing::RampDown { from, .. } | Closing::Drops { from, .. } => Some(from),
    };
    let risks = sim.risks(&b.criteria);
    let risky: Vec<usize> = from.map_or(Vec::new(), |f| {
        (f..risks.len()).filter(|&i| risks[i].is_some()).collect()
    });
    let mut v = json!({
        "name": plan.closing.name(),
        "from_point": from,
        "from_layer": from.map(|f| b.plan.points[f].layer),
        "safe": risky.is_empty(),
        "risky_points": risky.len(),
        "risky_layers": risky.iter().map(|&i| b.plan.points[i].layer).collect::<std::collections::BTreeSet<_>>(),
    });
    match plan.closing {
        Closing::NotNeeded => {}
        Closing::RampDown { pace, from } => {
            v["pace"] = json!(pace);
            v["power_w_min"] = json!(b.bead_as_laid(sim, from).power_w);
        }
        Closing::Drops {
            from,
            count,
            longest_wait_s,
        } => {
            let pacing = b.pacing();
            let m = &b.params.material;
            let caps: Vec<_> = pacing
                .drops(from)
                .into_iter()
                .map(|d| pacing.drop_cap(d))
                .collect();
            let r_max = caps.iter().map(|c| c.radius).fold(0.0, f64::max);
            let bond = bead_model::bond::bond_number(m.density_kg_m3, r_max, m.surface_tension_n_m);
            v["drops"] = json!(count);
            v["longest_wait_s"] = json!(longest_wait_s);
            v["total_wait_s"] = json!(plan.cooling.dwell_s[from..].iter().sum::<f64>());
            v["drop_radius_mm_max"] = json!(r_max * 1e3);
            v["drop_bond_max"] = json!(bond);
            v["drop_bond_limit"] = json!(b.params.bead.bond_max);
        }
    }
    v
}

fn first_risk_json(b: &Build, sim: &Simulation) -> Value {
    sim.first_risk(&b.criteria)
        .map(|(i, r)| json!({"i": i, "reason": r.as_str()}))
        .unwrap_or(Value::Null)
}
