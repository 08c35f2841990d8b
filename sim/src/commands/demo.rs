//! `waamtwin demo -o DIR`: the built-in closed-part scenario end to end: the part, the CTPP
//! plan, the heat of the build without dwells, the cooling dwells that keep it standing, and the
//! heat of the dwelled build.

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
    // Plan, simulate without dwells, plan the dwells, and simulate the dwelled path.
    println!(
        "{}",
        super::dwell::plan_and_dwell(
            &scenario,
            "the demo scenario",
            &mut dir,
            super::dwell::Extras::default(),
            None,
        )?
    );
    dir.finish("demo", scenario.to_json())?;
    Ok(())
}
