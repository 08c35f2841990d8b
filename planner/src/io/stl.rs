//! STL, binary and ASCII. Binary: 80-byte header, u32 triangle count, 50 bytes per triangle.

use super::{Encoding, FormatError, parse_f64, text};
use crate::mesh::TriMesh;
use nalgebra::Point3;
use std::fmt::Write;

const F: &str = "STL";

pub fn read_stl(bytes: &[u8]) -> Result<TriMesh, FormatError> {
    if bytes.is_empty() {
        return Err(FormatError {
            format: F,
            line: None,
            byte: None,
            message: "file is empty; expected a binary or ASCII STL".into(),
        });
    }
    if looks_ascii(bytes) {
        read_ascii(bytes)
    } else {
        read_binary(bytes)
    }
}

/// ASCII files start with "solid" — but so do some binary headers, so a file whose size matches
/// its binary triangle count exactly is binary whatever its first word.
fn looks_ascii(bytes: &[u8]) -> bool {
    let starts_solid = bytes.trim_ascii_start().starts_with(b"solid");
    if !starts_solid {
        return false;
    }
    if bytes.len() >= 84 {
        let n = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as u64;
        if 84 + 50 * n == bytes.len() as u64 {
            return false;
        }
    }
    true
}

fn read_binary(bytes: &[u8]) -> Result<TriMesh, FormatError> {
    if bytes.len() < 84 {
        return Err(FormatError::at_byte(
            F,
            bytes.len(),
            format!(
                "binary STL is {} bytes; expected at least 84 (header and triangle count)",
                bytes.len()
            ),
        ));
    }
    let n = u32::from_le_bytes(bytes[80..84].try_into().unwrap()) as u64;
    let need = 84 + 50 * n;
    if (bytes.len() as u64) < need {
        return Err(FormatError::at_byte(
            F,
            80,
            format!(
                "header claims {n} triangles ({need} bytes) but the file has {} bytes; truncated or not an STL",
                bytes.len()
            ),
        ));
    }
    let n = n as usize;
    let mut positions = Vec::with_capacity(3 * n);
    let mut faces = Vec::with_capacity(n);
    for t in 0..n {
        let rec = &bytes[84 + 50 * t..84 + 50 * (t + 1)];
        for c in 0..3 {
            let off = 12 + 12 * c;
            let xyz: [f64; 3] = std::array::from_fn(|k| {
                f32::from_le_bytes(rec[off + 4 * k..off + 4 * k + 4].try_into().unwrap()) as f64
            });
            positions.push(Point3::from(xyz));
        }
        let b = 3 * t as u32;
        faces.push([b, b + 1, b + 2]);
    }
    Ok(TriMesh::new(positions, faces))
}

fn read_ascii(bytes: &[u8]) -> Result<TriMesh, FormatError> {
    let src = text(bytes);
    let mut positions = Vec::new();
    let mut faces = Vec::new();
    let mut corner = 0usize;
    let mut in_loop = false;
    let mut last_line = 0;
    for (i, line) in src.lines().enumerate() {
        let ln = i + 1;
        last_line = ln;
        let mut toks = line.split_whitespace();
        match toks.next() {
            Some("vertex") => {
                if !in_loop {
                    return Err(FormatError::at_line(F, ln, "'vertex' outside 'outer loop'"));
                }
                let x = parse_f64(F, ln, toks.next(), "vertex x")?;
                let y = parse_f64(F, ln, toks.next(), "vertex y")?;
                let z = parse_f64(F, ln, toks.next(), "vertex z")?;
                positions.push(Point3::new(x, y, z));
                corner += 1;
            }
            Some("outer") => {
                in_loop = true;
                corner = 0;
            }
            Some("endloop") => {
                if corner != 3 {
                    return Err(FormatError::at_line(
                        F,
                        ln,
                        format!("facet has {corner} vertices; expected 3"),
                    ));
                }
                let b = (positions.len() - 3) as u32;
                faces.push([b, b + 1, b + 2]);
                in_loop = false;
            }
            Some("solid" | "facet" | "endfacet" | "endsolid") | None => {}
            Some(other) => {
                return Err(FormatError::at_line(
                    F,
                    ln,
                    format!(
                        "unexpected keyword '{other}'; expected facet, outer loop, vertex, endloop or endfacet"
                    ),
                ));
            }
        }
    }
    if in_loop {
        return Err(FormatError::at_line(
            F,
            last_line,
            "file ends inside a facet; truncated",
        ));
    }
    Ok(TriMesh::new(positions, faces))
}

pub fn write_stl(mesh: &TriMesh, encoding: Encoding) -> Vec<u8> {
    match encoding {
        Encoding::Binary => {
            let mut out = Vec::with_capacity(84 + 50 * mesh.n_faces());
            let mut header = [b' '; 80];
            header[..14].copy_from_slice(b"waamtwin mesh ");
            out.extend_from_slice(&header);
            out.extend_from_slice(&(mesh.n_faces() as u32).to_le_bytes());
            for f in 0..mesh.n_faces() {
                let n = mesh.face_normal(f);
                for k in 0..3 {
                    out.extend_from_slice(&(n[k] as f32).to_le_bytes());
                }
                for p in mesh.corners(f) {
                    for k in 0..3 {
                        out.extend_from_slice(&(p[k] as f32).to_le_bytes());
                    }
                }
                out.extend_from_slice(&0u16.to_le_bytes());
            }
            out
        }
        Encoding::Ascii => {
            let mut s = String::from("solid waamtwin\n");
            for f in 0..mesh.n_faces() {
                let n = mesh.face_normal(f);
                let _ = writeln!(
                    s,
                    "  facet normal {:e} {:e} {:e}\n    outer loop",
                    n.x, n.y, n.z
                );
                for p in mesh.corners(f) {
                    let _ = writeln!(s, "      vertex {:e} {:e} {:e}", p.x, p.y, p.z);
                }
                s.push_str("    endloop\n  endfacet\n");
            }
            s.push_str("endsolid waamtwin\n");
            s.into_bytes()
        }
    }
}
