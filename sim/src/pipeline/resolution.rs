//! Whether the path and the grid are fine enough for the heat model. The thin wall's nodes
//! along the bead are the path's deposits (merged where shorter than `node_mm`, never split),
//! and its preheat depends on their length: on the R 200 dome (measure.sh's) the lowest
//! revolutions read 36–40 K above a path of 2.6 mm deposits with 10.5 mm ones, 4–9 K with 5.2 mm
//! ones, the error falling as the square of the length (docs/PHYSICS.md "Resolution along the
//! bead"). Deposits longer than twice `node_mm` are reported, so that a preheat that is the
//! grid's is not taken for the part's. On the voxel model, the metal its grid laid is held
//! against the metal the beads hold ([`metal`]): a path inside the plate, or beads thinner than
//! half a voxel, lay none, and the run heats a part that is not there; and its edge is held
//! against the beads' height ([`coarse_voxels`]): a cell much taller than a layer lays the
//! layers in lumps, and one about as tall reads pools long where the beads climb past a layer
//! of cells ([`coarse_pool`]). On either model, beads on nothing but the plate far above its top
//! ([`floating`]) are laid on the plate all the same: a logged path in the machine's frame.

use crate::pipeline::params::{ThermalModel, ThermalSettings};
use crate::pipeline::risk::{Criteria, Risk, judge};
use thermal::run::{Cells, PointResult, RunResult};
use thermal::schedule::{Deposit, arc_lengths, bead_volume, segment_start};

/// One of the warnings below, as a command shows it (`line`) and as the outputs name it
/// (`kind`: thermal.json's and replay.json's `warnings`, a study's summary.csv).
#[derive(Debug, Clone, PartialEq)]
pub struct Warning {
    /// The function that found it: `coarse_deposits`, `coarse_pool`, `coarse_voxels`,
    /// `floating_path`, `metal_off`, `plan_infeasible`, or of a replay's readings
    /// ([`crate::pipeline::replay::doubts`])
    /// `probe_clock`, `probe_empty`, `probe_unread` or `probe_unit`.
    pub kind: &'static str,
    pub line: String,
}

/// A plan whose points ask for deposits outside the process window (CTPP Eq.6) away from its
/// closing zone (`zone`, per point), where the wire feed cannot lay the layer the spiral
/// expects whatever the heat does (`plan_infeasible`): report.html said it, the terminal and
/// thermal.json did not. In the closing zone the revolutions cross converging generators and
/// such points are expected (the hemisphere's last revolutions): not said.
pub fn infeasible(
    plan: &planner::plan::Plan,
    zone: &[bool],
    window_mm: [f64; 2],
) -> Option<Warning> {
    let away: Vec<&planner::orientation::Violation> = plan
        .violations
        .iter()
        .filter(|v| !zone.get(v.point).copied().unwrap_or(false))
        .collect();
    let first = away.first()?;
    let (lo, hi) = away
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(v.deposit_mm), b.max(v.deposit_mm))
        });
    Some(Warning {
        kind: "plan_infeasible",
        line: format!(
            "warning: the plan is not feasible (CTPP Eq.6): {} of its {} path points away from \
             the closing zone, the first at point {} (layer {}), ask for deposits of \
             {lo:.2}–{hi:.2} mm, outside the process window {:.2}–{:.2} mm, where the wire feed \
             cannot lay what the spiral asks (plan.json `violations`, report.html); widen the \
             window ([process] deposit_min_mm, deposit_max_mm) or change the part",
            away.len(),
            plan.points.len(),
            first.point,
            first.layer,
            window_mm[0],
            window_mm[1]
        ),
    })
}

/// The warnings a run of `deps` on the model `t` sets up earns before it starts: the thin wall's
/// deposits against its nodes, the voxel edge against the beads' height (named `key`:
/// `thermal.voxel_mm`, or `live.voxel_mm` where the twin has its own grid), and on either a path
/// laid far above the plate ([`floating`]).
pub fn before_run(t: &ThermalSettings, deps: &[Deposit], key: &str) -> Vec<Warning> {
    let grid = match t.model {
        ThermalModel::ThinWall => coarse_deposits(deps, t.node_m).map(|c| Warning {
            kind: "coarse_deposits",
            line: c.line(),
        }),
        ThermalModel::Voxel => coarse_voxels(deps, t.voxel_m).map(|c| Warning {
            kind: "coarse_voxels",
            line: c.line(key),
        }),
    };
    let path = floating(deps).map(|f| Warning {
        kind: "floating_path",
        line: f.line(),
    });
    let pace = slow_arc(deps).map(|s| Warning {
        kind: "slow_arc",
        line: s.line(),
    });
    grid.into_iter().chain(path).chain(pace).collect()
}

/// The arc's travel along the beads, over all of them: how far and in how long.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlowArc {
    pub length_m: f64,
    pub arc_s: f64,
}

/// Under this mean speed (m/s) the arc's travel is reported: a WAAM or DED torch lays its beads
/// at 2–20 mm/s, a slow TIG one at 1 mm/s; a logged time column in milliseconds, read as
/// seconds, makes a 5 mm/s path 0.005 mm/s and its build a thousand times as long, which the
/// clock-bound checks (1e7 s) let through.
const SLOW_ARC_M_S: f64 = 0.5e-3;
/// Beads shorter than this in all are not judged: a skeleton's drops, a spot.
const SLOW_ARC_MIN_M: f64 = 10e-3;

impl SlowArc {
    pub fn speed_mm_s(&self) -> f64 {
        self.length_m / self.arc_s * 1e3
    }

    /// A warning for the terminal: the speed, and the clock a thousand times too slow.
    pub fn line(&self) -> String {
        format!(
            "warning: the arc travels its {:.1} mm of bead in {:.0} s, a mean {:.4} mm/s, \
             where a WAAM torch runs 2-20 mm/s: the run heats the part as that slow a torch \
             would. A time column in milliseconds read as seconds does this ({:.2} mm/s at a \
             thousand times the pace): the toolpath's times are seconds",
            self.length_m * 1e3,
            self.arc_s,
            self.speed_mm_s(),
            self.speed_mm_s() * 1e3
        )
    }
}

/// The arc's mean speed along the beads of `deps` (their segments with the arc on; travels
/// between tracks, drops, an arc held still and a torch climbing its own axis left out), if under
/// [`SLOW_ARC_M_S`] over at least [`SLOW_ARC_MIN_M`] of bead.
pub fn slow_arc(deps: &[Deposit]) -> Option<SlowArc> {
    let (mut length_m, mut arc_s) = (0.0, 0.0);
    for (i, d) in deps.iter().enumerate() {
        let from = segment_start(deps, i);
        let seg: [f64; 3] = std::array::from_fn(|k| d.position[k] - from[k]);
        let len = seg.iter().map(|x| x * x).sum::<f64>().sqrt();
        let along: f64 = (0..3).map(|k| seg[k] * d.axis[k]).sum();
        if len <= 1e-9 || d.drop.is_some() || d.arc_time <= 0.0 || along.abs() > 0.9 * len {
            continue;
        }
        length_m += len;
        arc_s += d.arc_time;
    }
    (length_m >= SLOW_ARC_MIN_M && length_m < SLOW_ARC_M_S * arc_s)
        .then_some(SlowArc { length_m, arc_s })
}

/// Deposits laid on nothing but the plate with their path points far above its top (z = 0).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Floating {
    pub deposits: usize,
    /// The highest of their path points (the bead's top), m.
    pub highest_m: f64,
    /// The first of them: its path point's height and its bead's, m.
    pub first_top_m: f64,
    pub first_height_m: f64,
}

/// A bead on the plate whose bottom lies more than this many of its heights, and more than
/// [`FLOATING_MIN_M`], above the plate's top is reported: the ORNL event series' layers, whose
/// logged z wanders ±2 mm, lie within a layer (2.31 mm) of where they are laid.
const FLOATING_HEIGHTS: f64 = 5.0;
const FLOATING_MIN_M: f64 = 5e-3;

impl Floating {
    /// A warning for the terminal: what the models make of it and the offset that seats the
    /// first of them on the plate.
    pub fn line(&self) -> String {
        let offset = -(self.first_top_m - self.first_height_m) * 1e3;
        format!(
            "warning: {} deposits lie on nothing but the plate with their path points up to \
             {:.1} mm above its top (z = 0): both heat models lay such a bead on the plate, \
             the first {:.1} mm below its path. A path in the machine's frame puts the plate \
             elsewhere: [toolpath] z_offset_mm = {offset:.1} (added to what is set) seats the \
             first of them on the plate, its bead's top at {:.2} mm",
            self.deposits,
            self.highest_m * 1e3,
            (self.first_top_m - self.first_height_m) * 1e3,
            self.first_height_m * 1e3
        )
    }
}

/// The deposits of `deps` laid on the plate (no support) whose beads' bottoms lie more than
/// [`FLOATING_HEIGHTS`] bead heights (and [`FLOATING_MIN_M`]) above its top, if any. A torch
/// climbing along its build direction (a strut's column, `thermal::voxel`'s rule: its segment
/// within 26° of the axis) grows its metal from the plate and is left out, as are drops.
pub fn floating(deps: &[Deposit]) -> Option<Floating> {
    let climbs = |i: usize| {
        let (d, from) = (&deps[i], segment_start(deps, i));
        let seg: [f64; 3] = std::array::from_fn(|k| d.position[k] - from[k]);
        let len = seg.iter().map(|x| x * x).sum::<f64>().sqrt();
        let along: f64 = (0..3).map(|k| seg[k] * d.axis[k]).sum();
        len > 0.0 && along.abs() > 0.9 * len
    };
    let mut found: Option<Floating> = None;
    for (i, d) in deps.iter().enumerate() {
        // The bead's bottom above the plate's top: its height runs along its build direction.
        let fall = d.position[2] - d.height * d.axis[2];
        let far = fall > (FLOATING_HEIGHTS * d.height).max(FLOATING_MIN_M);
        if d.support.is_some() || d.drop.is_some() || !far || climbs(i) {
            continue;
        }
        let f = found.get_or_insert(Floating {
            deposits: 0,
            highest_m: d.position[2],
            first_top_m: d.position[2],
            first_height_m: d.height,
        });
        f.deposits += 1;
        f.highest_m = f.highest_m.max(d.position[2]);
    }
    found
}

/// The deposits longer than a node should be.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coarse {
    /// How many are longer than `limit_m`, of `deposits`.
    pub over: usize,
    pub deposits: usize,
    /// The longest, m.
    pub longest_m: f64,
    pub limit_m: f64,
}

impl Coarse {
    /// A warning for the terminal.
    pub fn line(&self) -> String {
        format!(
            "warning: thin wall: {} of {} deposits are longer than {:.1} mm (twice \
             [thermal] node_mm), up to {:.1} mm; each is one node along the bead, and the \
             preheat depends on their length (R 200's lowest revolutions read 22-26 K hot \
             with 10.5 mm deposits, docs/PHYSICS.md \"Resolution along the bead\"): more \
             points ([planner] n_points) refine it",
            self.over,
            self.deposits,
            self.limit_m * 1e3,
            self.longest_m * 1e3
        )
    }
}

/// The deposits of `deps` longer than twice `node_m` (their segments along the path; travels
/// between tracks are not deposits), if more than one in a hundred are: a few long ones (a
/// seam) do not set the preheat of the part.
pub fn coarse_deposits(deps: &[Deposit], node_m: f64) -> Option<Coarse> {
    let s = arc_lengths(deps);
    let limit_m = 2.0 * node_m;
    let lengths = s.windows(2).map(|w| w[1] - w[0]);
    let (over, longest_m) = lengths
        .filter(|&l| l > limit_m)
        .fold((0, 0.0_f64), |(n, m), l| (n + 1, m.max(l)));
    (over * 100 > deps.len()).then_some(Coarse {
        over,
        deposits: deps.len(),
        longest_m,
        limit_m,
    })
}

/// A voxel edge much taller than the beads: the grid lays a layer in whole cells, so where a
/// cell is taller than a layer the layers go down in lumps, a cell's height of metal at a time.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CoarseVoxels {
    pub voxel_m: f64,
    /// The beads' median height, m.
    pub height_m: f64,
}

/// Where the voxel edge is over 1.4 times the beads' height a warning is given. Measured
/// (docs/PHYSICS.md "The voxel grid against the layer"; the R 50 dome, the bottle, a cone and two
/// cylinders, beads 2.5-8 mm wide and 1.86-2.0 mm high, each against its own grid of 0.5-1 mm,
/// and the GAMMA wall's 0.75 mm layers against 0.5 mm): at edges of 1.5-2.5 bead heights the
/// points' preheats a median 13-31 % of the rise from the fine grid's, the melt pool a median
/// 55-86 % longer (the dome, the bottle, the cone), the first point at risk judged by its pool
/// 62-99 % earlier along the path; at 1.35 bead heights or less 1.1-8.7 % (the GAMMA wall's 1 mm
/// at 1.33 1.9 %; the default 2 mm on the dome's 1.86 mm beads 6.0 %). The threshold lies between
/// the two, set after the GAMMA wall was measured; the cone was measured after it was set (6.1 %
/// at 1.29, 13.6 % at 1.55). The beads' width mattered less: 1.25 cells across a 2.5 mm bead
/// read 3.8 %. What lies below the top layers reads less of it: the ORNL pad's thermocouples, in
/// its plate, 4.1 % from 2 mm at its twin's 4 mm (1.73 bead heights).
const VOXELS_PER_LAYER: f64 = 1.4;

impl CoarseVoxels {
    /// A warning for the terminal; `key` names the edge (`thermal.voxel_mm`, `live.voxel_mm`).
    pub fn line(&self, key: &str) -> String {
        format!(
            "warning: voxel model: {key} = {} is {:.2} times the beads' height ({:.2} mm, \
             the median): a cell much taller than a layer lays the layers in lumps. On the \
             parts of revolution measured such grids read the preheats 13-31 % of the rise \
             from a fine grid's and the melt pool 55-86 % longer, and judged the first point \
             at risk by its pool (humping, Bond) 62-99 % earlier along the path; temperatures \
             below the top layers less (the ORNL pad's thermocouples 4 % at 1.73 times). An \
             edge of {:.2} mm or less refines it (docs/PHYSICS.md \"The voxel grid against \
             the layer\")",
            self.voxel_m * 1e3,
            self.voxel_m / self.height_m,
            self.height_m * 1e3,
            self.height_m * 1e3
        )
    }
}

/// The voxel edge `voxel_m` against `deps`' beads, where it is over 1.4 times their median
/// height. A skeleton's drops are not layers and are left out.
pub fn coarse_voxels(deps: &[Deposit], voxel_m: f64) -> Option<CoarseVoxels> {
    let height_m = bead_height(deps)?;
    (voxel_m > VOXELS_PER_LAYER * height_m).then_some(CoarseVoxels { voxel_m, height_m })
}

/// The beads' median height, m, a skeleton's drops left out (None where no bead has one).
fn bead_height(deps: &[Deposit]) -> Option<f64> {
    let mut heights: Vec<f64> = deps
        .iter()
        .filter(|d| d.drop.is_none() && d.height > 0.0)
        .map(|d| d.height)
        .collect();
    if heights.is_empty() {
        return None;
    }
    let mid = heights.len() / 2;
    Some(*heights.select_nth_unstable_by(mid, f64::total_cmp).1)
}

/// A voxel run whose first point at risk is judged by its melt pool (humping, Bond) on cells
/// about as tall as the beads ([`POOL_EDGE_PER_LAYER`]) and not yet 1.4 times as tall, where
/// [`coarse_voxels`] says more.
#[derive(Debug, Clone, PartialEq)]
pub struct CoarsePool {
    pub first: usize,
    /// What its pool breaks ([`Criteria::breach`]).
    pub breach: String,
    pub voxel_m: f64,
    /// The beads' median height, m.
    pub height_m: f64,
}

/// Where the voxel edge is at least the beads' height (to 5 %) a first point at risk judged by
/// its pool is reported. Measured (docs/PHYSICS.md "A pool judged on cells as tall as the
/// beads"): where the beads climb past a layer of cells, a stretch of deposits lays a cell or
/// two across where their beads cover five, or none, and their arcs heat what little there is.
/// The first points at risk so judged at 1.0-1.11 bead heights (the R 50 dome's 366 at 2 mm and
/// 126 at 1.86 mm, the latter before "A leaning wall's faces", a torispherical head's 869, the
/// R 100 cylinder's 606) were judged by their
/// preheats (interpass), further along, at half the edge or on the thin wall (the dome's 602 at
/// 1 mm, the head's 957 at 1 mm: its knuckle's 300 pools over the humping limit none there); at
/// 0.94 the dome's first point at risk was its preheat's (645 at 1.75 mm, before "A leaning
/// wall's faces").
const POOL_EDGE_PER_LAYER: f64 = 0.95;

impl CoarsePool {
    /// A warning for the terminal; `key` names the edge (`thermal.voxel_mm`), `run` the run
    /// ("", or " of the run without dwells"), `dwells` the plan's dwells for pools and all of
    /// them where a plan was made.
    pub fn line(&self, key: &str, run: &str, dwells: Option<(usize, usize)>) -> String {
        let planned = match dwells {
            Some((pools, all)) if pools > 0 => format!(
                "; {pools} of the plan's {all} dwells are for pools (humping, Bond), which \
                 may need none"
            ),
            _ => String::new(),
        };
        format!(
            "warning: voxel model: the first point at risk{run}, point {}, is at risk by its \
             pool ({}), on cells {} mm tall ({key}) against beads {:.2} mm high. Where the \
             beads climb past a layer of cells, a stretch of deposits lays a cell or two where \
             their beads cover five, or none, and their arcs heat what little there is: the \
             pool reads long. On the parts measured such a verdict at 1.0-1.1 bead heights was \
             the grid's: at half the edge the first point at risk was judged by its preheat, \
             further along (a torispherical head's 869 → 957, the R 50 dome's 366 → 602). A \
             run at {key} = {:.2} says whether the pool is the part's{planned} \
             (docs/PHYSICS.md \"A pool judged on cells as tall as the beads\")",
            self.first,
            self.breach,
            self.voxel_m * 1e3,
            self.height_m * 1e3,
            0.5 * self.height_m * 1e3
        )
    }
}

/// The first point at risk of a voxel run on `deps` (edge `voxel_m`), where it is judged by its
/// pool on cells as tall as the beads or taller, up to where [`coarse_voxels`] warns of the
/// grid as a whole.
pub fn coarse_pool(
    c: &Criteria,
    points: &[PointResult],
    deps: &[Deposit],
    voxel_m: f64,
) -> Option<CoarsePool> {
    let height_m = bead_height(deps)?;
    // Over 1.4 bead heights [`coarse_voxels`] says it, of the pools too.
    if voxel_m < POOL_EDGE_PER_LAYER * height_m || voxel_m > VOXELS_PER_LAYER * height_m {
        return None;
    }
    let (first, risk) = points
        .iter()
        .enumerate()
        .find_map(|(i, p)| judge(c, p, 0.0).map(|r| (i, r)))?;
    matches!(risk, Risk::Humping | Risk::Bond).then(|| CoarsePool {
        first,
        breach: c.breach(&points[first], risk),
        voxel_m,
        height_m,
    })
}

/// The voxel model's metal against the beads': `laid_m3` the cells its deposits switched on,
/// `beads_m3` the beads' width × height × length.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Metal {
    pub laid_m3: f64,
    pub beads_m3: f64,
}

/// Where the laid metal is under half or over twice the beads' a warning is given: measured
/// 1.01-1.10 on the shipped voxel runs (the GAMMA wall, the ORNL pad, the R 50 dome, the bottle)
/// and 1.36 on beads 1.5 mm high on 2 mm voxels (each cell holds the whole bead's height), 0 on
/// a path inside the plate; a slab laid where a column should be was 12 times (docs/PHYSICS.md
/// "Voxel model").
const METAL_BOUNDS: [f64; 2] = [0.5, 2.0];

impl Metal {
    pub fn ratio(&self) -> f64 {
        self.laid_m3 / self.beads_m3
    }

    /// The two volumes in mm³ to a thousandth (the outputs' `metal_mm3`, `beads_mm3`).
    pub fn mm3(&self) -> [f64; 2] {
        [self.laid_m3, self.beads_m3].map(|v| (v * 1e12).round() / 1e3)
    }

    /// The same, where it is under half or over twice the beads' (and they hold any).
    pub fn off(self) -> Option<Metal> {
        (self.beads_m3 > 0.0 && !(METAL_BOUNDS[0]..=METAL_BOUNDS[1]).contains(&self.ratio()))
            .then_some(self)
    }

    /// The warning where it is off.
    pub fn warning(self) -> Option<Warning> {
        self.off().map(|m| Warning {
            kind: "metal_off",
            line: m.line(),
        })
    }

    /// A warning for the terminal.
    pub fn line(&self) -> String {
        let (which, why) = match self.ratio() < 1.0 {
            true => (
                "under half",
                "the path's points are the beads' tops: a toolpath whose z puts its beads \
                 in the plate lays none, and a bead under half a voxel high may lay none \
                 ([thermal] voxel_mm, the bead's height)",
            ),
            false => (
                "over twice",
                "a bead narrower or thinner than a voxel takes whole cells \
                 ([thermal] voxel_mm against the bead's width and height)",
            ),
        };
        format!(
            "warning: voxel model: the deposits laid {:.1} mm³ of metal where the path's beads \
             hold {:.1} mm³ (width × height × length), {which} of it, so the heat went into a \
             part of another size; {why}",
            self.laid_m3 * 1e9,
            self.beads_m3 * 1e9
        )
    }
}

/// The voxel run's metal against `deps`' beads (None on the thin wall, whose nodes are the
/// beads').
pub fn metal(result: &RunResult, deps: &[Deposit]) -> Option<Metal> {
    match result.cells {
        Cells::Voxel { metal_m3, .. } => Some(Metal {
            laid_m3: metal_m3,
            beads_m3: bead_volume(deps),
        }),
        Cells::ThinWall { .. } => None,
    }
}

#[cfg(test)]
mod tests {
    use super::{Metal, coarse_deposits, coarse_pool, coarse_voxels, floating, slow_arc};
    use crate::pipeline::risk::Criteria;
    use thermal::run::PointResult;
    use thermal::schedule::{Deposit, helix};

    /// Laid metal under half or over twice the beads' is reported, each with its cause; within
    /// (1.36: beads 1.5 mm high on 2 mm voxels) it is not, nor a path with no bead.
    #[test]
    fn metal_far_from_the_beads_is_reported() {
        let m = |laid_m3: f64, beads_m3: f64| Metal { laid_m3, beads_m3 }.off();
        assert_eq!(m(1.36e-9, 1e-9), None);
        assert_eq!(m(0.5e-9, 1e-9), None);
        assert_eq!(m(0.0, 0.0), None);
        let under = m(0.0, 600e-9).expect("reported").line();
        assert!(
            under.contains("laid 0.0 mm³") && under.contains("hold 600.0 mm³"),
            "{under}"
        );
        assert!(
            under.contains("under half") && under.contains("in the plate"),
            "{under}"
        );
        let over = m(270e-9, 22.5e-9).expect("reported").line();
        assert!(
            over.contains("over twice") && over.contains("whole cells"),
            "{over}"
        );
    }

    /// A voxel edge over 1.4 times the beads' median height is reported, with
    /// the key it was given as and the edge that fits; one under it is not, nor a skeleton's
    /// drops, nor a path with no bead.
    #[test]
    fn voxels_taller_than_the_layers_are_reported() {
        let mut beads = helix(0.025, 40, 3, 2e-3, 5e-3, 10e-3, 1700.0);
        // A few tall ones (a seam, a start) do not move the median.
        for d in beads.iter_mut().take(10) {
            d.height = 6e-3;
        }
        assert_eq!(coarse_voxels(&beads, 2.79e-3), None);
        let c = coarse_voxels(&beads, 2.81e-3).expect("reported");
        assert_eq!(c.height_m, 2e-3);
        let line = c.line("live.voxel_mm");
        assert!(
            line.contains("live.voxel_mm = 2.81 is 1.41 times the beads' height (2.00 mm"),
            "{line}"
        );
        assert!(line.contains("An edge of 2.00 mm or less"), "{line}");
        let drops: Vec<_> = beads
            .iter()
            .map(|d| Deposit {
                drop: Some(thermal::schedule::DropPart::Continues),
                ..*d
            })
            .collect();
        assert_eq!(coarse_voxels(&drops, 4e-3), None);
        assert_eq!(coarse_voxels(&[], 4e-3), None);
    }

    /// A first point at risk by its pool is reported on cells as tall as the beads (to 5 %)
    /// or taller, with the plan's dwells for pools where a plan was made; not on finer cells,
    /// nor where the first point at risk is its preheat's, however long the pools after it.
    #[test]
    fn a_pool_judged_on_cells_as_tall_as_the_beads_is_reported() {
        let mut beads = helix(0.025, 40, 3, 2e-3, 5e-3, 10e-3, 1700.0);
        beads.iter_mut().for_each(|d| d.height = 1.86e-3);
        let c = Criteria {
            interpass_max_k: Some(473.15),
            strength_loss_k: None,
            humping_pool_m: Some(15.7e-3),
            bond: None,
            melting_k: 1700.0,
        };
        let cool = PointResult {
            preheat: 400.0,
            pool_length: 9e-3,
            ..PointResult::default()
        };
        let mut points = vec![cool; beads.len()];
        points[70].pool_length = 16.5e-3;
        let found = coarse_pool(&c, &points, &beads, 2e-3).expect("reported");
        assert_eq!((found.first, found.height_m), (70, 1.86e-3));
        let line = found.line("thermal.voxel_mm", "", Some((30, 117)));
        for said in [
            "point 70, is at risk by its pool (melt pool 16.5 mm over the 15.7 mm humping limit), \
             on cells 2 mm tall (thermal.voxel_mm) against beads 1.86 mm high",
            "thermal.voxel_mm = 0.93 says",
            "30 of the plan's 117 dwells are for pools",
        ] {
            assert!(line.contains(said), "{said}: {line}");
        }
        assert!(!found.line("k", "", Some((0, 117))).contains("dwells are"));
        // Cells a twentieth under the beads' height, or half of it: not reported.
        assert_eq!(coarse_pool(&c, &points, &beads, 1.76e-3), None);
        assert!(coarse_pool(&c, &points, &beads, 1.77e-3).is_some());
        assert_eq!(coarse_pool(&c, &points, &beads, 0.93e-3), None);
        // Over 1.4 bead heights the grid's own warning says it.
        assert!(coarse_pool(&c, &points, &beads, 2.6e-3).is_some());
        assert_eq!(coarse_pool(&c, &points, &beads, 2.61e-3), None);
        // The preheat over its limit first.
        points[50].preheat = 480.0;
        assert_eq!(coarse_pool(&c, &points, &beads, 2e-3), None);
        assert_eq!(coarse_pool(&c, &points, &[], 2e-3), None);
    }

    /// A path laid on the plate is not reported; the same path 500 mm up (a log in the
    /// machine's frame) is, its first revolution (on nothing but the plate) counted and the
    /// offset that seats it given; a strut's column climbing from the plate is not.
    #[test]
    fn a_path_far_above_the_plate_is_reported() {
        let on_plate = helix(0.025, 40, 3, 2e-3, 5e-3, 10e-3, 1700.0);
        assert_eq!(floating(&on_plate), None);
        let up: Vec<Deposit> = on_plate
            .iter()
            .map(|d| Deposit {
                position: [d.position[0], d.position[1], d.position[2] + 0.5],
                start: d.start.map(|s| [s[0], s[1], s[2] + 0.5]),
                ..*d
            })
            .collect();
        let f = floating(&up).expect("reported");
        let unsupported = up.iter().filter(|d| d.support.is_none()).count();
        assert_eq!(f.deposits, unsupported);
        assert!(unsupported >= 40, "{unsupported}");
        let offset = -(up[0].position[2] - up[0].height) * 1e3;
        assert!((offset + 500.0).abs() < 2.0, "{offset}");
        let line = f.line();
        assert!(
            line.contains(&format!("z_offset_mm = {offset:.1}")) && line.contains("(z = 0)"),
            "{line}"
        );
        // A column of 2 mm deposits climbing 40 mm straight up from the plate.
        let strut: Vec<Deposit> = (0..20)
            .map(|k| Deposit {
                position: [0.0, 0.0, 2e-3 * (k + 1) as f64],
                start: (k == 0).then_some([0.0, 0.0, 0.0]),
                support: None,
                ..on_plate[0]
            })
            .collect();
        assert_eq!(floating(&strut), None);
    }

    /// A path whose times are a thousand times too long (a logged time column in ms read as
    /// s) is reported with its mean speed and the speed at a thousand times the pace: the helix
    /// at 10 mm/s is not, nor at 1 mm/s (a slow TIG torch), nor a column climbing its own axis.
    #[test]
    fn an_arc_slower_than_any_torch_is_reported() {
        let paced = |mm_s: f64| {
            let mut deps = helix(0.025, 40, 3, 2e-3, 5e-3, 10e-3, 1700.0);
            for d in deps.iter_mut() {
                d.arc_time *= 10.0 / mm_s;
                d.time *= 10.0 / mm_s;
            }
            deps
        };
        assert_eq!(slow_arc(&paced(10.0)), None);
        assert_eq!(slow_arc(&paced(1.0)), None);
        let slow = slow_arc(&paced(0.01)).expect("reported");
        // The chords are 0.1 % shorter than the arcs the helix times.
        assert!((slow.speed_mm_s() / 0.01 - 1.0).abs() < 0.01, "{slow:?}");
        let line = slow.line();
        assert!(
            line.contains("0.0100 mm/s") && line.contains("9.99 mm/s at a thousand"),
            "{line}"
        );
        let mut held = paced(0.01);
        for (k, d) in held.iter_mut().enumerate() {
            d.position = [0.0, 0.0, 2e-3 * (k + 1) as f64];
            d.axis = [0.0, 0.0, 1.0];
        }
        assert_eq!(slow_arc(&held), None, "a column climbing its own axis");
    }

    /// A helix of 8 deposits a revolution at R 25 mm (19.1 mm chords) is reported against 3 mm
    /// nodes; one of 40 (3.9 mm) is not.
    #[test]
    fn deposits_longer_than_two_nodes_are_reported() {
        let coarse = helix(0.025, 8, 3, 2e-3, 5e-3, 10e-3, 1700.0);
        let c = coarse_deposits(&coarse, 3e-3).expect("reported");
        assert_eq!((c.over, c.deposits), (23, 24));
        assert!((c.longest_m - 0.0191).abs() < 1e-4, "{}", c.longest_m);
        assert!(c.line().contains("19.1 mm"), "{}", c.line());
        let fine = helix(0.025, 40, 3, 2e-3, 5e-3, 10e-3, 1700.0);
        assert_eq!(coarse_deposits(&fine, 3e-3), None);
    }
}
