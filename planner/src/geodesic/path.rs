//! Geodesic paths by steepest descent of a distance field (the second half of the heat method's
//! use in CTPP: a generator is the path from a lower point down the distance to the upper boundary
//! or the closing point, Eq.1).
//!
//! φ is linear on each face, so the descent is straight inside a face and bends only on edges.
//! The walker has three states: inside a face (follow −∇φ to the exit edge), on an edge (cross
//! into the neighbour if its descent points inwards; otherwise the edge is a valley and the path
//! runs along it), and on a vertex (enter the incident face whose descent points into its wedge,
//! or follow the steepest descending edge).

use super::SurfacePoint;
use crate::mesh::{Topology, TriMesh};
use nalgebra::{Point3, Vector3};

const NONE: u32 = u32::MAX;

/// A traced path: surface points from the start to where the distance reaches zero.
#[derive(Debug, Clone, PartialEq)]
pub struct GeodesicPath {
    pub points: Vec<Point3<f64>>,
    pub length_mm: f64,
    /// Whether the descent reached the source set (φ = 0); false if it stalled at a spurious
    /// minimum of the discrete field.
    pub reached: bool,
}

/// Face adjacency for walking, built once per mesh.
pub struct Tracer<'a> {
    mesh: &'a TriMesh,
    topology: &'a Topology,
    /// Faces around each vertex (CSR).
    vf_start: Vec<u32>,
    vf: Vec<u32>,
    /// Per face, gradients of the three barycentric coordinates.
    bary_grad: Vec<[Vector3<f64>; 3]>,
    scale: f64,
}

#[derive(Debug, Clone, Copy)]
enum State {
    Face { f: usize, bary: [f64; 3] },
    Vertex(usize),
}

impl<'a> Tracer<'a> {
    pub fn new(mesh: &'a TriMesh, topology: &'a Topology) -> Tracer<'a> {
        let (count, corners) = crate::geometry::vertex_corners(&mesh.faces, mesh.n_vertices());
        let vf = corners.iter().map(|c| c.0).collect();
        let bary_grad = (0..mesh.n_faces())
            .map(|f| {
                let p = mesh.corners(f);
                let n2 = (p[1] - p[0]).cross(&(p[2] - p[0]));
                let nrm = n2.normalize();
                let two_a = n2.norm();
                std::array::from_fn(|k| nrm.cross(&(p[(k + 2) % 3] - p[(k + 1) % 3])) / two_a)
            })
            .collect();
        Tracer {
            mesh,
            topology,
            vf_start: count,
            vf,
            bary_grad,
            scale: mesh.mean_edge_length(),
        }
    }

    fn faces_of(&self, v: usize) -> &[u32] {
        &self.vf[self.vf_start[v] as usize..self.vf_start[v + 1] as usize]
    }

    fn grad(&self, f: usize, phi: &[f64]) -> Vector3<f64> {
        let face = self.mesh.faces[f];
        (0..3)
            .map(|k| self.bary_grad[f][k] * phi[face[k] as usize])
            .sum()
    }

    fn point(&self, f: usize, b: [f64; 3]) -> Point3<f64> {
        let p = self.mesh.corners(f);
        Point3::from(p[0].coords * b[0] + p[1].coords * b[1] + p[2].coords * b[2])
    }

    fn value(&self, f: usize, b: [f64; 3], phi: &[f64]) -> f64 {
        let face = self.mesh.faces[f];
        (0..3).map(|k| b[k] * phi[face[k] as usize]).sum()
    }

    /// Descend `phi` (a distance field, zero on its sources) from `start`.
    pub fn descend(&self, phi: &[f64], start: SurfacePoint) -> GeodesicPath {
        let stop = 1e-9 * self.scale;
        let mut state = match start {
            SurfacePoint::Vertex(v) => State::Vertex(v as usize),
            SurfacePoint::Face { face, bary } => State::Face {
                f: face as usize,
                bary,
            },
        };
        let mut points = vec![start.position(self.mesh)];
        let mut reached = false;
        let max_steps = 4 * self.mesh.n_faces() + 16;
        for _ in 0..max_steps {
            state = match state {
                State::Vertex(v) => {
                    if phi[v] <= stop {
                        reached = true;
                        break;
                    }
                    match self.leave_vertex(v, phi) {
                        Some(s) => s,
                        None => break,
                    }
                }
                State::Face { f, bary } => {
                    if self.value(f, bary, phi) <= stop {
                        reached = true;
                        break;
                    }
                    self.face_step(f, bary, phi)
                }
            };
            let p = match state {
                State::Vertex(v) => self.mesh.positions[v],
                State::Face { f, bary } => self.point(f, bary),
            };
            if (p - points.last().expect("start")).norm() > 1e-12 * self.scale {
                points.push(p);
            }
        }
        let length_mm = points.windows(2).map(|w| (w[1] - w[0]).norm()).sum();
        GeodesicPath {
            points,
            length_mm,
            reached,
        }
    }

    /// Descend `phi`, the distance from the single point `goal`, and finish exactly at the goal.
    /// φ is piecewise linear, so it has its minimum at a vertex near the goal rather than at the
    /// goal itself; the walk ends there, within a couple of edges, and the last step joins it.
    pub fn descend_to(&self, phi: &[f64], start: SurfacePoint, goal: Point3<f64>) -> GeodesicPath {
        let mut path = self.descend(phi, start);
        let near = 3.0 * self.scale;
        if let Some(&end) = path.points.last()
            && (end - goal).norm() < near
        {
            if (end - goal).norm() > 1e-12 * self.scale {
                path.length_mm += (end - goal).norm();
                path.points.push(goal);
            }
            path.reached = true;
        }
        path
    }

    /// Inside (or on the border of) face f: follow −∇φ to the exit, or hand over to an edge or a
    /// vertex when the descent leaves the face at once.
    fn face_step(&self, f: usize, bary: [f64; 3], phi: &[f64]) -> State {
        const EPS: f64 = 1e-12;
        let d = -self.grad(f, phi);
        let db: [f64; 3] = std::array::from_fn(|k| self.bary_grad[f][k].dot(&d));
        let zero: Vec<usize> = (0..3).filter(|&k| bary[k] <= EPS).collect();
        if zero.len() >= 2 {
            let c = (0..3).find(|k| !zero.contains(k)).expect("one corner left");
            return State::Vertex(self.mesh.faces[f][c] as usize);
        }
        if let Some(&k) = zero.iter().find(|&&k| db[k] < 0.0) {
            return self.cross_edge(f, k, bary, phi);
        }
        // Exit parameter: the first barycentric coordinate to reach zero.
        let mut t_exit = f64::INFINITY;
        for k in 0..3 {
            if db[k] < -EPS * d.norm() {
                t_exit = t_exit.min(-bary[k] / db[k]);
            }
        }
        if !t_exit.is_finite() || d.norm() == 0.0 {
            // Flat face: fall to the lowest corner.
            let face = self.mesh.faces[f];
            let c = (0..3)
                .min_by(|&a, &b| phi[face[a] as usize].total_cmp(&phi[face[b] as usize]))
                .expect("3");
            return State::Vertex(face[c] as usize);
        }
        let mut b: [f64; 3] = std::array::from_fn(|k| (bary[k] + t_exit * db[k]).max(0.0));
        let s: f64 = b.iter().sum();
        b.iter_mut().for_each(|x| *x /= s);
        for x in &mut b {
            if *x < 1e-10 {
                *x = 0.0;
            }
        }
        State::Face { f, bary: b }
    }

    /// On the edge opposite corner k of face f, with the descent leaving f through it.
    fn cross_edge(&self, f: usize, k: usize, bary: [f64; 3], phi: &[f64]) -> State {
        let face = self.mesh.faces[f];
        let (a, b) = (face[(k + 1) % 3], face[(k + 2) % 3]);
        let (wa, wb) = (bary[(k + 1) % 3], bary[(k + 2) % 3]);
        let e = self.topology.face_edges[f][(k + 1) % 3] as usize;
        if let Some(g) = self.topology.opposite_face(e, f) {
            let gface = self.mesh.faces[g];
            let pos = |v: u32| gface.iter().position(|&x| x == v).expect("shared vertex");
            let mut gb = [0.0; 3];
            gb[pos(a)] = wa;
            gb[pos(b)] = wb;
            let c = (0..3)
                .find(|&i| gface[i] != a && gface[i] != b)
                .expect("third corner");
            let dg = -self.grad(g, phi);
            if self.bary_grad[g][c].dot(&dg) > 0.0 {
                return State::Face { f: g, bary: gb };
            }
        }
        // A valley (or the boundary): run along the edge to its lower end.
        State::Vertex(if phi[a as usize] <= phi[b as usize] {
            a as usize
        } else {
            b as usize
        })
    }

    fn leave_vertex(&self, v: usize, phi: &[f64]) -> Option<State> {
        // The incident face whose descent points into its wedge at v, steepest first.
        let mut best: Option<(f64, usize, usize)> = None;
        for &f in self.faces_of(v) {
            let f = f as usize;
            let c = self.mesh.faces[f]
                .iter()
                .position(|&x| x as usize == v)
                .expect("corner");
            let d = -self.grad(f, phi);
            let (o1, o2) = ((c + 1) % 3, (c + 2) % 3);
            let inside = self.bary_grad[f][o1].dot(&d) > 0.0 && self.bary_grad[f][o2].dot(&d) > 0.0;
            if inside && best.is_none_or(|(s, _, _)| d.norm() > s) {
                best = Some((d.norm(), f, c));
            }
        }
        if let Some((_, f, c)) = best {
            let mut b = [0.0; 3];
            b[c] = 1.0;
            // Step off the vertex by the face's own rule.
            return Some(self.face_step_from_corner(f, c, b, phi));
        }
        // Otherwise the steepest descending edge.
        let p = self.mesh.positions[v];
        let mut next: Option<(f64, usize)> = None;
        for &f in self.faces_of(v) {
            for &w in &self.mesh.faces[f as usize] {
                let w = w as usize;
                if w == v || w as u32 == NONE {
                    continue;
                }
                let slope = (phi[v] - phi[w]) / (self.mesh.positions[w] - p).norm();
                if slope > 0.0 && next.is_none_or(|(s, _)| slope > s) {
                    next = Some((slope, w));
                }
            }
        }
        next.map(|(_, w)| State::Vertex(w))
    }

    /// From corner c of face f, move along −∇φ to the opposite edge.
    fn face_step_from_corner(&self, f: usize, c: usize, b: [f64; 3], phi: &[f64]) -> State {
        let d = -self.grad(f, phi);
        let db: [f64; 3] = std::array::from_fn(|k| self.bary_grad[f][k].dot(&d));
        // Only corner c's coordinate decreases; it reaches zero at t = 1/(−db_c).
        let t = -b[c] / db[c];
        let mut nb: [f64; 3] = std::array::from_fn(|k| (b[k] + t * db[k]).max(0.0));
        nb[c] = 0.0;
        let s: f64 = nb.iter().sum();
        nb.iter_mut().for_each(|x| *x /= s);
        State::Face { f, bary: nb }
    }
}
