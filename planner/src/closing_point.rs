//! The optimal closing point of a closed part (CTPP §2.2.2, Eq.4): the surface point that
//! maximises the smallest geodesic distance to the n_pts lower points. The smallest distance to a
//! set is the distance from the set, so this is one multi-source query; its maximum over
//! vertices is then refined below mesh resolution by a quadratic fit over the two-ring around the
//! best vertex (the paper's result is limited to mesh vertices).

use crate::geodesic::{HeatSolver, SurfacePoint};
use crate::geometry::closest::{ClosestPoint, vertex_normals};
use crate::mesh::TriMesh;
use nalgebra::{Point3, Vector3};

#[derive(Debug, Clone, PartialEq)]
pub struct ClosingPoint {
    pub point: SurfacePoint,
    pub position: Point3<f64>,
    /// min over lower points of the geodesic distance, at the best vertex.
    pub min_distance_mm: f64,
}

pub fn closing_point(
    solver: &HeatSolver,
    surface: &ClosestPoint,
    lower: &[SurfacePoint],
) -> ClosingPoint {
    let mesh = solver.mesh();
    let phi = solver.distance(lower);
    let best = (0..phi.len())
        .max_by(|&a, &b| phi[a].total_cmp(&phi[b]))
        .expect("vertices");
    let position = refine(mesh, &phi, best).unwrap_or(mesh.positions[best]);
    let c = surface.query(position);
    ClosingPoint {
        point: SurfacePoint::Face {
            face: c.face as u32,
            bary: c.bary,
        },
        position: c.point,
        min_distance_mm: phi[best],
    }
}

/// Fit φ ≈ a + b·u + c·w + d·u² + e·u·w + f·w² in the tangent plane at `v` over its two-ring and
/// return the fitted maximum, if it is a maximum inside the fitted patch.
fn refine(mesh: &TriMesh, phi: &[f64], v: usize) -> Option<Point3<f64>> {
    let mut ring = vec![v];
    for _ in 0..2 {
        let mut next = ring.clone();
        for f in &mesh.faces {
            if f.iter().any(|&x| ring.contains(&(x as usize))) {
                for &x in f {
                    if !next.contains(&(x as usize)) {
                        next.push(x as usize);
                    }
                }
            }
        }
        ring = next;
    }
    if ring.len() < 8 {
        return None;
    }
    let n = vertex_normals(mesh)[v];
    let t1 = n
        .cross(&Vector3::x())
        .try_normalize(1e-9)
        .unwrap_or_else(|| n.cross(&Vector3::y()).normalize());
    let t2 = n.cross(&t1);
    let p0 = mesh.positions[v];
    let mut ata = [0.0; 36];
    let mut atb = [0.0; 6];
    let mut radius: f64 = 0.0;
    for &i in &ring {
        let d = mesh.positions[i] - p0;
        let (u, w) = (d.dot(&t1), d.dot(&t2));
        radius = radius.max(u.hypot(w));
        let row = [1.0, u, w, u * u, u * w, w * w];
        for r in 0..6 {
            for c in 0..6 {
                ata[r * 6 + c] += row[r] * row[c];
            }
            atb[r] += row[r] * phi[i];
        }
    }
    let x = crate::geometry::solve_dense(&mut ata, &mut atb, 6)?;
    let (b, c, d, e, f) = (x[1], x[2], x[3], x[4], x[5]);
    // Stationary point: [2d e; e 2f] [u; w] = −[b; c]; a maximum needs a negative-definite Hessian.
    let det = 4.0 * d * f - e * e;
    if !(d < 0.0 && det > 0.0) {
        return None;
    }
    let u = (-2.0 * f * b + e * c) / det;
    let w = (e * b - 2.0 * d * c) / det;
    (u.hypot(w) < 0.5 * radius).then(|| p0 + t1 * u + t2 * w)
}
