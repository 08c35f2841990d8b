//! Discrete differential geometry on a triangle mesh: the cotangent Laplacian, the lumped mass
//! matrix, and per-face gradients and integrated divergence (Crane, Weischedel, Wardetzky 2013,
//! "Geodesics in Heat", §3.2). Conventions: `laplacian` is the positive semi-definite
//! L = −Δ (L_ii = Σ_j w_ij, L_ij = −w_ij, w_ij = (cot α_ij + cot β_ij)/2), so L·1 = 0.

pub mod closest;
pub mod sparse;

use crate::mesh::TriMesh;
use nalgebra::Vector3;
use sparse::Pattern;
use std::sync::Arc;

/// The operators of one mesh, built once.
pub struct Operators {
    pub pattern: Arc<Pattern>,
    /// Values of L on `pattern`.
    pub laplacian: Vec<f64>,
    /// Lumped (barycentric) vertex areas, mm².
    pub mass: Vec<f64>,
    /// Per face: cotangent of the angle at each corner.
    pub corner_cot: Vec<[f64; 3]>,
    /// Per face: unit normal and area.
    pub face_normal: Vec<Vector3<f64>>,
    pub face_area: Vec<f64>,
    pub mean_edge: f64,
    /// Per vertex, its (face, corner) pairs (CSR), so vertex sums gather in parallel.
    corner_start: Vec<u32>,
    corners: Vec<(u32, u8)>,
}

impl Operators {
    /// Build the operators; `edges` are the mesh's unique edges (lower index first).
    pub fn new(mesh: &TriMesh, edges: &[[u32; 2]]) -> Operators {
        let n = mesh.n_vertices();
        let pattern = Arc::new(Pattern::from_edges(n, edges));
        let mut edge_index = std::collections::HashMap::with_capacity(edges.len());
        for (e, &[i, j]) in edges.iter().enumerate() {
            edge_index.insert((i, j), e);
        }
        let mut laplacian = vec![0.0; pattern.nnz()];
        let mut mass = vec![0.0; n];
        let mut corner_cot = Vec::with_capacity(mesh.n_faces());
        let mut face_normal = Vec::with_capacity(mesh.n_faces());
        let mut face_area = Vec::with_capacity(mesh.n_faces());
        let mut edge_sum = 0.0;
        for (f, face) in mesh.faces.iter().enumerate() {
            let p = mesh.corners(f);
            let n2 = (p[1] - p[0]).cross(&(p[2] - p[0]));
            let area = 0.5 * n2.norm();
            face_normal.push(n2 / (2.0 * area));
            face_area.push(area);
            let mut cots = [0.0; 3];
            for k in 0..3 {
                let (a, b) = (p[(k + 1) % 3] - p[k], p[(k + 2) % 3] - p[k]);
                cots[k] = a.dot(&b) / a.cross(&b).norm();
                edge_sum += a.norm();
            }
            corner_cot.push(cots);
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
        }
        let mean_edge = edge_sum / (3 * mesh.n_faces()).max(1) as f64;
        let mut corner_start = vec![0u32; n + 1];
        for face in &mesh.faces {
            for &v in face {
                corner_start[v as usize + 1] += 1;
            }
        }
        for i in 0..n {
            corner_start[i + 1] += corner_start[i];
        }
        let mut fill = corner_start.clone();
        let mut corners = vec![(0u32, 0u8); corner_start[n] as usize];
        for (f, face) in mesh.faces.iter().enumerate() {
            for (k, &v) in face.iter().enumerate() {
                corners[fill[v as usize] as usize] = (f as u32, k as u8);
                fill[v as usize] += 1;
            }
        }
        Operators {
            pattern,
            laplacian,
            mass,
            corner_cot,
            face_normal,
            face_area,
            mean_edge,
            corner_start,
            corners,
        }
    }

    /// Values of M + t·L on the pattern.
    pub fn heat_matrix(&self, t: f64) -> Vec<f64> {
        let mut v: Vec<f64> = self.laplacian.iter().map(|l| t * l).collect();
        for (i, m) in self.mass.iter().enumerate() {
            v[self.pattern.diag_slot(i)] += m;
        }
        v
    }

    /// Gradient of a piecewise-linear function on face `f`: (1/2A) Σ_k u_k (N × e_k), with e_k
    /// the edge opposite corner k in counter-clockwise order.
    pub fn face_gradient(&self, mesh: &TriMesh, f: usize, u: &[f64]) -> Vector3<f64> {
        let p = mesh.corners(f);
        let nrm = self.face_normal[f];
        let face = mesh.faces[f];
        let mut g = Vector3::zeros();
        for k in 0..3 {
            let e = p[(k + 2) % 3] - p[(k + 1) % 3];
            g += u[face[k] as usize] * nrm.cross(&e);
        }
        g / (2.0 * self.face_area[f])
    }

    /// Integrated divergence of a per-face vector field at every vertex (Crane et al. Eq. (4)):
    /// ∇·X at i = ½ Σ_faces [cot θ₁ (e₁·X) + cot θ₂ (e₂·X)], e₁, e₂ the edges leaving i and θ
    /// the angles opposite them.
    pub fn divergence(&self, mesh: &TriMesh, field: &[Vector3<f64>]) -> Vec<f64> {
        use rayon::prelude::*;
        (0..mesh.n_vertices())
            .into_par_iter()
            .map(|v| {
                let corners =
                    &self.corners[self.corner_start[v] as usize..self.corner_start[v + 1] as usize];
                corners
                    .iter()
                    .map(|&(f, k)| {
                        let (f, k) = (f as usize, k as usize);
                        let p = mesh.corners(f);
                        let cot = self.corner_cot[f];
                        let (j, l) = ((k + 1) % 3, (k + 2) % 3);
                        // k→j is opposite corner l; k→l is opposite corner j.
                        0.5 * (cot[l] * (p[j] - p[k]).dot(&field[f])
                            + cot[j] * (p[l] - p[k]).dot(&field[f]))
                    })
                    .sum()
            })
            .collect()
    }
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
