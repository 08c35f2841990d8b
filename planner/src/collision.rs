//! Nozzle collisions (CTPP §2.4): at each path point the nozzle is a cylinder of radius
//! R_nozzle on the tool axis, from the contact-tip standoff to its length; it collides when
//! metal already deposited (an earlier path point) lies inside it. A collision is resolved by
//! rotating the tool about the direction of travel t (the bead keeps its build direction; the
//! torch leans sideways) by the smallest angle that frees it, up to `max_rotation_deg`; the
//! rotation is ramped in and out along the path at `rotation_rate_deg_mm` at most, so that the
//! robot's wrist turns no faster; what is still hit after that is reported unresolved. The
//! metal laid is a tube of radius R_tube along the path (its points, the cylinders widened by
//! R_tube); the arm (the torch body and the robot's wrist) is a second, wider cylinder further
//! up the tool axis.

use nalgebra::{Point3, Rotation3, Unit, Vector3};
use std::collections::HashMap;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nozzle {
    pub radius_mm: f64,
    /// Distance from the deposit to the nozzle tip along the tool axis.
    pub standoff_mm: f64,
    pub length_mm: f64,
    /// Largest rotation of the tool about the direction of travel, degrees (0: none).
    pub max_rotation_deg: f64,
    /// Fastest change of that rotation along the path, degrees per mm.
    pub rotation_rate_deg_mm: f64,
    /// R_tube: the metal laid as a tube of this radius along the path (0: its points).
    pub tube_radius_mm: f64,
    /// The arm behind the nozzle, if checked.
    pub arm: Option<Arm>,
}

/// The arm: a cylinder on the tool axis beyond the nozzle, mm.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Arm {
    pub radius_mm: f64,
    /// Where it starts along the tool axis, from the deposit.
    pub from_mm: f64,
    pub length_mm: f64,
}

impl Default for Nozzle {
    /// A CMT torch's nozzle: Ø 20 mm, 80 mm long, its tip 12 mm from the deposit; turned up to
    /// 30° about the travel at 2° per mm where it would hit; no arm checked.
    fn default() -> Self {
        Nozzle {
            radius_mm: 10.0,
            standoff_mm: 12.0,
            length_mm: 80.0,
            max_rotation_deg: 30.0,
            rotation_rate_deg_mm: 2.0,
            tube_radius_mm: 0.0,
            arm: None,
        }
    }
}

impl Nozzle {
    /// The cylinders on the tool axis: (from, to, radius) along it from the deposit, widened by
    /// R_tube.
    fn cylinders(&self) -> Vec<(f64, f64, f64)> {
        let mut c = vec![(
            self.standoff_mm,
            self.standoff_mm + self.length_mm,
            self.radius_mm + self.tube_radius_mm,
        )];
        if let Some(a) = self.arm {
            c.push((
                a.from_mm,
                a.from_mm + a.length_mm,
                a.radius_mm + self.tube_radius_mm,
            ));
        }
        c
    }
}

/// Collisions found and what was done with them.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Collisions {
    /// Path points whose nozzle, on the tool axis asked, meets metal already deposited.
    pub detected: Vec<usize>,
    /// Those still hit with the rotated tools.
    pub unresolved: Vec<usize>,
    /// The largest rotation applied, degrees.
    pub max_rotation_deg: f64,
}

/// The deposited points so far, on a grid of cells a nozzle radius wide.
struct Deposited<'a> {
    points: &'a [Point3<f64>],
    cell: f64,
    grid: HashMap<[i64; 3], Vec<u32>>,
}

impl<'a> Deposited<'a> {
    fn new(points: &'a [Point3<f64>], nozzle: &Nozzle) -> Self {
        let widest = nozzle.cylinders().iter().map(|c| c.2).fold(0.0, f64::max);
        Deposited {
            points,
            cell: widest.max(1.0),
            grid: HashMap::new(),
        }
    }

    fn key(&self, p: &Point3<f64>) -> [i64; 3] {
        std::array::from_fn(|k| (p[k] / self.cell).floor() as i64)
    }

    fn add(&mut self, i: usize) {
        let k = self.key(&self.points[i]);
        self.grid.entry(k).or_default().push(i as u32);
    }

    /// Whether the nozzle (or the arm) at `p` on the unit axis `b` contains a deposited point.
    fn hits(&self, p: &Point3<f64>, b: &Vector3<f64>, nozzle: &Nozzle) -> bool {
        nozzle.cylinders().into_iter().any(|(from, to, radius)| {
            let steps = ((to - from) / self.cell).ceil() as usize + 1;
            (0..=steps).any(|s| {
                let a = from + (to - from) * s as f64 / steps as f64;
                let c = self.key(&(p + b * a));
                (-1..=1).any(|dx| {
                    (-1..=1).any(|dy| {
                        (-1..=1).any(|dz| {
                            let cell = self.grid.get(&[c[0] + dx, c[1] + dy, c[2] + dz]);
                            cell.into_iter().flatten().any(|&j| {
                                let q = self.points[j as usize] - p;
                                let along = q.dot(b);
                                along >= from && along <= to && (q - b * along).norm() < radius
                            })
                        })
                    })
                })
            })
        })
    }
}

/// Indices of the path points whose nozzle contains an earlier point.
pub fn detect(points: &[Point3<f64>], tools: &[Vector3<f64>], nozzle: &Nozzle) -> Vec<usize> {
    let mut laid = Deposited::new(points, nozzle);
    let mut hits = Vec::new();
    for (i, (p, b)) in points.iter().zip(tools).enumerate() {
        if laid.hits(p, b, nozzle) {
            hits.push(i);
        }
        laid.add(i);
    }
    hits
}

/// The rotation step tried, degrees.
const STEP_DEG: f64 = 1.0;

/// Resolve the collisions of the path `points` with the tool axes `asked` (the build directions
/// tilted as the torch stands): the tools (those axes rotated about the direction of travel where
/// a collision asks), and what was found and left.
pub fn resolve(
    points: &[Point3<f64>],
    asked: &[Vector3<f64>],
    nozzle: &Nozzle,
) -> (Vec<Vector3<f64>>, Collisions) {
    let n = points.len();
    // The axis of the turn: the direction of travel square to the build direction.
    let travel: Vec<Unit<Vector3<f64>>> = (0..n)
        .map(|i| {
            let d = crate::frame::travel(points, i);
            let b = asked[i];
            Unit::try_new(d - b * d.dot(&b), 1e-9).unwrap_or(Vector3::x_axis())
        })
        .collect();
    let turned =
        |i: usize, deg: f64| Rotation3::from_axis_angle(&travel[i], deg.to_radians()) * asked[i];
    // The smallest rotation that frees each colliding point, against what is laid before it.
    let mut laid = Deposited::new(points, nozzle);
    let mut needed: Vec<(usize, f64)> = Vec::new();
    let mut detected = Vec::new();
    for i in 0..n {
        if laid.hits(&points[i], &asked[i], nozzle) {
            detected.push(i);
            // Towards the vertical first (up, away from the part below), then the other way.
            let up = if travel[i].cross(&asked[i]).z >= 0.0 {
                1.0
            } else {
                -1.0
            };
            let steps = (nozzle.max_rotation_deg / STEP_DEG).floor() as usize;
            let free = (1..=steps)
                .flat_map(|k| [up * k as f64 * STEP_DEG, -up * k as f64 * STEP_DEG])
                .find(|&deg| !laid.hits(&points[i], &turned(i, deg), nozzle));
            if let Some(deg) = free {
                needed.push((i, deg));
            }
        }
        laid.add(i);
    }
    // Ramped in and out along the path: at each point the largest of the needed rotations less
    // the rate times the path length to them.
    let mut s = vec![0.0; n];
    for i in 1..n {
        s[i] = s[i - 1] + (points[i] - points[i - 1]).norm();
    }
    let rate = nozzle.rotation_rate_deg_mm.max(1e-9);
    let mut angle = vec![0.0f64; n];
    for &(c, deg) in &needed {
        let reach = deg.abs() / rate;
        let lo = s.partition_point(|&x| x < s[c] - reach);
        let hi = s.partition_point(|&x| x <= s[c] + reach);
        for j in lo..hi {
            let a = deg.abs() - rate * (s[j] - s[c]).abs();
            if a > angle[j].abs() {
                angle[j] = a.copysign(deg);
            }
        }
    }
    let tools: Vec<Vector3<f64>> = (0..n)
        .map(|i| match angle[i] {
            0.0 => asked[i],
            a => turned(i, a),
        })
        .collect();
    let unresolved = detect(points, &tools, nozzle);
    let max_rotation_deg = angle.iter().map(|a| a.abs()).fold(0.0, f64::max);
    (
        tools,
        Collisions {
            detected,
            unresolved,
            max_rotation_deg,
        },
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    fn nozzle() -> Nozzle {
        Nozzle {
            radius_mm: 10.0,
            standoff_mm: 12.0,
            length_mm: 80.0,
            max_rotation_deg: 45.0,
            rotation_rate_deg_mm: 5.0,
            tube_radius_mm: 0.0,
            arm: None,
        }
    }

    #[test]
    fn a_wall_over_the_torch_is_a_collision() {
        let n = nozzle();
        // Deposited points on a flat row, then a point below them with the tool pointing up.
        let mut pts: Vec<Point3<f64>> = (0..20).map(|k| Point3::new(k as f64, 0.0, 30.0)).collect();
        pts.push(Point3::new(5.0, 0.0, 0.0));
        let tools = vec![Vector3::z(); pts.len()];
        assert_eq!(detect(&pts, &tools, &n), vec![20]);
        // Tool pointing away: no collision.
        let mut away = tools.clone();
        away[20] = -Vector3::z();
        assert!(detect(&pts, &away, &n).is_empty());
    }

    /// The metal as a tube: a point 11 mm off the nozzle's axis misses a nozzle of radius 10,
    /// and meets it once the metal is a tube of radius 2. The arm: metal 150 mm up the axis and
    /// 30 mm off it misses the nozzle (it ends at 92 mm), and hits an arm of radius 40 from 100
    /// to 300 mm.
    #[test]
    fn the_tube_and_the_arm() {
        let n = nozzle();
        let pts = vec![Point3::new(11.0, 0.0, 50.0), Point3::new(0.0, 0.0, 0.0)];
        let tools = vec![Vector3::z(); 2];
        assert!(detect(&pts, &tools, &n).is_empty());
        let tube = Nozzle {
            tube_radius_mm: 2.0,
            ..n
        };
        assert_eq!(detect(&pts, &tools, &tube), vec![1]);
        let far = vec![Point3::new(30.0, 0.0, 150.0), Point3::new(0.0, 0.0, 0.0)];
        assert!(detect(&far, &tools, &n).is_empty());
        let arm = Nozzle {
            arm: Some(Arm {
                radius_mm: 40.0,
                from_mm: 100.0,
                length_mm: 200.0,
            }),
            ..n
        };
        assert_eq!(detect(&far, &tools, &arm), vec![1]);
    }

    /// A row of metal 40 mm above and 8 mm beside a row being laid, the torch straight up: the
    /// nozzle (radius 10) hits it; turning the tool about the travel (x) away from it frees every
    /// point, the turn ramped at the rate allowed; a wall right above cannot be escaped within 5°
    /// and is reported.
    #[test]
    fn a_turn_about_the_travel_frees_the_nozzle() {
        let n = nozzle();
        let mut pts: Vec<Point3<f64>> = (0..40).map(|k| Point3::new(k as f64, 8.0, 40.0)).collect();
        pts.extend((0..40).map(|k| Point3::new(k as f64, 0.0, 0.0)));
        let asked = vec![Vector3::z(); pts.len()];
        let (tools, c) = resolve(&pts, &asked, &n);
        assert!(c.detected.len() > 10, "{c:?}");
        assert!(c.unresolved.is_empty(), "{c:?}");
        assert!(c.max_rotation_deg > 0.0 && c.max_rotation_deg <= n.max_rotation_deg);
        for w in (40..80).collect::<Vec<_>>().windows(2) {
            let turn = tools[w[0]].angle(&tools[w[1]]).to_degrees();
            assert!(
                turn <= n.rotation_rate_deg_mm * 1.0 + 1e-9,
                "{turn}° over 1 mm"
            );
        }
        // The turn keeps the tool square to the travel.
        assert!(tools[60].x.abs() < 1e-12);
        let tight = Nozzle {
            max_rotation_deg: 5.0,
            ..n
        };
        let mut over = pts.clone();
        for p in &mut over[..40] {
            p.y = 0.0;
        }
        let (_, c) = resolve(&over, &asked, &tight);
        assert!(
            !c.unresolved.is_empty() && c.unresolved.len() == c.detected.len(),
            "{c:?}"
        );
    }
}
