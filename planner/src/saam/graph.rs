//! The skeleton (Radel et al. 2019 §3.1): polylines whose shared vertices are its nodes (a node
//! of degree > 2 is an intersection), each with a deposit radius R_d and a priority. The slicer
//! propagates points away from the starting plane (the lowest z; the build direction is +z), so
//! each polyline is built from its lower end: one that rises and then falls cannot be, and one
//! that no chain of polylines joins to the starting plane is never reached.

use nalgebra::{Point3, Vector3};
use std::fmt;

/// §3.2's five priorities, in increasing order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Priority {
    None,
    NoConflict,
    Low,
    Conflict,
    High,
}

impl Priority {
    pub const NAMES: [&'static str; 5] = ["none", "no_conflict", "low", "conflict", "high"];

    pub fn parse(name: &str) -> Option<Priority> {
        let all = [
            Priority::None,
            Priority::NoConflict,
            Priority::Low,
            Priority::Conflict,
            Priority::High,
        ];
        Self::NAMES.iter().position(|n| *n == name).map(|k| all[k])
    }

    pub fn name(&self) -> &'static str {
        Self::NAMES[*self as usize]
    }
}

/// What a polyline of the input asks for.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BranchSpec {
    pub radius_mm: f64,
    pub priority: Priority,
}

/// A branch: a polyline between two nodes, ordered from its lower end, mm.
#[derive(Debug, Clone, PartialEq)]
pub struct Branch {
    pub points: Vec<Point3<f64>>,
    /// Curvilinear abscissa of each point.
    pub abscissa: Vec<f64>,
    pub radius_mm: f64,
    pub priority: Priority,
    /// The nodes at its lower and upper end.
    pub ends: [usize; 2],
    /// Level along its length (either end may start it).
    pub flat: bool,
    /// The input polyline it comes from (0-based).
    pub source: usize,
}

impl Branch {
    pub fn length(&self) -> f64 {
        *self.abscissa.last().unwrap_or(&0.0)
    }

    /// The point at abscissa `s` (clamped) and the unit direction of its segment.
    pub fn at(&self, s: f64) -> (Point3<f64>, Vector3<f64>) {
        let s = s.clamp(0.0, self.length());
        let k = self
            .abscissa
            .partition_point(|&a| a <= s)
            .clamp(1, self.points.len() - 1);
        let (a, b) = (self.points[k - 1], self.points[k]);
        let seg = self.abscissa[k] - self.abscissa[k - 1];
        let dir = (b - a) / seg;
        (a + dir * (s - self.abscissa[k - 1]), dir)
    }

    /// The same branch run from its other end (for a level one started there).
    pub fn reversed(&self) -> Branch {
        let points: Vec<Point3<f64>> = self.points.iter().rev().copied().collect();
        Branch {
            abscissa: abscissa(&points),
            points,
            ends: [self.ends[1], self.ends[0]],
            ..self.clone()
        }
    }
}

/// A node: where polylines meet or end.
#[derive(Debug, Clone, PartialEq)]
pub struct Node {
    pub position: Point3<f64>,
    /// (branch, end 0 lower or 1 upper) at this node.
    pub branches: Vec<(usize, usize)>,
    /// On the starting plane.
    pub start: bool,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Skeleton {
    pub branches: Vec<Branch>,
    pub nodes: Vec<Node>,
    /// The starting plane, z in mm.
    pub start_z: f64,
}

/// Why a skeleton cannot be built; polylines are named 1-based, as in the file.
#[derive(Debug, Clone, PartialEq)]
pub enum SkeletonError {
    Empty,
    NotFinite {
        vertex: usize,
    },
    ZeroLength {
        polyline: usize,
        segment: usize,
    },
    BadRadius {
        polyline: usize,
        radius_mm: f64,
    },
    /// Rises then falls (or the reverse): the slicer propagates away from the starting plane.
    TurnsDown {
        polyline: usize,
        at: Point3<f64>,
    },
    /// No chain of polylines built upwards joins it to the starting plane.
    Unreachable {
        polylines: Vec<usize>,
    },
}

impl fmt::Display for SkeletonError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SkeletonError::Empty => write!(f, "no polyline; expected `l` lines joining vertices"),
            SkeletonError::NotFinite { vertex } => write!(
                f,
                "vertex {} is not a finite coordinate within ±1e6 mm",
                vertex + 1
            ),
            SkeletonError::ZeroLength { polyline, segment } => write!(
                f,
                "polyline {} segment {} has zero length; expected distinct consecutive vertices",
                polyline + 1,
                segment + 1
            ),
            SkeletonError::BadRadius {
                polyline,
                radius_mm,
            } => write!(
                f,
                "polyline {}: deposit radius {radius_mm} mm; expected more than 0 and at most 50",
                polyline + 1
            ),
            SkeletonError::TurnsDown { polyline, at } => write!(
                f,
                "polyline {} turns back towards the starting plane at ({:.3}, {:.3}, {:.3}) mm; the slicer propagates points away from it (split the polyline there)",
                polyline + 1,
                at.x,
                at.y,
                at.z
            ),
            SkeletonError::Unreachable { polylines } => write!(
                f,
                "polylines {polylines:?} are joined to the starting plane by no chain built upwards; expected every polyline reachable from a vertex on the lowest z"
            ),
        }
    }
}

impl std::error::Error for SkeletonError {}

/// Vertices this close to the lowest z are on the starting plane, mm.
const PLANE_TOL_MM: f64 = 1e-3;

fn abscissa(points: &[Point3<f64>]) -> Vec<f64> {
    let mut s = vec![0.0];
    for w in points.windows(2) {
        s.push(s.last().unwrap() + (w[1] - w[0]).norm());
    }
    s
}

impl Skeleton {
    /// The skeleton of `vertices` joined by `lines` (indices), with each input polyline's spec.
    pub fn new(
        vertices: &[Point3<f64>],
        lines: &[Vec<u32>],
        spec: impl Fn(usize) -> BranchSpec,
    ) -> Result<Skeleton, SkeletonError> {
        if lines.is_empty() {
            return Err(SkeletonError::Empty);
        }
        if let Some(v) = vertices
            .iter()
            .position(|p| !p.coords.iter().all(|c| c.is_finite()))
        {
            return Err(SkeletonError::NotFinite { vertex: v });
        }
        // How many polylines use each vertex: an interior vertex another polyline uses is a
        // node, where the polyline is cut in two.
        let mut users = vec![0usize; vertices.len()];
        for line in lines {
            let mut seen: Vec<u32> = line.clone();
            seen.sort_unstable();
            seen.dedup();
            for v in seen {
                users[v as usize] += 1;
            }
        }
        let mut pieces: Vec<(usize, Vec<u32>)> = Vec::new();
        for (k, line) in lines.iter().enumerate() {
            let r = spec(k).radius_mm;
            if !(r > 0.0 && r <= 50.0) {
                return Err(SkeletonError::BadRadius {
                    polyline: k,
                    radius_mm: r,
                });
            }
            for (j, w) in line.windows(2).enumerate() {
                if (vertices[w[1] as usize] - vertices[w[0] as usize]).norm() < 1e-9 {
                    return Err(SkeletonError::ZeroLength {
                        polyline: k,
                        segment: j,
                    });
                }
            }
            let mut piece = vec![line[0]];
            for (j, &v) in line.iter().enumerate().skip(1) {
                piece.push(v);
                if j + 1 < line.len() && users[v as usize] > 1 {
                    pieces.push((k, std::mem::replace(&mut piece, vec![v])));
                }
            }
            pieces.push((k, piece));
        }
        let start_z = lines
            .iter()
            .flatten()
            .map(|&v| vertices[v as usize].z)
            .fold(f64::INFINITY, f64::min);
        // Nodes: the pieces' ends, by vertex.
        let mut node_of: std::collections::HashMap<u32, usize> = Default::default();
        let mut nodes: Vec<Node> = Vec::new();
        let mut branches = Vec::new();
        for (k, piece) in pieces {
            let mut points: Vec<Point3<f64>> =
                piece.iter().map(|&v| vertices[v as usize]).collect();
            let mut ids = [piece[0], *piece.last().unwrap()];
            let length: f64 = abscissa(&points).last().copied().unwrap_or(0.0);
            let tol = 1e-6 * length.max(1.0);
            let dz: Vec<f64> = points.windows(2).map(|w| w[1].z - w[0].z).collect();
            let rises = dz.iter().any(|&d| d > tol);
            let falls = dz.iter().any(|&d| d < -tol);
            if rises && falls {
                // The vertex where it turns.
                let first = dz.iter().position(|&d| d.abs() > tol).unwrap_or(0);
                let up = dz[first] > 0.0;
                let turn = dz
                    .iter()
                    .position(|&d| if up { d < -tol } else { d > tol })
                    .unwrap_or(0);
                return Err(SkeletonError::TurnsDown {
                    polyline: k,
                    at: points[turn],
                });
            }
            if falls {
                points.reverse();
                ids.swap(0, 1);
            }
            let mut ends = [0; 2];
            for (e, id) in ids.iter().enumerate() {
                let n = *node_of.entry(*id).or_insert_with(|| {
                    let p = vertices[*id as usize];
                    nodes.push(Node {
                        position: p,
                        branches: Vec::new(),
                        start: (p.z - start_z).abs() <= PLANE_TOL_MM,
                    });
                    nodes.len() - 1
                });
                nodes[n].branches.push((branches.len(), e));
                ends[e] = n;
            }
            let s = spec(k);
            branches.push(Branch {
                abscissa: abscissa(&points),
                points,
                radius_mm: s.radius_mm,
                priority: s.priority,
                ends,
                flat: !rises && !falls,
                source: k,
            });
        }
        let sk = Skeleton {
            branches,
            nodes,
            start_z,
        };
        let reached = sk.reachable();
        let mut missing: Vec<usize> = (0..sk.branches.len())
            .filter(|&b| !reached[b])
            .map(|b| sk.branches[b].source + 1)
            .collect();
        missing.dedup();
        if !missing.is_empty() {
            return Err(SkeletonError::Unreachable { polylines: missing });
        }
        Ok(sk)
    }

    /// Which branches the propagation reaches: from the nodes on the starting plane, a branch
    /// whose lower end (either end, for a level one) is reached, and then its upper end.
    fn reachable(&self) -> Vec<bool> {
        let mut node = self.nodes.iter().map(|n| n.start).collect::<Vec<_>>();
        let mut branch = vec![false; self.branches.len()];
        loop {
            let mut grew = false;
            for (b, br) in self.branches.iter().enumerate() {
                let from = node[br.ends[0]] || (br.flat && node[br.ends[1]]);
                if !branch[b] && from {
                    branch[b] = true;
                    node[br.ends[0]] = true;
                    node[br.ends[1]] = true;
                    grew = true;
                }
            }
            if !grew {
                return branch;
            }
        }
    }

    /// Branches leaving node n upwards (their lower end there, or level ones either end).
    pub fn leaving(&self, n: usize) -> Vec<usize> {
        self.nodes[n]
            .branches
            .iter()
            .filter(|&&(b, e)| e == 0 || self.branches[b].flat)
            .map(|&(b, _)| b)
            .collect()
    }

    /// Branches arriving at node n from below (their upper end there).
    pub fn arriving(&self, n: usize) -> Vec<usize> {
        self.nodes[n]
            .branches
            .iter()
            .filter(|&&(b, e)| e == 1 && !self.branches[b].flat)
            .map(|&(b, _)| b)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spec(_: usize) -> BranchSpec {
        BranchSpec {
            radius_mm: 3.0,
            priority: Priority::None,
        }
    }

    /// A Y: a stem and two arms from its top; a vertex shared mid-polyline becomes a node.
    #[test]
    fn a_y_has_one_intersection() {
        let v = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(0.0, 0.0, 10.0),
            Point3::new(5.0, 0.0, 20.0),
            Point3::new(-5.0, 0.0, 20.0),
        ];
        // The stem and the right arm drawn as one polyline, the left arm from the shared vertex.
        let sk = Skeleton::new(&v, &[vec![0, 1, 2], vec![1, 3]], spec).unwrap();
        assert_eq!(sk.branches.len(), 3);
        let top = sk.branches[0].ends[1];
        assert_eq!(sk.leaving(top).len(), 2);
        assert_eq!(sk.arriving(top), vec![0]);
        assert!(sk.nodes[sk.branches[0].ends[0]].start);
        let (p, d) = sk.branches[0].at(4.0);
        assert!((p - Point3::new(0.0, 0.0, 4.0)).norm() < 1e-12 && (d.z - 1.0).abs() < 1e-12);
    }

    #[test]
    fn bad_skeletons_are_named() {
        let v = [
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(0.0, 0.0, 10.0),
            Point3::new(0.0, 0.0, 10.0),
            Point3::new(5.0, 0.0, 3.0),
            Point3::new(9.0, 0.0, 20.0),
            Point3::new(9.0, 0.0, 30.0),
        ];
        let e = Skeleton::new(&v, &[vec![0, 1, 2]], spec).unwrap_err();
        assert_eq!(
            e,
            SkeletonError::ZeroLength {
                polyline: 0,
                segment: 1
            }
        );
        let e = Skeleton::new(&v, &[vec![0, 1, 3]], spec).unwrap_err();
        assert!(
            matches!(e, SkeletonError::TurnsDown { polyline: 0, .. }),
            "{e}"
        );
        let e = Skeleton::new(&v, &[vec![0, 1], vec![4, 5]], spec).unwrap_err();
        assert_eq!(e, SkeletonError::Unreachable { polylines: vec![2] });
        assert!(e.to_string().contains("[2]"));
        let e = Skeleton::new(&v, &[vec![0, 1]], |_| BranchSpec {
            radius_mm: 0.0,
            priority: Priority::Low,
        })
        .unwrap_err();
        assert!(e.to_string().contains("polyline 1"));
        // Drawn downwards: turned round, built from the plate.
        let sk = Skeleton::new(&v, &[vec![1, 0]], spec).unwrap();
        assert_eq!(sk.branches[0].points[0].z, 0.0);
    }
}
