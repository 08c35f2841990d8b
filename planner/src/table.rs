//! The kinematics of a 5-axis machine with a tilt-rotary table (trunnion): the torch fixed,
//! pointing down the machine's −Z, moved by X, Y, Z; the part on a rotary table (C, about the
//! table's own axis) carried by a tilting cradle (A, about the machine's X). A part point p
//! stands at m = P + Rx(A)·Rz(C)·(p + o) in the machine, P the pivot (where the tilt axis meets
//! the rotary axis) and o the part's origin on the table. The inverse finds A and C that bring
//! the tool axis τ (deposit → torch, in the part) to the machine's +Z: Rx(A)·Rz(C)·τ = +Z.

use nalgebra::{Point3, Rotation3, Vector3};

/// Where the table is and how far it tilts, mm and degrees.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Table {
    /// The pivot P in machine coordinates.
    pub pivot_mm: [f64; 3],
    /// The part's origin o on the rotary table, in the table's frame (z along its axis).
    pub part_offset_mm: [f64; 3],
    pub tilt_min_deg: f64,
    pub tilt_max_deg: f64,
}

impl Default for Table {
    /// A pivot at the machine's origin, the part's origin on it, A within ±120°.
    fn default() -> Self {
        Table {
            pivot_mm: [0.0; 3],
            part_offset_mm: [0.0; 3],
            tilt_min_deg: -120.0,
            tilt_max_deg: 120.0,
        }
    }
}

/// One pose of the machine: linear axes in mm, A and C in degrees (C unwound, continuous).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Axes {
    pub x: f64,
    pub y: f64,
    pub z: f64,
    pub a: f64,
    pub c: f64,
}

/// A tool axis the table cannot bring up: the tilt it needs is outside the limits.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OutOfReach {
    pub tilt_deg: f64,
}

fn rotation(a_deg: f64, c_deg: f64) -> Rotation3<f64> {
    Rotation3::from_axis_angle(&Vector3::x_axis(), a_deg.to_radians())
        * Rotation3::from_axis_angle(&Vector3::z_axis(), c_deg.to_radians())
}

impl Table {
    /// Forward: the part point and tool axis a pose puts under the torch.
    pub fn part_pose(&self, m: &Axes) -> (Point3<f64>, Vector3<f64>) {
        let r = rotation(m.a, m.c).inverse();
        let p = r * (Vector3::new(m.x, m.y, m.z) - Vector3::from(self.pivot_mm))
            - Vector3::from(self.part_offset_mm);
        (Point3::from(p), r * Vector3::z())
    }

    /// Inverse: the pose that puts part point `p` under the torch along tool axis `tool`; of
    /// the two tilts (±), the one within the limits whose C is nearest `previous_c` (where the
    /// axis is vertical C is free and stays at `previous_c`).
    pub fn axes(
        &self,
        p: &Point3<f64>,
        tool: &Vector3<f64>,
        previous_c: f64,
    ) -> Result<Axes, OutOfReach> {
        let t = tool.normalize();
        let a = t.z.clamp(-1.0, 1.0).acos().to_degrees();
        let horizontal = t.x.hypot(t.y);
        let base_c = if horizontal < 1e-12 {
            previous_c
        } else {
            // Rz(C) turns (τx, τy) onto +y, so that Rx(A) lifts it onto +Z.
            (90.0 - t.y.atan2(t.x).to_degrees()).rem_euclid(360.0)
        };
        let near = |c: f64| c + 360.0 * ((previous_c - c) / 360.0).round();
        let within = |a: f64| a >= self.tilt_min_deg - 1e-9 && a <= self.tilt_max_deg + 1e-9;
        let candidates = [(a, near(base_c)), (-a, near(base_c + 180.0))];
        let (a, c) = candidates
            .into_iter()
            .filter(|(a, _)| within(*a))
            .min_by(|x, y| {
                (x.1 - previous_c)
                    .abs()
                    .total_cmp(&(y.1 - previous_c).abs())
            })
            .ok_or(OutOfReach { tilt_deg: a })?;
        let c = if horizontal < 1e-12 { previous_c } else { c };
        let m = Vector3::from(self.pivot_mm)
            + rotation(a, c) * (p.coords + Vector3::from(self.part_offset_mm));
        Ok(Axes {
            x: m.x,
            y: m.y,
            z: m.z,
            a,
            c,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Tool axes all round: the inverse then the forward gives the point and axis back, the
    /// axis ends on +Z in the machine, and C moves continuously.
    #[test]
    fn inverse_then_forward() {
        let table = Table {
            pivot_mm: [100.0, -50.0, 200.0],
            part_offset_mm: [0.0, 0.0, 35.0],
            ..Table::default()
        };
        let mut c = 0.0;
        for k in 0..400 {
            let phi = k as f64 * 0.05;
            let tilt = 0.3 + 0.8 * (k as f64 * 0.01).sin().abs();
            let tool = Vector3::new(tilt.sin() * phi.cos(), tilt.sin() * phi.sin(), tilt.cos());
            let p = Point3::new(10.0 * phi.cos(), 5.0, 0.1 * k as f64);
            let m = table.axes(&p, &tool, c).unwrap();
            assert!((m.c - c).abs() < 180.0 || k == 0, "{k}: {} after {c}", m.c);
            c = m.c;
            let (q, t) = table.part_pose(&m);
            assert!((q - p).norm() < 1e-9 && (t - tool).norm() < 1e-12, "{k}");
            assert!((rotation(m.a, m.c) * tool - Vector3::z()).norm() < 1e-12);
        }
        // Straight up: no tilt, C kept.
        let m = table.axes(&Point3::origin(), &Vector3::z(), 42.0).unwrap();
        assert_eq!((m.a, m.c), (0.0, 42.0));
    }

    #[test]
    fn a_tilt_beyond_the_limits_is_refused() {
        let table = Table {
            tilt_min_deg: -30.0,
            tilt_max_deg: 30.0,
            ..Table::default()
        };
        let e = table
            .axes(&Point3::origin(), &Vector3::new(1.0, 0.0, 0.2), 0.0)
            .unwrap_err();
        assert!(e.tilt_deg > 70.0);
    }
}
