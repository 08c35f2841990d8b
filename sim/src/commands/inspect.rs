//! `waamtwin inspect MESH`: what the planner will see of a mesh file.

use crate::error::Result;
use crate::part::{part_from_mesh, read_mesh_file};
use planner::mesh::{LowerLoop, Part};
use serde_json::{Value, json};
use std::path::Path;

pub fn inspect(path: &Path) -> Result<Value> {
    let name = path.display().to_string();
    let raw = read_mesh_file(path)?;
    let part = part_from_mesh(raw, LowerLoop::LowestZ, &name)?;
    Ok(report(&name, &part))
}

pub fn report(name: &str, part: &Part) -> Value {
    let m = &part.mesh;
    let (lo, hi) = m.bounding_box();
    let loops: Vec<Value> = part
        .topology
        .loops
        .iter()
        .enumerate()
        .map(|(i, l)| {
            let role = if i == part.lower { "lower" } else { "upper" };
            json!({"role": role, "vertices": l.vertices.len(), "length_mm": l.length_mm, "mean_z_mm": l.mean_z})
        })
        .collect();
    let mut problems = Vec::new();
    if part.weld.degenerate_faces > 0 {
        problems.push(format!(
            "{} degenerate faces dropped",
            part.weld.degenerate_faces
        ));
    }
    if part.topology.flipped_faces > 0 {
        problems.push(format!(
            "{} faces reoriented to agree and point outward",
            part.topology.flipped_faces
        ));
    }
    if part.weld.unused_vertices > 0 {
        problems.push(format!(
            "{} unused vertices dropped",
            part.weld.unused_vertices
        ));
    }
    json!({
        "file": name,
        "vertices_read": part.weld.vertices_in,
        "vertices": m.n_vertices(),
        "faces": m.n_faces(),
        "part_kind": part.kind.as_str(),
        "boundary_loops": part.topology.loops.len(),
        "loops": loops,
        "components": 1,
        "bbox_min_mm": [lo.x, lo.y, lo.z],
        "bbox_max_mm": [hi.x, hi.y, hi.z],
        "area_mm2": m.area(),
        "mean_edge_mm": m.mean_edge_length(),
        "problems": problems,
    })
}

/// The human-readable form of [`report`].
pub fn format_report(r: &Value) -> String {
    let mut s = format!(
        "{}\n  part: {} ({} boundary loop{})\n  vertices: {} (read {}), faces: {}\n  area: {:.1} mm², mean edge: {:.3} mm\n",
        r["file"].as_str().unwrap_or(""),
        r["part_kind"].as_str().unwrap_or(""),
        r["boundary_loops"],
        if r["boundary_loops"] == 1 { "" } else { "s" },
        r["vertices"],
        r["vertices_read"],
        r["faces"],
        r["area_mm2"].as_f64().unwrap_or(0.0),
        r["mean_edge_mm"].as_f64().unwrap_or(0.0),
    );
    for l in r["loops"].as_array().into_iter().flatten() {
        s += &format!(
            "  {} loop: {} vertices, {:.1} mm long, mean z {:.2} mm\n",
            l["role"].as_str().unwrap_or(""),
            l["vertices"],
            l["length_mm"].as_f64().unwrap_or(0.0),
            l["mean_z_mm"].as_f64().unwrap_or(0.0)
        );
    }
    let problems = r["problems"].as_array().cloned().unwrap_or_default();
    if problems.is_empty() {
        s += "  problems: none\n";
    }
    for p in problems {
        s += &format!("  note: {}\n", p.as_str().unwrap_or(""));
    }
    s
}
