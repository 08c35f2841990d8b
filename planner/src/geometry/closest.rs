//! Closest point on a triangle mesh: a uniform grid of triangle boxes, searched in growing shells.
//! Used for true point-to-surface distances (CTPP Eq.2 gap measure, Fig. 30 deviation) and to
//! project curves onto the part.

use crate::mesh::TriMesh;
use nalgebra::{Point3, Vector3};
use std::collections::HashMap;

/// The closest point of the mesh to a query.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Closest {
    pub face: usize,
    pub bary: [f64; 3],
    pub point: Point3<f64>,
    pub distance: f64,
}

pub struct ClosestPoint<'a> {
    mesh: &'a TriMesh,
    cell: f64,
    origin: Point3<f64>,
    grid: HashMap<[i32; 3], Vec<u32>>,
    /// Shells to search before giving up on the grid and scanning every face.
    max_shell: i32,
}

impl<'a> ClosestPoint<'a> {
    pub fn new(mesh: &'a TriMesh) -> ClosestPoint<'a> {
        let (lo, hi) = mesh.bounding_box();
        let cell = (2.0 * mesh.mean_edge_length()).max(1e-9);
        let mut grid: HashMap<[i32; 3], Vec<u32>> = HashMap::new();
        let key = |p: Point3<f64>| -> [i32; 3] {
            std::array::from_fn(|k| ((p[k] - lo[k]) / cell).floor() as i32)
        };
        for f in 0..mesh.n_faces() {
            let c = mesh.corners(f);
            let (mut a, mut b) = (key(c[0]), key(c[0]));
            for p in &c[1..] {
                let k = key(*p);
                for i in 0..3 {
                    a[i] = a[i].min(k[i]);
                    b[i] = b[i].max(k[i]);
                }
            }
            for x in a[0]..=b[0] {
                for y in a[1]..=b[1] {
                    for z in a[2]..=b[2] {
                        grid.entry([x, y, z]).or_default().push(f as u32);
                    }
                }
            }
        }
        let extent = (hi - lo).norm() / cell;
        ClosestPoint {
            mesh,
            cell,
            origin: lo,
            grid,
            max_shell: extent.ceil() as i32 + 1,
        }
    }

    pub fn mesh(&self) -> &TriMesh {
        self.mesh
    }

    pub fn query(&self, p: Point3<f64>) -> Closest {
        let c: [i32; 3] =
            std::array::from_fn(|k| ((p[k] - self.origin[k]) / self.cell).floor() as i32);
        let mut best: Option<Closest> = None;
        for r in 0..=self.max_shell {
            for x in -r..=r {
                for y in -r..=r {
                    for z in -r..=r {
                        if x.abs() != r && y.abs() != r && z.abs() != r {
                            continue;
                        }
                        if let Some(faces) = self.grid.get(&[c[0] + x, c[1] + y, c[2] + z]) {
                            for &f in faces {
                                let q = self.to_face(p, f as usize);
                                if best.is_none_or(|b| q.distance < b.distance) {
                                    best = Some(q);
                                }
                            }
                        }
                    }
                }
            }
            // Everything outside shell r is at least r·cell away.
            if let Some(b) = best
                && b.distance <= r as f64 * self.cell
            {
                return b;
            }
        }
        best.unwrap_or_else(|| {
            (0..self.mesh.n_faces())
                .map(|f| self.to_face(p, f))
                .min_by(|a, b| a.distance.total_cmp(&b.distance))
                .expect("faces")
        })
    }

    /// First surface point along the ray origin + t·dir (t ≥ 0, within `max_t`), by sphere
    /// tracing: no surface lies closer than the distance to the nearest point, so stepping by it
    /// never skips a crossing.
    pub fn raycast(
        &self,
        origin: Point3<f64>,
        dir: Vector3<f64>,
        max_t: f64,
        tol: f64,
    ) -> Option<Closest> {
        let dir = dir.try_normalize(1e-12)?;
        let mut t = 0.0;
        for _ in 0..64 {
            if t > max_t {
                break;
            }
            let c = self.query(origin + dir * t);
            if c.distance <= tol {
                return Some(c);
            }
            t += c.distance;
        }
        None
    }

    /// Signed distance: positive on the side the face normal points to.
    pub fn signed_distance(&self, p: Point3<f64>) -> f64 {
        let c = self.query(p);
        let n = self.mesh.face_normal(c.face);
        let s = (p - c.point).dot(&n);
        if s < 0.0 { -c.distance } else { c.distance }
    }

    fn to_face(&self, p: Point3<f64>, f: usize) -> Closest {
        let [a, b, c] = self.mesh.corners(f);
        let bary = closest_on_triangle(p, a, b, c);
        let point = Point3::from(a.coords * bary[0] + b.coords * bary[1] + c.coords * bary[2]);
        Closest {
            face: f,
            bary,
            point,
            distance: (p - point).norm(),
        }
    }
}

/// Barycentric coordinates of the point of triangle abc closest to p (Ericson, Real-Time
/// Collision Detection, §5.1.5).
pub fn closest_on_triangle(
    p: Point3<f64>,
    a: Point3<f64>,
    b: Point3<f64>,
    c: Point3<f64>,
) -> [f64; 3] {
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(&ap), ac.dot(&ap));
    if d1 <= 0.0 && d2 <= 0.0 {
        return [1.0, 0.0, 0.0];
    }
    let bp = p - b;
    let (d3, d4) = (ab.dot(&bp), ac.dot(&bp));
    if d3 >= 0.0 && d4 <= d3 {
        return [0.0, 1.0, 0.0];
    }
    let vc = d1 * d4 - d3 * d2;
    if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
        let v = d1 / (d1 - d3);
        return [1.0 - v, v, 0.0];
    }
    let cp = p - c;
    let (d5, d6) = (ab.dot(&cp), ac.dot(&cp));
    if d6 >= 0.0 && d5 <= d6 {
        return [0.0, 0.0, 1.0];
    }
    let vb = d5 * d2 - d1 * d6;
    if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
        let w = d2 / (d2 - d6);
        return [1.0 - w, 0.0, w];
    }
    let va = d3 * d6 - d5 * d4;
    if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
        let w = (d4 - d3) / ((d4 - d3) + (d5 - d6));
        return [0.0, 1.0 - w, w];
    }
    let denom = 1.0 / (va + vb + vc);
    let (v, w) = (vb * denom, vc * denom);
    [1.0 - v - w, v, w]
}

/// Area-weighted vertex normals, for smooth normals inside faces.
pub fn vertex_normals(mesh: &TriMesh) -> Vec<Vector3<f64>> {
    let mut n = vec![Vector3::zeros(); mesh.n_vertices()];
    for (f, face) in mesh.faces.iter().enumerate() {
        let a = mesh.face_normal_area2(f);
        for &v in face {
            n[v as usize] += a;
        }
    }
    n.iter().map(|v| v.normalize()).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::shapes::Shape;

    #[test]
    fn distances_to_a_hemisphere() {
        let r = 50.0;
        let m = Shape::Hemisphere { radius_mm: r }.mesh(1.0);
        let cp = ClosestPoint::new(&m);
        for (p, expected) in [
            (Point3::new(0.0, 0.0, 80.0), 30.0),
            (Point3::new(10.0, 5.0, 20.0), r - (125.0f64 + 400.0).sqrt()),
            (Point3::new(0.0, 0.0, 0.0), r),
            (Point3::new(300.0, 0.0, 0.5), 250.0),
        ] {
            let d = cp.query(p).distance;
            assert!((d - expected).abs() < 0.05, "{p:?}: {d} vs {expected}");
        }
        // Outward normals: a point outside reads positive.
        assert!(cp.signed_distance(Point3::new(0.0, 0.0, 60.0)) > 0.0);
        assert!(cp.signed_distance(Point3::new(0.0, 0.0, 40.0)) < 0.0);
    }
}
