//! A set of points on a uniform grid of cubes, for the closest of them to a query point: the
//! neighbouring layer of a path (Chalvin et al. 2019 §3.1's facets, the local inter-layer
//! distance).

use nalgebra::Point3;
use std::collections::HashMap;
use std::ops::Range;

/// Points `range` of a slice, bucketed by cubes of `cell` mm.
pub struct PointGrid {
    cell: f64,
    map: HashMap<[i64; 3], Vec<u32>>,
    any: usize,
}

impl PointGrid {
    pub fn new(points: &[Point3<f64>], range: Range<usize>, cell_mm: f64) -> PointGrid {
        let mut map: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        let any = range.start;
        for i in range {
            map.entry(key(&points[i], cell_mm))
                .or_default()
                .push(i as u32);
        }
        PointGrid {
            cell: cell_mm,
            map,
            any,
        }
    }

    /// The index of the closest point: shells of cells outwards until the best found is nearer
    /// than the next shell can be (64 shells at most, then the best found or any point).
    pub fn closest(&self, points: &[Point3<f64>], p: &Point3<f64>) -> usize {
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
                return j;
            }
        }
        best.map_or(self.any, |b| b.1)
    }
}

fn key(p: &Point3<f64>, cell: f64) -> [i64; 3] {
    std::array::from_fn(|k| (p[k] / cell).floor() as i64)
}
