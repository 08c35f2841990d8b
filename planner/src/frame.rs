//! The tool frame a robot follows at each path point: the tool's approach axis z from the torch
//! down to the deposit (minus the tool axis of [`crate::orientation`]), x along the direction of
//! travel made square to it, y = z × x; as a rotation and a unit quaternion (w, x, y, z), the
//! form robot programs take. Any path with tool axes serves, an imported one included.

use crate::geometry::grid::PointGrid;
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

/// How the torch stands on the build direction: Chalvin's two tilts and the fastest the tool may
/// turn along the path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Torch {
    /// θ_n, degrees: positive pushes.
    pub lead_deg: f64,
    /// θ_t, degrees: positive towards b × t.
    pub side_deg: f64,
    /// The tool's largest angular rate along the path, degrees per mm.
    pub max_rate_deg_mm: f64,
}

impl Default for Torch {
    /// Straight along the build direction; 30°/mm, a wrist turning 300°/s at 10 mm/s travel
    /// (a KUKA KR 16's wrist axes turn at 330 to 615°/s). Tighter bounds leave the tool lagging
    /// where the build direction spins round a closing point, and the nozzle hits there
    /// (docs/PHYSICS.md).
    fn default() -> Self {
        Torch {
            lead_deg: 0.0,
            side_deg: 0.0,
            max_rate_deg_mm: 30.0,
        }
    }
}

/// What bounding the tool's rate did.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RateLimit {
    /// Points whose tool was turned less than asked.
    pub limited: usize,
    /// The fastest turn asked for, degrees per mm.
    pub max_asked_deg_mm: f64,
}

/// The tool axes `torch` asks for on the build directions `builds` along `points`: tilted
/// ([`tilted`]) and rate-bounded ([`limit_rate`]).
pub fn torch_axes(
    points: &[Point3<f64>],
    builds: &[Vector3<f64>],
    torch: &Torch,
) -> (Vec<Vector3<f64>>, RateLimit) {
    let (lead, side) = (torch.lead_deg.to_radians(), torch.side_deg.to_radians());
    let asked: Vec<Vector3<f64>> = (0..points.len())
        .map(|i| tilted(&builds[i], &travel(points, i), lead, side))
        .collect();
    let (tools, limited, max_asked_deg_mm) = limit_rate(points, &asked, torch.max_rate_deg_mm);
    (
        tools,
        RateLimit {
            limited,
            max_asked_deg_mm,
        },
    )
}

/// The tool axis (from the deposit to the torch) tilted from the build direction `build` as in
/// Chalvin et al. 2019 Fig. 10: by `lead_rad` (θ_n) in the feeding plane of the travel and b, a
/// positive lead pushing (the torch's body trails, its tip points along the travel), then by
/// `side_rad` (θ_t) in the plane square to the travel, positive towards b × t (the left of the
/// travel, seen from above). Zero angles give b back.
pub fn tilted(
    build: &Vector3<f64>,
    travel: &Vector3<f64>,
    lead_rad: f64,
    side_rad: f64,
) -> Vector3<f64> {
    let b = build.normalize();
    let Some(t) = (travel - b * travel.dot(&b)).try_normalize(1e-12) else {
        return b;
    };
    let side = b.cross(&t);
    let pushed = b * lead_rad.cos() - t * lead_rad.sin();
    (pushed * side_rad.cos() + side * side_rad.sin()).normalize()
}

/// The tool axes with the tool's angular rate along the path bounded by `max_deg_per_mm`: each
/// axis turned from the one before towards its own by at most the rate times the distance
/// between the points (a forward slew limit; the torch lags a sharp change and catches up). Also
/// the number of axes changed and the largest rate found before, °/mm.
pub fn limit_rate(
    points: &[Point3<f64>],
    tools: &[Vector3<f64>],
    max_deg_per_mm: f64,
) -> (Vec<Vector3<f64>>, usize, f64) {
    let mut out: Vec<Vector3<f64>> = tools.to_vec();
    let (mut changed, mut worst) = (0, 0.0f64);
    for i in 1..out.len() {
        let step = (points[i] - points[i - 1]).norm();
        let angle = out[i - 1].angle(&tools[i]);
        if step > 0.0 {
            worst = worst.max(tools[i - 1].angle(&tools[i]).to_degrees() / step);
        }
        let allowed = (max_deg_per_mm * step).to_radians();
        if angle > allowed + 1e-12 {
            let from = nalgebra::Unit::new_normalize(out[i - 1]);
            let to = nalgebra::Unit::new_normalize(tools[i]);
            out[i] = from
                .try_slerp(&to, allowed / angle, 1e-12)
                .map(|u| u.into_inner())
                .unwrap_or(out[i - 1]);
            changed += 1;
        }
    }
    (out, changed, worst)
}

/// The largest angular rate of the tool between neighbouring points, °/mm.
pub fn max_rate(points: &[Point3<f64>], tools: &[Vector3<f64>]) -> f64 {
    (1..points.len())
        .filter_map(|i| {
            let step = (points[i] - points[i - 1]).norm();
            (step > 0.0).then(|| tools[i - 1].angle(&tools[i]).to_degrees() / step)
        })
        .fold(0.0, f64::max)
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
    let grids: Vec<PointGrid> = ranges
        .iter()
        .map(|(_, r)| PointGrid::new(points, r.clone(), 1.0))
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
                .then(|| points[grids[k - 1].closest(points, &p)])
                .map(|q| (p - q).cross(&t));
            let upper = grids
                .get(k + 1)
                .map(|g| points[g.closest(points, &p)])
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

    /// Fig. 10's tilts: 10° of lead leans the tool back against the travel, 5° to the side
    /// towards b × t, and the tool stays a unit vector at the angle asked from b.
    #[test]
    fn lead_and_side_tilts() {
        let (b, t) = (Vector3::z(), Vector3::new(2.0, 0.0, 0.3));
        let lead = tilted(&b, &t, 10f64.to_radians(), 0.0);
        assert!((lead.angle(&b).to_degrees() - 10.0).abs() < 1e-9);
        assert!(lead.x < 0.0 && lead.y.abs() < 1e-12);
        let side = tilted(&b, &t, 0.0, 5f64.to_radians());
        assert!((side.angle(&b).to_degrees() - 5.0).abs() < 1e-9 && side.y > 0.0);
        assert!((tilted(&b, &t, 0.0, 0.0) - b).norm() < 1e-15);
    }

    /// A 90° jump of the tool on a line of 1 mm steps, limited to 15°/mm: six steps of 15°
    /// reach it, none more than the limit; a path already under the limit is unchanged.
    #[test]
    fn the_rate_limit_spreads_a_jump() {
        let pts: Vec<Point3<f64>> = (0..20).map(|i| Point3::new(i as f64, 0.0, 0.0)).collect();
        let tools: Vec<Vector3<f64>> = (0..20)
            .map(|i| if i < 5 { Vector3::z() } else { Vector3::y() })
            .collect();
        assert!((max_rate(&pts, &tools) - 90.0).abs() < 1e-9);
        let (out, changed, worst) = limit_rate(&pts, &tools, 15.0);
        assert_eq!(changed, 5);
        assert!((worst - 90.0).abs() < 1e-9);
        assert!(max_rate(&pts, &out) <= 15.0 + 1e-9);
        assert!((out[10] - Vector3::y()).norm() < 1e-12);
        let (same, none, _) = limit_rate(&pts, &out, 15.0);
        assert_eq!((same, none), (out.clone(), 0));
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
