//! The heat-model contract: what every model of the growing part does and gives, so that the
//! risk criteria, the dwell planner, the recording and the studies are written once.
//!
//! A model is started on a schedule ([`HeatModel::start`]) and driven one deposit at a time
//! ([`HeatRun::deposit`], with a dwell before it); it cools for a time on request, is cloned as
//! a checkpoint, and answers per-point results (preheat, peak, pool, time above the threshold,
//! what a point lies on) while it runs and in full when it finishes ([`RunResult`]: field
//! snapshots and the energy ledger too). The thin wall ([`crate::wall`]) and the voxel model
//! ([`crate::voxel`]) both implement it; [`ModelRun`] is either, chosen at run time.

use crate::error::ThermalError;
use crate::network::Ledger;
use crate::schedule::{Deposit, DropPart, strike_readings};
use crate::voxel::{VoxelModel, VoxelRun, VoxelSettings};
use crate::wall::{WallModel, WallRun, WallSettings};
use std::sync::atomic::{AtomicBool, Ordering};

/// Set by [`request_stop`]: every [`ModelRun`] in the process then ends at its next deposit or
/// cooling with [`ThermalError::Stopped`]. The command line stops on Ctrl-C by dying; a caller
/// that cannot kill the thread it runs on (Python's Ctrl-C, which arrives as a flag the
/// interpreter polls) asks through this instead.
static STOP: AtomicBool = AtomicBool::new(false);

/// Ask every heat run in this process to stop at its next step ([`ThermalError::Stopped`]).
pub fn request_stop() {
    STOP.store(true, Ordering::SeqCst);
}

/// Let heat runs go on again (before a new run, once a stopped one has returned).
pub fn clear_stop() {
    STOP.store(false, Ordering::SeqCst);
}

/// [`ThermalError::Stopped`] at `time_s` if a stop was asked for.
fn unless_stopped(time_s: f64) -> Result<(), ThermalError> {
    match STOP.load(Ordering::Relaxed) {
        true => Err(ThermalError::Stopped { time_s }),
        false => Ok(()),
    }
}

/// The substrate plate: a box under the part, its top face at z = 0.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Plate {
    /// Size x, y and thickness, m.
    pub size: [f64; 3],
    /// Centre of the plate's top face in x and y, m.
    pub centre: [f64; 2],
    /// Thin wall: the plate's cell size, m.
    pub cell: f64,
    /// Thin wall: cell layers through the thickness (the wall heats the plate's top skin first).
    pub layers: usize,
    /// A disc of diameter `size[0]` about `centre` (`size[1]` the same), not a box. The voxel
    /// model takes it; the thin wall, whose plate is a grid of cells, refuses it.
    pub disc: bool,
    /// The plate's own material where it is not the deposit's (an IN718 wall on a carbon-steel
    /// plate). The voxel model takes it; the thin wall, one material throughout, refuses it.
    pub material: Option<crate::material::Material>,
}

#[cfg(test)]
impl Plate {
    /// A square test plate of the deposit's material, `mm` a side and 10 mm thick, centred on
    /// the origin, of 5 mm cells three layers deep (the thin wall's).
    pub(crate) fn square_mm(mm: f64) -> Plate {
        Plate {
            size: [mm * 1e-3, mm * 1e-3, 0.01],
            centre: [0.0, 0.0],
            cell: 5e-3,
            layers: 3,
            disc: false,
            material: None,
        }
    }
}

/// What a deposit is laid on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Support {
    /// The substrate plate (the first revolution).
    Plate,
    /// An earlier revolution.
    Deposit,
    /// A deposit laid at or after the moment this one's preheat is read (`lead` upstream), or
    /// inside the torch's footprint at that moment: near a closing point, where a revolution is
    /// not much longer than the lead, the reading is the arc's own heat, and no dwell can come
    /// between the two.
    JustLaid,
}

/// Per deposit.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct PointResult {
    /// Temperature of the metal this deposit is laid on, read when the torch is `lead` upstream.
    pub preheat: f64,
    /// Highest temperature its metal reached, K.
    pub peak: f64,
    /// Length of molten bead behind the torch when it was laid, m.
    pub pool_length: f64,
    /// Radius of the half sphere of the molten volume, m.
    pub pool_radius: f64,
    /// Time its metal spent above the threshold, s.
    pub time_above: f64,
}

/// The field at one time: one temperature per deposit (K), its metal's once laid.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Snapshot {
    pub time: f64,
    pub temperature: Vec<f64>,
}

/// One deposit's metal temperature at every step of the run from when it was laid (the
/// settings' `traces`).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Trace {
    pub deposit: usize,
    /// s.
    pub time: Vec<f64>,
    /// K.
    pub temperature: Vec<f64>,
}

impl Trace {
    pub fn new(deposit: usize) -> Trace {
        Trace {
            deposit,
            time: Vec::new(),
            temperature: Vec::new(),
        }
    }
}

/// The hottest laid metal at every step (the settings' `watch_metal`): what the arc does to the
/// part between snapshots, every pass's peak included.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Hottest {
    /// s.
    pub time: Vec<f64>,
    /// K.
    pub temperature: Vec<f64>,
}

impl Hottest {
    /// Keep `t` at `now` when the run traces the hottest metal and some metal is laid.
    pub(crate) fn push(&mut self, on: bool, now: f64, t: f64) {
        if on && t.is_finite() {
            self.time.push(now);
            self.temperature.push(t);
        }
    }
}

/// A point whose temperature the run keeps (a thermocouple, a spot an IR camera reads): the
/// temperature of the model's cell nearest to it, within one cell, once there is one; NaN
/// before (metal not yet laid there).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ProbeTrace {
    /// m.
    pub position: [f64; 3],
    /// s.
    pub time: Vec<f64>,
    /// K.
    pub temperature: Vec<f64>,
}

impl ProbeTrace {
    pub fn new(position: [f64; 3]) -> ProbeTrace {
        ProbeTrace {
            position,
            time: Vec::new(),
            temperature: Vec::new(),
        }
    }
}

/// How a model discretised the part, and what it cost.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Cells {
    ThinWall {
        wall_nodes: usize,
        plate_cells: usize,
        /// Conjugate-gradient iterations over the run.
        cg_iterations: usize,
        /// Node steps over the run (a node stepped once counts one): the work, whatever the
        /// rates ([`crate::rates`]).
        #[serde(default)]
        node_steps: u64,
    },
    Voxel {
        voxels: usize,
        /// Voxel updates performed (steps × active voxels).
        updates: u64,
        /// The cells the deposits switched on, in m³: the metal the grid laid, to hold against
        /// the beads' ([`crate::schedule::bead_volume`]).
        #[serde(default)]
        metal_m3: f64,
    },
}

/// A finished run.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct RunResult {
    pub points: Vec<PointResult>,
    /// What each deposit is laid on.
    pub support: Vec<Support>,
    /// The field at the settings' snapshot times.
    pub snapshots: Vec<Snapshot>,
    /// The settings' traced deposits, step by step.
    pub traces: Vec<Trace>,
    /// The hottest laid metal, step by step (empty unless the settings ask for it).
    pub hottest: Hottest,
    /// The settings' probes, sampled as often as they ask (voxel model only).
    pub probes: Vec<ProbeTrace>,
    pub ledger: Ledger,
    /// Energy held by the part at the end above ambient, J.
    pub stored: f64,
    /// (in − stored − lost)/in.
    pub balance_error: f64,
    /// Deposits whose heat did not cover melting their own metal (source clamped at zero).
    pub underpowered: usize,
    pub steps: usize,
    pub cells: Cells,
}

/// How a deposit's arc burns when it is laid otherwise than its schedule says: the same metal,
/// in the same place, over another arc time with another heat (a slowed-down revolution: wire
/// feed and travel speed scaled together, the power the slower wire feed gives), or as a drop.
/// SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Burn {
    /// s.
    pub arc_time: f64,
    /// Heat entering the part over the arc, J.
    pub heat: f64,
    /// Laid as part of a drop ([`DropPart`]): its preheat is the metal beneath it as the drop
    /// struck, and a dwell before the strike acts on it ([`Support::Deposit`] unless it lies
    /// on the plate or, on the thin wall, its own node).
    pub drop: Option<DropPart>,
}

impl Burn {
    /// As deposit `d` of the schedule burns.
    pub fn of(d: &Deposit) -> Burn {
        Burn {
            arc_time: d.arc_time,
            heat: d.heat,
            drop: d.drop,
        }
    }

    /// `burn`, or deposit `d`'s own (`None`), checked for deposit i.
    pub fn or_scheduled(burn: Option<Burn>, d: &Deposit, i: usize) -> Result<Burn, ThermalError> {
        let burn = burn.unwrap_or_else(|| Burn::of(d));
        burn.check(i)?;
        Ok(burn)
    }

    /// Checks it for deposit i: a finite arc time and heat, neither negative.
    pub fn check(&self, i: usize) -> Result<(), ThermalError> {
        let fine = |x: f64| x.is_finite() && x >= 0.0;
        if fine(self.arc_time) && fine(self.heat) {
            Ok(())
        } else {
            Err(ThermalError::Schedule {
                deposit: i,
                reason: format!(
                    "burns {} s with {} J; expected finite numbers, neither negative",
                    self.arc_time, self.heat
                ),
            })
        }
    }
}

/// The drops a run has laid, and the readings of the one struck last.
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub(crate) struct Drops {
    /// Deposits laid as part of a drop, in order.
    laid: Vec<usize>,
    readings: Vec<(usize, f64)>,
}

impl Drops {
    /// Before deposit i is laid with `drop` on `deps`: a strike reads the drop's preheats now.
    pub(crate) fn before(
        &mut self,
        deps: &[Deposit],
        i: usize,
        drop: Option<DropPart>,
        beneath: impl Fn(usize) -> f64,
    ) {
        match drop {
            Some(DropPart::Strikes { deposits }) => {
                self.readings = strike_readings(deps, i, deposits, beneath);
            }
            // A drop that goes on without a strike read (a schedule that starts inside one)
            // reads its own metal beneath now.
            Some(DropPart::Continues) if !self.readings.iter().any(|r| r.0 == i) => {
                self.readings = vec![(i, beneath(i))];
            }
            _ => {}
        }
    }

    /// After deposit i is laid with `drop`: its preheat if it is part of a drop.
    pub(crate) fn after(&mut self, i: usize, drop: Option<DropPart>) -> Option<f64> {
        drop?;
        self.laid.push(i);
        self.readings.iter().find(|r| r.0 == i).map(|r| r.1)
    }

    pub(crate) fn contains(&self, i: usize) -> bool {
        self.laid.binary_search(&i).is_ok()
    }
}

/// A heat model running through a schedule. Cloning it is a checkpoint: the dwell planner
/// restarts from one with a trial dwell instead of simulating the build again.
pub trait HeatRun: Clone {
    /// Cool `dwell` seconds, then lay deposit i of the run's schedule (the next one): its metal
    /// arrives at the deposit temperature and the rest of its heat goes in over its arc time.
    fn deposit(&mut self, i: usize, dwell: f64) -> Result<(), ThermalError> {
        self.deposit_burning(i, dwell, None)
    }
    /// [`HeatRun::deposit`] with its arc burning as `burn` says instead of as the schedule does
    /// (`None`: as scheduled). The run's clock moves by the burn's arc time.
    fn deposit_burning(
        &mut self,
        i: usize,
        dwell: f64,
        burn: Option<Burn>,
    ) -> Result<(), ThermalError>;
    /// Let the part cool with the arc off for `duration` seconds.
    fn cool(&mut self, duration: f64) -> Result<(), ThermalError>;
    /// Bring all the metal laid so far, and the plate, to ambient at once, the clock unmoved: the
    /// coolest state any history of the part can leave before its next deposit (the heat taken out
    /// is booked in the ledger's `quenched`). A bound's device, not a process step
    /// (`sim::pipeline::bound`).
    fn quench(&mut self);
    /// Lose heat from now on with these coefficients (convection W/(m² K), emissivity, contact
    /// to the table W/(m² K)); the ambient stays. What a twin does when it has learned them.
    fn set_losses(&mut self, convection_w_m2k: f64, emissivity: f64, table_w_m2k: f64);
    /// Per deposit, the results so far: the preheat once it was read and the pool once the
    /// deposit is laid, which is what a judge needs while the run goes on. The peak and the time
    /// above the threshold are final in [`HeatRun::finish`].
    fn points(&self) -> &[PointResult];
    /// What deposit i is laid on.
    fn support(&self, i: usize) -> Support;
    /// Deposits laid so far.
    fn laid(&self) -> usize;
    /// Build time now, s.
    fn now(&self) -> f64;
    /// Temperature now of the metal deposit i is laid on, K.
    fn temperature_beneath(&self, i: usize) -> f64;
    /// Temperature now of deposit i's own metal, K.
    fn temperature_of(&self, i: usize) -> f64;
    /// How the model steps through a cooling: a caller that cools in pieces and wants the
    /// state one call gives needs it (the dwell planner's cache).
    fn cooling_steps(&self) -> CoolingSteps;
    fn finish(self) -> RunResult;
}

/// How a model steps through a cooling: the steps of one `cool(d)` call.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CoolingSteps {
    /// Doubling from 1 s up to `max` s, then what is left (implicit models).
    Doubling { max: f64 },
    /// Equal steps of at most `step` s (explicit models at their stability limit).
    Fixed { step: f64 },
}

/// Which model, with its settings: the one choice a caller makes.
#[derive(Debug, Clone, PartialEq)]
pub enum HeatModel {
    ThinWall(WallSettings),
    Voxel(VoxelSettings),
}

/// A run of either model.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub enum ModelRun {
    ThinWall(Box<WallRun>),
    Voxel(Box<VoxelRun>),
}

impl HeatModel {
    /// Build the model for `deps` and start a run at the first arc.
    pub fn start(&self, deps: &[Deposit]) -> Result<ModelRun, ThermalError> {
        Ok(match self {
            HeatModel::ThinWall(s) => {
                ModelRun::ThinWall(Box::new(WallRun::new(WallModel::build(deps, s)?, deps, s)))
            }
            HeatModel::Voxel(s) => {
                ModelRun::Voxel(Box::new(VoxelRun::new(VoxelModel::new(deps, s)?, deps)?))
            }
        })
    }

    /// Run the schedule as its times say (dwells are the gaps between arcs).
    pub fn simulate(&self, deps: &[Deposit]) -> Result<RunResult, ThermalError> {
        self.simulate_observed(deps, &mut |_| {})
    }

    /// [`HeatModel::simulate`], showing `after` the run after each deposit (a caller's
    /// progress bar, its checkpoints).
    pub fn simulate_observed(
        &self,
        deps: &[Deposit],
        after: &mut dyn FnMut(&ModelRun),
    ) -> Result<RunResult, ThermalError> {
        let mut run = self.start(deps)?;
        replay_observed(&mut run, deps, after)?;
        Ok(run.finish())
    }

    pub fn name(&self) -> &'static str {
        match self {
            HeatModel::ThinWall(_) => "thin-wall",
            HeatModel::Voxel(_) => "voxel",
        }
    }

    /// Where preheat is read, m upstream of the point.
    pub fn lead(&self) -> f64 {
        match self {
            HeatModel::ThinWall(s) => s.lead,
            HeatModel::Voxel(s) => s.lead,
        }
    }

    /// The times at which the field is kept, s.
    pub fn set_snapshot_times(&mut self, times: Vec<f64>) {
        match self {
            HeatModel::ThinWall(s) => s.snapshot_times = times,
            HeatModel::Voxel(s) => s.snapshot_times = times,
        }
    }

    /// The deposits whose temperature is kept at every step.
    pub fn set_traces(&mut self, deposits: Vec<usize>) {
        match self {
            HeatModel::ThinWall(s) => s.traces = deposits,
            HeatModel::Voxel(s) => s.traces = deposits,
        }
    }

    /// Points whose temperature the run keeps, at most every `every` seconds
    /// ([`RunResult::probes`]): the voxel model reads the nearest voxel, the thin wall the
    /// nearest bead node or plate cell.
    pub fn set_probes(&mut self, points: Vec<[f64; 3]>, every: f64) {
        match self {
            HeatModel::ThinWall(s) => (s.probes, s.probe_every) = (points, every),
            HeatModel::Voxel(s) => (s.probes, s.probe_every) = (points, every),
        }
    }

    /// How the voxel model puts a deposit's heat in (the thin wall spreads it over its
    /// footprint whatever this says).
    pub fn set_source(&mut self, source: crate::voxel::HeatSource) {
        if let HeatModel::Voxel(s) = self {
            s.source = source;
        }
    }

    /// The plate's own material (None: the deposit's). The thin wall refuses one at start.
    pub fn set_plate_material(&mut self, material: Option<crate::material::Material>) {
        match self {
            HeatModel::ThinWall(s) => s.plate.material = material,
            HeatModel::Voxel(s) => s.plate.material = material,
        }
    }

    /// Whether the run watches its laid metal at every step: each deposit's peak and time above
    /// the hot threshold, and the hottest of it ([`RunResult::hottest`]); NaN peaks where not.
    pub fn set_watch_metal(&mut self, on: bool) {
        match self {
            HeatModel::ThinWall(s) => s.watch_metal = on,
            HeatModel::Voxel(s) => s.watch_metal = on,
        }
    }
}

/// Lay every deposit of `deps` (the run's schedule) not yet laid on `run`, each after the gap
/// the schedule leaves before its arc: a fresh run from the first, a run kept part-way from
/// where it stopped.
pub fn replay<R: HeatRun>(run: &mut R, deps: &[Deposit]) -> Result<(), ThermalError> {
    replay_observed(run, deps, &mut |_| {})
}

/// [`replay`], showing `after` the run after each deposit.
pub fn replay_observed<R: HeatRun>(
    run: &mut R,
    deps: &[Deposit],
    after: &mut dyn FnMut(&R),
) -> Result<(), ThermalError> {
    let from = run.laid();
    let mut previous_end = match from {
        0 => deps.first().map_or(0.0, |d| d.arc_start()),
        k => deps[k - 1].time,
    };
    for (i, d) in deps.iter().enumerate().skip(from) {
        run.deposit(i, (d.arc_start() - previous_end).max(0.0))?;
        previous_end = d.time;
        after(run);
    }
    Ok(())
}

macro_rules! either {
    ($self:expr, $r:ident => $e:expr) => {
        match $self {
            ModelRun::ThinWall($r) => $e,
            ModelRun::Voxel($r) => $e,
        }
    };
}

/// Run `work` on every run (with its index), the results in the runs' order. Where they are
/// voxel runs on a GPU they step there as one batch ([`crate::voxel::share_device`]), each on
/// a thread of its own; they must then make the same calls: runs of one program on one grid
/// that differ in their state, their arc's heat and their losses (an ensemble's members).
/// Else they run on rayon's threads. Of several errors, the one met first: a member's own,
/// not the batch's failure that it caused in the others.
pub fn together<T: Send, E: Send>(
    mut runs: Vec<&mut ModelRun>,
    work: impl Fn(usize, &mut ModelRun) -> Result<T, E> + Sync,
) -> Result<Vec<T>, E> {
    use rayon::prelude::*;
    let n = runs.len();
    let mut models: Vec<&mut VoxelModel> = runs
        .iter_mut()
        .filter_map(|r| match r {
            ModelRun::Voxel(v) => Some(v.model_mut()),
            ModelRun::ThinWall(_) => None,
        })
        .collect();
    let seats = match models.len() == n {
        true => crate::voxel::share_device(&mut models),
        false => None,
    };
    drop(models);
    let Some(seats) = seats else {
        return runs
            .into_par_iter()
            .enumerate()
            .map(|(k, r)| work(k, r))
            .collect();
    };
    let order = std::sync::atomic::AtomicUsize::new(0);
    let outcomes: Vec<Result<T, (usize, E)>> = std::thread::scope(|s| {
        let handles: Vec<_> = runs
            .into_iter()
            .zip(seats)
            .enumerate()
            .map(|(k, (run, seat))| {
                let (work, order) = (&work, &order);
                s.spawn(move || {
                    // Held to the end: the seat goes after the error is counted, so the
                    // others' failures that its going causes are counted after it.
                    let _seat = seat;
                    work(k, run).map_err(|e| (order.fetch_add(1, Ordering::SeqCst), e))
                })
            })
            .collect();
        handles
            .into_iter()
            .map(|h| h.join().unwrap_or_else(|p| std::panic::resume_unwind(p)))
            .collect()
    });
    let mut first: Option<(usize, E)> = None;
    let mut out = Vec::with_capacity(outcomes.len());
    for o in outcomes {
        match o {
            Ok(t) => out.push(t),
            Err((at, e)) if first.as_ref().is_none_or(|f| at < f.0) => first = Some((at, e)),
            Err(_) => {}
        }
    }
    match first {
        Some((_, e)) => Err(e),
        None => Ok(out),
    }
}

impl HeatRun for ModelRun {
    fn deposit_burning(
        &mut self,
        i: usize,
        dwell: f64,
        burn: Option<Burn>,
    ) -> Result<(), ThermalError> {
        unless_stopped(self.now())?;
        either!(self, r => r.deposit_burning(i, dwell, burn))
    }
    fn cool(&mut self, duration: f64) -> Result<(), ThermalError> {
        unless_stopped(self.now())?;
        either!(self, r => r.cool(duration))
    }
    fn quench(&mut self) {
        either!(self, r => r.quench())
    }
    fn set_losses(&mut self, convection_w_m2k: f64, emissivity: f64, table_w_m2k: f64) {
        either!(self, r => r.set_losses(convection_w_m2k, emissivity, table_w_m2k))
    }
    fn points(&self) -> &[PointResult] {
        either!(self, r => r.points())
    }
    fn support(&self, i: usize) -> Support {
        either!(self, r => r.support(i))
    }
    fn laid(&self) -> usize {
        either!(self, r => r.laid())
    }
    fn now(&self) -> f64 {
        either!(self, r => r.now())
    }
    fn temperature_beneath(&self, i: usize) -> f64 {
        either!(self, r => r.temperature_beneath(i))
    }
    fn temperature_of(&self, i: usize) -> f64 {
        either!(self, r => r.temperature_of(i))
    }
    fn cooling_steps(&self) -> CoolingSteps {
        either!(self, r => r.cooling_steps())
    }
    fn finish(self) -> RunResult {
        either!(self, r => r.finish())
    }
}
