//! A voxel run in progress, one deposit at a time: the [`HeatRun`] contract over the model.

use super::metal::path_lengths;
use super::source::Goldak;
use super::{Read, VoxelModel, Watch};
use crate::error::ThermalError;
use crate::run::{
    Burn, Cells, CoolingSteps, Drops, HeatRun, Hottest, PointResult, ProbeTrace, RunResult,
    Snapshot, Support, Trace,
};
use crate::schedule::{Deposit, just_laid, read_fractions, segment_start};
use std::sync::Arc;

/// A voxel run in progress, one deposit at a time (the [`HeatRun`] contract). Cloning it is a
/// checkpoint: the active set is copied whole.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub struct VoxelRun {
    model: VoxelModel,
    deps: Arc<Vec<Deposit>>,
    /// The stable explicit step, s.
    dt_max: f64,
    /// Per deposit, the preheats read during its arc: (point, fraction of the arc), as the
    /// thin wall reads them (dwell-independent: the torch is `lead` upstream along the path).
    probes_at: Arc<Vec<Vec<(usize, f64)>>>,
    /// Per deposit, whether it lies on metal just laid when its preheat is read
    /// ([`crate::schedule::just_laid`], within the source's rear length).
    just_laid: Arc<Vec<bool>>,
    /// Per deposit, its distance along the path from the first, m ([`path_lengths`]).
    along: Arc<Vec<f64>>,
    points: Vec<PointResult>,
    snapshots: Vec<Snapshot>,
    traces: Vec<Trace>,
    hottest: Hottest,
    probes: Vec<ProbeTrace>,
    /// Per probe, its voxel once one lies within a cell of it.
    probe_voxels: Vec<Option<u32>>,
    underpowered: usize,
    /// Heat the new metal has taken beyond what its deposits' arcs gave and the arcs since
    /// have not yet made up, J: taken from the next arcs, so that the run takes in its arcs'
    /// heat (η·P·t), not more.
    pub(super) deficit: f64,
    drops: Drops,
    now: f64,
    laid: usize,
    /// The next preheat to read in the current deposit's list.
    next_probe: usize,
    source: Vec<(u32, f32)>,
}

impl VoxelRun {
    /// The model as it stands: its field, read and corrected by a data assimilation.
    pub fn model(&self) -> &VoxelModel {
        &self.model
    }

    pub fn model_mut(&mut self) -> &mut VoxelModel {
        &mut self.model
    }

    /// Start a run; fails when the material leaves no stable step (no heat capacity, say).
    pub fn new(model: VoxelModel, deps: &[Deposit]) -> Result<VoxelRun, ThermalError> {
        let now = deps.first().map_or(0.0, |d| d.arc_start());
        let dt_max = model.stable_step();
        if !(dt_max.is_finite() && dt_max > 0.0) {
            return Err(ThermalError::NonFinite {
                time_s: now,
                position_mm: deps
                    .first()
                    .map_or([0.0; 3], |d| d.position.map(|x| x * 1e3)),
                what: "stable time step (s)",
                value: dt_max,
            });
        }
        // Not watched: the peaks and times above are not read, and say so. (A GPU reads them
        // on the device alongside its step, at no cost to the host.)
        let start = match model.watches() {
            true => PointResult {
                peak: model.settings.surroundings.ambient_k,
                ..PointResult::default()
            },
            false => PointResult {
                peak: f64::NAN,
                time_above: f64::NAN,
                ..PointResult::default()
            },
        };
        let mut points = vec![start; deps.len()];
        let mut probes_at = vec![Vec::new(); deps.len()];
        let reads = read_fractions(deps, model.settings.lead);
        for (k, &r) in reads.iter().enumerate() {
            match r {
                // Pushed in path order, which is arc order: the torch passes k's reading
                // point before k + 1's.
                Some((j, f)) => probes_at[j].push((k, f)),
                // Read before the path starts: the plate as it is.
                None => points[k].preheat = model.temperature_under(deps, k),
            }
        }
        Ok(VoxelRun {
            dt_max,
            now,
            deps: Arc::new(deps.to_vec()),
            probes_at: Arc::new(probes_at),
            just_laid: Arc::new(just_laid(deps, &reads, |i| Goldak::rear(deps[i].width))),
            along: Arc::new(path_lengths(deps)),
            points,
            snapshots: Vec::new(),
            traces: model
                .settings
                .traces
                .iter()
                .map(|&d| Trace::new(d))
                .collect(),
            hottest: Hottest::default(),
            probes: model
                .settings
                .probes
                .iter()
                .map(|&p| ProbeTrace::new(p))
                .collect(),
            probe_voxels: vec![None; model.settings.probes.len()],
            underpowered: 0,
            deficit: 0.0,
            drops: Drops::default(),
            laid: 0,
            next_probe: 0,
            source: Vec::new(),
            model,
        })
    }

    /// Voxels switched on so far.
    pub fn voxels(&self) -> usize {
        self.model.active()
    }

    /// One step of `dt` with the current source, and what the results track.
    pub(super) fn advance(&mut self, dt: f64, source_on: bool) {
        #[cfg(feature = "gpu")]
        if self.model.settings.device == super::Device::Gpu {
            return self.advance_on_gpu(dt, source_on);
        }
        let source: &[(u32, f32)] = if source_on { &self.source } else { &[] };
        let laid = self.laid + usize::from(source_on);
        let points = &mut self.points;
        let watch = self.model.watches().then_some(Watch { laid, points });
        let hottest = self.model.step_watched(dt, source, watch);
        self.now += dt;
        let on = self.model.settings.watch_metal;
        self.hottest.push(on, self.now, hottest);
        self.record(laid);
    }

    /// The laid metal's peaks and times above after a step of dt, and the hottest of it.
    #[cfg(feature = "gpu")]
    pub(super) fn observe(&mut self, laid: usize, dt: f64) {
        let hottest = self.model.observe(laid, dt, &mut self.points);
        let on = self.model.settings.watch_metal;
        self.hottest.push(on, self.now, hottest);
    }

    /// What the run keeps of the field after a step: probes falling due, snapshots reached,
    /// traces of deposits 0..laid.
    pub(super) fn record(&mut self, laid: usize) {
        self.sample_probes(self.model.settings.probe_every);
        self.model.keep(laid, self.now, &mut self.snapshots);
        for tr in &mut self.traces {
            if tr.deposit < laid {
                tr.time.push(self.now);
                tr.temperature.push(self.model.metal_t(tr.deposit));
            }
        }
    }

    /// `advance` on the device: the step and the deposits' peaks there; the field read back
    /// where the host must read it this step (a trace, a snapshot, a probe falling due).
    #[cfg(feature = "gpu")]
    pub(super) fn advance_on_gpu(&mut self, dt: f64, source_on: bool) {
        let laid = self.laid + usize::from(source_on);
        let source: &[(u32, f32)] = if source_on { &self.source } else { &[] };
        // A trace reads the field every step: then the host observes the metal too, as on the
        // CPU, so that peaks and traces come from one mean (the device's is f32).
        let host_observes = !self.traces.is_empty();
        let observed = if host_observes { 0 } else { laid };
        self.model.gpu_step(dt, source, observed, self.now + dt);
        self.now += dt;
        let times = &self.model.settings.snapshot_times;
        let snapshot = times
            .get(self.snapshots.len())
            .is_some_and(|&t| t <= self.now + 1e-9);
        let every = self.model.settings.probe_every;
        let probe = self.probes.iter().any(|tr| {
            tr.time
                .last()
                .is_none_or(|&t| self.now - t >= every - 1e-12)
        });
        if !(snapshot || probe || !self.traces.is_empty()) {
            if self.model.gpu_full() {
                self.read_device(Read::Sums);
            }
            return;
        }
        self.read_device(Read::Temperatures);
        if host_observes {
            self.observe(laid, dt);
        }
        self.record(laid);
    }

    /// On a GPU, read the device back: the losses and the hottest metal, and with `what`
    /// the temperatures (`Temperatures`, mid-call) or the whole field (`All`, the host's copy
    /// current, as every call ends).
    pub(super) fn read_device(&mut self, what: Read) {
        #[cfg(feature = "gpu")]
        if self.model.settings.device == super::Device::Gpu {
            let on = self.model.settings.watch_metal;
            let (points, hottest) = (&mut self.points, &mut self.hottest);
            self.model.gpu_read(points, hottest, on, what);
        }
        let _ = what;
    }

    /// On a GPU, the device's copy made where it has none or has outgrown it (the host's copy
    /// is current whenever this is called).
    pub(super) fn device_ready(&mut self) -> Result<(), ThermalError> {
        #[cfg(feature = "gpu")]
        if self.model.settings.device == super::Device::Gpu {
            return self.model.gpu_ready(&self.points);
        }
        Ok(())
    }

    /// Keep each probe's temperature, at most every `every` seconds (the settings'
    /// `probe_every` as the run goes; 0 at its end, so that a trace holds the run's last
    /// moment: a reading there is compared, not left past the trace).
    pub(super) fn sample_probes(&mut self, every: f64) {
        for (k, trace) in self.probes.iter_mut().enumerate() {
            if trace
                .time
                .last()
                .is_some_and(|&t| self.now - t < (every - 1e-12).max(1e-9))
            {
                continue;
            }
            if self.probe_voxels[k].is_none() {
                self.probe_voxels[k] = self.model.voxel_near(trace.position);
            }
            trace.time.push(self.now);
            trace
                .temperature
                .push(self.probe_voxels[k].map_or(f64::NAN, |v| self.model.temperature(v)));
        }
    }

    /// Whether a preheat of deposit i's arc falls due once `elapsed` of it has passed.
    pub(super) fn reads_due(&self, i: usize, arc: f64, elapsed: f64) -> bool {
        self.probes_at[i]
            .get(self.next_probe)
            .is_some_and(|&(_, f)| f * arc <= elapsed + 1e-9)
    }

    /// The preheats read during deposit i's arc of `arc` seconds once `elapsed` of it has passed
    /// (those not read yet: `next_probe` counts them in `probes_at[i]`, which is in arc order).
    pub(super) fn read(&mut self, i: usize, arc: f64, elapsed: f64) {
        let probes = &self.probes_at[i];
        while let Some(&(k, f)) = probes.get(self.next_probe)
            && f * arc <= elapsed + 1e-9
        {
            self.points[k].preheat = self.model.temperature_under(&self.deps, k);
            self.next_probe += 1;
        }
    }

    /// A numerical failure shows as a non-finite temperature or loss: checked on the metal of
    /// `deposit` and in the ledger, and on every voxel when either is off or after a cooling.
    pub(super) fn check(&self, deposit: Option<usize>) -> Result<(), ThermalError> {
        let m = &self.model;
        #[cfg(feature = "gpu")]
        if let Some(reason) = m.gpu_failure() {
            return Err(ThermalError::DeviceLost {
                time_s: self.now,
                reason: reason.to_string(),
            });
        }
        let fine = |i: usize| m.mean_t(&m.laid[i]).is_finite() && m.ledger.lost().is_finite();
        if deposit.is_some_and(fine) {
            return Ok(());
        }
        if let Some(v) = m.t.iter().position(|t| !t.is_finite()) {
            return Err(ThermalError::NonFinite {
                time_s: self.now,
                position_mm: m.centre_of(v as u32).map(|x| x * 1e3),
                what: "temperature (K)",
                value: m.t[v] as f64,
            });
        }
        if !m.ledger.lost().is_finite() {
            let at = deposit.map_or([f64::NAN; 3], |i| self.deps[i].position);
            return Err(ThermalError::NonFinite {
                time_s: self.now,
                position_mm: at.map(|x| x * 1e3),
                what: "heat lost (J)",
                value: m.ledger.lost(),
            });
        }
        Ok(())
    }
}

impl HeatRun for VoxelRun {
    fn deposit_burning(
        &mut self,
        i: usize,
        dwell: f64,
        burn: Option<Burn>,
    ) -> Result<(), ThermalError> {
        let burn = Burn::or_scheduled(burn, &self.deps[i], i)?;
        self.cool(dwell)?;
        let (model, deps) = (&self.model, &self.deps);
        self.drops
            .before(deps, i, burn.drop, |k| model.temperature_under(deps, k));
        self.next_probe = 0;
        self.read(i, burn.arc_time, 0.0);
        // A point read during its own deposit (its segment longer than the lead) is read
        // before the deposit's metal, laid whole, covers its substrate: the torch, still
        // upstream, has not laid it there (the thin wall's rule; docs/PHYSICS.md "The preheat
        // of a long deposit"). It is the first read during the deposit, if any.
        if let Some(&(k, _)) = self.probes_at[i].get(self.next_probe)
            && k == i
        {
            self.points[k].preheat = self.model.temperature_under(&self.deps, k);
            self.next_probe += 1;
        }
        let before = self.model.ledger.deposited;
        self.model.lay(&self.deps, i);
        // The arc's heat less what the new metal took, and less what earlier metal took beyond
        // its own arcs: a deposit whose cells hold more than its bead (the grid lays a cell
        // whole where a bead covers part of it) takes the rest from the arcs after it. Clamped
        // at zero alone, the R 50 voxel dome at 2 mm (431 such deposits) took 1.9 % more heat
        // than its arcs gave.
        let rest = burn.heat - (self.model.ledger.deposited - before);
        self.underpowered += usize::from(rest < 0.0);
        let rest = rest - self.deficit;
        self.deficit = (-rest).max(0.0);
        let mut source = std::mem::take(&mut self.source);
        let heat = Burn {
            heat: rest.max(0.0),
            ..burn
        };
        self.model.source(&self.deps, i, heat, &mut source);
        self.source = source;
        self.device_ready()?;
        let (mut left, mut elapsed) = (burn.arc_time, 0.0);
        while left > 1e-12 {
            let dt = self.dt_max.min(left);
            self.advance(dt, true);
            left -= dt;
            elapsed += dt;
            if self.reads_due(i, burn.arc_time, elapsed) {
                self.read_device(Read::Temperatures);
                self.read(i, burn.arc_time, elapsed);
            }
        }
        self.read_device(Read::All);
        if let Some(t) = self.drops.after(i, burn.drop) {
            self.points[i].preheat = t;
        }
        (self.points[i].pool_length, self.points[i].pool_radius) =
            self.model.pool(&self.deps, &self.along, i);
        self.laid = i + 1;
        self.check(Some(i))
    }

    fn cool(&mut self, duration: f64) -> Result<(), ThermalError> {
        if duration <= 1e-9 {
            return Ok(());
        }
        self.device_ready()?;
        let end = self.now + duration;
        while self.now < end - 1e-9 {
            let dt = self.dt_max.min(end - self.now);
            self.advance(dt, false);
        }
        self.read_device(Read::All);
        self.check(None)
    }

    fn quench(&mut self) {
        self.model.quench();
    }

    fn set_losses(&mut self, convection_w_m2k: f64, emissivity: f64, table_w_m2k: f64) {
        self.model
            .set_losses(convection_w_m2k, emissivity, table_w_m2k);
    }

    fn points(&self) -> &[PointResult] {
        &self.points
    }

    /// The thin wall's rule without its nodes: on the plate, on an earlier revolution, or on
    /// metal laid when (or after) this point's preheat was read, or within the source's rear
    /// length (c_r, one bead width: the thin wall's default footprint) of the torch then, where
    /// the reading is the arc's own heat and no dwell can come between the two.
    fn support(&self, i: usize) -> Support {
        match self.deps[i].support {
            None => Support::Plate,
            // A drop is read as its arc strikes, after the wait before it.
            Some(_) if self.drops.contains(i) => Support::Deposit,
            Some(_) if self.just_laid[i] => Support::JustLaid,
            Some(_) => Support::Deposit,
        }
    }

    fn laid(&self) -> usize {
        self.laid
    }

    fn now(&self) -> f64 {
        self.now
    }

    fn temperature_beneath(&self, i: usize) -> f64 {
        self.model.temperature_under(&self.deps, i)
    }

    /// The mean of deposit i's own voxels; a deposit that switched on no cell of its own (a
    /// bead thinner than the cells, laid where the metal already is) has its metal in the cells
    /// where it lies, and reads the one nearest the middle of its segment, else the metal of
    /// the last deposit before it that laid any (as the snapshots and peaks take it): it read
    /// ambient, so that a skeleton's drop so laid would be taken for solid as its arc stopped.
    fn temperature_of(&self, i: usize) -> f64 {
        let m = &self.model;
        if !m.laid[i].is_empty() {
            return m.mean_t(&m.laid[i]);
        }
        let (a, b) = (segment_start(&self.deps, i), self.deps[i].position);
        match m.voxel_near(std::array::from_fn(|k| 0.5 * (a[k] + b[k]))) {
            Some(v) => m.temperature(v),
            None => m.metal_t(i),
        }
    }

    fn cooling_steps(&self) -> CoolingSteps {
        CoolingSteps::Fixed { step: self.dt_max }
    }

    fn finish(mut self) -> RunResult {
        self.sample_probes(0.0);
        let support = (0..self.deps.len()).map(|i| self.support(i)).collect();
        let m = &self.model;
        // A deposit with no voxel of its own shares the metal of the one before it.
        for i in 1..self.points.len() {
            if m.laid[i].is_empty() {
                self.points[i].peak = self.points[i - 1].peak;
                self.points[i].time_above = self.points[i - 1].time_above;
            }
        }
        let stored: f64 = (0..m.h.len() as u32)
            .map(|v| {
                let (_, _, h_ambient, mass) = m.material_of(v);
                mass * (m.h[v as usize] as f64 - h_ambient)
            })
            .sum();
        let e = m.ledger.energy_in();
        RunResult {
            points: self.points,
            support,
            snapshots: self.snapshots,
            traces: self.traces,
            hottest: self.hottest,
            probes: self.probes,
            ledger: m.ledger,
            stored,
            balance_error: if e > 0.0 {
                (e - stored - m.ledger.lost()) / e
            } else {
                0.0
            },
            underpowered: self.underpowered,
            steps: m.steps,
            cells: Cells::Voxel {
                voxels: m.h.len(),
                updates: m.updates,
                metal_m3: m.laid.iter().map(Vec::len).sum::<usize>() as f64
                    * m.settings.size.powi(3),
            },
        }
    }
}
