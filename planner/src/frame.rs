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

#[cfg(test)]
mod tests {
    use super::*;

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
