//! `waamtwin simulate SCENARIO -o DIR`: plan, beads, and the heat of the build without dwells;
//! thermal.json and layers.csv beside the plan's files.

use crate::commands::checkpoint;
use crate::commands::cost::{Keeps, check, check_plate, part_to_plan};
use crate::error::Result;
use crate::output::RunDir;
use crate::pipeline::checkpoint::Checkpoints;
use crate::pipeline::deposition::Cooling;
use crate::pipeline::{Build, Simulation, resolution};
use crate::progress::Stage;
use crate::record::{Run, Scene};
use crate::scenario::Scenario;
use planner::mesh::Part;
use serde_json::json;
use std::fmt::Write;
use std::path::Path;
use thermal::{Cells, celsius};

pub fn run(scenario: &Path, out: &Path, resume: checkpoint::Options) -> Result<String> {
    let s = Scenario::load(scenario)?;
    let file = scenario.display().to_string();
    let keeps = one_run(&s);
    check_plate(&file, &s.thermal, &s.material, keeps)?;
    let part = part_to_plan(&file, &s.part)?;
    let mut dir = RunDir::create(out)?;
    let b = super::plan::build(&s, &part)?;
    let print = checkpoint::of_run("simulate", &s.to_json(), b.deposits());
    let mut folder = checkpoint::Folder::open(out, "simulate", print, resume)?;
    check(
        &file,
        &b.params.thermal,
        &s.material,
        b.deposits(),
        b.deposits().last().map_or(0.0, |d| d.time),
        Keeps {
            planned: part.mesh.n_vertices(),
            ..keeps
        },
    )?;
    let mut ck = Checkpoints::to(&mut folder);
    let sim = heat(&b, &Cooling::default(), s.output.frames, &mut ck, "heat")?;
    super::plan::write_plan(&mut dir, &s, &b)?;
    for w in write_thermal(&mut dir, &b, &sim)? {
        eprintln!("{}", w.line);
    }
    record(&mut dir, &s, &part, &b, &sim, None)?;
    dir.finish("simulate", s.to_json())?;
    folder.close()?;
    Ok(summary(&b, &sim))
}

/// What one heat run of the scenario keeps (the cost check's input).
pub fn one_run(s: &Scenario) -> Keeps {
    Keeps {
        frames: s.output.frames,
        recorded: s.output.records(),
        ..Keeps::ONE_RUN
    }
}

/// The build heated as `cooling` says, behind a spinner on a terminal; with `frames` > 0 also
/// the step-by-step temperature of the points the temperature-history plot shows.
pub fn heat(
    b: &Build,
    cooling: &Cooling,
    frames: usize,
    ck: &mut Checkpoints<'_>,
    stage: &str,
) -> Result<Simulation> {
    let bar = crate::progress::Bar::start("heating the build", b.plan.points.len() as u64);
    let traces = match frames {
        0 => Vec::new(),
        _ => crate::record::history_points(b.plan.points.len()).to_vec(),
    };
    Ok(
        b.simulate_kept(cooling, frames, traces, ck, stage, &mut |k, n| {
            bar.set(k, n)
        })?,
    )
}

/// The inspection outputs the scenario switches on (`[output]`): run.rrd, run.mcap, fields.h5
/// and the plots. `before` is the same build without dwells, where dwells were planned.
/// What a dwell run adds to its recordings: the run without dwells, the fewest arc stops any
/// plan can make, and how sure the plan is (where planned at a confidence).
pub struct Dwelled<'a> {
    pub before: &'a Simulation,
    pub arc_stops_lower_bound: usize,
    pub confidence: Option<String>,
}

pub fn record(
    dir: &mut RunDir,
    s: &Scenario,
    part: &Part,
    b: &Build,
    sim: &Simulation,
    dwelled: Option<Dwelled<'_>>,
) -> Result<()> {
    let sinks = crate::record::sinks(&s.output);
    if sinks.is_empty() {
        return Ok(());
    }
    let _stage = Stage::start("writing run.rrd, run.mcap, fields.h5 and the plots");
    let planar = planner::planar::slice(part, b.params.process.deposit_m * 1e3);
    let scene = Scene::build(Run {
        s,
        title: &s.title(),
        part: &part.mesh,
        build: b,
        sim,
        before: dwelled.as_ref().map(|d| d.before),
        planar_deposits_mm: Some(planar.all_deposits().collect()),
        arc_stops_lower_bound: dwelled.as_ref().map(|d| d.arc_stops_lower_bound),
        confidence: dwelled.and_then(|d| d.confidence),
    });
    crate::record::record(&scene, sinks, dir)
}

pub fn summary(b: &Build, sim: &Simulation) -> String {
    format!(
        "build {:.0} s, max preheat {:.0} °C{}, energy balance {:.2e}, {:.1} s wall",
        sim.build_time_s(),
        celsius(sim.max_preheat_k()),
        match sim.first_risk(&b.criteria) {
            Some((i, risk)) => format!(
                " (at risk from point {i}: {})",
                b.criteria.breach(&sim.result.points[i], risk)
            ),
            None => String::new(),
        },
        sim.result.balance_error,
        sim.wall_clock_s
    )
}

/// The outputs' `warnings`: what the grid or the path made doubtful before the run and after,
/// each its kind and the line the command showed.
pub fn warnings_json(
    before: &[resolution::Warning],
    after: &[resolution::Warning],
) -> Vec<serde_json::Value> {
    before
        .iter()
        .chain(after)
        .map(|w| json!({"kind": w.kind, "message": w.line}))
        .collect()
}

/// The warning where a voxel run's first point at risk is judged by its pool on cells as tall
/// as the beads ([`resolution::coarse_pool`]); `run` names the run in the line, `dwells` the
/// plan's dwells for pools and all of them.
pub fn coarse_pool(
    b: &Build,
    sim: &Simulation,
    run: &str,
    dwells: Option<(usize, usize)>,
) -> Option<resolution::Warning> {
    if !matches!(sim.result.cells, Cells::Voxel { .. }) {
        return None;
    }
    let voxel_m = b.params.thermal.voxel_m;
    let found = resolution::coarse_pool(&b.criteria, &sim.result.points, b.deposits(), voxel_m);
    found.map(|p| resolution::Warning {
        kind: "coarse_pool",
        line: p.line("thermal.voxel_mm", run, dwells),
    })
}

/// thermal.json, layers.csv, and path.csv again with times, dwells and per-point results.
/// thermal.json's `warnings` are those the run earned before it started (shown with its
/// estimate) and after (the voxel grid's metal against the beads', a pool judged on its cells);
/// the latter are returned, for the command to show.
pub fn write_thermal(
    dir: &mut RunDir,
    b: &Build,
    sim: &Simulation,
) -> Result<Vec<resolution::Warning>> {
    let (pl, params) = (&b.plan, &b.params);
    let built = b.as_built(sim);
    let (err_lo, err_hi) = planner::plan::range(built.iter().map(|b| b.height_error * 1e3));
    let (so_lo, so_hi) = planner::plan::range(built.iter().map(|b| b.stickout * 1e3));
    let r = &sim.result;
    let zone = b.closing_zone(sim);
    let risks = sim.risks(&b.criteria);
    // Revolutions with a point at risk, and whether that point is in the closing zone.
    let mut risky: Vec<(usize, bool)> = Vec::new();
    for (i, q) in pl.points.iter().enumerate() {
        if risks[i].is_some() {
            match risky.last_mut() {
                Some(last) if last.0 == q.layer => last.1 |= zone[i],
                _ => risky.push((q.layer, zone[i])),
            }
        }
    }
    let (wall_nodes, plate_cells, voxels, cg_iterations, updates) = match r.cells {
        Cells::ThinWall {
            wall_nodes,
            plate_cells,
            cg_iterations,
            node_steps,
        } => (
            Some(wall_nodes),
            Some(plate_cells),
            None,
            cg_iterations,
            node_steps,
        ),
        Cells::Voxel {
            voxels, updates, ..
        } => (None, None, Some(voxels), 0, updates),
    };
    let metal = resolution::metal(r, b.deposits());
    let first = sim.first_risk(&b.criteria);
    let window_mm = [params.process.deposit_min_m, params.process.deposit_max_m].map(|m| m * 1e3);
    let after: Vec<resolution::Warning> = metal
        .and_then(resolution::Metal::warning)
        .into_iter()
        .chain(resolution::infeasible(pl, &zone, window_mm))
        .chain(coarse_pool(b, sim, "", None))
        .collect();
    let before = resolution::before_run(&params.thermal, b.deposits(), "thermal.voxel_mm");
    let warnings = warnings_json(&before, &after);
    let json = json!({
        "model": sim.model,
        "energy_in_j": r.ledger.energy_in(),
        "energy_balance_error": r.balance_error,
        "energy_stored_j": r.stored,
        "energy_lost_j": {"convection": r.ledger.convection, "radiation": r.ledger.radiation, "table": r.ledger.table},
        "max_preheat_c": celsius(sim.max_preheat_k()),
        "interpass_max_c": celsius(params.dwell.interpass_max_k),
        "first_overheat": first.map(|(i, _)| i),
        // What that point breaks: interpass, strength, humping or bond.
        "first_overheat_reason": first.map(|(_, r)| r.as_str()),
        "risky_revolutions": risky.iter().map(|&(layer, _)| layer).collect::<Vec<_>>(),
        "risk_in_closing_zone": risky.iter().any(|&(_, zone)| zone),
        "closing_zone_mm": pl.closing_point.map(|_| params.dwell.closing_zone_mm),
        "build_time_s": sim.build_time_s(),
        "probe": crate::record::probe(sim).map(|p| json!({"point": p.point, "frame": p.frame, "t_s": p.t_s, "temperature_c": p.temperature_c})),
        "wall_nodes": wall_nodes,
        "plate_cells": plate_cells,
        "voxels": voxels,
        // The metal the voxel grid laid and the beads' (null on the thin wall).
        "metal_mm3": metal.map(|m| m.mm3()[0]),
        "beads_mm3": metal.map(|m| m.mm3()[1]),
        // What the grid or the path made doubtful (`pipeline::resolution`), each a kind and
        // the line the command showed.
        "warnings": warnings,
        "steps": r.steps,
        "cg_iterations": cg_iterations,
        // Node steps or voxel updates: the heat model's work, whatever its rates.
        "cell_updates": updates,
        "underpowered_deposits": r.underpowered,
        "as_built": {
            "hot_height_loss_per_k": params.bead.hot_metal.height_loss_per_k,
            "height_error_mm": {"min": err_lo, "max": err_hi},
            "stickout_mm": {"min": so_lo, "max": so_hi},
        },
        // Wall-clock seconds of the heat model (the interface's name).
        "wall_s": sim.wall_clock_s,
    });
    dir.write_json("thermal.json", &json)?;
    let mut zone_layers = vec![false; pl.points.last().map_or(0, |q| q.layer + 1)];
    for (q, &z) in pl.points.iter().zip(&zone) {
        zone_layers[q.layer] |= z;
    }
    let mut csv = String::from(
        "layer,t_start_s,duration_s,preheat_max_c,preheat_mean_c,dwell_s,risk,closing_zone,pace_max,drops\n",
    );
    // A revolution's risk: the first its points break, judged as thermal.json and dwell.json
    // judge them.
    let mut layer_risk: Vec<Option<&str>> = vec![None; zone_layers.len()];
    for (q, r) in pl.points.iter().zip(&risks) {
        if layer_risk[q.layer].is_none() {
            layer_risk[q.layer] = r.map(|r| r.as_str());
        }
    }
    for l in b.layers(sim) {
        let risk = layer_risk[l.layer].unwrap_or("");
        let _ = writeln!(
            csv,
            "{},{:.3},{:.3},{:.2},{:.2},{:.3},{risk},{},{:.3},{}",
            l.layer,
            l.t_start_s,
            l.duration_s,
            celsius(l.preheat_max_k),
            celsius(l.preheat_mean_k),
            l.dwell_s,
            u8::from(zone_layers[l.layer]),
            l.pace_max,
            l.drops
        );
    }
    dir.write("layers.csv", csv.as_bytes())?;
    let mut path = format!(
        "{},preheat_c,peak_c,pool_length_mm,time_above_s,built_height_mm,built_width_mm,stickout_mm,pace,drop\n",
        super::plan::PATH_COLUMNS
    );
    for (i, q) in pl.points.iter().enumerate() {
        let (d, p) = (&sim.deposits[i], &r.points[i]);
        let bead = b.bead_as_laid(sim, i);
        super::plan::path_row(&mut path, i, q, &bead, d.time, sim.dwell_s[i]);
        let _ = writeln!(
            path,
            ",{:.2},{:.2},{:.3},{:.3},{:.5},{:.5},{:.4},{:.4},{}",
            celsius(p.preheat),
            celsius(p.peak),
            p.pool_length * 1e3,
            p.time_above,
            built[i].height * 1e3,
            built[i].width * 1e3,
            built[i].stickout * 1e3,
            sim.pace[i],
            // 0: a running torch; 1: a drop strikes here; 2: the drop goes on.
            match sim.drop[i] {
                None => 0,
                Some(thermal::schedule::DropPart::Strikes { .. }) => 1,
                Some(thermal::schedule::DropPart::Continues) => 2,
            }
        );
    }
    dir.write("path.csv", path.as_bytes())?;
    Ok(after)
}
