//! `waamtwin mesh SCENARIO -o FILE`: the scenario's part (a library shape or a mesh file) as a
//! welded STL, OBJ or PLY mesh, the extension picking the format.

use crate::error::{Error, Result};
use crate::output::write_atomic;
use crate::part::load_part;
use crate::scenario::Scenario;
use planner::io::{Encoding, MeshFormat, write_mesh};
use std::path::Path;

pub fn run(scenario: &Path, out: &Path) -> Result<String> {
    let s = Scenario::load(scenario)?;
    let p = load_part(&s.part)?;
    let name = out.display().to_string();
    let format = MeshFormat::from_extension(&name).ok_or_else(|| {
        Error::input(format!(
            "{name}: unknown mesh extension; expected .stl, .obj or .ply"
        ))
    })?;
    write_atomic(out, &write_mesh(&p.mesh, format, Encoding::Binary))?;
    Ok(format!(
        "{}: {} vertices, {} faces, {} part",
        name,
        p.mesh.n_vertices(),
        p.mesh.n_faces(),
        p.kind.as_str()
    ))
}
