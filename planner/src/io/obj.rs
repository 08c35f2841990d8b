//! Wavefront OBJ: `v x y z` and `f a b c ...` (1-based, negative relative, `a/t/n` forms).
//! Polygons are fan-triangulated; other records are ignored.

use super::{FormatError, parse_f64, text};
use crate::mesh::TriMesh;
use nalgebra::Point3;
use std::fmt::Write;

const F: &str = "OBJ";

pub fn read_obj(bytes: &[u8]) -> Result<TriMesh, FormatError> {
    let src = text(bytes);
    let mut positions = Vec::new();
    let mut faces = Vec::new();
    for (i, line) in src.lines().enumerate() {
        let ln = i + 1;
        let mut toks = line.split_whitespace();
        match toks.next() {
            Some("v") => positions.push(vertex(ln, &mut toks)?),
            Some("f") => {
                let poly = indices(ln, toks, positions.len(), "face")?;
                if poly.len() < 3 {
                    return Err(FormatError::at_line(
                        F,
                        ln,
                        format!("face has {} vertices; expected at least 3", poly.len()),
                    ));
                }
                for k in 1..poly.len() - 1 {
                    faces.push([poly[0], poly[k], poly[k + 1]]);
                }
            }
            _ => {}
        }
    }
    Ok(TriMesh::new(positions, faces))
}

/// The polylines of an OBJ: its `v x y z` records and its `l a b c ...` lines (1-based, negative
/// relative, `a/t` forms), each at least two vertices; faces and other records are ignored. A
/// skeleton for skeleton arc AM (Radel et al. 2019).
pub fn read_obj_polylines(bytes: &[u8]) -> Result<Polylines, FormatError> {
    let src = text(bytes);
    let mut positions = Vec::new();
    let mut lines = Vec::new();
    for (i, line) in src.lines().enumerate() {
        let ln = i + 1;
        let mut toks = line.split_whitespace();
        match toks.next() {
            Some("v") => positions.push(vertex(ln, &mut toks)?),
            Some("l") => {
                let poly = indices(ln, toks, positions.len(), "line")?;
                if poly.len() < 2 {
                    return Err(FormatError::at_line(
                        F,
                        ln,
                        format!("polyline has {} vertices; expected at least 2", poly.len()),
                    ));
                }
                lines.push(poly);
            }
            _ => {}
        }
    }
    Ok(Polylines {
        vertices: positions,
        lines,
    })
}

/// An OBJ's polylines: its vertices and, per `l` line, the indices it joins.
#[derive(Debug, Clone, PartialEq)]
pub struct Polylines {
    pub vertices: Vec<Point3<f64>>,
    pub lines: Vec<Vec<u32>>,
}

/// A `v x y z` record's point.
fn vertex<'a>(
    ln: usize,
    toks: &mut impl Iterator<Item = &'a str>,
) -> Result<Point3<f64>, FormatError> {
    let x = parse_f64(F, ln, toks.next(), "vertex x")?;
    let y = parse_f64(F, ln, toks.next(), "vertex y")?;
    let z = parse_f64(F, ln, toks.next(), "vertex z")?;
    Ok(Point3::new(x, y, z))
}

/// A record's vertex indices (1-based, negative relative to the `n` vertices so far, `a/t/n`
/// forms), 0-based.
fn indices<'a>(
    ln: usize,
    toks: impl Iterator<Item = &'a str>,
    n: usize,
    what: &str,
) -> Result<Vec<u32>, FormatError> {
    toks.map(|tok| {
        let idx = tok.split('/').next().unwrap_or("");
        let k: i64 = idx.parse().map_err(|_| {
            FormatError::at_line(F, ln, format!("{what} index '{tok}'; expected an integer"))
        })?;
        let n = n as i64;
        let v = if k > 0 { k - 1 } else { n + k };
        if k == 0 || v < 0 || v >= n {
            return Err(FormatError::at_line(
                F,
                ln,
                format!("{what} index {k} refers to no vertex ({n} defined so far)"),
            ));
        }
        Ok(v as u32)
    })
    .collect()
}

pub fn write_obj(mesh: &TriMesh) -> Vec<u8> {
    let mut s = String::from("# waamtwin mesh, mm\n");
    for p in &mesh.positions {
        let _ = writeln!(s, "v {:e} {:e} {:e}", p.x, p.y, p.z);
    }
    for f in &mesh.faces {
        let _ = writeln!(s, "f {} {} {}", f[0] + 1, f[1] + 1, f[2] + 1);
    }
    s.into_bytes()
}
