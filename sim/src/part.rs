//! Turning a scenario's `[part]` or a mesh path into a validated [`Part`].

use crate::error::{Error, Result};
use crate::scenario::{PartSource, PartSpec};
use planner::io::{MeshFormat, read_mesh};
use planner::mesh::{LowerLoop, Part, TriMesh};
use std::path::Path;

/// Largest mesh file read (1 GiB): beyond it a part is not a thin-wall mid-surface.
const MAX_MESH_BYTES: u64 = 1 << 30;

pub fn read_mesh_file(path: &Path) -> Result<TriMesh> {
    let name = path.display().to_string();
    let format = MeshFormat::from_extension(&name).ok_or_else(|| {
        Error::input(format!(
            "{name}: unknown mesh extension; expected .stl, .obj or .ply"
        ))
    })?;
    let len = std::fs::metadata(path)
        .map_err(|e| Error::input(format!("{name}: {e}")))?
        .len();
    if len > MAX_MESH_BYTES {
        return Err(Error::input(format!(
            "{name}: file is {len} bytes; expected at most {MAX_MESH_BYTES}"
        )));
    }
    let bytes = std::fs::read(path).map_err(|e| Error::input(format!("{name}: {e}")))?;
    read_mesh(&bytes, format).map_err(|e| Error::input(format!("{name}: {e}")))
}

pub fn part_from_mesh(mesh: TriMesh, lower: LowerLoop, name: &str) -> Result<Part> {
    Part::from_mesh(mesh, lower).map_err(|e| Error::input(format!("{name}: {e}")))
}

pub fn load_part(spec: &PartSpec) -> Result<Part> {
    match &spec.source {
        PartSource::Mesh(path) => part_from_mesh(
            read_mesh_file(path)?,
            spec.lower,
            &path.display().to_string(),
        ),
        PartSource::Shape { shape, edge_mm } => part_from_mesh(
            shape.mesh(*edge_mm),
            spec.lower,
            &format!("shape \"{}\"", shape.name()),
        ),
    }
}
