//! `waamtwin plan SCENARIO -o DIR [--strategy ctpp|planar]`: plan.json, generators.csv, path.csv.

use crate::cli::Strategy;
use crate::error::Result;
use crate::output::RunDir;
use crate::part::load_part;
use crate::pipeline::Build;
use crate::pipeline::beads::{Bead, Beads};
use crate::progress::Stage;
use crate::scenario::Scenario;
use bead_model::eq7;
use bead_model::window::Modulation;
use planner::mesh::Part;
use planner::plan::{Plan, range};
use planner::planar;
use planner::tube;
use serde_json::{Value, json};
use std::fmt::Write;
use std::path::Path;

/// Violations listed in plan.json; the total is always given.
const MAX_LISTED_VIOLATIONS: usize = 1000;

/// Plan a scenario's part (CTPP) and lay out its build. Errors of the part's shape (branching,
/// too short) are input errors.
pub fn build(s: &Scenario, part: &Part) -> Result<Build> {
    let _stage = Stage::start("planning the spiral");
    Ok(crate::pipeline::build(part, &s.plan_params(), s.params())?)
}

pub fn run(scenario: &Path, out: &Path, strategy: Strategy) -> Result<String> {
    let s = Scenario::load(scenario)?;
    // The tube strategies lay their layers on the analytic torus; no mesh is needed.
    // CTPP's geodesics hold the heat method's factors: a part too fine to plan is refused
    // before it is meshed; planar slicing holds the mesh alone.
    let part = match strategy {
        Strategy::Ctpp => Some(super::cost::part_to_plan(
            &scenario.display().to_string(),
            &s.part,
        )?),
        Strategy::Planar => Some(load_part(&s.part)?),
        _ => None,
    };
    let part = || part.as_ref().expect("loaded for mesh strategies");
    let mut dir = RunDir::create(out)?;
    let line = match strategy {
        Strategy::Ctpp => {
            let b = build(&s, part())?;
            write_plan(&mut dir, &s, &b)?;
            summary(&b.plan)
        }
        Strategy::Planar => write_planar(&mut dir, &s, part())?,
        Strategy::TubePerpendicular => {
            super::tube::write(&mut dir, &s, scenario, tube::Strategy::PerpendicularToAxis)?
        }
        Strategy::TubeNonPlanar => {
            super::tube::write(&mut dir, &s, scenario, tube::Strategy::NonPlanar)?
        }
    };
    dir.finish("plan", s.to_json())?;
    Ok(line)
}

pub fn summary(pl: &Plan) -> String {
    let (lo, hi) = pl.deposit_range();
    format!(
        "{} part: {} generators ({} filled), {} revolutions, deposits {lo:.3}..{hi:.3} mm, {} ({} violations)",
        pl.kind.as_str(),
        pl.generators.len(),
        pl.n_filled,
        pl.spiral.n_revolutions(),
        if pl.feasible() {
            "feasible"
        } else {
            "not feasible"
        },
        pl.violations.len()
    )
}

/// plan.json, generators.csv and path.csv of a CTPP plan.
pub fn write_plan(dir: &mut RunDir, s: &Scenario, b: &Build) -> Result<()> {
    let pl = &b.plan;
    let mut json = plan_json(s, pl);
    json["bead"] = bead_json(s, pl, &b.beads);
    json["interlayer"] = write_interlayer(dir, s, pl)?;
    json["plate"] = plate_json(b);
    dir.write_json("plan.json", &json)?;
    dir.write("generators.csv", generators_csv(pl).as_bytes())?;
    dir.write("path.csv", path_csv(b).as_bytes())?;
    Ok(())
}

/// The plate the heat models run on: its size, where it lies, and whether it was fitted to the
/// part (`[thermal] plate_mm` left out) or given.
fn plate_json(b: &Build) -> Value {
    let t = &b.params.thermal;
    let centre = crate::pipeline::deposition::plate_centre(b.deposits());
    let footprint = crate::pipeline::footprint_m(b.deposits());
    json!({
        "size_mm": t.plate_m.map(|v| v * 1e3),
        "centre_mm": centre.map(|v| v * 1e3),
        "source": if t.plate_fit { "fitted" } else { "scenario" },
        "footprint_mm": footprint.map(|v| v * 1e3),
        "margin_mm": crate::pipeline::PLATE_MARGIN_M * 1e3,
        "shape": if t.plate_disc { "disc" } else { "box" },
    })
}

/// The local inter-layer distance of the spiral (each point against the closest of the
/// revolution beneath; the first revolution, on the plate, left out), as the tube strategies
/// have it: interlayer.csv, interlayer.png, and its spread for plan.json.
fn write_interlayer(dir: &mut RunDir, s: &Scenario, pl: &Plan) -> Result<Value> {
    let positions: Vec<_> = pl.points.iter().map(|q| q.position).collect();
    let layers: Vec<usize> = pl.points.iter().map(|q| q.layer).collect();
    let distances = planner::interlayer::distances(&positions, &layers, None);
    let delta = s.plan_params().deposit_mm;
    let ranges = planner::interlayer::layer_ranges(&layers);
    let mut csv = String::from("i,layer,around_deg,distance_mm,variation_pct\n");
    let mut map = Vec::new();
    for r in &ranges {
        for i in r.clone() {
            let Some(d) = distances[i] else { continue };
            let around = 360.0 * (i - r.start) as f64 / r.len() as f64;
            let pct = 100.0 * (d / delta - 1.0);
            let _ = writeln!(csv, "{i},{},{around:.3},{d:.5},{pct:.3}", layers[i]);
            map.push((around, layers[i] as f64, pct));
        }
    }
    dir.write("interlayer.csv", csv.as_bytes())?;
    #[cfg(feature = "recording")]
    if !map.is_empty() {
        crate::record::interlayer_map(
            dir,
            &format!("CTPP on the {}", s.title()),
            &map,
            "degrees round the revolution from the seam",
        )?;
    }
    Ok(planner::interlayer::Spread::of(distances, delta)
        .map_or(Value::Null, |sp| super::tube::spread_json(&sp)))
}

fn bead_json(s: &Scenario, pl: &Plan, b: &Beads) -> Value {
    let r = |f: &dyn Fn(&Bead) -> f64| {
        let (lo, hi) = range(b.beads.iter().map(f));
        minmax(lo, hi)
    };
    let listed: Vec<Value> = b
        .outside_window
        .iter()
        .take(MAX_LISTED_VIOLATIONS)
        .map(|&i| {
            let q = &pl.points[i];
            json!({"i": i, "layer": q.layer, "generator": q.generator, "deposit_mm": q.deposit_mm})
        })
        .collect();
    json!({
        "modulation": match s.process.modulation { Modulation::WireFeed { .. } => "wire_feed", Modulation::TravelSpeed { .. } => "travel_speed" },
        "section": format!("{:?}", s.process.section).to_lowercase(),
        "window_deposit_mm": minmax(b.window_m.0 * 1e3, b.window_m.1 * 1e3),
        "window_violations_total": b.outside_window.len(),
        "window_violations": listed,
        "wfs_m_min": r(&|x| x.wfs_m_s * 60.0),
        "travel_mm_s": r(&|x| x.travel_m_s * 1e3),
        "arc_power_w": r(&|x| x.power_w),
        "heat_input_j_mm": r(&|x| x.heat_j_m * 1e-3),
        "bond_number": r(&|x| x.bond),
        "bond_max": s.bead.bond_max,
        "bond_over_max": b.beads.iter().filter(|x| x.bond > s.bead.bond_max).count(),
        "tilt_from_vertical_deg": r(&|x| x.tilt_rad.to_degrees()),
    })
}

/// {min, max} of some values, or null where there are none.
fn minmax_opt(values: impl Iterator<Item = f64>) -> Value {
    let (lo, hi) = range(values);
    if lo > hi { Value::Null } else { minmax(lo, hi) }
}

fn minmax(lo: f64, hi: f64) -> Value {
    json!({"min": lo, "max": hi})
}

pub fn plan_json(s: &Scenario, pl: &Plan) -> Value {
    let p = s.plan_params();
    let (glo, ghi) = pl.generator_length_range();
    let (dlo, dhi) = pl.deposit_range();
    let (slo, shi) = range(pl.points.iter().map(|q| q.step_mm));
    let last_gen = pl.generators.len() - 1;
    let seam = |g: usize| g == 0 || g == last_gen;
    let violations: Vec<Value> = pl
        .violations
        .iter()
        .take(MAX_LISTED_VIOLATIONS)
        .map(|v| {
            json!({"i": v.point, "layer": v.layer, "generator": v.generator, "deposit_mm": v.deposit_mm, "bound_mm": v.bound_mm, "seam": seam(v.generator)})
        })
        .collect();
    let outside = pl
        .points
        .iter()
        .filter(|q| {
            q.deposit_mm < p.deposit_min_mm - p.tolerance_mm
                || q.deposit_mm > p.deposit_max_mm + p.tolerance_mm
        })
        .count();
    json!({
        "strategy": "ctpp",
        "part_kind": pl.kind.as_str(),
        "n_generators": pl.generators.len(),
        "n_filled": pl.n_filled,
        "n_step_layers": pl.spiral.start_up.n_step_layers(),
        "n_layers": pl.spiral.n_layers,
        "n_revolutions": pl.spiral.n_revolutions(),
        "n_points": pl.points.len(),
        "generator_length_mm": minmax(glo, ghi),
        "deposit_mm": minmax(dlo, dhi),
        "step_along_generator_mm": minmax(slo, shi),
        "deposit_share_outside": outside as f64 / pl.points.len().max(1) as f64,
        "closing_point_mm": pl.closing_point.map(|c| json!([c.x, c.y, c.z])),
        "seam": seam_json(pl),
        "feasible": pl.feasible(),
        "feasible_along_generators": slo >= p.deposit_min_mm - 1e-9 && shi <= p.deposit_max_mm + 1e-9,
        "violations_total": pl.violations.len(),
        "violations_at_seam": pl.violations.iter().filter(|v| seam(v.generator)).count(),
        "violations": violations,
        "deviation_mm": {"min": pl.deviation.min_mm, "max": pl.deviation.max_mm, "rms": pl.deviation.rms_mm},
        "collisions": {"detected": pl.collisions.detected.len(),
            "detected_layers": minmax_opt(pl.collisions.detected.iter().map(|&i| pl.points[i].layer as f64)),
            "resolved": pl.collisions.detected.len() - pl.collisions.detected.iter().filter(|i| pl.collisions.unresolved.contains(i)).count(),
            "unresolved": pl.collisions.unresolved.len(),
            "unresolved_points": pl.collisions.unresolved.iter().take(50).map(|&i| json!({"i": i, "layer": pl.points[i].layer,
                "position_mm": [pl.points[i].position.x, pl.points[i].position.y, pl.points[i].position.z]})).collect::<Vec<_>>(),
            "max_rotation_deg": pl.collisions.max_rotation_deg},
        "tool": tool_json(&p.torch, pl),
    })
}

/// How the torch stands (Chalvin Fig. 10) and how fast the tool turns along the path.
fn tool_json(torch: &planner::frame::Torch, pl: &Plan) -> Value {
    let positions: Vec<_> = pl.points.iter().map(|q| q.position).collect();
    let tools: Vec<_> = pl.points.iter().map(|q| q.tool).collect();
    json!({
        "lead_deg": torch.lead_deg,
        "side_deg": torch.side_deg,
        "rate_max_deg_mm": torch.max_rate_deg_mm,
        "rate_asked_max_deg_mm": pl.rate_limit.max_asked_deg_mm,
        "rate_limited_points": pl.rate_limit.limited,
        "rate_found_max_deg_mm": planner::frame::max_rate(&positions, &tools),
    })
}

/// Where the spiral starts, on which generator as the lower loop listed them before the seam
/// was placed, and why (`planner::spiral::Seam`).
fn seam_json(pl: &Plan) -> Value {
    let g = &pl.generators[0];
    let start = g.start();
    json!({
        "generator": 0,
        "lower_loop_generator": pl.seam.first,
        "position_mm": [start.x, start.y, start.z],
        "generator_length_mm": g.length(),
        "reason": pl.seam.reason.key(),
        "n_layers": pl.seam.n_layers,
        "eq5_n_layers": pl.seam.eq5_layers,
        "step_margin_mm": pl.seam.margin_mm,
        "miss_mm": (pl.seam.margin_mm < 0.0).then(|| -pl.seam.margin_mm),
    })
}

fn generators_csv(pl: &Plan) -> String {
    let mut csv = String::from("id,filled,length_mm,x0,y0,z0,x1,y1,z1\n");
    for (i, g) in pl.generators.iter().enumerate() {
        let (a, b) = (g.start(), g.end());
        let _ = writeln!(
            csv,
            "{i},{},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4},{:.4}",
            u8::from(g.filled),
            g.length(),
            a.x,
            a.y,
            a.z,
            b.x,
            b.y,
            b.z
        );
    }
    csv
}

/// The columns of path.csv every command writes (`../shared/interface.md`).
pub const PATH_COLUMNS: &str =
    "i,x,y,z,tool_x,tool_y,tool_z,layer,generator,deposit_mm,wfs_m_min,travel_mm_s,t_s,dwell_s";

/// One path.csv row's contract columns (no line end): wire feed and travel speed from Eq.7 under
/// the scenario's modulation, time from the deposition schedule. Deposit and wire feed at full
/// (round-trip) precision, so that Eq.7 can be checked from the file.
pub fn path_row(
    csv: &mut String,
    i: usize,
    q: &planner::plan::PathPoint,
    bead: &Bead,
    t_s: f64,
    dwell_s: f64,
) {
    let _ = write!(
        csv,
        "{i},{:.4},{:.4},{:.4},{:.6},{:.6},{:.6},{},{},{},{},{},{:.3},{:.3}",
        q.position.x,
        q.position.y,
        q.position.z,
        q.tool.x,
        q.tool.y,
        q.tool.z,
        q.layer,
        q.generator,
        q.deposit_mm,
        bead.wfs_m_s * 60.0,
        bead.travel_m_s * 1e3,
        t_s,
        dwell_s
    );
}

fn path_csv(b: &Build) -> String {
    let deposits = b.deposits();
    let mut csv = format!("{PATH_COLUMNS}\n");
    for (i, (q, bead)) in b.plan.points.iter().zip(&b.beads.beads).enumerate() {
        path_row(&mut csv, i, q, bead, deposits[i].time, 0.0);
        csv.push('\n');
    }
    csv
}

/// The planar baseline: slices every h, the local deposit each asks for, and the top remainder.
fn write_planar(dir: &mut RunDir, s: &Scenario, part: &Part) -> Result<String> {
    let p = s.plan_params();
    crate::pipeline::seat::check(part, p.deposit_mm).map_err(crate::pipeline::Error::Unseated)?;
    let sl = planar::slice(part, p.deposit_mm);
    let all: Vec<f64> = sl.all_deposits().collect();
    let (lo, hi) = range(all.iter().copied());
    let inside =
        |d: f64| d >= p.deposit_min_mm - p.tolerance_mm && d <= p.deposit_max_mm + p.tolerance_mm;
    let outside = all.iter().filter(|&&d| !inside(d)).count();
    let c = part.lower_loop().centroid;
    let mut csv = String::from(
        "i,x,y,z,tool_x,tool_y,tool_z,layer,generator,deposit_mm,wfs_m_min,travel_mm_s,t_s,dwell_s\n",
    );
    let mut i = 0;
    for (k, layer) in sl.layers.iter().enumerate() {
        let mut order: Vec<usize> = (0..layer.points.len()).collect();
        let ang = |j: usize| (layer.points[j].y - c.y).atan2(layer.points[j].x - c.x);
        order.sort_by(|&a, &b| ang(a).total_cmp(&ang(b)));
        for j in order {
            let q = layer.points[j];
            let d = layer.deposit_mm[j];
            let wfs = eq7::wire_feed(
                d * 1e-3,
                s.process.wire_diameter_m,
                s.process.bead_width_m,
                s.process.travel_speed_m_s,
            ) * 60.0;
            let _ = writeln!(
                csv,
                "{i},{:.4},{:.4},{:.4},0,0,1,{k},-1,{d:.5},{wfs:.6},{:.3},,0",
                q.x,
                q.y,
                q.z,
                s.process.travel_speed_m_s * 1e3
            );
            i += 1;
        }
    }
    let json = json!({
        "strategy": "planar",
        "part_kind": part.kind.as_str(),
        "n_generators": 0,
        "n_filled": 0,
        "n_step_layers": 0,
        "n_layers": sl.layers.len(),
        "generator_length_mm": Value::Null,
        "deposit_mm": minmax(lo, hi),
        "deposit_share_outside": outside as f64 / all.len().max(1) as f64,
        "top_deposit_mm": minmax(range(sl.top_deposit_mm.iter().copied()).0, range(sl.top_deposit_mm.iter().copied()).1),
        "closing_point_mm": Value::Null,
        "feasible": outside == 0,
        "violations_total": outside,
        "violations": [],
        "deviation_mm": Value::Null,
        "collisions": {"detected": Value::Null, "resolved": Value::Null, "unresolved": Value::Null},
    });
    dir.write_json("plan.json", &json)?;
    dir.write("generators.csv", b"id,filled,length_mm,x0,y0,z0,x1,y1,z1\n")?;
    dir.write("path.csv", csv.as_bytes())?;
    Ok(format!(
        "planar: {} layers, deposits {lo:.3}..{hi:.3} mm, {:.1} % outside [{}, {}]",
        sl.layers.len(),
        100.0 * outside as f64 / all.len().max(1) as f64,
        p.deposit_min_mm,
        p.deposit_max_mm
    ))
}
