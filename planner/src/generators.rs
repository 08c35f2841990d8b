//! Generators (CTPP §2.2): geodesic curves from the lower boundary to the upper boundary (open
//! parts, Eq.1) or to the closing point (closed parts), then gap detection and filling between
//! neighbours (Eq.2, Eq.3, Fig. 12).

use crate::geodesic::SurfacePoint;
use crate::geodesic::path::{GeodesicPath, Tracer};
use crate::geometry::closest::ClosestPoint;
use crate::mesh::{Part, Topology};
use nalgebra::{Point3, Vector3};
use std::f64::consts::TAU;

/// Half-width of the arc over which a generator's direction is measured, mm.
const TANGENT_WINDOW_MM: f64 = 2.0;

/// One generator: a polyline on the surface from its lower point upwards.
#[derive(Debug, Clone, PartialEq)]
pub struct Generator {
    pub points: Vec<Point3<f64>>,
    /// Cumulative arc length at each point, mm.
    pub arc: Vec<f64>,
    /// Inserted by gap filling (Eq.3) rather than traced from a lower point.
    pub filled: bool,
    /// Whether the descent reached its target.
    pub reached: bool,
}

impl Generator {
    pub fn new(points: Vec<Point3<f64>>, filled: bool, reached: bool) -> Generator {
        let mut arc = Vec::with_capacity(points.len());
        let mut s = 0.0;
        for (i, p) in points.iter().enumerate() {
            if i > 0 {
                s += (p - points[i - 1]).norm();
            }
            arc.push(s);
        }
        Generator {
            points,
            arc,
            filled,
            reached,
        }
    }

    pub fn from_path(path: GeodesicPath) -> Generator {
        Generator::new(path.points, false, path.reached)
    }

    pub fn length(&self) -> f64 {
        *self.arc.last().unwrap_or(&0.0)
    }

    /// The point at arc length `s` (clamped) and the unit direction of the generator there,
    /// taken over ±`TANGENT_WINDOW_MM` of arc: the traced polyline zig-zags at the scale of the
    /// mesh edges, its smoothed chord does not.
    pub fn at(&self, s: f64) -> (Point3<f64>, Vector3<f64>) {
        let p = self.point_at(s);
        let (a, b) = (
            self.point_at(s - TANGENT_WINDOW_MM),
            self.point_at(s + TANGENT_WINDOW_MM),
        );
        (
            p,
            (b - a)
                .try_normalize(1e-12)
                .unwrap_or_else(|| self.segment_at(s).1),
        )
    }

    fn point_at(&self, s: f64) -> Point3<f64> {
        self.segment_at(s).0
    }

    fn segment_at(&self, s: f64) -> (Point3<f64>, Vector3<f64>) {
        let n = self.points.len();
        if n == 1 {
            return (self.points[0], Vector3::z());
        }
        let s = s.clamp(0.0, self.length());
        let i = self.arc.partition_point(|&a| a < s).clamp(1, n - 1);
        let (a, b) = (self.points[i - 1], self.points[i]);
        let seg = self.arc[i] - self.arc[i - 1];
        let t = if seg > 0.0 {
            (s - self.arc[i - 1]) / seg
        } else {
            0.0
        };
        let dir = (b - a).try_normalize(0.0).unwrap_or_else(Vector3::z);
        (a + (b - a) * t, dir)
    }

    pub fn start(&self) -> Point3<f64> {
        self.points[0]
    }

    pub fn end(&self) -> Point3<f64> {
        *self.points.last().expect("non-empty generator")
    }

    /// `m` points at equal arc-length fractions.
    fn resample(&self, m: usize) -> Vec<Point3<f64>> {
        (0..m)
            .map(|i| self.at(self.length() * i as f64 / (m - 1) as f64).0)
            .collect()
    }
}

/// The lower boundary discretised at `n` constant angular steps around the vertical axis through
/// the loop's centroid (§2.2.1, Fig. 10a). Each point lies on a boundary edge.
pub fn lower_points(part: &Part, n: usize) -> Vec<SurfacePoint> {
    let lp = part.lower_loop();
    let c = lp.centroid;
    let m = &part.mesh;
    let verts = &lp.vertices;
    (0..n)
        .filter_map(|i| {
            let th = TAU * i as f64 / n as f64;
            let dir = Vector3::new(th.cos(), th.sin(), 0.0);
            // The nearest crossing of the ray (in the xy projection) with a loop segment.
            let mut best: Option<(f64, usize, f64)> = None;
            for k in 0..verts.len() {
                let (a, b) = (
                    m.positions[verts[k] as usize],
                    m.positions[verts[(k + 1) % verts.len()] as usize],
                );
                if let Some((t, u)) = ray_segment_xy(c, dir, a, b)
                    && best.is_none_or(|(bt, _, _)| t < bt)
                {
                    best = Some((t, k, u));
                }
            }
            let (_, k, u) = best?;
            Some(on_boundary_edge(
                part,
                verts[k],
                verts[(k + 1) % verts.len()],
                u,
            ))
        })
        .collect()
}

/// How far past a segment's ends (in its own parameter u) a crossing still counts: a ray
/// through a loop vertex meets its two edges at u = 1 and u = 0 only up to rounding, and with
/// an exact test may miss both.
const SEGMENT_END_SLACK: f64 = 1e-9;

/// Ray c + t·dir against segment a→b in the xy plane: (t ≥ 0, u ∈ [0, 1], a crossing within
/// [`SEGMENT_END_SLACK`] of an end taken at that end).
fn ray_segment_xy(
    c: Point3<f64>,
    dir: Vector3<f64>,
    a: Point3<f64>,
    b: Point3<f64>,
) -> Option<(f64, f64)> {
    let e = b - a;
    let den = dir.x * e.y - dir.y * e.x;
    if den.abs() < 1e-15 {
        return None;
    }
    let w = a - c;
    let t = (w.x * e.y - w.y * e.x) / den;
    let u = (w.x * dir.y - w.y * dir.x) / den;
    (t >= 0.0 && (-SEGMENT_END_SLACK..=1.0 + SEGMENT_END_SLACK).contains(&u))
        .then_some((t, u.clamp(0.0, 1.0)))
}

/// The point (1 − u)·a + u·b of boundary edge ab, as a point of its face.
fn on_boundary_edge(part: &Part, a: u32, b: u32, u: f64) -> SurfacePoint {
    let t: &Topology = &part.topology;
    let e = t
        .edges
        .iter()
        .position(|&[x, y]| (x, y) == (a.min(b), a.max(b)))
        .expect("loop edge");
    let f = t.edge_faces[e][0] as usize;
    let face = part.mesh.faces[f];
    let mut bary = [0.0; 3];
    for k in 0..3 {
        if face[k] == a {
            bary[k] = 1.0 - u;
        } else if face[k] == b {
            bary[k] = u;
        }
    }
    SurfacePoint::Face {
        face: f as u32,
        bary,
    }
}

/// Trace one generator per lower point down the distance field `target` (zero on the upper
/// boundary, or the distance from the closing point `goal`), so each runs to its nearest target
/// point (Eq.1).
pub fn trace(
    tracer: &Tracer,
    target: &[f64],
    goal: Option<Point3<f64>>,
    lower: &[SurfacePoint],
) -> Vec<Generator> {
    use rayon::prelude::*;
    lower
        .par_iter()
        .map(|&p| {
            Generator::from_path(match goal {
                Some(g) => tracer.descend_to(target, p, g),
                None => tracer.descend(target, p),
            })
        })
        .collect()
}

/// ε of Eq.3 between two neighbours: the largest distance from the strip ψ between them (points
/// paired at equal arc-length fractions, sampled at the rung midpoints) to the part surface. This
/// is a true point-to-surface distance, finer than the paper's vertex-to-vertex Eq.2.
pub fn gap(
    a: &Generator,
    b: &Generator,
    surface: &ClosestPoint,
    step_mm: f64,
) -> (f64, Vec<Point3<f64>>) {
    let m = ((a.length().max(b.length()) / step_mm).ceil() as usize).max(2) + 1;
    let (pa, pb) = (a.resample(m), b.resample(m));
    let mid: Vec<Point3<f64>> = pa
        .iter()
        .zip(&pb)
        .map(|(x, y)| Point3::from((x.coords + y.coords) / 2.0))
        .collect();
    let eps = mid
        .iter()
        .map(|q| surface.query(*q).distance)
        .fold(0.0, f64::max);
    (eps, mid)
}

/// Where generators end: the closing point (closed part), or the upper loop (open part), along
/// which a gap's middle is found.
pub enum Target {
    ClosingPoint { point: Point3<f64> },
    UpperLoop,
}

/// When gap filling stops.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FillLimits {
    /// ε₀ of Eq.3, mm.
    pub eps0: f64,
    /// Sampling step along the generators, mm.
    pub step_mm: f64,
    pub max_fill: usize,
}

/// Fill gaps (Eq.3, Fig. 12b): while ε > ε₀ between neighbours, insert their median curve
/// projected onto the part (see [`median`]), from the middle of their lower ends (along the lower
/// loop) to the middle of their upper ends along the stretch of the upper loop the gap spans, or
/// to the closing point. Neighbours are cyclic. Returns how many were inserted.
pub fn fill_gaps(
    gens: &mut Vec<Generator>,
    part: &Part,
    surface: &ClosestPoint,
    target: &Target,
    normals: &[Vector3<f64>],
    limits: FillLimits,
) -> usize {
    let FillLimits {
        eps0,
        step_mm,
        max_fill,
    } = limits;
    let lower = LoopParam::new(part, part.lower);
    let upper = part.upper.map(|u| LoopParam::new(part, u));
    let n = gens.len();
    let eps: Vec<f64> = (0..n)
        .map(|i| gap(&gens[i], &gens[(i + 1) % n], surface, step_mm).0)
        .collect();
    // Unwrapped parameters of the upper ends, in generator order (see `unwrap_upper_ends`).
    let (mut ends, turn) = match &upper {
        Some(up) => unwrap_upper_ends(up, gens, &eps),
        None => (vec![0.0; n], 0.0),
    };
    let mut filled = 0;
    let mut i = 0;
    while i < gens.len() && filled < max_fill {
        let j = (i + 1) % gens.len();
        let (eps, _) = gap(&gens[i], &gens[j], surface, step_mm);
        let (la, lb) = (lower.param(gens[i].start()), lower.param(gens[j].start()));
        let apart = lower.wrap(lb - la).abs();
        if eps <= eps0 || apart < 1e-3 * step_mm {
            i += 1;
            continue;
        }
        let start = lower.point(la + lower.wrap(lb - la) / 2.0);
        let (end, end_param) = match (target, &upper) {
            (Target::ClosingPoint { point, .. }, _) => (*point, 0.0),
            (Target::UpperLoop, Some(up)) => {
                let next = if j == 0 { ends[0] + turn } else { ends[j] };
                let mid = 0.5 * (ends[i] + next);
                (up.point(mid).position(&part.mesh), mid)
            }
            (Target::UpperLoop, None) => unreachable!("open parts have an upper loop"),
        };
        let new = median(
            &gens[i],
            &gens[j],
            start.position(&part.mesh),
            end,
            surface,
            normals,
            step_mm,
        );
        if !new.reached {
            i += 1;
            continue;
        }
        gens.insert(
            i + 1,
            Generator {
                filled: true,
                ..new
            },
        );
        ends.insert(i + 1, end_param);
        filled += 1;
    }
    filled
}

/// The median curve of two neighbours projected onto the part (Eq.3, Fig. 12b), from `start` on
/// the lower boundary to `end`. Each median point is projected along the normal blended from the
/// start's to the end's, to the first surface it meets: where the neighbours diverge to either
/// side of a tube, the median runs inside it and the nearest surface point would pick a side at
/// random, while the blended normal points to the patch between them.
fn median(
    a: &Generator,
    b: &Generator,
    start: Point3<f64>,
    end: Point3<f64>,
    surface: &ClosestPoint,
    normals: &[Vector3<f64>],
    step_mm: f64,
) -> Generator {
    let m = ((a.length().max(b.length()) / step_mm).ceil() as usize).max(2) + 1;
    let (pa, pb) = (a.resample(m), b.resample(m));
    let normal_at = |p: Point3<f64>| {
        let c = surface.query(p);
        let f = surface.mesh().faces[c.face];
        (0..3)
            .map(|k| normals[f[k] as usize] * c.bary[k])
            .sum::<Vector3<f64>>()
    };
    let (n0, n1) = (normal_at(start), normal_at(end));
    let middle = |k: usize| Point3::from((pa[k].coords + pb[k].coords) / 2.0);
    // The fill's own ends differ from the median's where the neighbours converge away from it
    // (on a bent tube both run to the inside of the bend, the fill's end is on the outside):
    // the median is shifted, linearly in t, by the offsets of the ends, so it leads there.
    let (off0, off1) = (start - middle(0), end - middle(m - 1));
    let mut pts = vec![start];
    for k in 1..m - 1 {
        let t = k as f64 / (m - 1) as f64;
        let shift = off0 * (1.0 - t) + off1 * t;
        let mid = middle(k) + shift;
        let near = surface.query(mid);
        let gap = (pa[k] - pb[k]).norm() + shift.norm();
        let q = if near.distance < 0.25 * gap.max(step_mm) {
            near.point
        } else {
            let dir = n0 * (1.0 - t) + n1 * t;
            // The patch between the neighbours lies within half their spacing of the median,
            // along the blended normal one way or the other; of what is found, the point nearest
            // the curve's last keeps the fill on one side of a tube (no jump across it).
            let last = *pts.last().expect("starts with `start`");
            [
                surface.raycast(mid, dir, gap, 1e-6).map(|c| c.point),
                surface.raycast(mid, -dir, gap, 1e-6).map(|c| c.point),
                Some(near.point),
            ]
            .into_iter()
            .flatten()
            .min_by(|a, b| (a - last).norm().total_cmp(&(b - last).norm()))
            .expect("the nearest point is always there")
        };
        // Where the median passes a tube's axis every projection may land across it: then walk
        // on from the last point as the neighbours (and the shift) advance, in the tangent plane.
        let last = *pts.last().expect("starts with `start`");
        let advance =
            ((pa[k] - pa[k - 1]) + (pb[k] - pb[k - 1])) / 2.0 + (off1 - off0) / (m - 1) as f64;
        let q = if (q - last).norm() > 3.0 * advance.norm() + step_mm {
            let n = normal_at(last).normalize();
            let along = advance - n * n.dot(&advance);
            surface.query(last + along).point
        } else {
            q
        };
        pts.push(q);
    }
    pts.push(end);
    // A median that still jumps (across a tube, or to an end it could not reach along the
    // surface) is no generator: the gap stays open and is reported.
    let smooth = pts.windows(2).all(|w| {
        (w[1] - w[0]).norm()
            <= 3.0 * step_mm.max(1e-9) + 3.0 * (a.length().max(b.length()) / (m - 1) as f64)
    });
    Generator::new(pts, true, smooth)
}

/// Arc parameters of the generators' upper ends, unwrapped so that consecutive ends differ by the
/// short way round, except where that loses the turn the ends must make in all: the generators
/// sweep the surface, so their ends go once around the upper loop. Where Eq.1's generators all
/// converge (a bent tube's run to the inside of the bend), the short way sums to no turn; the
/// missing turn then belongs to the neighbours with the widest gap between them, which run to
/// either side of the part. Also returns the turn from the last end back round to the first.
fn unwrap_upper_ends(up: &LoopParam, gens: &[Generator], eps: &[f64]) -> (Vec<f64>, f64) {
    let n = gens.len();
    let u: Vec<f64> = gens.iter().map(|g| up.param(g.end())).collect();
    let mut step: Vec<f64> = (0..n).map(|i| up.wrap(u[(i + 1) % n] - u[i])).collect();
    let total: f64 = step.iter().sum();
    if total.abs() < 0.5 * up.length {
        let k = (0..n)
            .max_by(|&a, &b| eps[a].total_cmp(&eps[b]))
            .expect("generators");
        step[k] -= up.length * if step[k] >= 0.0 { 1.0 } else { -1.0 };
    }
    let mut ends = vec![u[0]];
    for i in 0..n - 1 {
        ends.push(ends[i] + step[i]);
    }
    // The pair that carries the turn may be the last and the first.
    (ends, step.iter().sum())
}

/// A boundary loop as a closed polyline parametrised by arc length.
struct LoopParam<'a> {
    part: &'a Part,
    vertices: &'a [u32],
    arc: Vec<f64>,
    length: f64,
}

impl<'a> LoopParam<'a> {
    fn new(part: &'a Part, index: usize) -> LoopParam<'a> {
        let vertices = &part.topology.loops[index].vertices;
        let pos = |k: usize| part.mesh.positions[vertices[k % vertices.len()] as usize];
        let mut arc = vec![0.0];
        for k in 0..vertices.len() {
            arc.push(arc[k] + (pos(k + 1) - pos(k)).norm());
        }
        let length = arc[vertices.len()];
        LoopParam {
            part,
            vertices,
            arc,
            length,
        }
    }

    fn pos(&self, k: usize) -> Point3<f64> {
        self.part.mesh.positions[self.vertices[k % self.vertices.len()] as usize]
    }

    /// Map a difference of parameters to (−L/2, L/2].
    fn wrap(&self, d: f64) -> f64 {
        let d = d.rem_euclid(self.length);
        if d > self.length / 2.0 {
            d - self.length
        } else {
            d
        }
    }

    /// Arc parameter of the loop point nearest to p.
    fn param(&self, p: Point3<f64>) -> f64 {
        let mut best = (f64::INFINITY, 0.0);
        for k in 0..self.vertices.len() {
            let (a, b) = (self.pos(k), self.pos(k + 1));
            let ab = b - a;
            let t = ((p - a).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
            let d = (p - (a + ab * t)).norm();
            if d < best.0 {
                best = (d, self.arc[k] + t * (self.arc[k + 1] - self.arc[k]));
            }
        }
        best.1
    }

    fn point(&self, u: f64) -> SurfacePoint {
        let u = u.rem_euclid(self.length);
        let k = (self.arc.partition_point(|&a| a <= u) - 1).min(self.vertices.len() - 1);
        let t = (u - self.arc[k]) / (self.arc[k + 1] - self.arc[k]);
        let n = self.vertices.len();
        on_boundary_edge(self.part, self.vertices[k], self.vertices[(k + 1) % n], t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::mesh::LowerLoop;
    use crate::shapes::tube_grid;

    /// A ray through a loop vertex meets both its edges at u = 1 and u = 0 up to rounding, and
    /// must still find one of them: `scenarios/mesh_file.toml`'s cone (84 loop vertices, 120
    /// rays) lost a lower point this way and could not be planned. Tubes of 60 to 140 vertices
    /// around, each with rays through some of its vertices (120 rays share a divisor with most).
    #[test]
    fn a_ray_through_a_loop_vertex_finds_its_point() {
        for around in 60..=140 {
            let part = Part::from_mesh(tube_grid(50.0, 20.0, around, 4), LowerLoop::LowestZ)
                .expect("a tube is a valid part");
            let found = lower_points(&part, 120).len();
            assert_eq!(
                found, 120,
                "{around} vertices around: {found} of 120 points"
            );
        }
    }
}
