//! The tool frame a robot follows at each path point: the tool's approach axis z from the torch
//! down to the deposit (minus the tool axis of [`crate::orientation`]), x along the direction of
//! travel made square to it, y = z × x; as a rotation and a unit quaternion (w, x, y, z), the
//! form robot programs take. Any path with tool axes serves, an imported one included.

use crate::orientation::MIN_CHORD_MM;
use nalgebra::{Matrix3, Point3, Rotation3, UnitQuaternion, Vector3};

/// A tool frame: where and how the torch stands, mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Frame {
    pub position: Point3<f64>,
    pub rotation: Rotation3<f64>,
}

impl Frame {
    /// The unit quaternion of the rotation, w ≥ 0 (w, x, y, z).
    pub fn quaternion(&self) -> [f64; 4] {
        let q = UnitQuaternion::from_rotation_matrix(&self.rotation);
        let c = q.coords;
        let s = if c.w < 0.0 { -1.0 } else { 1.0 };
        [s * c.w, s * c.x, s * c.y, s * c.z]
    }

    /// The tool axis, from the deposit to the torch.
    pub fn tool(&self) -> Vector3<f64> {
        -self.rotation.matrix().column(2).into_owned()
    }

    /// KUKA's A, B, C (rad): the rotation as Rz(A)·Ry(B)·Rx(C).
    pub fn abc(&self) -> [f64; 3] {
        let (c, b, a) = self.rotation.euler_angles();
        [a, b, c]
    }
}

/// The direction of travel at point i, not normalised: the chord between the points before and
/// after it, widened until it is at least [`MIN_CHORD_MM`] long (where generators converge, near
/// a closing point, neighbouring points are hundredths of a millimetre apart and their
/// difference says nothing of where the torch goes).
pub fn travel(points: &[Point3<f64>], i: usize) -> Vector3<f64> {
    let n = points.len();
    let mut k = 1;
    loop {
        let d = points[(i + k).min(n - 1)] - points[i.saturating_sub(k)];
        if d.norm() >= MIN_CHORD_MM || k >= n {
            return d;
        }
        k += 1;
    }
}

/// The frames of `points` with tool axes `tools` (unit, from the deposit to the torch): x the
/// direction of travel ([`travel`]) made square to z, or, where the path stands still or runs
/// along the tool, the last such x.
pub fn frames(points: &[Point3<f64>], tools: &[Vector3<f64>]) -> Vec<Frame> {
    let n = points.len();
    let mut last_x = Vector3::x();
    (0..n)
        .map(|i| {
            let z = -tools[i].normalize();
            let travel = travel(points, i);
            let x = (travel - z * travel.dot(&z))
                .try_normalize(1e-9)
                .or_else(|| (last_x - z * last_x.dot(&z)).try_normalize(1e-9))
                .unwrap_or_else(|| z.cross(&Vector3::y()).normalize());
            last_x = x;
            let y = z.cross(&x);
            Frame {
                position: points[i],
                rotation: Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z])),
            }
        })
        .collect()
}

/// The numeric build direction of Chalvin et al. 2019 §3.1, for any path given as points in
/// order with their layer (a layer's points contiguous): t from the point before to the point
/// after on the same layer; n the mean of the unit normals of two facets, the lower (those two
/// points and the closest point of the layer below) and the upper (with the closest point of the
/// layer above), one of them on the first and last layers; the build direction b square to
/// both (the paper's basis (t, n, b)), unit, pointing from the layer below to the layer above.
/// No surface is needed.
pub fn numeric_build_directions(points: &[Point3<f64>], layers: &[usize]) -> Vec<Vector3<f64>> {
    let n = points.len();
    // Each layer's range of points, and a grid of its points for the closest-point search.
    let mut ranges: Vec<(usize, std::ops::Range<usize>)> = Vec::new();
    for (i, &layer) in layers.iter().enumerate().take(n) {
        match ranges.last_mut() {
            Some((l, r)) if *l == layer => r.end = i + 1,
            _ => ranges.push((layer, i..i + 1)),
        }
    }
    let grids: Vec<Grid> = ranges
        .iter()
        .map(|(_, r)| Grid::new(points, r.clone()))
        .collect();
    let mut out = vec![Vector3::zeros(); n];
    for (k, (_, r)) in ranges.iter().enumerate() {
        for i in r.clone() {
            let (a, c) = (
                points[(i + 1).min(r.end - 1)],
                points[i.saturating_sub(1).max(r.start)],
            );
            let t = a - c;
            let p = points[i];
            // Facet normals oriented so that n × t points to the layer above.
            let lower = (k > 0)
                .then(|| grids[k - 1].closest(points, &p))
                .map(|q| (p - q).cross(&t));
            let upper = grids
                .get(k + 1)
                .map(|g| g.closest(points, &p))
                .map(|q| (q - p).cross(&t));
            let unit = |v: Option<Vector3<f64>>| v.and_then(|v| v.try_normalize(1e-15));
            let normal = match (unit(lower), unit(upper)) {
                (Some(a), Some(b)) => a + b,
                (Some(a), None) | (None, Some(a)) => a,
                (None, None) => Vector3::zeros(),
            };
            // n = (q − p) × t, so t × n is (q − p)'s part square to t, times |t|²: upwards.
            out[i] = t
                .cross(&normal)
                .try_normalize(1e-15)
                .unwrap_or_else(Vector3::z);
        }
    }
    out
}

/// A layer's points on a uniform grid, for the closest one to a point.
struct Grid {
    cell: f64,
    map: std::collections::HashMap<[i64; 3], Vec<u32>>,
    any: usize,
}

impl Grid {
    fn new(points: &[Point3<f64>], range: std::ops::Range<usize>) -> Grid {
        let cell = 1.0;
        let mut map: std::collections::HashMap<[i64; 3], Vec<u32>> = Default::default();
        let any = range.start;
        for i in range {
            map.entry(key(&points[i], cell)).or_default().push(i as u32);
        }
        Grid { cell, map, any }
    }

    /// The closest point: shells of cells outwards until the best found is nearer than the
    /// next shell can be.
    fn closest(&self, points: &[Point3<f64>], p: &Point3<f64>) -> Point3<f64> {
        let c = key(p, self.cell);
        let mut best: Option<(f64, usize)> = None;
        for ring in 0..64i64 {
            for dx in -ring..=ring {
                for dy in -ring..=ring {
                    for dz in -ring..=ring {
                        if dx.abs().max(dy.abs()).max(dz.abs()) != ring {
                            continue;
                        }
                        for &j in self
                            .map
                            .get(&[c[0] + dx, c[1] + dy, c[2] + dz])
                            .into_iter()
                            .flatten()
                        {
                            let d = (points[j as usize] - p).norm();
                            if best.is_none_or(|b| d < b.0) {
                                best = Some((d, j as usize));
                            }
                        }
                    }
                }
            }
            if let Some((d, j)) = best
                && d <= ring as f64 * self.cell
            {
                return points[j];
            }
        }
        points[best.map_or(self.any, |b| b.1)]
    }
}

fn key(p: &Point3<f64>, cell: f64) -> [i64; 3] {
    std::array::from_fn(|k| (p[k] / cell).floor() as i64)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Chalvin et al. 2019 §3.1 on their quarter torus, layers perpendicular to the neutral
    /// axis (iso-u circles of the tube), 26 points per millimetre: the numeric build direction
    /// against the analytic one (the tube's ∂/∂u, the neutral axis's direction), on average
    /// within 0.25° (the paper: 0.15°; measured here 0.030°). With each layer's points right
    /// above the ones beneath and even spacing the two facets' errors cancel exactly, so the
    /// layers are uneven and shifted.
    #[test]
    fn the_numeric_build_direction_on_the_quarter_torus() {
        let (big, small) = (60.0f64, 20.0f64);
        let at = |u: f64, v: f64| {
            let rho = big + small * v.cos();
            Point3::new(rho * u.cos() - big, small * v.sin(), rho * u.sin())
        };
        let along_u =
            |u: f64, v: f64| Vector3::new(-u.sin(), 0.0, u.cos()) * (big + small * v.cos());
        // Layers 1.5 to 3 mm apart on the neutral axis, each circle's points shifted against the
        // layer's beneath (so no closest point is square to the path); 26 points per mm.
        let per = (std::f64::consts::TAU * small * 26.0).round() as usize;
        let (mut pts, mut layers, mut want) = (Vec::new(), Vec::new(), Vec::new());
        for l in 0..6 {
            let u = (1.5 * l as f64 + 0.1 * (l * l) as f64) / big;
            for k in 0..per {
                let v = std::f64::consts::TAU * (k as f64 + 0.37 * l as f64) / per as f64;
                pts.push(at(u, v));
                layers.push(l);
                want.push(along_u(u, v).normalize());
            }
        }
        let got = numeric_build_directions(&pts, &layers);
        let inner: Vec<usize> = (per..5 * per).collect();
        let mean = inner
            .iter()
            .map(|&i| got[i].angle(&want[i]).to_degrees())
            .sum::<f64>()
            / inner.len() as f64;
        eprintln!("mean {mean:.4}°");
        assert!(mean < 0.25, "{mean}°");
        // Every layer, the first and last with one facet, points upwards.
        assert!((0..pts.len()).all(|i| got[i].dot(&want[i]) > 0.99));
    }

    /// A circle round z with the torch straight above: x the travel, z down, a right-handed
    /// orthonormal frame whose quaternion and A, B, C give its rotation back.
    #[test]
    fn a_circle_with_the_torch_above() {
        let pts: Vec<Point3<f64>> = (0..36)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 36.0;
                Point3::new(20.0 * a.cos(), 20.0 * a.sin(), 2.0)
            })
            .collect();
        let tools = vec![Vector3::z(); pts.len()];
        for (k, f) in frames(&pts, &tools).iter().enumerate() {
            let m = f.rotation.matrix();
            assert!((m.transpose() * m - Matrix3::identity()).norm() < 1e-12);
            assert!((m.determinant() - 1.0).abs() < 1e-12);
            assert!((f.tool() - Vector3::z()).norm() < 1e-12);
            let a = k as f64 * std::f64::consts::TAU / 36.0;
            let tangent = Vector3::new(-a.sin(), a.cos(), 0.0);
            assert!(m.column(0).dot(&tangent) > 0.99, "point {k}");
            let q = f.quaternion();
            let back =
                UnitQuaternion::from_quaternion(nalgebra::Quaternion::new(q[0], q[1], q[2], q[3]));
            assert!((back.to_rotation_matrix().matrix() - m).norm() < 1e-12);
            let [aa, bb, cc] = f.abc();
            let r = Rotation3::from_euler_angles(cc, bb, aa);
            assert!((r.matrix() - m).norm() < 1e-12);
        }
    }
}
