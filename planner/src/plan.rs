//! The CTPP pipeline, step by step as in the paper: single-branch check (§2.1), lower points
//! (§2.2.1), generators (Eq.1) or closing point (Eq.4), gap filling (Eq.2–3), spiral (§2.3, Table 1,
//! Eq.5), build direction and true deposit (§2.4), feasibility (Eq.6), deviation (Fig. 30).

use crate::closing_point::closing_point;
use crate::collision::{Collisions, Nozzle, detect, resolve};
use crate::deviation::{Deviation, deviation};
use crate::frame::{RateLimit, Torch, limit_rate, torch_axes};
use crate::generators::{FillLimits, Generator, Target, fill_gaps, lower_points, trace};
use crate::geodesic::path::Tracer;
use crate::geodesic::{HeatOptions, HeatSolver};
use crate::geometry::closest::{ClosestPoint, vertex_normals};
use crate::geometry::sparse::FactorError;
use crate::mesh::{Part, PartKind};
use crate::orientation::{Violation, orient, violations};
use crate::skeleton::{MultiBranch, check_single_branch};
use crate::spiral::{Seam, Spiral, SpiralError, place_seam, spiral_of};
use nalgebra::{Point3, Vector3};
use std::fmt;

/// What the planner needs from a scenario, in mm.
#[derive(Debug, Clone, PartialEq)]
pub struct PlanParams {
    /// n_pts (§2.2.1).
    pub n_points: usize,
    /// ε₀ (Eq.3).
    pub gap_max_mm: f64,
    pub deposit_mm: f64,
    pub deposit_min_mm: f64,
    pub deposit_max_mm: f64,
    /// Deposits this close to the window count as inside it: the height resolution of the
    /// process (about 0.01 mm for CMT wire feed control).
    pub tolerance_mm: f64,
    pub nozzle: Nozzle,
    pub torch: Torch,
}

impl Default for PlanParams {
    /// The documented defaults (scenarios/README.md `[planner]`): 120 points a generator,
    /// ε₀ = 0.2 mm, a 2 mm deposit within [1.8, 2.2] mm, the default nozzle and torch.
    fn default() -> Self {
        PlanParams {
            n_points: 120,
            gap_max_mm: 0.2,
            deposit_mm: 2.0,
            deposit_min_mm: 1.8,
            deposit_max_mm: 2.2,
            tolerance_mm: 0.01,
            nozzle: crate::collision::Nozzle::default(),
            torch: crate::frame::Torch::default(),
        }
    }
}

/// One point of the path, in deposition order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PathPoint {
    pub position: Point3<f64>,
    /// The build direction b = n × t: the bead's height runs along it.
    pub build: Vector3<f64>,
    /// Unit vector from the deposit to the torch: b tilted by the torch's lead and side angles
    /// and rate-bounded ([`crate::frame::torch_axes`]), turned about the direction of travel where
    /// the nozzle would hit the part ([`crate::collision::resolve`]).
    pub tool: Vector3<f64>,
    pub layer: usize,
    pub generator: usize,
    /// d: the step along the generator from the point beneath.
    pub step_mm: f64,
    /// H = d·cos θ: the deposit height along the build direction.
    pub deposit_mm: f64,
}

#[derive(Debug, Clone)]
pub struct Plan {
    pub kind: PartKind,
    pub generators: Vec<Generator>,
    pub n_filled: usize,
    pub closing_point: Option<Point3<f64>>,
    pub spiral: Spiral,
    /// Where the spiral starts and why (the generators are listed from it on).
    pub seam: Seam,
    pub points: Vec<PathPoint>,
    pub violations: Vec<Violation>,
    pub deviation: Deviation,
    /// Nozzle collisions found, and those the tool's turn did not resolve.
    pub collisions: Collisions,
    /// What bounding the tool's angular rate did.
    pub rate_limit: RateLimit,
}

impl Plan {
    pub fn feasible(&self) -> bool {
        self.violations.is_empty()
    }

    pub fn generator_length_range(&self) -> (f64, f64) {
        range(self.generators.iter().map(|g| g.length()))
    }

    pub fn deposit_range(&self) -> (f64, f64) {
        range(self.points.iter().map(|p| p.deposit_mm))
    }
}

pub fn range(it: impl Iterator<Item = f64>) -> (f64, f64) {
    it.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| {
        (lo.min(x), hi.max(x))
    })
}

#[derive(Debug, Clone, PartialEq)]
pub enum PlanError {
    MultiBranch(MultiBranch),
    Spiral(SpiralError),
    Factor(FactorError),
    LowerPoints { found: usize, wanted: usize },
    Unreached { generator: usize },
}

impl fmt::Display for PlanError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            PlanError::MultiBranch(e) => e.fmt(f),
            PlanError::Spiral(e) => e.fmt(f),
            PlanError::Factor(e) => e.fmt(f),
            PlanError::LowerPoints { found, wanted } => write!(
                f,
                "only {found} of {wanted} lower points found: the lower boundary is not star-shaped around its centroid"
            ),
            PlanError::Unreached { generator } => {
                write!(
                    f,
                    "generator {generator} stalled before its target (a spurious minimum of the distance field)"
                )
            }
        }
    }
}

impl std::error::Error for PlanError {}

/// Levels of the single-branch check.
const BRANCH_LEVELS: usize = 64;

pub fn plan(part: &Part, p: &PlanParams) -> Result<Plan, PlanError> {
    let (mesh, topo) = (&part.mesh, &part.topology);
    let solver = HeatSolver::new(mesh, &topo.is_boundary_vertex, HeatOptions::default())
        .map_err(PlanError::Factor)?;
    let surface = ClosestPoint::new(mesh);
    let tracer = Tracer::new(mesh, topo);

    // §2.1: one branch.
    let from_lower = solver.distance_from_vertices(&part.lower_loop().vertices);
    let upper = part
        .upper_loop()
        .map(|l| solver.distance_from_vertices(&l.vertices));
    let s: Vec<f64> = match &upper {
        Some(up) => from_lower
            .iter()
            .zip(up)
            .map(|(a, b)| a / (a + b).max(1e-300))
            .collect(),
        None => {
            let top = from_lower.iter().cloned().fold(0.0, f64::max);
            from_lower.iter().map(|a| a / top).collect()
        }
    };
    check_single_branch(mesh, topo, &s, &from_lower, BRANCH_LEVELS)
        .map_err(PlanError::MultiBranch)?;

    // §2.2: lower points, then generators to the upper boundary or the closing point.
    let lower = lower_points(part, p.n_points);
    if lower.len() < p.n_points {
        return Err(PlanError::LowerPoints {
            found: lower.len(),
            wanted: p.n_points,
        });
    }
    let (target, closing) = match (part.kind, upper) {
        (PartKind::Open, Some(up)) => (up, None),
        _ => {
            let c = closing_point(&solver, &surface, &lower);
            (solver.distance(&[c.point]), Some(c.position))
        }
    };
    let mut generators = trace(&tracer, &target, closing, &lower);
    if let Some(i) = generators.iter().position(|g| !g.reached) {
        return Err(PlanError::Unreached { generator: i });
    }
    let fill_target = match closing {
        Some(point) => Target::ClosingPoint { point },
        None => Target::UpperLoop,
    };
    let normals_v = vertex_normals(mesh);
    let n_filled = fill_gaps(
        &mut generators,
        part,
        &surface,
        &fill_target,
        &normals_v,
        FillLimits {
            eps0: p.gap_max_mm,
            step_mm: p.deposit_mm,
            max_fill: 4 * p.n_points,
        },
    );

    // §2.3: the spiral, from a seam and with a count of revolutions that keep Eq.6.
    let mut lengths: Vec<f64> = generators.iter().map(|g| g.length()).collect();
    let seam = place_seam(&lengths, p.deposit_mm, p.deposit_min_mm, p.deposit_max_mm)
        .map_err(PlanError::Spiral)?;
    generators.rotate_left(seam.first);
    lengths.rotate_left(seam.first);
    let sp = spiral_of(
        &lengths,
        p.deposit_mm,
        p.deposit_min_mm,
        p.deposit_max_mm,
        Some(seam.n_layers),
    )
    .map_err(PlanError::Spiral)?;

    // A closed part's last revolution is the closing point itself: one point, not N.
    let mut sp = sp;
    if part.kind == PartKind::Closed {
        let last = sp.n_revolutions() - 1;
        let first_of_last = sp
            .points
            .iter()
            .position(|q| q.layer == last)
            .expect("last revolution");
        sp.points.truncate(first_of_last + 1);
    }

    // §2.4: positions, normals and directions, then build direction and true deposit.
    let located: Vec<(Point3<f64>, Vector3<f64>, Vector3<f64>)> = {
        use rayon::prelude::*;
        sp.points
            .par_iter()
            .map(|sp| {
                let (pos, along) = generators[sp.generator].at(sp.s_mm);
                let c = surface.query(pos);
                let face = mesh.faces[c.face];
                let n = (0..3)
                    .map(|k| normals_v[face[k] as usize] * c.bary[k])
                    .sum::<Vector3<f64>>()
                    .normalize();
                (pos, n, along)
            })
            .collect()
    };
    let positions: Vec<Point3<f64>> = located.iter().map(|l| l.0).collect();
    let normals: Vec<Vector3<f64>> = located.iter().map(|l| l.1).collect();
    let along: Vec<Vector3<f64>> = located.iter().map(|l| l.2).collect();
    let step: Vec<f64> = sp.points.iter().map(|q| q.step_mm).collect();
    let layers: Vec<usize> = sp.points.iter().map(|q| q.layer).collect();
    let oriented = orient(&positions, &layers, &normals, &along, &step);
    let mut points: Vec<PathPoint> = sp
        .points
        .iter()
        .zip(&oriented)
        .zip(&positions)
        .map(|((q, o), pos)| PathPoint {
            position: *pos,
            build: o.tool,
            tool: o.tool,
            layer: q.layer,
            generator: q.generator,
            step_mm: q.step_mm,
            deposit_mm: o.deposit_mm,
        })
        .collect();

    // §2.5: feasibility.
    let deposits: Vec<f64> = points.iter().map(|q| q.deposit_mm).collect();
    let layers: Vec<usize> = points.iter().map(|q| q.layer).collect();
    let gens: Vec<usize> = points.iter().map(|q| q.generator).collect();
    let violations = violations(
        &deposits,
        &layers,
        &gens,
        p.deposit_min_mm,
        p.deposit_max_mm,
        p.tolerance_mm,
    );

    // Fig. 30: deviation of the swept surface.
    let deviation = deviation(&positions, generators.len(), &surface);
    let builds: Vec<Vector3<f64>> = points.iter().map(|q| q.build).collect();
    let (tools, collisions, rate_limit) = torch_tools(&positions, &builds, &p.nozzle, &p.torch);
    for (q, t) in points.iter_mut().zip(tools) {
        q.tool = t;
    }
    Ok(Plan {
        kind: part.kind,
        generators,
        n_filled,
        closing_point: closing,
        spiral: sp,
        seam,
        points,
        violations,
        deviation,
        collisions,
        rate_limit,
    })
}

/// The tools a robot follows on build directions `builds`: tilted as the torch stands and
/// rate-bounded ([`torch_axes`]), turned away from collisions ([`resolve`]), and bounded once
/// more because the turns ramp at their own rate on top of the tool's; then what the nozzle
/// still hits (a point the lagging tool brings into collision counts as detected).
pub fn torch_tools(
    positions: &[Point3<f64>],
    builds: &[Vector3<f64>],
    nozzle: &Nozzle,
    torch: &Torch,
) -> (Vec<Vector3<f64>>, Collisions, RateLimit) {
    let (asked, asked_limit) = torch_axes(positions, builds, torch);
    let (turned, mut collisions) = resolve(positions, &asked, nozzle);
    let (tools, limited, _) = limit_rate(positions, &turned, torch.max_rate_deg_mm);
    collisions.unresolved = detect(positions, &tools, nozzle);
    for &i in &collisions.unresolved {
        if let Err(at) = collisions.detected.binary_search(&i) {
            collisions.detected.insert(at, i);
        }
    }
    let rate_limit = RateLimit {
        limited: asked_limit.limited + limited,
        ..asked_limit
    };
    (tools, collisions, rate_limit)
}
