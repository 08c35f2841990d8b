//! `waamtwin simulate SCENARIO -o DIR`: plan, beads, and the heat of the build without dwells;
//! thermal.json and layers.csv beside the plan's files.

use crate::beads::beads;
use crate::deposition::{schedule, wall_settings};
use crate::error::{Error, Result};
use crate::output::RunDir;
use crate::part::load_part;
use crate::progress::Stage;
use crate::record::{Run, Scene};
use crate::scenario::{Scenario, ThermalModel};
use planner::mesh::Part;
use planner::plan::Plan;
use serde_json::json;
use std::fmt::Write;
use std::path::Path;
use std::time::Instant;
use thermal::schedule::Deposit;
use thermal::voxel::{VoxelModel, VoxelSettings};
use thermal::wall::{Support, WallModel, WallResult};

const C: f64 = 273.15;

/// A simulated build: the schedule and what the thermal model made of it.
pub struct Simulation {
    pub deposits: Vec<Deposit>,
    pub result: WallResult,
    pub wall_s: f64,
    /// What each deposit is laid on.
    pub support: Vec<Support>,
}

/// Simulate the build with `dwell_s[i]` before point i, keeping the field at up to `frames`
/// times for the inspection outputs (0: none).
pub fn simulate(s: &Scenario, pl: &Plan, dwell_s: &[f64], frames: usize) -> Result<Simulation> {
    let b = beads(s, pl);
    let deposits = schedule(s, pl, &b, dwell_s);
    let build_s = deposits.last().map_or(0.0, |d| d.time);
    let times = match frames {
        0 => Vec::new(),
        n => crate::record::frame_times(build_s, deposits.len(), n),
    };
    let settings = wall_settings(s, &deposits, times);
    let clock = Instant::now();
    let _stage = Stage::start("simulating the heat of the build");
    let result = match s.thermal.model {
        ThermalModel::Fe => {
            let model = WallModel::build(&deposits, &settings)
                .map_err(|e| Error::input(format!("thermal: {e}")))?;
            model.run(&deposits, &settings, 0.0)
        }
        ThermalModel::Voxel => voxel(&deposits, &settings, s)?,
    };
    let support = result.support.clone();
    Ok(Simulation {
        deposits,
        result,
        wall_s: clock.elapsed().as_secs_f64(),
        support,
    })
}

/// The voxel model on the same schedule: per point the preheat, peak, time above the threshold
/// and pool, the energy ledger, and the field at the frame times (a temperature per deposit,
/// which the recording maps onto the wall as it does the thin wall's nodes).
fn voxel(
    deposits: &[Deposit],
    w: &thermal::wall::WallSettings,
    s: &Scenario,
) -> Result<WallResult> {
    let settings = VoxelSettings {
        material: w.material.clone(),
        surroundings: w.surroundings,
        plate: w.plate.clone(),
        size: s.thermal.voxel_m,
        deposit_temperature: w.deposit_temperature,
        lead: w.lead,
        hot_threshold: w.hot_threshold,
        snapshot_times: w.snapshot_times.clone(),
        courant: 0.9,
    };
    let model =
        VoxelModel::new(deposits, &settings).map_err(|e| Error::input(format!("thermal: {e}")))?;
    let r = model.run(deposits);
    Ok(WallResult {
        points: r.points,
        ledger: r.ledger,
        stored: r.stored,
        balance_error: r.balance_error,
        node_positions: Vec::new(),
        node_of_deposit: (0..deposits.len()).collect(),
        n_wall_nodes: r.voxels, // reported as "voxels" in thermal.json
        snapshots: r.snapshots,
        final_temperature: Vec::new(),
        steps: r.steps,
        cg_iterations: 0,
        underpowered: r.underpowered,
        support: deposits
            .iter()
            .map(|d| {
                if d.support.is_some() {
                    Support::Deposit
                } else {
                    Support::Plate
                }
            })
            .collect(),
    })
}

pub fn run(scenario: &Path, out: &Path) -> Result<String> {
    let s = Scenario::load(scenario)?;
    let part = load_part(&s.part)?;
    let mut dir = RunDir::create(out)?;
    let pl = super::plan::plan_part(&s, &part)?;
    let sim = simulate(&s, &pl, &[], s.output.frames)?;
    super::plan::write_plan(&mut dir, &s, &pl)?;
    let no_dwell = vec![0.0; pl.points.len()];
    write_thermal(&mut dir, &s, &pl, &sim, &no_dwell)?;
    record(&mut dir, &s, &part, &pl, &sim, &no_dwell, None)?;
    dir.finish("simulate", s.to_json())?;
    Ok(summary(&s, &sim))
}

/// The inspection outputs the scenario switches on (`[output]`): run.rrd, run.mcap, fields.h5
/// and the plots. `before` is the same build without dwells, where dwells were planned.
pub fn record(
    dir: &mut RunDir,
    s: &Scenario,
    part: &Part,
    pl: &Plan,
    sim: &Simulation,
    dwell_s: &[f64],
    before: Option<&Simulation>,
) -> Result<()> {
    let sinks = crate::record::sinks(s);
    if sinks.is_empty() {
        return Ok(());
    }
    let _stage = Stage::start("writing run.rrd, run.mcap, fields.h5 and the plots");
    let planar = planner::planar::slice(part, s.process.deposit_m * 1e3);
    let scene = Scene::build(Run {
        s,
        title: &s.title(),
        part: &part.mesh,
        plan: pl,
        beads: &beads(s, pl),
        sim,
        dwell_s,
        before,
        planar_deposits_mm: Some(planar.all_deposits().collect()),
    });
    crate::record::record(&scene, sinks, dir)
}

pub fn summary(s: &Scenario, sim: &Simulation) -> String {
    let max = sim
        .result
        .points
        .iter()
        .map(|p| p.preheat)
        .fold(f64::NEG_INFINITY, f64::max);
    let first = first_overheat(s, sim);
    format!(
        "build {:.0} s, max preheat {:.0} °C{}, energy balance {:.2e}, {:.1} s wall",
        sim.deposits.last().map_or(0.0, |d| d.time),
        max - C,
        match first {
            Some(i) => format!(
                " (over {:.0} °C from point {i})",
                s.dwell.interpass_max_k - C
            ),
            None => String::new(),
        },
        sim.result.balance_error,
        sim.wall_s
    )
}

/// The first point at risk by the scenario's criteria (the interpass limit among them).
pub fn first_overheat(s: &Scenario, sim: &Simulation) -> Option<usize> {
    (0..sim.result.points.len())
        .find(|&i| crate::risk::judge(s, &sim.result.points[i], sim.support[i], 0.0).is_some())
}

/// Per revolution: start, duration, preheat max and mean, dwell, risk.
pub struct LayerRow {
    pub layer: usize,
    pub t_start_s: f64,
    pub duration_s: f64,
    pub preheat_max_k: f64,
    pub preheat_mean_k: f64,
    pub dwell_s: f64,
}

pub fn layers(pl: &Plan, sim: &Simulation, dwell_s: &[f64]) -> Vec<LayerRow> {
    let mut rows: Vec<LayerRow> = Vec::new();
    for (i, q) in pl.points.iter().enumerate() {
        let d = &sim.deposits[i];
        let pre = sim.result.points[i].preheat;
        let dwell = dwell_s.get(i).copied().unwrap_or(0.0);
        match rows.last_mut() {
            Some(r) if r.layer == q.layer => {
                r.duration_s = d.time - r.t_start_s;
                r.preheat_max_k = r.preheat_max_k.max(pre);
                r.preheat_mean_k += pre;
                r.dwell_s += dwell;
            }
            _ => rows.push(LayerRow {
                layer: q.layer,
                t_start_s: d.arc_start() - dwell,
                duration_s: d.time - d.arc_start() + dwell,
                preheat_max_k: pre,
                preheat_mean_k: pre,
                dwell_s: dwell,
            }),
        }
    }
    for r in &mut rows {
        let n = pl
            .points
            .iter()
            .filter(|q| q.layer == r.layer)
            .count()
            .max(1);
        r.preheat_mean_k /= n as f64;
    }
    rows
}

/// Predicted as-built beads: the plan's deposits stacked with the hot-metal law at the simulated
/// preheat (bead model, `[bead]`).
pub fn as_built(s: &Scenario, pl: &Plan, sim: &Simulation) -> Vec<bead_model::as_built::BuiltBead> {
    let planned: Vec<f64> = pl.points.iter().map(|q| q.deposit_mm * 1e-3).collect();
    let generator: Vec<usize> = pl.points.iter().map(|q| q.generator).collect();
    let preheat: Vec<f64> = sim.result.points.iter().map(|p| p.preheat).collect();
    bead_model::as_built::stack(
        &planned,
        &generator,
        &preheat,
        s.process.bead_width_m,
        s.bead.stickout_m,
        &s.bead.hot_metal,
    )
}

/// thermal.json, layers.csv, and path.csv again with times, dwells and per-point results.
pub fn write_thermal(
    dir: &mut RunDir,
    s: &Scenario,
    pl: &Plan,
    sim: &Simulation,
    dwell_s: &[f64],
) -> Result<()> {
    let built = as_built(s, pl, sim);
    let (err_lo, err_hi) = planner::plan::range(built.iter().map(|b| b.height_error * 1e3));
    let (so_lo, so_hi) = planner::plan::range(built.iter().map(|b| b.stickout * 1e3));
    let r = &sim.result;
    let zone = crate::risk::closing_zone(s, pl);
    // Revolutions with a point at risk, and whether that point is in the closing zone.
    let mut risky: Vec<(usize, bool)> = Vec::new();
    for (i, q) in pl.points.iter().enumerate() {
        if crate::risk::judge(s, &r.points[i], sim.support[i], 0.0).is_some() {
            match risky.last_mut() {
                Some(last) if last.0 == q.layer => last.1 |= zone[i],
                _ => risky.push((q.layer, zone[i])),
            }
        }
    }
    let max_preheat = r
        .points
        .iter()
        .map(|p| p.preheat)
        .fold(f64::NEG_INFINITY, f64::max);
    let json = json!({
        "model": match s.thermal.model { ThermalModel::Fe => "fe", ThermalModel::Voxel => "voxel" },
        "energy_in_j": r.ledger.energy_in(),
        "energy_balance_error": r.balance_error,
        "energy_stored_j": r.stored,
        "energy_lost_j": {"convection": r.ledger.convection, "radiation": r.ledger.radiation, "table": r.ledger.table},
        "max_preheat_c": max_preheat - C,
        "interpass_max_c": s.dwell.interpass_max_k - C,
        "first_overheat": first_overheat(s, sim),
        "risky_revolutions": risky.iter().map(|&(layer, _)| layer).collect::<Vec<_>>(),
        "risk_in_closing_zone": risky.iter().any(|&(_, zone)| zone),
        "closing_zone_mm": pl.closing_point.map(|_| s.dwell.closing_zone_mm),
        "build_time_s": sim.deposits.last().map_or(0.0, |d| d.time),
        "probe": crate::record::probe(sim).map(|p| json!({"point": p.point, "frame": p.frame, "t_s": p.t_s, "temperature_c": p.temperature_c})),
        // The voxel run carries its active voxel count where the thin wall has its nodes.
        "wall_nodes": (s.thermal.model == ThermalModel::Fe).then_some(r.n_wall_nodes),
        "plate_cells": (s.thermal.model == ThermalModel::Fe).then(|| r.node_positions.len().saturating_sub(r.n_wall_nodes)),
        "voxels": (s.thermal.model == ThermalModel::Voxel).then_some(r.n_wall_nodes),
        "steps": r.steps,
        "cg_iterations": r.cg_iterations,
        "underpowered_deposits": r.underpowered,
        "as_built": {
            "hot_height_loss_per_k": s.bead.hot_metal.height_loss_per_k,
            "height_error_mm": {"min": err_lo, "max": err_hi},
            "stickout_mm": {"min": so_lo, "max": so_hi},
        },
        "wall_s": sim.wall_s,
    });
    dir.write_json("thermal.json", &json)?;
    let mut zone_layers = vec![false; pl.points.last().map_or(0, |q| q.layer + 1)];
    for (q, &z) in pl.points.iter().zip(&zone) {
        zone_layers[q.layer] |= z;
    }
    let mut csv = String::from(
        "layer,t_start_s,duration_s,preheat_max_c,preheat_mean_c,dwell_s,risk,closing_zone\n",
    );
    for l in layers(pl, sim, dwell_s) {
        let risk = if l.preheat_max_k > s.dwell.interpass_max_k {
            "interpass"
        } else {
            ""
        };
        let _ = writeln!(
            csv,
            "{},{:.3},{:.3},{:.2},{:.2},{:.3},{risk},{}",
            l.layer,
            l.t_start_s,
            l.duration_s,
            l.preheat_max_k - C,
            l.preheat_mean_k - C,
            l.dwell_s,
            u8::from(zone_layers[l.layer])
        );
    }
    dir.write("layers.csv", csv.as_bytes())?;
    let mut path = format!(
        "{},preheat_c,peak_c,pool_length_mm,time_above_s,built_height_mm,built_width_mm,stickout_mm\n",
        super::plan::PATH_COLUMNS
    );
    let b = beads(s, pl);
    for (i, q) in pl.points.iter().enumerate() {
        let (d, p) = (&sim.deposits[i], &r.points[i]);
        super::plan::path_row(
            &mut path,
            i,
            q,
            &b.beads[i],
            d.time,
            dwell_s.get(i).copied().unwrap_or(0.0),
        );
        let _ = writeln!(
            path,
            ",{:.2},{:.2},{:.3},{:.3},{:.5},{:.5},{:.4}",
            p.preheat - C,
            p.peak - C,
            p.pool_length * 1e3,
            p.time_above,
            built[i].height * 1e3,
            built[i].width * 1e3,
            built[i].stickout * 1e3
        );
    }
    dir.write("path.csv", path.as_bytes())?;
    Ok(())
}
