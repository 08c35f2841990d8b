//! Nozzle collision detection (CTPP §2.4): at each path point the nozzle is a cylinder of radius
//! R_nozzle on the tool axis, from the contact-tip standoff to its length; it collides when
//! metal already deposited (an earlier path point) lies inside it. Resolution (rotating the tool
//! about t) is not done here: every detected collision is reported unresolved.

use nalgebra::{Point3, Vector3};
use std::collections::HashMap;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Nozzle {
    pub radius_mm: f64,
    /// Distance from the deposit to the nozzle tip along the tool axis.
    pub standoff_mm: f64,
    pub length_mm: f64,
}

/// Indices of the path points whose nozzle contains an earlier point.
pub fn detect(points: &[Point3<f64>], tools: &[Vector3<f64>], nozzle: &Nozzle) -> Vec<usize> {
    let cell = nozzle.radius_mm.max(1.0);
    let key =
        |p: &Point3<f64>| -> [i64; 3] { std::array::from_fn(|k| (p[k] / cell).floor() as i64) };
    let mut grid: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
    let mut hits = Vec::new();
    let steps = (nozzle.length_mm / cell).ceil() as usize + 1;
    for (i, (p, b)) in points.iter().zip(tools).enumerate() {
        let mut hit = false;
        'axis: for s in 0..=steps {
            let a = nozzle.standoff_mm + nozzle.length_mm * s as f64 / steps as f64;
            let c = key(&(p + b * a));
            for dx in -1..=1 {
                for dy in -1..=1 {
                    for dz in -1..=1 {
                        for &j in grid
                            .get(&[c[0] + dx, c[1] + dy, c[2] + dz])
                            .into_iter()
                            .flatten()
                        {
                            let q = points[j as usize] - p;
                            let along = q.dot(b);
                            if along >= nozzle.standoff_mm
                                && along <= nozzle.standoff_mm + nozzle.length_mm
                                && (q - b * along).norm() < nozzle.radius_mm
                            {
                                hit = true;
                                break 'axis;
                            }
                        }
                    }
                }
            }
        }
        if hit {
            hits.push(i);
        }
        grid.entry(key(p)).or_default().push(i as u32);
    }
    hits
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_wall_over_the_torch_is_a_collision() {
        let n = Nozzle {
            radius_mm: 10.0,
            standoff_mm: 12.0,
            length_mm: 80.0,
        };
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
}
