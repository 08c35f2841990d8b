//! Deviation of the built surface from the part (CTPP Fig. 30): the surface swept by consecutive
//! revolutions of the path (each point joined to its neighbour on the path and to the point above
//! it on the next revolution) against the input mesh, as signed distances (positive outside).

use crate::geometry::closest::ClosestPoint;
use nalgebra::Point3;

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Deviation {
    pub min_mm: f64,
    pub max_mm: f64,
    pub rms_mm: f64,
    pub samples: usize,
}

/// `points` in path order with `per_revolution` points a revolution (the same generator recurs
/// every `per_revolution` points).
pub fn deviation(
    points: &[Point3<f64>],
    per_revolution: usize,
    surface: &ClosestPoint,
) -> Deviation {
    use rayon::prelude::*;
    let n = points.len();
    let tris: Vec<[usize; 3]> = (0..n.saturating_sub(per_revolution + 1))
        .flat_map(|i| {
            [
                [i, i + 1, i + per_revolution],
                [i + 1, i + per_revolution + 1, i + per_revolution],
            ]
        })
        .collect();
    let d: Vec<f64> = tris
        .par_iter()
        .flat_map_iter(|t| {
            let [a, b, c] = t.map(|k| points[k].coords);
            // Centroid and edge midpoints: where a flat facet strays furthest from a curved part.
            [
                (a + b + c) / 3.0,
                (a + b) / 2.0,
                (b + c) / 2.0,
                (a + c) / 2.0,
            ]
            .into_iter()
            .map(|q| surface.signed_distance(Point3::from(q)))
        })
        .collect();
    if d.is_empty() {
        return Deviation {
            min_mm: 0.0,
            max_mm: 0.0,
            rms_mm: 0.0,
            samples: 0,
        };
    }
    Deviation {
        min_mm: d.iter().cloned().fold(f64::INFINITY, f64::min),
        max_mm: d.iter().cloned().fold(f64::NEG_INFINITY, f64::max),
        rms_mm: (d.iter().map(|x| x * x).sum::<f64>() / d.len() as f64).sqrt(),
        samples: d.len(),
    }
}
