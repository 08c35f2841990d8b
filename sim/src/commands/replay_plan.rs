//! `waamtwin replay SCENARIO -o DIR` where SCENARIO is a part's scenario with `[toolpath]
//! format = "path"` (issue 29, item 3): a `plan` or `dwell` run's path.csv laid again as it was
//! laid — its dwells, paces and drops — and judged as `simulate` judges, under this scenario's
//! parameters and model. A plan can so be checked under other parameters (a calibration one
//! standard deviation to the hot side) or on the other heat model.
//!
//! The part is planned again from the scenario (the planner is deterministic) and the path.csv
//! must be that plan's, point by point: its rows give the cooling, the plan the geometry.

use super::checkpoint;
use super::cost::{Keeps, check, check_plate, part_to_plan};
use super::simulate::{heat, record, summary, write_thermal};
use crate::error::{Error, Result};
use crate::measured::path::{PathRow, rows};
use crate::output::RunDir;
use crate::pipeline::Build;
use crate::pipeline::checkpoint::Checkpoints;
use crate::pipeline::deposition::Cooling;
use crate::scenario::Scenario;
use std::path::Path;
use thermal::schedule::DropPart;

/// How far a path.csv point may lie from the plan's, mm: path.csv writes 4 decimals.
const SAME_POINT_MM: f64 = 0.01;

pub fn run(scenario: &Path, out: &Path, resume: checkpoint::Options) -> Result<String> {
    let (s, path_file) = Scenario::load_planned(scenario)?;
    let file = scenario.display().to_string();
    let keeps = super::simulate::one_run(&s);
    check_plate(&file, &s.thermal, &s.material, keeps)?;
    let part = part_to_plan(&file, &s.part)?;
    let b = super::plan::build(&s, &part)?;
    let name = path_file.display().to_string();
    let laid = rows(&super::replay::read(&path_file)?, &name)?;
    let cooling = cooling_of(&b, &laid, &name)?;
    let mut dir = RunDir::create(out)?;
    let print = checkpoint::of_run("replay", &s.to_json(), b.deposits());
    let mut folder = checkpoint::Folder::open(out, "replay", print, resume)?;
    let end = b.deposits().last().map_or(0.0, |d| d.time) + cooling.total_dwell_s();
    check(
        &file,
        &b.params.thermal,
        &s.material,
        b.deposits(),
        end,
        Keeps {
            planned: part.mesh.n_vertices(),
            ..keeps
        },
    )?;
    let mut ck = Checkpoints::to(&mut folder);
    let sim = heat(&b, &cooling, s.output.frames, &mut ck, "heat")?;
    super::plan::write_plan(&mut dir, &s, &b)?;
    for w in write_thermal(&mut dir, &b, &sim)? {
        eprintln!("{}", w.line);
    }
    record(&mut dir, &s, &part, &b, &sim, None)?;
    dir.finish("replay", s.to_json())?;
    folder.close()?;
    Ok(format!("{name} replayed: {}", summary(&b, &sim)))
}

/// The cooling `laid` says, checked point by point against `b`'s plan.
fn cooling_of(b: &Build, laid: &[PathRow], name: &str) -> Result<Cooling> {
    let points = &b.plan.points;
    if laid.len() != points.len() {
        return Err(Error::input(format!(
            "{name}: {} path points; this scenario's plan has {}: expected the path.csv of a \
             plan of this scenario's part",
            laid.len(),
            points.len()
        )));
    }
    for (i, (r, p)) in laid.iter().zip(points).enumerate() {
        let at = [p.position.x, p.position.y, p.position.z];
        let off = (0..3)
            .map(|k| (r.position_mm[k] - at[k]).abs())
            .fold(0.0, f64::max);
        if off > SAME_POINT_MM || r.layer != p.layer {
            return Err(Error::input(format!(
                "{name} line {}: point {i} at ({:.4}, {:.4}, {:.4}) mm in layer {}; this \
                 scenario's plan lays it at ({:.4}, {:.4}, {:.4}) mm in layer {}: expected the \
                 path.csv of a plan of this scenario's part (one planned with the same [part], \
                 [planner] and [process])",
                i + 2,
                r.position_mm[0],
                r.position_mm[1],
                r.position_mm[2],
                r.layer,
                at[0],
                at[1],
                at[2],
                p.layer
            )));
        }
    }
    let drop = laid
        .iter()
        .enumerate()
        .map(|(i, r)| match r.drop {
            1 => Some(DropPart::Strikes {
                deposits: 1 + laid[i + 1..].iter().take_while(|n| n.drop == 2).count(),
            }),
            2 => Some(DropPart::Continues),
            _ => None,
        })
        .collect();
    Ok(Cooling {
        dwell_s: laid.iter().map(|r| r.dwell_s).collect(),
        pace: laid.iter().map(|r| r.pace).collect(),
        drop,
    })
}
