//! Single-branch check (CTPP §2.1): a continuous spiral needs a part whose skeleton has one
//! branch. Equivalently (a Reeb graph of the build parameter), every level set of the parameter
//! that runs from the lower boundary (0) to the upper boundary or the closing point (1) is one
//! closed loop. A "pair of pants" or two chimneys split a level set in two.

use crate::mesh::{Topology, TriMesh};
use std::fmt;

/// Where the part branches: the level set at this distance from the lower boundary has `loops`
/// separate loops.
#[derive(Debug, Clone, PartialEq)]
pub struct MultiBranch {
    pub loops: usize,
    pub distance_mm: f64,
    pub height_mm: f64,
}

impl fmt::Display for MultiBranch {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "the part branches: at {:.1} mm from the lower boundary (z ≈ {:.1} mm) a layer splits into {} loops; CTPP needs a single-branch part",
            self.distance_mm, self.height_mm, self.loops
        )
    }
}

impl std::error::Error for MultiBranch {}

/// Check `levels` level sets of `s` (0 on the lower boundary, 1 at the top) strictly inside (0, 1).
/// `lower_distance` gives the distance from the lower boundary for the message.
pub fn check_single_branch(
    mesh: &TriMesh,
    topology: &Topology,
    s: &[f64],
    lower_distance: &[f64],
    levels: usize,
) -> Result<(), MultiBranch> {
    for l in 1..levels {
        let c = l as f64 / levels as f64;
        let (loops, at) = level_components(mesh, topology, s, c);
        if loops > 1 {
            let (dist, z) = at.iter().fold((0.0, 0.0), |(d, z), &(a, b, t)| {
                (
                    d + lower_distance[a] * (1.0 - t) + lower_distance[b] * t,
                    z + mesh.positions[a].z * (1.0 - t) + mesh.positions[b].z * t,
                )
            });
            let n = at.len() as f64;
            return Err(MultiBranch {
                loops,
                distance_mm: dist / n,
                height_mm: z / n,
            });
        }
    }
    Ok(())
}

/// Components of the level set {s = c}, and its crossing points (edge ends and parameter).
fn level_components(
    mesh: &TriMesh,
    topology: &Topology,
    s: &[f64],
    c: f64,
) -> (usize, Vec<(usize, usize, f64)>) {
    let above = |v: u32| s[v as usize] >= c;
    let ne = topology.edges.len();
    let crossing: Vec<bool> = topology
        .edges
        .iter()
        .map(|&[a, b]| above(a) != above(b))
        .collect();
    let mut parent: Vec<u32> = (0..ne as u32).collect();
    fn find(p: &mut [u32], mut x: u32) -> u32 {
        while p[x as usize] != x {
            p[x as usize] = p[p[x as usize] as usize];
            x = p[x as usize];
        }
        x
    }
    for fe in &topology.face_edges {
        let cut: Vec<u32> = fe
            .iter()
            .copied()
            .filter(|&e| crossing[e as usize])
            .collect();
        if let [a, b] = cut[..] {
            let (ra, rb) = (find(&mut parent, a), find(&mut parent, b));
            parent[ra as usize] = rb;
        }
    }
    let mut roots = std::collections::HashSet::new();
    let mut at = Vec::new();
    for (e, &cut) in crossing.iter().enumerate() {
        if cut {
            roots.insert(find(&mut parent, e as u32));
            let [a, b] = topology.edges[e];
            let (sa, sb) = (s[a as usize], s[b as usize]);
            at.push((a as usize, b as usize, (c - sa) / (sb - sa)));
        }
    }
    let _ = mesh;
    (roots.len(), at)
}
