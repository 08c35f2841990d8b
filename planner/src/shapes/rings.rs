//! Meshing a surface given as rings around an axis: S(θ, t), θ periodic, t from the lower
//! boundary (t = 0) to the upper boundary or the pole (t = 1).
//!
//! Rings are spaced at equal arc length along the mean meridian, and each ring gets as many
//! points as its circumference needs at the requested edge length; consecutive rings are zipped
//! together by their angular parameter. This keeps triangles close to equilateral on domes, where
//! a plain (θ, t) grid would pile slivers up at the pole.

use crate::mesh::TriMesh;
use nalgebra::Point3;
use std::f64::consts::TAU;

/// Number of samples used to measure meridians and circumferences.
const SAMPLES: usize = 512;

pub struct RingSurface<F: Fn(f64, f64) -> Point3<f64>> {
    pub map: F,
    /// The ring at t = 1 collapses to one point.
    pub closed_top: bool,
}

impl<F: Fn(f64, f64) -> Point3<f64>> RingSurface<F> {
    pub fn mesh(&self, edge_mm: f64) -> TriMesh {
        let mut positions = Vec::new();
        let mut rings: Vec<(u32, usize)> = Vec::new(); // (first vertex, count)
        for (t, n) in self.rings(edge_mm) {
            let first = positions.len() as u32;
            positions.extend((0..n).map(|k| (self.map)(TAU * k as f64 / n as f64, t)));
            rings.push((first, n));
        }
        let mut faces = Vec::new();
        for w in rings.windows(2) {
            zip(w[0], w[1], &mut faces);
        }
        TriMesh::new(positions, faces)
    }

    /// The vertices [`RingSurface::mesh`] makes, counted without making them.
    pub fn vertices(&self, edge_mm: f64) -> usize {
        self.rings(edge_mm).iter().map(|&(_, n)| n).sum()
    }

    /// Each ring's parameter t and its vertex count: as many as its circumference needs at
    /// `edge_mm` (at least six), one at a closed top (the pole, t = 1).
    fn rings(&self, edge_mm: f64) -> Vec<(f64, usize)> {
        let ts = self.ring_parameters(edge_mm);
        let last = ts.len() - 1;
        ts.iter()
            .enumerate()
            .map(|(i, &t)| match self.closed_top && i == last {
                true => (1.0, 1),
                false => (
                    t,
                    ((self.circumference(t) / edge_mm).round() as usize).max(6),
                ),
            })
            .collect()
    }

    /// t values of the rings: equal arc length along the meridian averaged over four angles.
    fn ring_parameters(&self, edge_mm: f64) -> Vec<f64> {
        let mut cumulative = vec![0.0; SAMPLES + 1];
        for j in 1..=SAMPLES {
            let (t0, t1) = ((j - 1) as f64 / SAMPLES as f64, j as f64 / SAMPLES as f64);
            let step: f64 = (0..4)
                .map(|q| {
                    let th = TAU * q as f64 / 4.0;
                    ((self.map)(th, t1) - (self.map)(th, t0)).norm()
                })
                .sum::<f64>()
                / 4.0;
            cumulative[j] = cumulative[j - 1] + step;
        }
        let total = cumulative[SAMPLES];
        let n_rings = ((total / (edge_mm * 0.866)).round() as usize).max(2);
        (0..=n_rings)
            .map(|i| {
                let s = total * i as f64 / n_rings as f64;
                let j = cumulative.partition_point(|&c| c < s).clamp(1, SAMPLES);
                let frac =
                    (s - cumulative[j - 1]) / (cumulative[j] - cumulative[j - 1]).max(1e-300);
                ((j - 1) as f64 + frac.clamp(0.0, 1.0)) / SAMPLES as f64
            })
            .collect()
    }

    fn circumference(&self, t: f64) -> f64 {
        (0..SAMPLES)
            .map(|k| {
                let a = (self.map)(TAU * k as f64 / SAMPLES as f64, t);
                let b = (self.map)(TAU * (k + 1) as f64 / SAMPLES as f64, t);
                (b - a).norm()
            })
            .sum()
    }
}

/// Triangulate the band between two rings by walking both in angular order.
fn zip((a0, na): (u32, usize), (b0, nb): (u32, usize), faces: &mut Vec<[u32; 3]>) {
    let va = |i: usize| a0 + (i % na) as u32;
    let vb = |j: usize| b0 + (j % nb) as u32;
    if nb == 1 {
        for i in 0..na {
            faces.push([va(i), va(i + 1), b0]);
        }
        return;
    }
    let (mut i, mut j) = (0, 0);
    while i < na || j < nb {
        let advance_a =
            j == nb || (i < na && (i + 1) as f64 / na as f64 <= (j + 1) as f64 / nb as f64);
        if advance_a {
            faces.push([va(i), va(i + 1), vb(j)]);
            i += 1;
        } else {
            faces.push([va(i), vb(j + 1), vb(j)]);
            j += 1;
        }
    }
}
