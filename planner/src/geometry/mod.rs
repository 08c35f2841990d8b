//! Discrete differential geometry on a triangle mesh: the cotangent Laplacian, the lumped mass
//! matrix, and per-face gradients and integrated divergence (Crane, Weischedel, Wardetzky 2013,
//! "Geodesics in Heat", §3.2). Conventions: `laplacian` is the positive semi-definite
//! L = −Δ (L_ii = Σ_j w_ij, L_ij = −w_ij, w_ij = (cot α_ij + cot β_ij)/2), so L·1 = 0.

pub mod closest;
pub mod grid;
pub mod intrinsic;
pub mod sparse;

use crate::mesh::TriMesh;

use intrinsic::Intrinsic;
use sparse::Pattern;
use std::sync::Arc;

/// A per-face vector in the face's own flat layout (see [`Intrinsic::layout`]).
pub type FaceVector = [f64; 2];

/// The operators of one triangulation, built once from its edge lengths alone.
pub struct Operators {
    pub pattern: Arc<Pattern>,
    /// Values of L on `pattern`.
    pub laplacian: Vec<f64>,
    /// Lumped (barycentric) vertex areas, mm².
    pub mass: Vec<f64>,
    /// The triangulation's faces (the mesh's own, or intrinsic Delaunay ones).
    pub faces: Vec<[u32; 3]>,
    /// Per face: its flat layout, the cotangent at each corner, its area.
    pub layout: Vec<[[f64; 2]; 3]>,
    pub corner_cot: Vec<[f64; 3]>,
    pub face_area: Vec<f64>,
    pub mean_edge: f64,
    /// Per vertex, its (face, corner) pairs (CSR), so vertex sums gather in parallel.
    corner_start: Vec<u32>,
    corners: Vec<(u32, u8)>,
}

impl Operators {
    /// The operators of a triangulation given by faces and edge lengths.
    pub fn new(t: &Intrinsic, n_vertices: usize) -> Operators {
        let n = n_vertices;
        let edges = t.edges();
        let pattern = Arc::new(Pattern::from_edges(n, &edges));
        let mut edge_index = std::collections::HashMap::with_capacity(edges.len());
        for (e, &[i, j]) in edges.iter().enumerate() {
            edge_index.insert((i, j), e);
        }
        let mut laplacian = vec![0.0; pattern.nnz()];
        let mut mass = vec![0.0; n];
        let (mut corner_cot, mut layout, mut face_area) = (Vec::new(), Vec::new(), Vec::new());
        let mut edge_sum = 0.0;
        for (f, face) in t.faces.iter().enumerate() {
            let area = t.area(f);
            let cots: [f64; 3] = std::array::from_fn(|k| t.cot(f, k));
            edge_sum += t.lengths[f].iter().sum::<f64>();
            for k in 0..3 {
                // Edge opposite corner k joins the other two corners.
                let (i, j) = (face[(k + 1) % 3], face[(k + 2) % 3]);
                let e = edge_index[&(i.min(j), i.max(j))];
                let w = 0.5 * cots[k];
                let [s0, s1] = pattern.edge_slots(e);
                laplacian[s0] -= w;
                laplacian[s1] -= w;
                laplacian[pattern.diag_slot(i as usize)] += w;
                laplacian[pattern.diag_slot(j as usize)] += w;
                mass[face[k] as usize] += area / 3.0;
            }
            corner_cot.push(cots);
            layout.push(t.layout(f));
            face_area.push(area);
        }
        let mean_edge = edge_sum / (3 * t.faces.len()).max(1) as f64;
        let (corner_start, corners) = vertex_corners(&t.faces, n);
        Operators {
            pattern,
            laplacian,
            mass,
            faces: t.faces.clone(),
            layout,
            corner_cot,
            face_area,
            mean_edge,
            corner_start,
            corners,
        }
    }

    /// The operators of a mesh as it is.
    pub fn of_mesh(mesh: &TriMesh) -> Operators {
        Operators::new(&Intrinsic::from_mesh(mesh), mesh.n_vertices())
    }

    /// Values of M + t·L on the pattern.
    pub fn heat_matrix(&self, t: f64) -> Vec<f64> {
        let mut v: Vec<f64> = self.laplacian.iter().map(|l| t * l).collect();
        for (i, m) in self.mass.iter().enumerate() {
            v[self.pattern.diag_slot(i)] += m;
        }
        v
    }

    /// Gradient of a piecewise-linear function on face `f`, in its layout: (1/2A) Σ_k u_k ⊥e_k,
    /// with e_k the edge opposite corner k in counter-clockwise order and ⊥ a quarter turn.
    pub fn face_gradient(&self, f: usize, u: &[f64]) -> FaceVector {
        let p = &self.layout[f];
        let face = self.faces[f];
        let mut g = [0.0; 2];
        for k in 0..3 {
            let (a, b) = (p[(k + 1) % 3], p[(k + 2) % 3]);
            let e = [b[0] - a[0], b[1] - a[1]];
            g[0] += u[face[k] as usize] * -e[1];
            g[1] += u[face[k] as usize] * e[0];
        }
        let s = 1.0 / (2.0 * self.face_area[f]);
        [g[0] * s, g[1] * s]
    }

    /// Integrated divergence of a per-face field at every vertex (Crane et al. Eq. (4)):
    /// ∇·X at i = ½ Σ_faces [cot θ₁ (e₁·X) + cot θ₂ (e₂·X)], e₁, e₂ the edges leaving i and θ
    /// the angles opposite them.
    pub fn divergence(&self, field: &[FaceVector]) -> Vec<f64> {
        use rayon::prelude::*;
        (0..self.corner_start.len() - 1)
            .into_par_iter()
            .map(|v| {
                let corners =
                    &self.corners[self.corner_start[v] as usize..self.corner_start[v + 1] as usize];
                corners
                    .iter()
                    .map(|&(f, k)| {
                        let (f, k) = (f as usize, k as usize);
                        let p = &self.layout[f];
                        let cot = self.corner_cot[f];
                        let x = field[f];
                        let (j, l) = ((k + 1) % 3, (k + 2) % 3);
                        let dot = |q: [f64; 2]| (q[0] - p[k][0]) * x[0] + (q[1] - p[k][1]) * x[1];
                        // k→j is opposite corner l; k→l is opposite corner j.
                        0.5 * (cot[l] * dot(p[j]) + cot[j] * dot(p[l]))
                    })
                    .sum()
            })
            .collect()
    }
}

/// Per vertex, the (face, corner) pairs where it sits, as a CSR: `start[v]..start[v + 1]` indexes
/// `corners`.
pub fn vertex_corners(faces: &[[u32; 3]], n: usize) -> (Vec<u32>, Vec<(u32, u8)>) {
    let mut start = vec![0u32; n + 1];
    for face in faces {
        for &v in face {
            start[v as usize + 1] += 1;
        }
    }
    for i in 0..n {
        start[i + 1] += start[i];
    }
    let mut fill = start.clone();
    let mut corners = vec![(0u32, 0u8); start[n] as usize];
    for (f, face) in faces.iter().enumerate() {
        for (k, &v) in face.iter().enumerate() {
            corners[fill[v as usize] as usize] = (f as u32, k as u8);
            fill[v as usize] += 1;
        }
    }
    (start, corners)
}

/// Gaussian elimination with partial pivoting on a small dense system (row-major m × m); `None`
/// if it is singular.
pub fn solve_dense(a: &mut [f64], b: &mut [f64], m: usize) -> Option<Vec<f64>> {
    for col in 0..m {
        let piv =
            (col..m).max_by(|&i, &j| a[i * m + col].abs().total_cmp(&a[j * m + col].abs()))?;
        if a[piv * m + col].abs() < 1e-300 {
            return None;
        }
        if piv != col {
            for j in 0..m {
                a.swap(col * m + j, piv * m + j);
            }
            b.swap(col, piv);
        }
        let p = a[col * m + col];
        for i in col + 1..m {
            let f = a[i * m + col] / p;
            if f != 0.0 {
                for j in col..m {
                    a[i * m + j] -= f * a[col * m + j];
                }
                b[i] -= f * b[col];
            }
        }
    }
    let mut x = vec![0.0; m];
    for i in (0..m).rev() {
        let s: f64 = (i + 1..m).map(|j| a[i * m + j] * x[j]).sum();
        x[i] = (b[i] - s) / a[i * m + i];
    }
    Some(x)
}
