//! Intrinsic triangulations: a mesh's faces with their edge lengths, and intrinsic Delaunay edge
//! flips (Bobenko & Springborn 2007; Sharp, Soliman, Crane, "Navigating Intrinsic
//! Triangulations", 2019). A flip replaces the diagonal of two faces by the other one, its length
//! found by laying the two triangles flat: the surface is unchanged, only its triangulation. On
//! an intrinsic Delaunay triangulation every cotangent weight is non-negative, which the cotan
//! Laplacian needs to be an M-matrix (a maximum principle, no spurious extrema).

use crate::mesh::TriMesh;

const NONE: u32 = u32::MAX;

/// Faces (counter-clockwise) and, per face, the length of edge k (from corner k to k + 1).
#[derive(Debug, Clone)]
pub struct Intrinsic {
    pub faces: Vec<[u32; 3]>,
    pub lengths: Vec<[f64; 3]>,
    /// Edge flips performed.
    pub flips: usize,
}

impl Intrinsic {
    /// The mesh as it is, with lengths from its positions.
    pub fn from_mesh(mesh: &TriMesh) -> Intrinsic {
        let lengths = (0..mesh.n_faces())
            .map(|f| {
                let p = mesh.corners(f);
                std::array::from_fn(|k| (p[(k + 1) % 3] - p[k]).norm())
            })
            .collect();
        Intrinsic {
            faces: mesh.faces.clone(),
            lengths,
            flips: 0,
        }
    }

    /// Flip to the intrinsic Delaunay triangulation of the same surface.
    pub fn delaunay(mesh: &TriMesh) -> Intrinsic {
        let mut t = Intrinsic::from_mesh(mesh);
        let mut nb = neighbours(&t.faces);
        let mut queue: Vec<(u32, u8)> = (0..t.faces.len() as u32)
            .flat_map(|f| (0..3u8).map(move |k| (f, k)))
            .collect();
        let limit = 50 * t.faces.len() + 100;
        while let Some((f, k)) = queue.pop() {
            if t.flips > limit {
                break;
            }
            let (g, kg) = nb[f as usize][k as usize];
            if g == NONE || f > g {
                // Each interior edge once (from its lower face); boundary edges never flip.
                if g == NONE {
                    continue;
                }
            }
            if is_delaunay(&t, f as usize, k as usize, g as usize, kg as usize) {
                continue;
            }
            if let Some(outer) = flip(
                &mut t,
                &mut nb,
                f as usize,
                k as usize,
                g as usize,
                kg as usize,
            ) {
                t.flips += 1;
                queue.extend(outer);
            }
        }
        t
    }

    /// Cotangent of the angle at corner k of face f.
    pub fn cot(&self, f: usize, k: usize) -> f64 {
        let l = self.lengths[f];
        // Corner k lies between edges k (to k+1) and k+2 (from k+2); opposite is edge k+1.
        let (a, b, c) = (l[k], l[(k + 2) % 3], l[(k + 1) % 3]);
        (a * a + b * b - c * c) / (4.0 * self.area(f))
    }

    pub fn area(&self, f: usize) -> f64 {
        let [a, b, c] = self.lengths[f];
        let s = 0.5 * (a + b + c);
        (s * (s - a) * (s - b) * (s - c)).max(0.0).sqrt()
    }

    /// The face laid flat: corner 0 at the origin, corner 1 on the x axis, corner 2 above it.
    pub fn layout(&self, f: usize) -> [[f64; 2]; 3] {
        let [l01, l12, l20] = self.lengths[f];
        let x = (l01 * l01 + l20 * l20 - l12 * l12) / (2.0 * l01);
        let y = (l20 * l20 - x * x).max(0.0).sqrt();
        [[0.0, 0.0], [l01, 0.0], [x, y]]
    }

    /// Unique edges (lower vertex first).
    pub fn edges(&self) -> Vec<[u32; 2]> {
        let mut e: Vec<[u32; 2]> = self
            .faces
            .iter()
            .flat_map(|f| (0..3).map(move |k| [f[k].min(f[(k + 1) % 3]), f[k].max(f[(k + 1) % 3])]))
            .collect();
        e.sort_unstable();
        e.dedup();
        e
    }
}

/// Per face and edge slot: the face across and its slot.
fn neighbours(faces: &[[u32; 3]]) -> Vec<[(u32, u8); 3]> {
    let mut map = std::collections::HashMap::with_capacity(faces.len() * 3);
    for (f, face) in faces.iter().enumerate() {
        for k in 0..3 {
            map.insert((face[k], face[(k + 1) % 3]), (f as u32, k as u8));
        }
    }
    faces
        .iter()
        .map(|face| {
            std::array::from_fn(|k| *map.get(&(face[(k + 1) % 3], face[k])).unwrap_or(&(NONE, 0)))
        })
        .collect()
}

/// Is edge k of f (shared with slot kg of g) Delaunay: cot γ + cot δ ≥ 0 for the angles
/// opposite it?
fn is_delaunay(t: &Intrinsic, f: usize, k: usize, g: usize, kg: usize) -> bool {
    t.cot(f, (k + 2) % 3) + t.cot(g, (kg + 2) % 3) >= -1e-12
}

/// Flip edge k of f = (a, b, c), shared with g = (b, a, d): new faces (a, d, c) in f and
/// (d, b, c) in g. Returns the four outer edges to re-check, or None if the flip is degenerate.
fn flip(
    t: &mut Intrinsic,
    nb: &mut [[(u32, u8); 3]],
    f: usize,
    k: usize,
    g: usize,
    kg: usize,
) -> Option<[(u32, u8); 4]> {
    let (fa, ga) = (t.faces[f], t.faces[g]);
    let (a, b, c) = (fa[k], fa[(k + 1) % 3], fa[(k + 2) % 3]);
    let d = ga[(kg + 2) % 3];
    let (lf, lg) = (t.lengths[f], t.lengths[g]);
    let (l_ab, l_bc, l_ca) = (lf[k], lf[(k + 1) % 3], lf[(k + 2) % 3]);
    let (l_ad, l_db) = (lg[(kg + 1) % 3], lg[(kg + 2) % 3]);
    // Lay out a = (0, 0), b = (l_ab, 0), c above, d below.
    let place = |l_from_a: f64, l_from_b: f64, up: f64| {
        let x = (l_ab * l_ab + l_from_a * l_from_a - l_from_b * l_from_b) / (2.0 * l_ab);
        [x, up * (l_from_a * l_from_a - x * x).max(0.0).sqrt()]
    };
    let (pc, pd) = (place(l_ca, l_bc, 1.0), place(l_ad, l_db, -1.0));
    let l_cd = ((pc[0] - pd[0]).powi(2) + (pc[1] - pd[1]).powi(2)).sqrt();
    // The quad must be convex for the new diagonal to lie inside it.
    if !(pc[1] > 0.0 && pd[1] < 0.0) || c == d {
        return None;
    }
    let (n_bc, n_ca) = (nb[f][(k + 1) % 3], nb[f][(k + 2) % 3]);
    let (n_ad, n_db) = (nb[g][(kg + 1) % 3], nb[g][(kg + 2) % 3]);
    t.faces[f] = [a, d, c];
    t.lengths[f] = [l_ad, l_cd, l_ca];
    t.faces[g] = [d, b, c];
    t.lengths[g] = [l_db, l_bc, l_cd];
    let (fu, gu) = (f as u32, g as u32);
    nb[f] = [n_ad, (gu, 2), n_ca];
    nb[g] = [n_db, n_bc, (fu, 1)];
    for (n, face, slot) in [(n_ad, fu, 0u8), (n_ca, fu, 2), (n_db, gu, 0), (n_bc, gu, 1)] {
        if n.0 != NONE {
            nb[n.0 as usize][n.1 as usize] = (face, slot);
        }
    }
    Some([(fu, 0), (fu, 2), (gu, 0), (gu, 1)])
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Point3;

    #[test]
    fn flips_a_thin_quad_to_the_short_diagonal() {
        // A rhombus split along its long diagonal: flipping gives the short one.
        let p = |x: f64, y: f64| Point3::new(x, y, 0.0);
        let m = TriMesh::new(
            vec![p(-2.0, 0.0), p(0.0, -0.5), p(2.0, 0.0), p(0.0, 0.5)],
            vec![[0, 1, 2], [0, 2, 3]],
        );
        let t = Intrinsic::delaunay(&m);
        assert_eq!(t.flips, 1);
        let edges = t.edges();
        assert!(edges.contains(&[1, 3]) && !edges.contains(&[0, 2]));
        let total: f64 = (0..2).map(|f| t.area(f)).sum();
        assert!((total - 2.0).abs() < 1e-12, "area kept: {total}");
        for f in 0..2 {
            for k in 0..3 {
                assert!(t.cot(f, k) > -1e-12);
            }
        }
    }
}
