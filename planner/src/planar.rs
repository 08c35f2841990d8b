//! The planar 2.5D baseline (CTPP §3.3, Fig. 25): horizontal slices every h, and the local deposit
//! height each slice asks for, which is the distance along the surface to the slice beneath
//! (measured as the straight distance to the nearest point of the previous contour, which is the
//! surface distance to second order). The top is what is left between the last slice and the
//! upper boundary (or the apex of a closed part), which no layer of height h fits.

use crate::mesh::Part;
use nalgebra::Point3;

#[derive(Debug, Clone, PartialEq)]
pub struct PlanarLayer {
    pub z_mm: f64,
    /// Contour points (edge crossings), in no particular order.
    pub points: Vec<Point3<f64>>,
    pub deposit_mm: Vec<f64>,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Planar {
    pub layers: Vec<PlanarLayer>,
    /// What each upper-boundary vertex (or the apex) still needs above the last slice.
    pub top_deposit_mm: Vec<f64>,
}

impl Planar {
    pub fn all_deposits(&self) -> impl Iterator<Item = f64> + '_ {
        self.layers
            .iter()
            .flat_map(|l| l.deposit_mm.iter().copied())
            .chain(self.top_deposit_mm.iter().copied())
    }
}

pub fn slice(part: &Part, h: f64) -> Planar {
    let m = &part.mesh;
    let zmax = m
        .positions
        .iter()
        .map(|p| p.z)
        .fold(f64::NEG_INFINITY, f64::max);
    let lower: Vec<Point3<f64>> = part
        .lower_loop()
        .vertices
        .iter()
        .map(|&v| m.positions[v as usize])
        .collect();
    let mut previous = lower;
    let mut layers = Vec::new();
    let mut k = 1;
    while (k as f64) * h < zmax {
        let z = k as f64 * h;
        let points = contour(part, z);
        if points.is_empty() {
            break;
        }
        let deposit_mm = points.iter().map(|p| nearest(&previous, *p)).collect();
        layers.push(PlanarLayer {
            z_mm: z,
            points: points.clone(),
            deposit_mm,
        });
        previous = points;
        k += 1;
    }
    let top: Vec<Point3<f64>> = match part.upper_loop() {
        Some(l) => l
            .vertices
            .iter()
            .map(|&v| m.positions[v as usize])
            .collect(),
        None => vec![
            *m.positions
                .iter()
                .max_by(|a, b| a.z.total_cmp(&b.z))
                .expect("vertices"),
        ],
    };
    // Each top point needs what lies between it and the highest slice below it.
    let top_deposit_mm = top
        .iter()
        .map(|p| {
            layers
                .iter()
                .rev()
                .find(|l| l.z_mm <= p.z)
                .map(|l| nearest(&l.points, *p))
                .unwrap_or(p.z)
        })
        .collect();
    Planar {
        layers,
        top_deposit_mm,
    }
}

fn contour(part: &Part, z: f64) -> Vec<Point3<f64>> {
    let m = &part.mesh;
    part.topology
        .edges
        .iter()
        .filter_map(|&[a, b]| {
            let (pa, pb) = (m.positions[a as usize], m.positions[b as usize]);
            if (pa.z >= z) != (pb.z >= z) {
                let t = (z - pa.z) / (pb.z - pa.z);
                Some(pa + (pb - pa) * t)
            } else {
                None
            }
        })
        .collect()
}

fn nearest(set: &[Point3<f64>], p: Point3<f64>) -> f64 {
    set.iter()
        .map(|q| (q - p).norm())
        .fold(f64::INFINITY, f64::min)
}
