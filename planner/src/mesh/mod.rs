//! Connectivity and validation of the part's mid-surface: one indexed triangle mesh.
//!
//! Readers (`crate::io`) and the part library (`crate::shapes`) produce a raw [`TriMesh`];
//! [`Part::from_mesh`] welds it, checks it and classifies it as an open or a closed part.
//! Everything downstream (geodesics, generators, the spiral) works on a [`Part`].

mod topology;
mod weld;

pub use topology::{BoundaryLoop, Topology};
pub use weld::{WeldStats, weld};

use nalgebra::{Point3, Vector3};
use std::fmt;

/// An indexed triangle mesh in millimetres. Faces are counter-clockwise seen from the side the
/// normal points to.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct TriMesh {
    pub positions: Vec<Point3<f64>>,
    pub faces: Vec<[u32; 3]>,
}

impl TriMesh {
    pub fn new(positions: Vec<Point3<f64>>, faces: Vec<[u32; 3]>) -> Self {
        Self { positions, faces }
    }

    pub fn n_vertices(&self) -> usize {
        self.positions.len()
    }

    pub fn n_faces(&self) -> usize {
        self.faces.len()
    }

    pub fn corners(&self, f: usize) -> [Point3<f64>; 3] {
        self.faces[f].map(|v| self.positions[v as usize])
    }

    /// Face normal scaled by twice the face area.
    pub fn face_normal_area2(&self, f: usize) -> Vector3<f64> {
        let [a, b, c] = self.corners(f);
        (b - a).cross(&(c - a))
    }

    pub fn face_normal(&self, f: usize) -> Vector3<f64> {
        self.face_normal_area2(f).normalize()
    }

    pub fn area(&self) -> f64 {
        (0..self.n_faces())
            .map(|f| 0.5 * self.face_normal_area2(f).norm())
            .sum()
    }

    /// Axis-aligned bounding box (min, max). An empty mesh gives (origin, origin).
    pub fn bounding_box(&self) -> (Point3<f64>, Point3<f64>) {
        let mut lo = Point3::from([f64::INFINITY; 3]);
        let mut hi = Point3::from([f64::NEG_INFINITY; 3]);
        for p in &self.positions {
            for k in 0..3 {
                lo[k] = lo[k].min(p[k]);
                hi[k] = hi[k].max(p[k]);
            }
        }
        if self.positions.is_empty() {
            (Point3::origin(), Point3::origin())
        } else {
            (lo, hi)
        }
    }

    pub fn diagonal(&self) -> f64 {
        let (lo, hi) = self.bounding_box();
        (hi - lo).norm()
    }

    /// Mean length of the faces' edges (interior edges counted twice, which does not matter for
    /// a length scale).
    pub fn mean_edge_length(&self) -> f64 {
        if self.faces.is_empty() {
            return 0.0;
        }
        let mut sum = 0.0;
        for f in 0..self.n_faces() {
            let [a, b, c] = self.corners(f);
            sum += (b - a).norm() + (c - b).norm() + (a - c).norm();
        }
        sum / (3 * self.n_faces()) as f64
    }

    /// Reverse every face's orientation.
    pub fn flip(&mut self) {
        for f in &mut self.faces {
            f.swap(1, 2);
        }
    }

    /// Apply a rigid or affine map to every vertex.
    pub fn map_positions(&mut self, f: impl Fn(Point3<f64>) -> Point3<f64>) {
        for p in &mut self.positions {
            *p = f(*p);
        }
    }
}

/// Open parts have a lower boundary on the substrate and an upper boundary; closed parts only the
/// lower one and close at a point (CTPP §2.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PartKind {
    Open,
    Closed,
}

impl PartKind {
    pub fn as_str(self) -> &'static str {
        match self {
            PartKind::Open => "open",
            PartKind::Closed => "closed",
        }
    }
}

/// Which boundary loop stands on the substrate.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum LowerLoop {
    /// The loop of lowest mean z (the usual case: the part is built upwards from a plate).
    #[default]
    LowestZ,
    /// An explicit loop index in [`Topology::loops`] order.
    Index(usize),
}

/// A welded, validated, classified mid-surface.
#[derive(Debug, Clone)]
pub struct Part {
    pub mesh: TriMesh,
    pub topology: Topology,
    pub kind: PartKind,
    /// Index into `topology.loops` of the loop on the substrate.
    pub lower: usize,
    /// Index of the upper loop (open parts only).
    pub upper: Option<usize>,
    pub weld: WeldStats,
}

impl Part {
    /// Weld, validate and classify a raw mesh.
    pub fn from_mesh(mesh: TriMesh, lower: LowerLoop) -> Result<Part, MeshError> {
        check_finite(&mesh)?;
        let (mut mesh, weld) = weld(mesh);
        if mesh.faces.is_empty() {
            return Err(MeshError::Empty);
        }
        let topology = Topology::build(&mut mesh)?;
        let n_loops = topology.loops.len();
        let (kind, lower_idx, upper) = match n_loops {
            1 => (PartKind::Closed, 0, None),
            2 => {
                let lo = match lower {
                    LowerLoop::LowestZ => {
                        if topology.loops[0].mean_z <= topology.loops[1].mean_z {
                            0
                        } else {
                            1
                        }
                    }
                    LowerLoop::Index(i) if i < 2 => i,
                    LowerLoop::Index(i) => {
                        return Err(MeshError::BadLowerLoop { index: i, loops: 2 });
                    }
                };
                (PartKind::Open, lo, Some(1 - lo))
            }
            n => return Err(MeshError::LoopCount { loops: n }),
        };
        if let (PartKind::Closed, LowerLoop::Index(i)) = (kind, lower)
            && i != 0
        {
            return Err(MeshError::BadLowerLoop { index: i, loops: 1 });
        }
        Ok(Part {
            mesh,
            topology,
            kind,
            lower: lower_idx,
            upper,
            weld,
        })
    }

    pub fn lower_loop(&self) -> &BoundaryLoop {
        &self.topology.loops[self.lower]
    }

    pub fn upper_loop(&self) -> Option<&BoundaryLoop> {
        self.upper.map(|u| &self.topology.loops[u])
    }
}

fn check_finite(mesh: &TriMesh) -> Result<(), MeshError> {
    for (i, p) in mesh.positions.iter().enumerate() {
        if let Some(k) = (0..3).find(|&k| !p[k].is_finite()) {
            return Err(MeshError::NonFinite {
                vertex: i,
                axis: ['x', 'y', 'z'][k],
                value: p[k],
            });
        }
    }
    let n = mesh.positions.len();
    for (f, face) in mesh.faces.iter().enumerate() {
        if let Some(&v) = face.iter().find(|&&v| v as usize >= n) {
            return Err(MeshError::IndexOutOfRange {
                face: f,
                index: v as usize,
                n_vertices: n,
            });
        }
    }
    Ok(())
}

/// What can be wrong with a mesh as a CTPP part. Each variant carries the evidence.
#[derive(Debug, Clone, PartialEq)]
pub enum MeshError {
    Empty,
    NonFinite {
        vertex: usize,
        axis: char,
        value: f64,
    },
    IndexOutOfRange {
        face: usize,
        index: usize,
        n_vertices: usize,
    },
    NonManifoldEdge {
        edge: [usize; 2],
        faces: Vec<usize>,
    },
    NonManifoldVertex {
        vertex: usize,
        position: [f64; 3],
    },
    NonOrientable {
        face: usize,
    },
    Components {
        count: usize,
        faces: Vec<usize>,
    },
    LoopCount {
        loops: usize,
    },
    BadLowerLoop {
        index: usize,
        loops: usize,
    },
}

impl fmt::Display for MeshError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            MeshError::Empty => write!(
                f,
                "the mesh has no usable triangle (expected at least one non-degenerate face)"
            ),
            MeshError::NonFinite {
                vertex,
                axis,
                value,
            } => {
                write!(
                    f,
                    "vertex {vertex} has a non-finite {axis} coordinate ({value}); expected a finite number"
                )
            }
            MeshError::IndexOutOfRange {
                face,
                index,
                n_vertices,
            } => write!(
                f,
                "face {face} refers to vertex {index}, but the mesh has {n_vertices} vertices"
            ),
            MeshError::NonManifoldEdge { edge, faces } => write!(
                f,
                "non-manifold edge between vertices {} and {}: shared by {} faces {:?}; expected at most 2",
                edge[0],
                edge[1],
                faces.len(),
                faces
            ),
            MeshError::NonManifoldVertex { vertex, position } => write!(
                f,
                "non-manifold vertex {vertex} at ({:.3}, {:.3}, {:.3}) mm: its faces do not form one fan",
                position[0], position[1], position[2]
            ),
            MeshError::NonOrientable { face } => {
                write!(
                    f,
                    "the surface is not orientable (found at face {face}); expected a consistently orientable surface"
                )
            }
            MeshError::Components { count, faces } => write!(
                f,
                "the mesh has {count} connected components (faces per component {faces:?}); expected one connected surface"
            ),
            MeshError::LoopCount { loops } => write!(
                f,
                "the surface has {loops} boundary loops; expected 2 (open part: lower and upper) or 1 (closed part)"
            ),
            MeshError::BadLowerLoop { index, loops } => {
                write!(
                    f,
                    "lower boundary loop {index} does not exist; the surface has {loops} loops"
                )
            }
        }
    }
}

impl std::error::Error for MeshError {}

#[cfg(test)]
mod tests;
