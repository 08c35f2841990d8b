//! `waamtwin demo -o DIR`: the built-in closed-part scenario, through as much of the pipeline as
//! exists.

use crate::error::Result;
use crate::output::RunDir;
use crate::part::load_part;
use crate::scenario::Scenario;
use planner::io::{Encoding, MeshFormat, write_mesh};
use std::path::Path;

/// The demo's scenario, shipped as `scenarios/demo_dome.toml`.
pub const DEMO_SCENARIO: &str = include_str!("../../../scenarios/demo_dome.toml");

pub fn demo(out: &Path) -> Result<()> {
    let scenario = Scenario::parse(
        DEMO_SCENARIO,
        "scenarios/demo_dome.toml",
        Path::new("scenarios"),
    )?;
    let mut dir = RunDir::create(out)?;
    let part = load_part(&scenario.part)?;
    dir.write(
        "part.stl",
        &write_mesh(&part.mesh, MeshFormat::Stl, Encoding::Binary),
    )?;
    dir.write_json("mesh.json", &super::inspect::report("part.stl", &part))?;
    let plan = super::plan::plan_part(&scenario, &part)?;
    super::plan::write_plan(&mut dir, &scenario, &plan)?;
    println!("{}", super::plan::summary(&plan));
    let sim = super::simulate::simulate(&scenario, &plan, &[])?;
    super::simulate::write_thermal(&mut dir, &scenario, &plan, &sim, &[])?;
    println!("{}", super::simulate::summary(&scenario, &sim));
    dir.finish("demo", scenario.to_json())?;
    Ok(())
}
