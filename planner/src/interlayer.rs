//! The local inter-layer distance of a layered path (Chalvin et al. 2019 §2, Fig. 5 and 7): for
//! each point, the distance to the closest point of the layer beneath, the polyline between its
//! points (the first layer against a base curve, the plate's). This is the height a bead must
//! have there; its spread against the nominal Δ is what the process window has to absorb. Works
//! on any path whose layers are contiguous runs of points, a CTPP spiral's revolutions included.

use crate::geometry::grid::PointGrid;
use nalgebra::Point3;
use std::ops::Range;

/// The distance from each point to the layer beneath, mm; the first layer's to `base` (None
/// where no base is given).
pub fn distances(
    points: &[Point3<f64>],
    layers: &[usize],
    base: Option<&[Point3<f64>]>,
) -> Vec<Option<f64>> {
    let ranges = layer_ranges(layers);
    let mut out = vec![None; points.len()];
    let base_grid = base
        .filter(|b| !b.is_empty())
        .map(|b| (b, PointGrid::new(b, 0..b.len(), 1.0)));
    for (k, r) in ranges.iter().enumerate() {
        let owned;
        let (line, range, grid): (&[Point3<f64>], Range<usize>, &PointGrid) = if k == 0 {
            match &base_grid {
                Some((b, g)) => (b, 0..b.len(), g),
                None => continue,
            }
        } else {
            let below = ranges[k - 1].clone();
            owned = PointGrid::new(points, below.clone(), 1.0);
            (points, below, &owned)
        };
        for i in r.clone() {
            out[i] = Some(to_polyline(line, &range, grid, &points[i]));
        }
    }
    out
}

/// Each layer's contiguous run of points, in order.
pub fn layer_ranges(layers: &[usize]) -> Vec<Range<usize>> {
    let mut ranges: Vec<(usize, Range<usize>)> = Vec::new();
    for (i, &layer) in layers.iter().enumerate() {
        match ranges.last_mut() {
            Some((l, r)) if *l == layer => r.end = i + 1,
            _ => ranges.push((layer, i..i + 1)),
        }
    }
    ranges.into_iter().map(|(_, r)| r).collect()
}

/// The distance from `p` to the polyline `line[range]`: to the segments on either side of its
/// closest vertex.
fn to_polyline(
    line: &[Point3<f64>],
    range: &Range<usize>,
    grid: &PointGrid,
    p: &Point3<f64>,
) -> f64 {
    let j = grid.closest(line, p);
    let mut best = (line[j] - p).norm();
    for (a, b) in [(j.wrapping_sub(1), j), (j, j + 1)] {
        if a >= range.start && b < range.end && a < b {
            best = best.min(to_segment(&line[a], &line[b], p));
        }
    }
    best
}

fn to_segment(a: &Point3<f64>, b: &Point3<f64>, p: &Point3<f64>) -> f64 {
    let ab = b - a;
    let len2 = ab.norm_squared();
    if len2 == 0.0 {
        return (p - a).norm();
    }
    let s = ((p - a).dot(&ab) / len2).clamp(0.0, 1.0);
    (p - (a + ab * s)).norm()
}

/// The spread of the local inter-layer distance against the nominal Δ.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Spread {
    pub n_points: usize,
    pub nominal_mm: f64,
    pub min_mm: f64,
    pub max_mm: f64,
    pub mean_mm: f64,
}

impl Spread {
    /// The spread of the distances given (None skipped); None where there are none.
    pub fn of(distances: impl IntoIterator<Item = Option<f64>>, nominal_mm: f64) -> Option<Spread> {
        let (mut n, mut lo, mut hi, mut sum) = (0usize, f64::INFINITY, f64::NEG_INFINITY, 0.0);
        for d in distances.into_iter().flatten() {
            n += 1;
            lo = lo.min(d);
            hi = hi.max(d);
            sum += d;
        }
        (n > 0).then(|| Spread {
            n_points: n,
            nominal_mm,
            min_mm: lo,
            max_mm: hi,
            mean_mm: sum / n as f64,
        })
    }

    /// The smallest and largest distance as a variation from Δ, %.
    pub fn variation_pct(&self) -> (f64, f64) {
        let v = |d: f64| 100.0 * (d / self.nominal_mm - 1.0);
        (v(self.min_mm), v(self.max_mm))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two concentric circles 2 mm apart in z and 1 mm apart in radius: √5 everywhere, the first
    /// against a base 3 mm beneath it.
    #[test]
    fn circles_stacked() {
        let circle = |r: f64, z: f64, n: usize, phase: f64| -> Vec<Point3<f64>> {
            (0..n)
                .map(|k| {
                    let a = std::f64::consts::TAU * (k as f64 + phase) / n as f64;
                    Point3::new(r * a.cos(), r * a.sin(), z)
                })
                .collect()
        };
        let base = circle(10.0, 0.0, 2000, 0.0);
        let mut pts = circle(10.0, 3.0, 500, 0.3);
        pts.extend(circle(11.0, 5.0, 700, 0.0));
        let layers: Vec<usize> = (0..pts.len()).map(|i| usize::from(i >= 500)).collect();
        let d = distances(&pts, &layers, Some(&base));
        assert!(d[..500].iter().all(|x| (x.unwrap() - 3.0).abs() < 1e-4));
        assert!(
            d[500..]
                .iter()
                .all(|x| (x.unwrap() - 5f64.sqrt()).abs() < 1e-3)
        );
        let none = distances(&pts, &layers, None);
        assert!(none[..500].iter().all(Option::is_none));
        let s = Spread::of(d[500..].iter().copied(), 2.0).unwrap();
        let (lo, hi) = s.variation_pct();
        assert!((lo - 100.0 * (5f64.sqrt() / 2.0 - 1.0)).abs() < 0.1, "{lo}");
        assert!(hi >= lo && s.n_points == 700);
    }
}
