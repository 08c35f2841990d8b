//! `waamtwin geodesic MESH --from lower|upper|vertex:I,.. -o OUT.csv`.

use crate::error::{Error, Result};
use crate::output::write_atomic;
use crate::part::{part_from_mesh, read_mesh_file};
use planner::geodesic::{HeatOptions, HeatSolver};
use planner::mesh::{LowerLoop, Part};
use std::fmt::Write;
use std::path::Path;

/// Which vertices are the sources.
pub fn parse_sources(from: &str, part: &Part) -> Result<Vec<u32>> {
    match from {
        "lower" => Ok(part.lower_loop().vertices.clone()),
        "upper" => part
            .upper_loop()
            .map(|l| l.vertices.clone())
            .ok_or_else(|| Error::input("--from upper: the part is closed and has no upper boundary; expected lower or vertex:I")),
        _ => {
            let list = from.strip_prefix("vertex:").ok_or_else(|| {
                Error::input(format!("--from {from}: expected lower, upper or vertex:I[,J..]"))
            })?;
            let n = part.mesh.n_vertices();
            list.split(',')
                .map(|t| match t.trim().parse::<usize>() {
                    Ok(i) if i < n => Ok(i as u32),
                    Ok(i) => Err(Error::input(format!("--from {from}: vertex {i} does not exist; the welded mesh has {n} vertices"))),
                    Err(_) => Err(Error::input(format!("--from {from}: '{t}' is not a vertex index"))),
                })
                .collect()
        }
    }
}

pub fn geodesic(mesh: &Path, from: &str, out: &Path) -> Result<usize> {
    let name = mesh.display().to_string();
    let part = part_from_mesh(read_mesh_file(mesh)?, LowerLoop::LowestZ, &name)?;
    let sources = parse_sources(from, &part)?;
    let t = &part.topology;
    let solver = HeatSolver::new(&part.mesh, &t.is_boundary_vertex, HeatOptions::default())
        .map_err(|e| Error::failure(format!("{name}: {e}")))?;
    let d = solver.distance_from_vertices(&sources);
    let mut csv = String::from("x,y,z,distance_mm\n");
    for (p, di) in part.mesh.positions.iter().zip(&d) {
        let _ = writeln!(csv, "{},{},{},{}", p.x, p.y, p.z, di);
    }
    write_atomic(out, csv.as_bytes())?;
    Ok(d.len())
}
