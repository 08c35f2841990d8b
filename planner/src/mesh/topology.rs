//! Edge connectivity, manifold and orientation checks, components and boundary loops.

use super::{MeshError, TriMesh};
use nalgebra::{Point3, Vector3};
use std::collections::HashMap;

pub const NONE: u32 = u32::MAX;

/// One boundary loop, vertices in order along the boundary.
#[derive(Debug, Clone, PartialEq)]
pub struct BoundaryLoop {
    pub vertices: Vec<u32>,
    pub length_mm: f64,
    pub mean_z: f64,
    pub centroid: Point3<f64>,
}

/// Connectivity of a manifold, consistently oriented, connected mesh.
#[derive(Debug, Clone)]
pub struct Topology {
    /// Unique edges, lower index first.
    pub edges: Vec<[u32; 2]>,
    /// Per face, the edge from corner k to corner k+1.
    pub face_edges: Vec<[u32; 3]>,
    /// Per edge, its one or two faces (`NONE` for a missing second face).
    pub edge_faces: Vec<[u32; 2]>,
    pub is_boundary_vertex: Vec<bool>,
    pub loops: Vec<BoundaryLoop>,
    /// Faces flipped to make the orientation consistent and outward.
    pub flipped_faces: usize,
}

impl Topology {
    /// Build connectivity, reorienting faces of `mesh` in place so they agree with each other and
    /// point away from the mesh's centroid.
    pub fn build(mesh: &mut TriMesh) -> Result<Topology, MeshError> {
        let (edges, face_edges, edge_faces) = edge_tables(mesh)?;
        check_vertex_fans(mesh, &edge_faces, &edges)?;
        let flipped = orient(mesh, &edges, &face_edges, &edge_faces)?;
        // Orientation swapped corners of some faces: rebuild the per-face edge slots.
        let (edges, face_edges, edge_faces) = edge_tables(mesh)?;
        let mut is_boundary_vertex = vec![false; mesh.n_vertices()];
        for (e, ef) in edge_faces.iter().enumerate() {
            if ef[1] == NONE {
                for v in edges[e] {
                    is_boundary_vertex[v as usize] = true;
                }
            }
        }
        let loops = boundary_loops(mesh, &face_edges, &edge_faces);
        Ok(Topology {
            edges,
            face_edges,
            edge_faces,
            is_boundary_vertex,
            loops,
            flipped_faces: flipped,
        })
    }

    pub fn is_boundary_edge(&self, e: usize) -> bool {
        self.edge_faces[e][1] == NONE
    }

    /// The face across edge `e` from face `f`, if any.
    pub fn opposite_face(&self, e: usize, f: usize) -> Option<usize> {
        let [a, b] = self.edge_faces[e];
        let g = if a as usize == f { b } else { a };
        (g != NONE).then_some(g as usize)
    }
}

type EdgeTables = (Vec<[u32; 2]>, Vec<[u32; 3]>, Vec<[u32; 2]>);

fn edge_tables(mesh: &TriMesh) -> Result<EdgeTables, MeshError> {
    let mut index: HashMap<(u32, u32), u32> = HashMap::with_capacity(mesh.n_faces() * 3 / 2 + 1);
    let mut edges = Vec::new();
    let mut edge_faces: Vec<[u32; 2]> = Vec::new();
    let mut face_edges = Vec::with_capacity(mesh.n_faces());
    for (f, face) in mesh.faces.iter().enumerate() {
        let mut fe = [0u32; 3];
        for (k, slot_out) in fe.iter_mut().enumerate() {
            let (a, b) = (face[k], face[(k + 1) % 3]);
            let key = (a.min(b), a.max(b));
            let e = *index.entry(key).or_insert_with(|| {
                edges.push([key.0, key.1]);
                edge_faces.push([NONE, NONE]);
                (edges.len() - 1) as u32
            });
            let slot = &mut edge_faces[e as usize];
            if slot[0] == NONE {
                slot[0] = f as u32;
            } else if slot[1] == NONE {
                slot[1] = f as u32;
            } else {
                let faces: Vec<usize> = mesh
                    .faces
                    .iter()
                    .enumerate()
                    .filter(|(_, g)| g.contains(&key.0) && g.contains(&key.1))
                    .map(|(i, _)| i)
                    .collect();
                return Err(MeshError::NonManifoldEdge {
                    edge: [key.0 as usize, key.1 as usize],
                    faces,
                });
            }
            *slot_out = e;
        }
        face_edges.push(fe);
    }
    Ok((edges, face_edges, edge_faces))
}

/// Does face `f` traverse the edge `[lo, hi]` from `lo` to `hi`?
fn runs_forward(mesh: &TriMesh, f: usize, [lo, hi]: [u32; 2]) -> bool {
    let face = mesh.faces[f];
    let k = face.iter().position(|&x| x == lo).expect("vertex of face");
    face[(k + 1) % 3] == hi
}

/// Breadth-first propagation of one orientation; then make it outward. Errors on a non-orientable
/// surface or on more than one component.
fn orient(
    mesh: &mut TriMesh,
    edges: &[[u32; 2]],
    face_edges: &[[u32; 3]],
    edge_faces: &[[u32; 2]],
) -> Result<usize, MeshError> {
    let n = mesh.n_faces();
    let mut component = vec![usize::MAX; n];
    let mut sizes = Vec::new();
    let mut flipped = 0;
    let mut queue = std::collections::VecDeque::new();
    for seed in 0..n {
        if component[seed] != usize::MAX {
            continue;
        }
        let c = sizes.len();
        sizes.push(0usize);
        component[seed] = c;
        queue.push_back(seed);
        while let Some(f) = queue.pop_front() {
            sizes[c] += 1;
            for e in face_edges[f] {
                let [a, b] = edge_faces[e as usize];
                let g = if a as usize == f { b } else { a };
                if g == NONE {
                    continue;
                }
                let g = g as usize;
                let ends = edges[e as usize];
                let consistent = runs_forward(mesh, f, ends) != runs_forward(mesh, g, ends);
                if component[g] == usize::MAX {
                    component[g] = c;
                    if !consistent {
                        mesh.faces[g].swap(1, 2);
                        flipped += 1;
                    }
                    queue.push_back(g);
                } else if !consistent {
                    return Err(MeshError::NonOrientable { face: g });
                }
            }
        }
    }
    if sizes.len() > 1 {
        return Err(MeshError::Components {
            count: sizes.len(),
            faces: sizes,
        });
    }
    // Outward: the area-weighted normals point away from the centroid on balance.
    let centroid = mesh
        .positions
        .iter()
        .fold(Vector3::zeros(), |s, p| s + p.coords)
        / mesh.n_vertices() as f64;
    let outward: f64 = (0..n)
        .map(|f| {
            let [a, b, c] = mesh.corners(f);
            let mid = (a.coords + b.coords + c.coords) / 3.0;
            mesh.face_normal_area2(f).dot(&(mid - centroid))
        })
        .sum();
    if outward < 0.0 {
        mesh.flip();
        flipped = n - flipped;
    }
    Ok(flipped)
}

fn check_vertex_fans(
    mesh: &TriMesh,
    edge_faces: &[[u32; 2]],
    edges: &[[u32; 2]],
) -> Result<(), MeshError> {
    // Union-find over corners: corners of the same vertex in faces adjacent across an edge at that
    // vertex are one fan. A manifold vertex has exactly one fan.
    let n = mesh.n_faces() * 3;
    let mut parent: Vec<u32> = (0..n as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    let corner = |f: usize, v: u32| {
        f * 3
            + mesh.faces[f]
                .iter()
                .position(|&w| w == v)
                .expect("vertex of face")
    };
    for (e, ef) in edge_faces.iter().enumerate() {
        if ef[1] == NONE {
            continue;
        }
        for v in edges[e] {
            let a = find(&mut parent, corner(ef[0] as usize, v) as u32);
            let b = find(&mut parent, corner(ef[1] as usize, v) as u32);
            parent[a as usize] = b;
        }
    }
    let mut fan_of = vec![NONE; mesh.n_vertices()];
    for f in 0..mesh.n_faces() {
        for k in 0..3 {
            let v = mesh.faces[f][k] as usize;
            let r = find(&mut parent, (f * 3 + k) as u32);
            if fan_of[v] == NONE {
                fan_of[v] = r;
            } else if fan_of[v] != r {
                let p = mesh.positions[v];
                return Err(MeshError::NonManifoldVertex {
                    vertex: v,
                    position: [p.x, p.y, p.z],
                });
            }
        }
    }
    Ok(())
}

fn boundary_loops(
    mesh: &TriMesh,
    face_edges: &[[u32; 3]],
    edge_faces: &[[u32; 2]],
) -> Vec<BoundaryLoop> {
    // Each boundary edge is walked in its face's direction; manifold vertices have one outgoing.
    let mut next = vec![NONE; mesh.n_vertices()];
    for (e, ef) in edge_faces.iter().enumerate() {
        if ef[1] != NONE {
            continue;
        }
        let f = ef[0] as usize;
        let k = face_edges[f]
            .iter()
            .position(|&x| x as usize == e)
            .expect("edge of its face");
        next[mesh.faces[f][k] as usize] = mesh.faces[f][(k + 1) % 3];
    }
    let mut seen = vec![false; mesh.n_vertices()];
    let mut loops = Vec::new();
    for start in 0..mesh.n_vertices() {
        if next[start] == NONE || seen[start] {
            continue;
        }
        let mut vertices = Vec::new();
        let mut v = start as u32;
        while v != NONE && !seen[v as usize] {
            seen[v as usize] = true;
            vertices.push(v);
            v = next[v as usize];
        }
        let pts: Vec<Point3<f64>> = vertices
            .iter()
            .map(|&v| mesh.positions[v as usize])
            .collect();
        let length_mm = (0..pts.len())
            .map(|i| (pts[(i + 1) % pts.len()] - pts[i]).norm())
            .sum();
        let centroid =
            Point3::from(pts.iter().fold(Vector3::zeros(), |s, p| s + p.coords) / pts.len() as f64);
        loops.push(BoundaryLoop {
            vertices,
            length_mm,
            mean_z: centroid.z,
            centroid,
        });
    }
    loops
}
