//! Welding of coincident vertices, and removal of the faces that welding makes degenerate.
//!
//! STL stores every triangle's corners separately; the surface only becomes a surface once equal
//! corners share one index. The tolerance is relative to the bounding box, so the same file
//! welds the same in metres or millimetres.

use super::TriMesh;
use std::collections::HashMap;

/// Vertices closer than this share one index: 1e-7 of the bounding-box diagonal, well above
/// single-precision rounding of a coordinate (~6e-8 relative) and far below any real edge.
pub const WELD_RELATIVE_TOLERANCE: f64 = 1e-7;

/// Faces whose area is below this share of diagonal² are slivers with no direction.
const DEGENERATE_RELATIVE_AREA: f64 = 1e-14;

#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct WeldStats {
    pub vertices_in: usize,
    pub vertices_out: usize,
    pub degenerate_faces: usize,
    pub unused_vertices: usize,
}

/// Merge vertices within the tolerance, drop degenerate faces and unused vertices.
pub fn weld(mesh: TriMesh) -> (TriMesh, WeldStats) {
    let diag = mesh.diagonal();
    let tol = (diag * WELD_RELATIVE_TOLERANCE).max(f64::MIN_POSITIVE);
    // Cells counted from the box's low corner, so a cell index stays within 1/tolerance (1e7)
    // whatever the coordinates; a box of no size (one point) is one cell. The fuzzer found
    // `x / tol` saturating i64 and the neighbour's index overflowing.
    let (lo, _) = mesh.bounding_box();
    let cell = |x: f64, o: f64| ((x - o) / tol).floor().clamp(-1e15, 1e15) as i64;
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut remap = Vec::with_capacity(mesh.positions.len());
    let mut out: Vec<nalgebra::Point3<f64>> = Vec::new();
    for p in &mesh.positions {
        let c = [cell(p.x, lo.x), cell(p.y, lo.y), cell(p.z, lo.z)];
        let mut found = None;
        'search: for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    if let Some(list) = grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]) {
                        for &j in list {
                            if (out[j as usize] - p).norm() <= tol {
                                found = Some(j);
                                break 'search;
                            }
                        }
                    }
                }
            }
        }
        let j = found.unwrap_or_else(|| {
            out.push(*p);
            let j = (out.len() - 1) as u32;
            grid.entry(c).or_default().push(j);
            j
        });
        remap.push(j);
    }
    let min_area2 = 2.0 * DEGENERATE_RELATIVE_AREA * diag * diag;
    let mut faces = Vec::with_capacity(mesh.faces.len());
    let mut degenerate = 0;
    for f in &mesh.faces {
        let g = f.map(|v| remap[v as usize]);
        let [a, b, c] = g.map(|v| out[v as usize]);
        if g[0] == g[1]
            || g[1] == g[2]
            || g[0] == g[2]
            || (b - a).cross(&(c - a)).norm() <= min_area2
        {
            degenerate += 1;
        } else {
            faces.push(g);
        }
    }
    // Compact: drop vertices no face uses.
    let mut new_index = vec![u32::MAX; out.len()];
    let mut positions = Vec::new();
    for f in &mut faces {
        for v in f.iter_mut() {
            if new_index[*v as usize] == u32::MAX {
                new_index[*v as usize] = positions.len() as u32;
                positions.push(out[*v as usize]);
            }
            *v = new_index[*v as usize];
        }
    }
    let stats = WeldStats {
        vertices_in: mesh.positions.len(),
        vertices_out: positions.len(),
        degenerate_faces: degenerate,
        unused_vertices: out.len() - positions.len(),
    };
    (TriMesh::new(positions, faces), stats)
}
