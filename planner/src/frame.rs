//! The tool frame a robot follows at each path point: the tool's approach axis z from the torch
//! down to the deposit (minus the tool axis of [`crate::orientation`]), x along the direction of
//! travel made square to it (turning no faster than the wrist's budget), y = z × x; as a
//! rotation and a unit quaternion (w, x, y, z), the form robot programs take. Any path with
//! tool axes serves, an imported one included.

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

/// The direction of travel at point i as the torch sees it, square to its axis `z`: the chord
/// between the points before and after it made square to z, widened until that is at least
/// [`MIN_CHORD_MM`] long. [`travel`]'s chord is not enough: where a plan steps from one
/// revolution to the next along a tilted tool (a flat top whose build direction lies almost
/// level), its chord runs nearly along z and what is left square to it is the points' jitter,
/// which turned the frame's x through up to 179° in a move of hundredths of a millimetre (a
/// robot's wrist flicked round at a standstill).
fn travel_across(points: &[Point3<f64>], i: usize, z: &Vector3<f64>) -> Vector3<f64> {
    let n = points.len();
    let mut k = 1;
    loop {
        let d = points[(i + k).min(n - 1)] - points[i.saturating_sub(k)];
        let across = d - z * d.dot(z);
        if across.norm() >= MIN_CHORD_MM || k >= n {
            return across;
        }
        k += 1;
    }
}

/// The fastest the frame's x may turn about the tool axis along the path, degrees per mm: the
/// wrist's budget of [`Torch::default`]. The torch is round, so where x points about its axis
/// is the wrist's concern alone; where the direction of travel swings faster (the last turns
/// round a closing point, a few hundredths of a millimetre across, or a path doubling back) x
/// follows it at this rate instead of spinning the wrist at a standstill.
pub const ROLL_RATE_DEG_MM: f64 = 30.0;

/// The frames of `points` with tool axes `tools` (unit, from the deposit to the torch): x the
/// direction of travel square to z ([`travel_across`]), turned from the x before it by at most
/// [`ROLL_RATE_DEG_MM`] times the move; where the path stands still or runs along the tool,
/// the last such x.
pub fn frames(points: &[Point3<f64>], tools: &[Vector3<f64>]) -> Vec<Frame> {
    let n = points.len();
    let mut last_x: Option<Vector3<f64>> = None;
    (0..n)
        .map(|i| {
            let z = -tools[i].normalize();
            let want = travel_across(points, i, &z).try_normalize(1e-9);
            let before = last_x.and_then(|x| (x - z * x.dot(&z)).try_normalize(1e-9));
            let x = match (want, before) {
                (Some(w), Some(b)) => {
                    let most = (ROLL_RATE_DEG_MM * (points[i] - points[i - 1]).norm()).to_radians();
                    turned_toward(b, w, &z, most)
                }
                (Some(w), None) => w,
                (None, Some(b)) => b,
                (None, None) => z
                    .cross(&Vector3::y())
                    .try_normalize(1e-9)
                    .unwrap_or_else(|| z.cross(&Vector3::x()).normalize()),
            };
            last_x = Some(x);
            let y = z.cross(&x);
            Frame {
                position: points[i],
                rotation: Rotation3::from_matrix_unchecked(Matrix3::from_columns(&[x, y, z])),
            }
        })
        .collect()
}

/// `from` turned about `z` toward `to` (both unit and square to z) by at most `most` radians.
fn turned_toward(
    from: Vector3<f64>,
    to: Vector3<f64>,
    z: &Vector3<f64>,
    most: f64,
) -> Vector3<f64> {
    let angle = z.dot(&from.cross(&to)).atan2(from.dot(&to));
    if angle.abs() <= most {
        return to;
    }
    let a = most.copysign(angle);
    from * a.cos() + z.cross(&from) * a.sin()
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

    /// Path points 4345–4362 of a superellipsoid "square dome" (|x|⁴ + |y|⁴ + |z|⁴ = 40⁴, from
    /// an STL) on its flat top: the torch lies almost level, the step to the next revolution
    /// (4351 → 4352) runs along it, and points 4352–4356 sit hundredths of a millimetre apart.
    /// The frame's x never turns faster than [`ROLL_RATE_DEG_MM`] plus the tool's own turn; x
    /// taken from the chord alone turned 179° in the 0.007 mm move to 4354.
    #[test]
    fn the_frame_does_not_spin_where_points_bunch_along_a_level_torch() {
        let rows = [
            [5.5369, -1.4175, 39.9918, -0.999906, 0.013181, 0.003740],
            [5.4979, -1.4076, 39.9919, -0.999952, 0.009105, 0.003714],
            [5.4582, -1.3974, 39.9919, -0.999978, 0.005507, 0.003687],
            [5.6056, 0.0000, 39.9917, -0.745024, -0.667030, 0.003059],
            [5.5900, 0.0000, 39.9917, -0.739558, -0.673086, 0.003030],
            [5.5758, 0.0000, 39.9917, -0.736151, -0.676811, 0.003008],
            [5.5622, 0.0000, 39.9918, -0.740930, -0.671576, 0.003028],
            [3.8234, 0.0000, 39.9943, -0.997102, 0.076027, 0.002798],
            [3.8315, 0.0000, 39.9943, -0.996772, 0.080232, 0.002797],
            [3.8382, 0.0000, 39.9943, -0.996481, 0.083768, 0.002797],
            [3.8455, 0.0000, 39.9943, -0.996156, 0.087557, 0.002796],
            [3.8534, 0.0000, 39.9943, -0.995785, 0.091675, 0.002795],
            [3.7508, 0.9603, 39.9944, -0.997395, -0.072069, 0.002933],
            [3.7751, 0.9665, 39.9944, -0.998255, -0.058976, 0.002935],
            [3.7994, 0.9727, 39.9944, -0.998943, -0.045878, 0.002938],
            [3.8259, 0.9795, 39.9943, -0.999498, -0.031551, 0.002940],
            [3.8609, 0.9884, 39.9943, -0.999916, -0.012649, 0.002944],
            [3.8995, 0.9983, 39.9942, -0.999433, -0.033538, 0.002957],
        ];
        let pts: Vec<Point3<f64>> = rows.iter().map(|r| Point3::new(r[0], r[1], r[2])).collect();
        let tools: Vec<Vector3<f64>> = rows
            .iter()
            .map(|r| Vector3::new(r[3], r[4], r[5]).normalize())
            .collect();
        let f = frames(&pts, &tools);
        for i in 1..f.len() {
            let x = |k: usize| f[k].rotation.matrix().column(0).into_owned();
            let turn = x(i).angle(&x(i - 1)).to_degrees();
            let tilt = tools[i].angle(&tools[i - 1]).to_degrees();
            let most = ROLL_RATE_DEG_MM * (pts[i] - pts[i - 1]).norm() + tilt + 1e-9;
            assert!(
                turn <= most,
                "point {}: x turned {turn:.1}° for {most:.1}°",
                4345 + i
            );
        }
        // Where the travel is clear of the tool, x is the travel: 4357 → 4362 runs along +y.
        assert!(f[15].rotation.matrix().column(0).y > 0.9);
    }
}
