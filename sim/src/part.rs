//! Turning a scenario's `[part]` or a mesh path into a validated [`Part`].

use crate::error::{Error, Result};
use crate::scenario::{PartSource, PartSpec};
use planner::io::{MeshFormat, read_mesh};
use planner::mesh::{LowerLoop, Part, TriMesh};
use std::path::Path;

/// Largest mesh file read (1 GiB): beyond it a part is not a thin-wall mid-surface.
const MAX_MESH_BYTES: u64 = 1 << 30;

/// A part file's bytes, refused beyond [`MAX_MESH_BYTES`] before it is read.
fn read_capped(path: &Path, name: &str) -> Result<Vec<u8>> {
    let len = std::fs::metadata(path)
        .map_err(|e| Error::input(format!("{name}: {e}")))?
        .len();
    if len > MAX_MESH_BYTES {
        return Err(Error::input(format!(
            "{name}: file is {len} bytes; expected at most {MAX_MESH_BYTES}"
        )));
    }
    std::fs::read(path).map_err(|e| Error::input(format!("{name}: {e}")))
}

pub fn read_mesh_file(path: &Path) -> Result<TriMesh> {
    let name = path.display().to_string();
    let format = MeshFormat::from_extension(&name).ok_or_else(|| {
        Error::input(format!(
            "{name}: unknown mesh extension; expected .stl, .obj or .ply"
        ))
    })?;
    let bytes = read_capped(path, &name)?;
    let mesh = read_mesh(&bytes, format).map_err(|e| Error::input(format!("{name}: {e}")))?;
    if mesh.faces.is_empty()
        && format == MeshFormat::Obj
        && planner::io::read_obj_polylines(&bytes).is_ok_and(|p| !p.lines.is_empty())
    {
        return Err(Error::input(format!(
            "{name}: polylines and no face: a skeleton; expected a surface mesh here (a skeleton is built with `waamtwin skeleton`)"
        )));
    }
    Ok(mesh)
}

/// The skeleton of a scenario whose `[part] mesh` is an OBJ of polylines (`l` lines), each
/// with its radius and priority from `[skeleton]`.
pub fn load_skeleton(
    spec: &PartSpec,
    set: &crate::scenario::SkeletonSettings,
) -> Result<planner::saam::Skeleton> {
    let PartSource::Mesh(path) = &spec.source else {
        return Err(Error::input(
            "[part]: a skeleton is an OBJ of polylines; expected mesh = \"file.obj\"",
        ));
    };
    let name = path.display().to_string();
    if MeshFormat::from_extension(&name) != Some(MeshFormat::Obj) {
        return Err(Error::input(format!(
            "{name}: a skeleton is read from an OBJ's `l` lines; expected a .obj file"
        )));
    }
    let bytes = read_capped(path, &name)?;
    let planner::io::Polylines { vertices, lines } = planner::io::read_obj_polylines(&bytes)
        .map_err(|e| Error::input(format!("{name}: {e}")))?;
    for (key, n) in [
        ("radii_mm", set.radii_mm.len()),
        ("priorities", set.priorities.len()),
    ] {
        if n > lines.len() {
            return Err(Error::input(format!(
                "[skeleton] {key} has {n} entries; {name} has {} polylines",
                lines.len()
            )));
        }
    }
    planner::saam::Skeleton::new(&vertices, &lines, |k| planner::saam::graph::BranchSpec {
        radius_mm: set.radii_mm.get(k).copied().unwrap_or(set.radius_mm),
        priority: set
            .priorities
            .get(k)
            .copied()
            .unwrap_or(planner::saam::Priority::None),
    })
    .map_err(|e| Error::input(format!("{name}: {e}")))
}

pub fn part_from_mesh(mesh: TriMesh, lower: LowerLoop, name: &str) -> Result<Part> {
    Part::from_mesh(mesh, lower).map_err(|e| Error::input(format!("{name}: {e}")))
}

pub fn load_part(spec: &PartSpec) -> Result<Part> {
    let (mut mesh, name) = match &spec.source {
        PartSource::Mesh(path) => (read_mesh_file(path)?, path.display().to_string()),
        PartSource::Shape { shape, edge_mm } => {
            (shape.mesh(*edge_mm), format!("shape \"{}\"", shape.name()))
        }
    };
    let (k, o) = (spec.mm_per_unit, nalgebra::Vector3::from(spec.offset_mm));
    if k != 1.0 || o != nalgebra::Vector3::zeros() {
        mesh.map_positions(|p| nalgebra::Point3::from(p.coords * k + o));
    }
    part_from_mesh(mesh, spec.lower, &name)
}
