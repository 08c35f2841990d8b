//! The engine: plan → beads → deposition schedule → heat → risk → dwells, as plain data in and
//! plain data out. No file, terminal or network IO happens here: the commands read the
//! scenario, call this, and write the files; a notebook or another tool can drive it from Rust
//! with parameters it fills in itself.
//!
//! A [`Build`] is made once from a plan and its [`Params`] (the beads and the schedule are
//! computed there, once); it runs through either heat model ([`Build::simulate`]), is judged
//! ([`Simulation::risks`]) and given dwells ([`Build::plan_dwells`]).
//!
//! Each command's work is one call here, the command reading the scenario before and writing
//! the files after: `plan` [`build`]; `simulate` [`Build::simulate_kept`]; `dwell`
//! [`dwelled::dwell`]; a study's case [`Build::case`]; `replay` [`replay::Replay::replay`];
//! `calibrate` [`calibrate::calibrate`]; `follow` [`twin::follow::Follower`] fed row by row;
//! `skeleton` [`skeleton::skeleton`]; `export` [`program::program`]. Long calls tell their
//! progress through a [`Report`].
//!
//! ```
//! use planner::mesh::{LowerLoop, Part};
//! use planner::plan::PlanParams;
//! use planner::shapes::Shape;
//! use sim::pipeline::{build, params::Params};
//!
//! // The documented defaults (scenarios/README.md), then parameters set in Rust.
//! let (mut params, mut planning) = (Params::default(), PlanParams::default());
//! params.thermal.plate_m = [0.08, 0.08, 0.008];
//! params.dwell.interpass_max_k = thermal::kelvin(250.0);
//! planning.n_points = 40;
//!
//! // A closed dome R 20 mm from its mesh, planned with CTPP, heated, given its dwells.
//! let mesh = Shape::Hemisphere { radius_mm: 20.0 }.mesh(2.5);
//! let part = Part::from_mesh(mesh, LowerLoop::default()).unwrap();
//! let dome = build(&part, &planning, params).unwrap();
//! let before = dome.simulate(&[], 0).unwrap();
//! let dwells = dome.plan_dwells().unwrap();
//! let after = dome.simulate_cooled(&dwells.cooling, 0, vec![]).unwrap();
//! assert!(before.first_risk(&dome.criteria).is_some());
//! // Every point is safe, the closing point's too: a closing strategy laid it.
//! assert_eq!(after.first_risk(&dome.criteria), None);
//! println!("{:.0} s of dwell, closed by {}", dwells.cooling.total_dwell_s(), dwells.closing.name());
//!
//! // A value outside its documented range is refused before anything runs, named as a
//! // scenario names it.
//! let mut bad = Params::default();
//! bad.process.efficiency = 1.5;
//! let e = build(&part, &planning, bad).unwrap_err();
//! assert_eq!(e.to_string(), "process.efficiency = 1.5; expected in (0, 1]");
//! ```

pub mod arc_stops;
pub mod beads;
pub mod bound;
pub mod calibrate;
pub mod checkpoint;
pub mod confidence;
pub mod cost;
pub mod deposition;
pub mod dwell;
pub mod dwelled;
pub mod pace;
pub mod params;
pub mod program;
pub mod replay;
pub mod resolution;
pub mod risk;
pub mod seat;
pub mod skeleton;
pub mod twin;

/// Small parts the engine's unit tests plan and heat.
#[cfg(test)]
pub(crate) mod test_parts {
    use super::Build;
    use planner::mesh::{LowerLoop, Part};
    use planner::shapes::Shape;

    /// A closed dome of radius `radius_mm` planned with CTPP (40 points a layer) under the
    /// scenario tables `tables` (TOML), on the thin wall.
    pub(crate) fn dome(radius_mm: f64, tables: &str) -> Build {
        let text = format!("[part]\nshape = \"disk\"\nradius_mm = 1.0\n{tables}");
        let s = crate::scenario::Scenario::parse(&text, "test", ".".as_ref()).unwrap();
        let mut planning = s.plan_params();
        planning.n_points = 40;
        let mesh = Shape::Hemisphere { radius_mm }.mesh(2.5);
        let part = Part::from_mesh(mesh, LowerLoop::default()).unwrap();
        Build::new(super::plan(&part, &planning).unwrap(), s.params())
    }
}

pub use params::Params;

use beads::Beads;
use checkpoint::Checkpoints;
use deposition::Cooling;
use dwell::{DwellPlan, Search};
use pace::Pacing;
use params::DwellSettings;
use planner::mesh::Part;
use planner::plan::{Plan, PlanParams};
use risk::{Criteria, Risk, judge};
use std::fmt;
use thermal::schedule::Deposit;
use thermal::{HeatModel, HeatRun, ModelRun, RunResult, ThermalError};

/// What can stop the engine: the part cannot be planned, or the heat model cannot take the
/// build or fails on it.
#[derive(Debug, Clone, PartialEq)]
pub enum Error {
    /// The planner's verdict on the part (branching, too short, …): the user's input, with
    /// its evidence (which generator, which branch) for a caller to act on.
    Plan(planner::plan::PlanError),
    /// The part does not stand on the plate ([`seat::check`]): the user's input.
    Unseated(seat::Unseated),
    /// A parameter outside its documented range ([`params::Params::check`]): the caller's
    /// input, naming the key in the interface's units.
    Invalid(params::Invalid),
    Thermal(ThermalError),
    /// Measurements that cannot serve as asked (no reading in a fit window, no metal laid):
    /// the user's input.
    Measured(String),
    /// A state the engine should have kept and did not: a bug of ours, named.
    Lost(String),
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            // A part too short for the start-up is most often a mesh drawn in inches or
            // centimetres, read as millimetres (2.7 units tall, a 69 mm head in inches).
            Error::Plan(
                e @ planner::plan::PlanError::Spiral(planner::spiral::SpiralError::TooShort {
                    ..
                }),
            ) => write!(
                f,
                "plan: {e}; expected a part taller than that, in mm (a mesh file drawn in other units takes [part] mesh_unit = \"m\", \"cm\" or \"in\")"
            ),
            Error::Plan(e) => write!(f, "plan: {e}"),
            Error::Unseated(e) => e.fmt(f),
            Error::Invalid(e) => write!(f, "{e}"),
            Error::Thermal(e) => write!(f, "thermal: {e}"),
            Error::Measured(e) => f.write_str(e),
            Error::Lost(e) => write!(f, "{e} (a bug)"),
        }
    }
}

impl std::error::Error for Error {}

impl From<ThermalError> for Error {
    fn from(e: ThermalError) -> Self {
        Error::Thermal(e)
    }
}

/// What an engine call tells of its progress (the engine prints nothing): each stage as it
/// starts, and within a heat run the deposits laid of all. The commands draw it on the terminal
/// (`crate::progress::Terminal`); [`Quiet`] hears nothing.
pub trait Report {
    /// A stage starts (the one before it has ended).
    fn stage(&mut self, _what: &str) {}
    /// `done` of `total` deposits laid in the stage's heat run.
    fn laid(&mut self, _done: usize, _total: usize) {}
}

/// Progress nobody hears.
pub struct Quiet;

impl Report for Quiet {}

/// Plan a part with CTPP.
pub fn plan(part: &Part, params: &PlanParams) -> Result<Plan, Error> {
    planner::plan::plan(part, params).map_err(Error::Plan)
}

/// The plan command's work (and the start of simulate's and dwell's): `part` planned with
/// CTPP ([`plan`]) and its build laid out ([`Build::new`]: beads, schedule, criteria).
/// The parameters are checked first ([`Params::check`], [`params::planning`]).
pub fn build(part: &Part, planning: &PlanParams, params: Params) -> Result<Build, Error> {
    params.check().map_err(Error::Invalid)?;
    params::planning(planning).map_err(Error::Invalid)?;
    seat::check(part, planning.deposit_mm).map_err(Error::Unseated)?;
    Ok(Build::new(plan(part, planning)?, params))
}

/// A planned build with its beads and schedule, ready to be heated, judged and given dwells.
#[derive(Debug, Clone)]
pub struct Build {
    pub plan: Plan,
    pub params: Params,
    /// Per path point, the machine settings and the heat they put in.
    pub beads: Beads,
    pub criteria: Criteria,
    /// The schedule without dwells.
    deposits: Vec<Deposit>,
}

/// A simulated build: the schedule it ran and what the heat model made of it.
#[derive(Debug, Clone)]
pub struct Simulation {
    /// The schedule with its dwells.
    pub deposits: Vec<Deposit>,
    /// Per point: the dwell before it (s), its pace, the part of a drop it was laid as.
    pub dwell_s: Vec<f64>,
    pub pace: Vec<f64>,
    pub drop: Vec<Option<thermal::schedule::DropPart>>,
    pub result: RunResult,
    /// "thin-wall" or "voxel".
    pub model: &'static str,
    /// Wall-clock time of the heat model, s.
    pub wall_clock_s: f64,
}

/// The margin a fitted plate leaves around the part's footprint on each side, m: room for the
/// first bead's width and the heat it spreads into the plate (a few bead widths).
pub const PLATE_MARGIN_M: f64 = 0.025;

/// The plate a part needs: the size `least` in x and y grown to the footprint of the deposits
/// laid on the plate plus [`PLATE_MARGIN_M`] on each side (the plate is centred under that
/// footprint, [`deposition::plate_centre`]); the thickness is `least`'s.
pub fn plate_fitted(least: [f64; 3], deposits: &[Deposit]) -> [f64; 3] {
    let [w, d] = footprint_m(deposits);
    [
        least[0].max(w + 2.0 * PLATE_MARGIN_M),
        least[1].max(d + 2.0 * PLATE_MARGIN_M),
        least[2],
    ]
}

/// The extent in x and y of the beads laid on the plate (their centre lines widened by half a
/// bead each side), m.
pub fn footprint_m(deposits: &[Deposit]) -> [f64; 2] {
    let on_plate = deposits.iter().filter(|d| d.support.is_none());
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for d in on_plate {
        for k in 0..2 {
            lo[k] = lo[k].min(d.position[k] - 0.5 * d.width);
            hi[k] = hi[k].max(d.position[k] + 0.5 * d.width);
        }
    }
    std::array::from_fn(|k| (hi[k] - lo[k]).max(0.0))
}

impl Build {
    /// The build of `plan`; where `params` asks for a fitted plate, the plate grown to the part.
    pub fn new(plan: Plan, mut params: Params) -> Build {
        let beads = beads::beads(&params.process, &params.material, &plan.points);
        let deposits = deposition::schedule(&params.process, &plan, &beads, &Cooling::default());
        if params.thermal.plate_fit {
            params.thermal.plate_m = plate_fitted(params.thermal.plate_m, &deposits);
        }
        let criteria = Criteria::new(&params);
        Build {
            plan,
            params,
            beads,
            criteria,
            deposits,
        }
    }

    /// The schedule without dwells.
    pub fn deposits(&self) -> &[Deposit] {
        &self.deposits
    }

    /// The scenario's heat model on `deposits`, keeping the field at `snapshot_times`.
    pub fn heat_model(&self, deposits: &[Deposit], snapshot_times: Vec<f64>) -> HeatModel {
        let p = &self.params;
        deposition::heat_model(
            &p.material,
            &p.thermal,
            deposits,
            snapshot_times,
            Vec::new(),
        )
    }

    /// Heat the build with `dwell_s[i]` before point i, keeping the field at up to `frames`
    /// times (0: none; fewer on long paths, [`frame_times`]).
    pub fn simulate(&self, dwell_s: &[f64], frames: usize) -> Result<Simulation, ThermalError> {
        self.simulate_cooled(&Cooling::dwells(dwell_s), frames, Vec::new())
    }

    /// Heat the build cooled as `cooling` says (dwells, paces, drops), keeping the field at up
    /// to `frames` times and the temperature of the points in `traces` at every step
    /// (`RunResult::traces`). Both keep the hottest laid metal at every step
    /// (`RunResult::hottest`): one run's few bytes a step, where the dwell planner's cloned
    /// checkpoints go without.
    pub fn simulate_cooled(
        &self,
        cooling: &Cooling,
        frames: usize,
        traces: Vec<usize>,
    ) -> Result<Simulation, ThermalError> {
        self.simulate_observed(cooling, frames, traces, &mut |_, _| {})
    }

    /// [`Build::simulate_cooled`], telling `laid` (deposits laid, of how many) after each
    /// deposit: the shell's progress bar; the engine prints nothing.
    pub fn simulate_observed(
        &self,
        cooling: &Cooling,
        frames: usize,
        traces: Vec<usize>,
        laid: &mut dyn FnMut(usize, usize),
    ) -> Result<Simulation, ThermalError> {
        self.simulate_kept(cooling, frames, traces, &mut Checkpoints::off(), "", laid)
    }

    /// [`Build::simulate_observed`] with checkpoints: the run is kept under `stage.run` as it
    /// goes and its result under `stage`; a run that resumes takes the result, or goes on from
    /// the run kept part-way.
    pub fn simulate_kept(
        &self,
        cooling: &Cooling,
        frames: usize,
        traces: Vec<usize>,
        ck: &mut Checkpoints<'_>,
        stage: &str,
        laid: &mut dyn FnMut(usize, usize),
    ) -> Result<Simulation, ThermalError> {
        let deposits = deposition::schedule(&self.params.process, &self.plan, &self.beads, cooling);
        let build_s = deposits.last().map_or(0.0, |d| d.time);
        let times = match frames {
            0 => Vec::new(),
            n => frame_times(build_s, deposits.len(), n),
        };
        let mut model = self.heat_model(&deposits, times);
        model.set_traces(traces);
        model.set_watch_metal(true);
        let n = deposits.len();
        let (result, wall_s) = ck.stage(stage, |ck, progress| {
            let mut run = match ck.load::<ModelRun>(progress) {
                Some(run) => run,
                None => model.start(&deposits)?,
            };
            laid(run.laid(), n);
            thermal::run::replay_observed(&mut run, &deposits, &mut |r| {
                laid(r.laid(), n);
                ck.save_if_due(progress, || r);
            })?;
            Ok::<_, ThermalError>(run.finish())
        })?;
        Ok(Simulation {
            dwell_s: (0..n).map(|i| cooling.dwell(i)).collect(),
            pace: (0..n).map(|i| cooling.pace(i)).collect(),
            drop: (0..n).map(|i| cooling.drop_part(i)).collect(),
            deposits,
            result,
            model: model.name(),
            wall_clock_s: wall_s,
        })
    }

    /// A study case's work: the build's dwells planned (`dwell`) or none, and the build
    /// heated with them.
    pub fn case(&self, dwell: bool) -> Result<(Cooling, Simulation), ThermalError> {
        let cooling = match dwell {
            true => self.plan_dwells()?.cooling,
            false => Cooling::none(self.plan.points.len()),
        };
        let sim = self.simulate_cooled(&cooling, 0, Vec::new())?;
        Ok((cooling, sim))
    }

    /// How each point burns at another pace or as a drop.
    pub fn pacing(&self) -> Pacing<'_> {
        Pacing::new(&self.params.process, &self.plan, &self.beads)
    }

    /// Point i's machine settings as `sim` laid it (at its pace).
    pub fn bead_as_laid(&self, sim: &Simulation, i: usize) -> beads::Bead {
        self.beads.beads[i].paced(sim.pace[i], &self.params.process)
    }

    /// What a cooling search judges by, aims for and may do.
    pub fn search<'a>(&'a self, pacing: &'a Pacing<'a>) -> Search<'a> {
        Search {
            criteria: &self.criteria,
            dwell: &self.params.dwell,
            ambient_k: self.params.thermal.ambient_k,
            pacing,
            policy: dwell::Policy::Search,
            stop: None,
        }
    }

    /// The cooling that keeps every point safe, searched on the scenario's heat model.
    pub fn plan_dwells(&self) -> Result<DwellPlan, ThermalError> {
        self.plan_dwells_weighted(self.params.dwell.count_weight_s)
    }

    /// [`Build::plan_dwells`] with an arc stop weighed as `weight_s` seconds of build time.
    pub fn plan_dwells_weighted(&self, weight_s: f64) -> Result<DwellPlan, ThermalError> {
        self.plan_dwells_kept(weight_s, &mut Checkpoints::off(), "")
    }

    /// The revolution-dwell policy ([`dwell::Policy::RevolutionDwell`]): one dwell before each
    /// revolution, the shortest that keeps it safe, and the closing zone closed as the search
    /// closes it; `uncured` names the revolutions no such dwell keeps safe.
    pub fn revolution_dwells(&self) -> Result<DwellPlan, ThermalError> {
        self.revolution_dwells_unless(&std::sync::atomic::AtomicBool::new(false))
    }

    /// [`Build::revolution_dwells`], ended with [`ThermalError::Stopped`] before the next
    /// revolution once `stop` is set (by work beside it that failed).
    pub fn revolution_dwells_unless(
        &self,
        stop: &std::sync::atomic::AtomicBool,
    ) -> Result<DwellPlan, ThermalError> {
        let (weight, policy) = (
            self.params.dwell.count_weight_s,
            dwell::Policy::RevolutionDwell,
        );
        self.plan_dwells_as(weight, policy, Some(stop), &mut Checkpoints::off(), "")
    }

    /// [`Build::plan_dwells_weighted`], the search kept under `stage` between revolutions
    /// ([`dwell::plan_dwells_kept`]).
    pub fn plan_dwells_kept(
        &self,
        weight_s: f64,
        ck: &mut Checkpoints<'_>,
        stage: &str,
    ) -> Result<DwellPlan, ThermalError> {
        self.plan_dwells_as(weight_s, dwell::Policy::Search, None, ck, stage)
    }

    fn plan_dwells_as(
        &self,
        weight_s: f64,
        policy: dwell::Policy,
        stop: Option<&std::sync::atomic::AtomicBool>,
        ck: &mut Checkpoints<'_>,
        stage: &str,
    ) -> Result<DwellPlan, ThermalError> {
        let model = self.heat_model(&self.deposits, Vec::new());
        let run = model.start(&self.deposits)?;
        let dwell = DwellSettings {
            count_weight_s: weight_s,
            ..self.params.dwell.clone()
        };
        let pacing = self.pacing();
        let search = Search {
            dwell: &dwell,
            policy,
            stop,
            ..self.search(&pacing)
        };
        let (pl, deps, lead) = (&self.plan, &self.deposits, model.lead());
        dwell::plan_dwells_kept(&search, pl, deps, lead, run, ck, stage)
    }

    /// The fewest arc stops any cooling plan of the build can make ([`bound`]), on the
    /// scenario's heat model.
    pub fn arc_stops_lower_bound(&self) -> Result<bound::StopsBound, ThermalError> {
        let model = self.heat_model(&self.deposits, Vec::new());
        let run = model.start(&self.deposits)?;
        let radius = self.params.dwell.closing_zone_mm;
        let zone = risk::closing_zone(&self.plan, radius, |k| run.support(k))
            .iter()
            .position(|&z| z);
        let pacing = self.pacing();
        let search = self.search(&pacing);
        bound::arc_stops_lower_bound(&search, &self.deposits, model.lead(), zone, run)
    }

    /// Per path point, whether it lies in the closing zone of `sim` (within `[dwell]
    /// closing_zone_mm` of the closing point, or from the revolution where the revolutions start
    /// to lie on metal just laid, [`risk::closing_zone`]): the zone the dwell planner's closing
    /// strategy works in.
    pub fn closing_zone(&self, sim: &Simulation) -> Vec<bool> {
        // A drop reads its preheat as it strikes, on metal no longer the arc's; the planner lays
        // drops only where the points lay on metal just laid.
        let support = |i: usize| match sim.drop[i] {
            Some(_) => thermal::Support::JustLaid,
            None => sim.result.support[i],
        };
        risk::closing_zone(&self.plan, self.params.dwell.closing_zone_mm, support)
    }

    /// Per revolution: start, duration, preheat max and mean, dwell.
    pub fn layers(&self, sim: &Simulation) -> Vec<LayerRow> {
        let pl = &self.plan;
        let mut rows: Vec<LayerRow> = Vec::new();
        for (i, q) in pl.points.iter().enumerate() {
            let d = &sim.deposits[i];
            let pre = sim.result.points[i].preheat;
            let dwell = sim.dwell_s[i];
            match rows.last_mut() {
                Some(r) if r.layer == q.layer => {
                    r.duration_s = d.time - r.t_start_s;
                    r.preheat_max_k = r.preheat_max_k.max(pre);
                    r.preheat_mean_k += pre;
                    r.dwell_s += dwell;
                    r.pace_max = r.pace_max.max(sim.pace[i]);
                    r.drops += usize::from(strikes(sim.drop[i]));
                }
                _ => rows.push(LayerRow {
                    layer: q.layer,
                    t_start_s: d.arc_start() - dwell,
                    duration_s: d.time - d.arc_start() + dwell,
                    preheat_max_k: pre,
                    preheat_mean_k: pre,
                    dwell_s: dwell,
                    pace_max: sim.pace[i],
                    drops: usize::from(strikes(sim.drop[i])),
                }),
            }
        }
        for r in &mut rows {
            let n = pl
                .points
                .iter()
                .filter(|q| q.layer == r.layer)
                .count()
                .max(1);
            r.preheat_mean_k /= n as f64;
        }
        rows
    }

    /// Predicted as-built beads: the plan's deposits stacked with the hot-metal law at the
    /// simulated preheat (bead model, `[bead]`).
    pub fn as_built(&self, sim: &Simulation) -> Vec<bead_model::as_built::BuiltBead> {
        let pl = &self.plan;
        let planned: Vec<f64> = pl.points.iter().map(|q| q.deposit_mm * 1e-3).collect();
        let generator: Vec<usize> = pl.points.iter().map(|q| q.generator).collect();
        let preheat: Vec<f64> = sim.result.points.iter().map(|p| p.preheat).collect();
        let b = &self.params.bead;
        bead_model::as_built::stack(
            &planned,
            &generator,
            &preheat,
            self.params.process.bead_width_m,
            b.stickout_m,
            &b.hot_metal,
        )
    }
}

impl Simulation {
    pub fn build_time_s(&self) -> f64 {
        self.deposits.last().map_or(0.0, |d| d.time)
    }

    /// Per point, the first criterion it breaks (every point judged, none exempt).
    pub fn risks(&self, c: &Criteria) -> Vec<Option<Risk>> {
        let r = &self.result;
        (0..r.points.len())
            .map(|i| judge(c, &r.points[i], 0.0))
            .collect()
    }

    /// The first point at risk, and why.
    pub fn first_risk(&self, c: &Criteria) -> Option<(usize, Risk)> {
        let r = &self.result;
        (0..r.points.len()).find_map(|i| judge(c, &r.points[i], 0.0).map(|k| (i, k)))
    }

    /// Per point, whether a dwell can act on its layer-on-layer limits
    /// ([`risk::dwell_can_act`]).
    pub fn dwell_can_act(&self) -> Vec<bool> {
        self.result
            .support
            .iter()
            .map(|&s| risk::dwell_can_act(s))
            .collect()
    }

    /// The hottest preheat of the build, K.
    pub fn max_preheat_k(&self) -> f64 {
        self.result
            .points
            .iter()
            .map(|p| p.preheat)
            .fold(f64::NEG_INFINITY, f64::max)
    }
}

/// Per revolution.
#[derive(Debug, Clone, PartialEq)]
pub struct LayerRow {
    pub layer: usize,
    pub t_start_s: f64,
    pub duration_s: f64,
    pub preheat_max_k: f64,
    pub preheat_mean_k: f64,
    pub dwell_s: f64,
    /// The slowest pace of its points (1: as planned).
    pub pace_max: f64,
    /// Drops struck in it.
    pub drops: usize,
}

fn strikes(d: Option<thermal::schedule::DropPart>) -> bool {
    matches!(d, Some(thermal::schedule::DropPart::Strikes { .. }))
}

/// Most field values kept over a run, frames × path points (16 MB of f32 per sink).
pub const FIELD_BUDGET: usize = 4_000_000;

/// When to keep the field: evenly over the build, at most `frames` times and at most
/// [`FIELD_BUDGET`] values in all, always including the end of the build.
pub fn frame_times(build_s: f64, n_points: usize, frames: usize) -> Vec<f64> {
    let n = frames.min(FIELD_BUDGET / n_points.max(1)).max(1);
    (1..=n).map(|k| build_s * k as f64 / n as f64).collect()
}

#[cfg(test)]
mod tests {
    use planner::plan::PlanError;
    use planner::spiral::SpiralError;

    /// A part too short for the start-up names the units a mesh file may be drawn in; other
    /// verdicts of the planner do not.
    #[test]
    fn a_part_too_short_for_the_start_up_names_the_mesh_units() {
        let short = super::Error::Plan(PlanError::Spiral(SpiralError::TooShort {
            shortest_mm: 5.68,
            start_up_mm: 10.98,
        }));
        let said = short.to_string();
        assert!(
            said.starts_with("plan: the shortest generator (5.68 mm)"),
            "{said}"
        );
        assert!(
            said.ends_with("mesh_unit = \"m\", \"cm\" or \"in\")"),
            "{said}"
        );
        let other = super::Error::Plan(PlanError::Spiral(SpiralError::NoModulation {
            h_min: 2.0,
            h_max: 2.0,
        }));
        assert!(!other.to_string().contains("mesh_unit"));
    }

    #[test]
    fn frames_are_bounded_and_end_at_the_build() {
        let t = super::frame_times(100.0, 10, 50);
        assert_eq!(t.len(), 50);
        assert_eq!(*t.last().unwrap(), 100.0);
        let t = super::frame_times(100.0, 1_000_000, 50);
        assert_eq!(t.len(), 4);
    }
}
