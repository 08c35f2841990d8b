//! Geodesic distance by the heat method (Crane, Weischedel, Wardetzky, "Geodesics in Heat",
//! ACM TOG 2013), sectioned by the paper's three steps:
//!
//! 1. integrate the heat flow u̇ = Δu for a short time t = m·h² (one backward-Euler step,
//!    (M + tL) u = δ_sources); on a mesh with boundary, average the Neumann and Dirichlet
//!    solutions (§3.4) unless a source lies on the boundary;
//! 2. evaluate the normalised field X = −∇u / |∇u| per face;
//! 3. solve the Poisson equation L φ = −∇·X.
//!
//! **Many sources.** Step 3 pins every source (Dirichlet φ = its offset, 0 for a vertex) instead
//! of solving with free ends and shifting φ so that its minimum over the sources is zero: the shift
//! leaves φ uneven along a source loop and under-reads distances near it by up to half. Pinned,
//! the result matches the minimum of single-source distances.
//!
//! **Factor once.** All matrices share one sparsity pattern, so one symbolic factorisation serves
//! them all. The two heat matrices and a Poisson matrix pinned at one fixed vertex are factored when
//! the solver is built. A point source, with the rings around it pinned at exact values, costs
//! one multi-column solve with Green's functions of the anchored factor (see
//! [`HeatSolver::poisson_green`]); a larger source set, such as a boundary loop, costs one
//! numeric factorisation, cached for the next query with the same set.

pub mod path;

use crate::geometry::intrinsic::Intrinsic;
use crate::geometry::sparse::{Factor, FactorError, Symbolic};
use crate::geometry::{FaceVector, Operators};
use crate::mesh::TriMesh;
use nalgebra::Point3;
use std::collections::HashMap;
use std::sync::{Arc, Mutex};

/// A point on the surface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SurfacePoint {
    Vertex(u32),
    /// Inside (or on the border of) a face, with barycentric weights of its three corners.
    Face {
        face: u32,
        bary: [f64; 3],
    },
}

impl SurfacePoint {
    pub fn position(&self, mesh: &TriMesh) -> Point3<f64> {
        match *self {
            SurfacePoint::Vertex(v) => mesh.positions[v as usize],
            SurfacePoint::Face { face, bary } => {
                let p = mesh.corners(face as usize);
                Point3::from(p[0].coords * bary[0] + p[1].coords * bary[1] + p[2].coords * bary[2])
            }
        }
    }
}

/// Numerical knobs, with the reason for each default.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HeatOptions {
    /// m in t = m·h²: the paper's recommended m = 1 (smaller is sharper but noisier).
    pub time_factor: f64,
    /// Rings of vertices around the sources pinned at their straight-line distance to the nearest
    /// source point or source edge (an edge with both ends sources). Near the sources the surface
    /// is flat to second order, so these values are exact up to O(d³κ²); pinning them removes the
    /// point-source singularity of step 3, where the heat method is least accurate (measured in
    /// PERFORMANCE.md).
    pub exact_rings: usize,
    /// Build the operators on the intrinsic Delaunay triangulation of the surface (edge flips):
    /// non-negative cotangent weights on any mesh, and no change on a mesh that is Delaunay
    /// already, like the part library's (measured in PERFORMANCE.md).
    pub intrinsic_delaunay: bool,
}

impl Default for HeatOptions {
    fn default() -> Self {
        Self {
            time_factor: 1.0,
            exact_rings: 2,
            intrinsic_delaunay: true,
        }
    }
}

/// Pinned-set factors kept for reuse: the CTPP asks the same few sets (lower loop, upper loop,
/// lower points) several times.
const CACHE_SETS: usize = 4;

/// Up to this many pinned vertices, Green's functions of the anchored factor beat a new numeric
/// factorisation (a point source with two exact rings pins about 19).
const GREEN_MAX_PINS: usize = 40;

pub struct HeatSolver<'m> {
    mesh: &'m TriMesh,
    ops: Operators,
    boundary: Vec<bool>,
    symbolic: Symbolic,
    heat_neumann: Factor,
    heat_dirichlet: Option<Factor>,
    /// Poisson matrix pinned at `anchor`.
    poisson_anchor: Factor,
    anchor: u32,
    cache: Mutex<Vec<(Vec<u32>, Arc<Factor>)>>,
    options: HeatOptions,
    flips: usize,
}

impl<'m> HeatSolver<'m> {
    /// Build operators and factor the fixed matrices. `edges` are the mesh's unique edges and
    /// `boundary` flags its boundary vertices (both from [`crate::mesh::Topology`]).
    pub fn new(
        mesh: &'m TriMesh,
        boundary: &[bool],
        options: HeatOptions,
    ) -> Result<Self, FactorError> {
        let triangulation = if options.intrinsic_delaunay {
            Intrinsic::delaunay(mesh)
        } else {
            Intrinsic::from_mesh(mesh)
        };
        let ops = Operators::new(&triangulation, mesh.n_vertices());
        let symbolic = Symbolic::new(ops.pattern.clone())?;
        let t = options.time_factor * ops.mean_edge * ops.mean_edge;
        let heat = ops.heat_matrix(t);
        let heat_neumann = symbolic.factor(&heat)?;
        let fixed: Vec<u32> = (0..mesh.n_vertices() as u32)
            .filter(|&v| boundary[v as usize])
            .collect();
        let heat_dirichlet = if fixed.is_empty() || fixed.len() == mesh.n_vertices() {
            None
        } else {
            let mut d = heat;
            ops.pattern.pin(&mut d, &fixed);
            Some(symbolic.factor(&d)?)
        };
        let anchor = 0;
        let mut lap = ops.laplacian.clone();
        ops.pattern.pin(&mut lap, &[anchor]);
        let poisson_anchor = symbolic.factor(&lap)?;
        Ok(HeatSolver {
            mesh,
            ops,
            boundary: boundary.to_vec(),
            symbolic,
            heat_neumann,
            heat_dirichlet,
            poisson_anchor,
            anchor,
            cache: Mutex::new(Vec::new()),
            options,
            flips: triangulation.flips,
        })
    }

    pub fn mesh(&self) -> &TriMesh {
        self.mesh
    }

    pub fn operators(&self) -> &Operators {
        &self.ops
    }

    /// Edge flips the intrinsic Delaunay triangulation took (0 when it is off).
    pub fn flips(&self) -> usize {
        self.flips
    }

    /// Geodesic distance from the nearest of `vertices` to every vertex.
    pub fn distance_from_vertices(&self, vertices: &[u32]) -> Vec<f64> {
        let pts: Vec<SurfacePoint> = vertices.iter().map(|&v| SurfacePoint::Vertex(v)).collect();
        self.distance(&pts)
    }

    /// Geodesic distance from the nearest of `sources` to every vertex. Empty sources give an
    /// infinite distance everywhere.
    pub fn distance(&self, sources: &[SurfacePoint]) -> Vec<f64> {
        let n = self.mesh.n_vertices();
        if sources.is_empty() {
            return vec![f64::INFINITY; n];
        }
        // Step 1: heat flow from the sources.
        let mut delta = vec![0.0; n];
        for s in sources {
            match *s {
                SurfacePoint::Vertex(v) => delta[v as usize] += 1.0,
                SurfacePoint::Face { face, bary } => {
                    for (k, &v) in self.mesh.faces[face as usize].iter().enumerate() {
                        delta[v as usize] += bary[k];
                    }
                }
            }
        }
        let on_boundary = delta
            .iter()
            .zip(&self.boundary)
            .any(|(d, b)| *d > 0.0 && *b);
        let mut u = delta.clone();
        match (&self.heat_dirichlet, on_boundary) {
            (Some(dir), false) => {
                let mut ud: Vec<f64> = delta
                    .iter()
                    .zip(&self.boundary)
                    .map(|(d, b)| if *b { 0.0 } else { *d })
                    .collect();
                rayon::join(
                    || self.heat_neumann.solve_in_place(&mut u, 1),
                    || dir.solve_in_place(&mut ud, 1),
                );
                for (a, b) in u.iter_mut().zip(&ud) {
                    *a = 0.5 * (*a + b);
                }
            }
            _ => self.heat_neumann.solve_in_place(&mut u, 1),
        }
        // Step 2: the normalised negative gradient.
        use rayon::prelude::*;
        let field: Vec<FaceVector> = (0..self.ops.faces.len())
            .into_par_iter()
            .map(|f| {
                let g = self.ops.face_gradient(f, &u);
                let len = g[0].hypot(g[1]);
                if len > 0.0 && len.is_finite() {
                    [-g[0] / len, -g[1] / len]
                } else {
                    [0.0, 0.0]
                }
            })
            .collect();
        // Step 3: L φ = −∇·X with the sources pinned.
        let rhs: Vec<f64> = self.ops.divergence(&field).iter().map(|d| -d).collect();
        let pins = self.pins(sources);
        let mut phi = if pins.len() <= GREEN_MAX_PINS && !pins.iter().any(|p| p.0 == self.anchor) {
            self.poisson_green(rhs, &pins)
        } else {
            self.poisson_pinned(rhs, &pins)
        };
        for p in &mut phi {
            *p = p.max(0.0);
        }
        phi
    }

    /// Pinned vertices with their distance to the nearest source: the sources themselves, and the
    /// rings around them at straight-line distance (see [`HeatOptions::exact_rings`]).
    fn pins(&self, sources: &[SurfacePoint]) -> Vec<(u32, f64)> {
        let mesh = self.mesh;
        let mut best: HashMap<u32, f64> = HashMap::new();
        let put = |best: &mut HashMap<u32, f64>, v: u32, d: f64| {
            let e = best.entry(v).or_insert(f64::INFINITY);
            *e = e.min(d);
        };
        // Source points, and source edges between source vertices.
        let mut points: Vec<Point3<f64>> = Vec::with_capacity(sources.len());
        for s in sources {
            let q = s.position(mesh);
            points.push(q);
            match *s {
                SurfacePoint::Vertex(v) => put(&mut best, v, 0.0),
                SurfacePoint::Face { face, bary } => {
                    for (k, &v) in mesh.faces[face as usize].iter().enumerate() {
                        let d = if bary[k] > 1.0 - 1e-12 {
                            0.0
                        } else {
                            (mesh.positions[v as usize] - q).norm()
                        };
                        put(&mut best, v, d);
                    }
                }
            }
        }
        let is_source: HashMap<u32, ()> = best
            .iter()
            .filter(|(_, d)| **d == 0.0)
            .map(|(v, _)| (*v, ()))
            .collect();
        let pat = &self.ops.pattern;
        let mut segments: Vec<(Point3<f64>, Point3<f64>)> = Vec::new();
        for &v in is_source.keys() {
            for (r, _) in pat.column(v as usize) {
                if r as u32 > v && is_source.contains_key(&(r as u32)) {
                    segments.push((mesh.positions[v as usize], mesh.positions[r]));
                }
            }
        }
        let rings = self.options.exact_rings;
        // Breadth-first rings around the pinned set.
        let mut frontier: Vec<u32> = best.keys().copied().collect();
        frontier.sort_unstable();
        let mut seen: std::collections::HashSet<u32> = frontier.iter().copied().collect();
        let mut near: Vec<u32> = Vec::new();
        for _ in 0..rings {
            let mut next = Vec::new();
            for &v in &frontier {
                for (r, _) in pat.column(v as usize) {
                    if seen.insert(r as u32) {
                        next.push(r as u32);
                    }
                }
            }
            near.extend_from_slice(&next);
            frontier = next;
        }
        for v in near {
            let p = mesh.positions[v as usize];
            let to_points = points
                .iter()
                .map(|q| (p - q).norm())
                .fold(f64::INFINITY, f64::min);
            let to_segments = segments
                .iter()
                .map(|(a, b)| point_segment_distance(p, *a, *b))
                .fold(f64::INFINITY, f64::min);
            put(&mut best, v, to_points.min(to_segments));
        }
        let mut pins: Vec<(u32, f64)> = best.into_iter().collect();
        pins.sort_unstable_by_key(|p| p.0);
        pins
    }

    /// A few pinned vertices P, from the factor pinned at the anchor r (r ∉ P), without a new
    /// factorisation. With y = L_r⁻¹ b (b_r = 0) and the Green's functions g_s = L_r⁻¹ e_s, every
    /// φ = y + Σ c_s g_s + d·1 satisfies the free rows (i ∉ P ∪ {r}). Row r holds when
    /// Σ c_s = −Σ b (since 1ᵀL = 0), and φ_s = value_s for s ∈ P: k + 1 equations for the k + 1
    /// unknowns (c, d), a small dense system. Cost: one solve with k + 1 right-hand sides.
    fn poisson_green(&self, b: Vec<f64>, pins: &[(u32, f64)]) -> Vec<f64> {
        let n = b.len();
        let k = pins.len();
        let r = self.anchor as usize;
        let total: f64 = b.iter().sum();
        let mut cols = vec![0.0; n * (k + 1)];
        cols[..n].copy_from_slice(&b);
        cols[r] = 0.0;
        for (j, &(s, _)) in pins.iter().enumerate() {
            cols[n * (j + 1) + s as usize] = 1.0;
        }
        // Two fixed halves solved side by side: the same arithmetic on one thread or two.
        let half = n * ((k + 2) / 2);
        let (c0, c1) = cols.split_at_mut(half);
        rayon::join(
            || self.poisson_anchor.solve_in_place(c0, half / n),
            || self.poisson_anchor.solve_in_place(c1, k + 1 - half / n),
        );
        // Bordered system [G 1; 1ᵀ 0] [c; d] = [value − y_P; −Σb], G_st = g_t(s).
        let m = k + 1;
        let mut a = vec![0.0; m * m];
        let mut rhs = vec![0.0; m];
        for (i, &(s, value)) in pins.iter().enumerate() {
            for j in 0..k {
                a[i * m + j] = cols[n * (j + 1) + s as usize];
            }
            a[i * m + k] = 1.0;
            rhs[i] = value - cols[s as usize];
        }
        for j in 0..k {
            a[k * m + j] = 1.0;
        }
        rhs[k] = -total;
        let x = crate::geometry::solve_dense(&mut a, &mut rhs, m)
            .expect("bordered Green's system is regular");
        let (c, d) = (&x[..k], x[k]);
        use rayon::prelude::*;
        (0..n)
            .into_par_iter()
            .map(|i| cols[i] + (0..k).map(|j| c[j] * cols[n * (j + 1) + i]).sum::<f64>() + d)
            .collect()
    }

    /// Several pinned vertices: a numeric factorisation of L with their rows and columns replaced
    /// by the identity, cached by the set.
    fn poisson_pinned(&self, mut b: Vec<f64>, pins: &[(u32, f64)]) -> Vec<f64> {
        let set: Vec<u32> = pins.iter().map(|p| p.0).collect();
        let factor = self.pinned_factor(&set);
        let pat = &self.ops.pattern;
        // Move the known values to the right-hand side: b_i −= L_is φ_s.
        for &(s, value) in pins {
            for (i, slot) in pat.column(s as usize) {
                b[i] -= self.ops.laplacian[slot] * value;
            }
        }
        for &(s, value) in pins {
            b[s as usize] = value;
        }
        factor.solve_in_place(&mut b, 1);
        b
    }

    fn pinned_factor(&self, set: &[u32]) -> Arc<Factor> {
        let mut cache = self.cache.lock().expect("cache lock");
        if let Some(pos) = cache.iter().position(|(k, _)| k.as_slice() == set) {
            let hit = cache.remove(pos);
            let f = hit.1.clone();
            cache.push(hit);
            return f;
        }
        let mut lap = self.ops.laplacian.clone();
        self.ops.pattern.pin(&mut lap, set);
        // L with at least one pinned vertex per component is positive definite; a failure here
        // means a degenerate mesh, which `Part` validation excludes.
        let f = Arc::new(
            self.symbolic
                .factor(&lap)
                .expect("pinned Laplacian is positive definite"),
        );
        if cache.len() == CACHE_SETS {
            cache.remove(0);
        }
        cache.push((set.to_vec(), f.clone()));
        f
    }
}

fn point_segment_distance(p: Point3<f64>, a: Point3<f64>, b: Point3<f64>) -> f64 {
    let ab = b - a;
    let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
    (p - (a + ab * t)).norm()
}

#[cfg(test)]
mod tests;
