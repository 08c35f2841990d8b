//! `waamtwin plan SCENARIO -o DIR --strategy tube-perpendicular|tube-non-planar`: the layered
//! paths of Chalvin et al. 2019 on a `quarter_torus` part ([`planner::tube`]), beside CTPP's
//! spiral on the same part: path.csv (the deposit of each point its local inter-layer
//! distance, the bead laid for it by Eq.7, a `strike` column where the arc is struck: each layer
//! is its own bead), interlayer.csv and interlayer.png (the map of the distance against Δ), and
//! plan.json with the statistics.

use crate::commands::plan::{PATH_COLUMNS, path_row};
use crate::error::{Error, Result};
use crate::output::RunDir;
use crate::pipeline::beads::beads;
use crate::scenario::{PartSource, Scenario};
use planner::interlayer::{Spread, layer_ranges};
use planner::plan::PathPoint;
use planner::shapes::Shape;
use planner::tube::{LaidTube, QuarterTorus, Strategy, lay, path};
use serde_json::{Value, json};
use std::fmt::Write;
use std::path::Path;

/// Plan the tube strategy on the scenario's quarter torus and write its files; the summary line.
pub fn write(dir: &mut RunDir, s: &Scenario, file: &Path, strategy: Strategy) -> Result<String> {
    let file = file.display();
    let torus = torus(s, &file.to_string())?;
    let p = s.plan_params();
    let tube = path(&torus, strategy, p.deposit_mm, s.planner.n_points)
        .map_err(|e| Error::input(format!("{file}: {e}")))?;
    let laid = lay(&tube, &p.nozzle, &p.torch);
    let b = beads(&s.process, &s.material, &laid.points);
    let spread = Spread::of(laid.points.iter().map(|q| Some(q.deposit_mm)), p.deposit_mm)
        .ok_or_else(|| Error::input(format!("{file}: the tube has no layer")))?;
    dir.write("path.csv", path_csv(&laid.points, &b.beads).as_bytes())?;
    dir.write(
        "interlayer.csv",
        interlayer_csv(&laid.points, &torus, p.deposit_mm).as_bytes(),
    )?;
    #[cfg(feature = "recording")]
    crate::record::interlayer_map(
        dir,
        &format!("{} on the quarter torus", strategy.name()),
        &map_points(&laid.points, &torus, p.deposit_mm),
        "v, degrees round the tube (0 the outer side)",
    )?;
    let (lo, hi) = spread.variation_pct();
    let n_layers = layer_ranges(&laid.points.iter().map(|q| q.layer).collect::<Vec<_>>()).len();
    let json = plan_json(
        s,
        strategy,
        &torus,
        &laid,
        &spread,
        &b.outside_window,
        n_layers,
    );
    dir.write_json("plan.json", &json)?;
    Ok(format!(
        "{}: {n_layers} layers, {} points, inter-layer distance {:.3}..{:.3} mm ({lo:+.1} %..{hi:+.1} % of Δ {} mm), {} outside the window",
        strategy.name(),
        laid.points.len(),
        spread.min_mm,
        spread.max_mm,
        p.deposit_mm,
        b.outside_window.len()
    ))
}

fn torus(s: &Scenario, file: &str) -> Result<QuarterTorus> {
    match &s.part.source {
        PartSource::Shape {
            shape:
                Shape::QuarterTorus {
                    bend_radius_mm,
                    tube_radius_mm,
                },
            ..
        } => Ok(QuarterTorus {
            bend_radius_mm: *bend_radius_mm,
            tube_radius_mm: *tube_radius_mm,
        }),
        _ => Err(Error::input(format!(
            "{file}: [part] is {}; the tube strategies need shape = \"quarter_torus\"",
            s.title()
        ))),
    }
}

/// path.csv's contract columns and `strike` (1 where the arc is struck before the point: the
/// first of each layer, and of each arc where a layer is cut by the upper boundary).
fn path_csv(points: &[PathPoint], beads: &[crate::pipeline::beads::Bead]) -> String {
    let mut csv = format!("{PATH_COLUMNS},strike\n");
    let mut t = 0.0;
    for (i, (q, bead)) in points.iter().zip(beads).enumerate() {
        let strike =
            i == 0 || q.layer != points[i - 1].layer || q.generator != points[i - 1].generator + 1;
        if i > 0 && !strike {
            t += (q.position - points[i - 1].position).norm() * 1e-3 / bead.travel_m_s;
        }
        path_row(&mut csv, i, q, bead, t, 0.0);
        let _ = writeln!(csv, ",{}", u8::from(strike));
    }
    csv
}

fn interlayer_csv(points: &[PathPoint], torus: &QuarterTorus, delta: f64) -> String {
    let mut csv = String::from("i,layer,u_deg,v_deg,distance_mm,variation_pct\n");
    for (i, q) in points.iter().enumerate() {
        let (u, v) = torus.uv(&q.position);
        let _ = writeln!(
            csv,
            "{i},{},{:.4},{:.4},{:.5},{:.3}",
            q.layer,
            u.to_degrees(),
            v.to_degrees(),
            q.deposit_mm,
            100.0 * (q.deposit_mm / delta - 1.0)
        );
    }
    csv
}

/// (v in degrees, layer, variation %) per point, for the map.
#[cfg(feature = "recording")]
fn map_points(points: &[PathPoint], torus: &QuarterTorus, delta: f64) -> Vec<(f64, f64, f64)> {
    points
        .iter()
        .map(|q| {
            let (_, v) = torus.uv(&q.position);
            (
                v.to_degrees(),
                q.layer as f64,
                100.0 * (q.deposit_mm / delta - 1.0),
            )
        })
        .collect()
}

pub fn spread_json(s: &Spread) -> Value {
    let (lo, hi) = s.variation_pct();
    json!({"nominal_mm": s.nominal_mm, "n_points": s.n_points, "min_mm": s.min_mm, "max_mm": s.max_mm,
        "mean_mm": s.mean_mm, "min_variation_pct": lo, "max_variation_pct": hi})
}

fn plan_json(
    s: &Scenario,
    strategy: Strategy,
    torus: &QuarterTorus,
    laid: &LaidTube,
    spread: &Spread,
    outside: &[usize],
    n_layers: usize,
) -> Value {
    let p = s.plan_params();
    let errors = &laid.build_error_deg;
    let c = &laid.collisions;
    let (dlo, dhi) = planner::plan::range(laid.points.iter().map(|q| q.deposit_mm));
    json!({
        "strategy": format!("tube_{}", strategy.name()),
        "source": "Chalvin, Campocasso, Baizeau, Hugel 2019, §2 (Eq.1, Eq.2), §3.1",
        "part_kind": "open",
        "torus": {"bend_radius_mm": torus.bend_radius_mm, "tube_radius_mm": torus.tube_radius_mm},
        "layer_mm": p.deposit_mm,
        "points_per_layer": s.planner.n_points,
        "n_layers": n_layers,
        "n_points": laid.points.len(),
        "deposit_mm": {"min": dlo, "max": dhi},
        "interlayer": spread_json(spread),
        "window_deposit_mm": {"min": p.deposit_min_mm, "max": p.deposit_max_mm},
        "window_violations_total": outside.len(),
        "feasible": outside.is_empty(),
        "build_direction_numeric_vs_analytic_deg": {
            "mean": errors.iter().sum::<f64>() / errors.len().max(1) as f64,
            "max": errors.iter().copied().fold(0.0, f64::max),
        },
        "collisions": {"detected": c.detected.len(),
            "resolved": c.detected.len() - c.detected.iter().filter(|i| c.unresolved.contains(i)).count(),
            "unresolved": c.unresolved.len(),
            "max_rotation_deg": c.max_rotation_deg},
        "tool": {"lead_deg": p.torch.lead_deg, "side_deg": p.torch.side_deg,
            "rate_max_deg_mm": p.torch.max_rate_deg_mm,
            "rate_asked_max_deg_mm": laid.rate_limit.max_asked_deg_mm,
            "rate_limited_points": laid.rate_limit.limited},
    })
}
