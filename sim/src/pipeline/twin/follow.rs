//! Following a build as its readings arrive (no IO: the command tails the files and feeds the
//! rows here): each row assimilated in time order, forecasts made at their moments (every
//! `forecast_every_s` and at each layer's end) from the readings up to then and no later,
//! filled in with what was measured once their time has come, and at each layer's end the next
//! layer's start judged against the interpass limit at its 95th percentile.
//!
//! A forecast is the ensemble's, put on the sensor's own footing: the last reading plus the
//! change the ensemble forecasts and its misfit to the reading, each weighed by what the
//! verified forecasts taught so far (a line fitted by recursive least squares, per horizon over
//! all probes until a probe has its own 20 verifications, then per probe: model output
//! statistics, Glahn & Lowry 1972, J. Appl. Meteor. 11, 1203–1211). Where the model is right
//! about a sensor the weights go toward 1 (the ensemble's own forecast); where the sensor sees
//! less of each pass than the model does (a thermocouple further from the bead than thought)
//! they fall toward 0, and the forecast toward persistence. The ensemble's own mean is kept
//! beside it (`ensemble_c`).
//!
//! A layer is a pass of the torch as a replay cuts them ([`replay::pass_starts`]): a track after
//! travel or after a pause with the arc off; and within a pass, each climb onto a new revolution
//! ([`layers`]): a CTPP spiral is followed and judged revolution by revolution.

use super::asrun::{AsRun, MachineRow};
use super::{Twin, enkf, probe_k, quantile};
use crate::pipeline::Error;
use crate::pipeline::replay;
use serde::{Deserialize, Serialize};
use thermal::ZERO_CELSIUS_K as C;
use thermal::schedule::Deposit;
use thermal::{HeatRun, ModelRun};

/// One layer of the program: deposits `first..=last`, from its first arc to its last deposit's
/// end, s.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Layer {
    pub first: usize,
    pub last: usize,
    pub start_s: f64,
    pub end_s: f64,
}

/// The moments at the layers' ends (all but the last's), with their layer.
fn layer_ends(layers: &[Layer]) -> impl Iterator<Item = (f64, Option<usize>)> + '_ {
    layers
        .iter()
        .enumerate()
        .filter(|(k, _)| k + 1 < layers.len())
        .map(|(k, l)| (l.end_s, Some(k)))
}

/// The program's layers, in order: its passes (a track after travel or after a pause with the
/// arc off, as [`replay::pass_starts`] cuts them), each cut again where it climbs onto a new
/// revolution: a deposit laid on the highest revolution so far (counted through the supports:
/// on the plate 0, on a deposit of revolution r, r + 1). A CTPP spiral, one pass from its first
/// arc to its last, is then a layer a revolution, as `dwell` judges it; a wall or a pad whose
/// passes are its layers is cut where it was. A deposit that found no support counts as on the
/// plate: it can delay a cut, never add one.
pub fn layers(deps: &[Deposit]) -> Vec<Layer> {
    let mut revolution: Vec<usize> = Vec::with_capacity(deps.len());
    let mut highest = 0;
    let mut firsts: Vec<usize> = Vec::new();
    for (i, d) in deps.iter().enumerate() {
        let r = d
            .support
            .filter(|&s| s < i)
            .map_or(0, |s| revolution[s] + 1);
        revolution.push(r);
        let paused = i > 0 && d.arc_start() > deps[i - 1].time + 1e-9;
        if i == 0 || d.start.is_some() || paused || r > highest {
            firsts.push(i);
        }
        highest = highest.max(r);
    }
    firsts
        .iter()
        .enumerate()
        .map(|(k, &first)| {
            let last = firsts.get(k + 1).map_or(deps.len() - 1, |&n| n - 1);
            Layer {
                first,
                last,
                start_s: deps[first].arc_start(),
                end_s: deps[last].time,
            }
        })
        .collect()
}

/// What a forecast is for: a time ahead, or the next layer's start.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub enum Horizon {
    After(f64),
    NextLayer,
}

impl Horizon {
    pub fn label(&self) -> String {
        match self {
            Horizon::After(h) => format!("{h}"),
            Horizon::NextLayer => "next_layer".into(),
        }
    }
}

/// One probe's forecast, °C.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Forecast {
    pub made_at_s: f64,
    pub target_t_s: f64,
    pub probe: usize,
    pub horizon: Horizon,
    /// The twin's forecast (the module's doc), and its 5–95 % band ([`Learned::band`]).
    pub predicted_c: f64,
    pub p05_c: f64,
    pub p95_c: f64,
    /// The open loop: the scenario's values, corrected by nothing.
    pub open_loop_c: f64,
    /// The last reading at `made_at_s`, carried forward: the forecast any spreadsheet makes.
    pub persistence_c: Option<f64>,
    /// What the probe read at `target_t_s` (linear between the rows around it), once read.
    pub measured_c: Option<f64>,
    /// The ensemble's mean at the target, the change it forecast from `made_at_s`, and its
    /// mean less the reading then.
    pub ensemble_c: f64,
    change_c: f64,
    misfit_c: f64,
    /// The learned lines this forecast teaches: its probe's and its horizon's over all probes.
    class: usize,
    pooled: usize,
}

/// √ of a forecast's lead in minutes: what its error is scaled by ([`Learned::band`]).
fn lead_scale(f: &Forecast) -> f64 {
    ((f.target_t_s - f.made_at_s) / 60.0).max(1e-3).sqrt()
}

/// Verified errors the band is cut from, and the fewest it is cut from.
const KEPT_ERRORS: usize = 50;
const FEWEST_ERRORS: usize = 10;

/// Verified forecasts after which a probe's own line takes over from its horizon's.
const OWN_LINE_AFTER: usize = 20;

/// The most a learned line weighs the ensemble's change, or its misfit, by.
const W_MAX: f64 = 1.5;

/// Forgetting of the learned lines per verified forecast: about the last 50 weigh.
const FORGET: f64 = 0.98;

/// What a learned line is fitted on: the ensemble's forecast change from the moment the
/// forecast is made, the ensemble's misfit to the reading then (its mean less the reading),
/// and 1.
const REGRESSORS: usize = 3;

/// A line y = w₁·Δm + w₂·(m₀ − y₀) + b fitted by recursive least squares with forgetting, and
/// the variance of its errors before each update (the error a forecast made with it should
/// expect). With w₁ = w₂ = 1 and b = 0 the forecast is the ensemble's own mean; with w₁ = 1,
/// w₂ = 0 its change added to the reading; with all 0, persistence.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Learned {
    theta: [f64; REGRESSORS],
    p: [[f64; REGRESSORS]; REGRESSORS],
    error_var: f64,
    verified: usize,
    /// The last `KEPT_ERRORS` errors before each update, measured − forecast, °C: what the
    /// band is cut from once there are `FEWEST_ERRORS` of them.
    errors: std::collections::VecDeque<f64>,
}

impl Learned {
    /// Before any verification: the ensemble not yet trusted (w = 0 ± 1, b = 0 ± 1 °C:
    /// persistence until the verified forecasts show what the model is worth), and the
    /// reading's error.
    fn new(sd_reading: f64) -> Learned {
        Learned {
            theta: [0.0; REGRESSORS],
            p: [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
            error_var: sd_reading * sd_reading,
            verified: 0,
            errors: std::collections::VecDeque::new(),
        }
    }

    /// The 5–95 % band about a forecast, °C below and above it: the wider, on each side, of a
    /// normal of the members' spread `sd` weighed as the change is and the expected error, and
    /// the verified errors' own quantiles where there are `FEWEST_ERRORS` of them
    /// (split-conformal, Vovk et al. 2005: skewed errors make a skewed band).
    /// The errors are kept divided by `scale` (√ of the lead time in minutes: a next layer's
    /// start may lie a minute ahead or fifteen, and a diffusing error grows as √t) and the band
    /// multiplied back by it.
    /// Until then the expected error is at least `unverified_var` (the twin's innovations'
    /// running variance: its error at the sensors, known from the first analyses on, where
    /// the reading's error alone made a band too narrow for what a forecast meets).
    fn band(&self, sd: f64, scale: f64, unverified_var: f64) -> (f64, f64) {
        let var = match self.errors.len() < FEWEST_ERRORS {
            true => self.error_var.max(unverified_var),
            false => self.error_var,
        };
        let half = 1.645 * (self.theta[0].powi(2) * sd * sd + var * scale * scale).sqrt();
        if self.errors.len() < FEWEST_ERRORS {
            return (half, half);
        }
        let e: Vec<f64> = self.errors.iter().copied().collect();
        (
            half.max(-scale * quantile(&e, 0.05)),
            half.max(scale * quantile(&e, 0.95)),
        )
    }

    /// The change from the reading it forecasts, for the ensemble's change `change` and
    /// misfit `misfit`.
    fn predict(&self, change: f64, misfit: f64) -> f64 {
        let x = [change, misfit, 1.0];
        (0..REGRESSORS).map(|i| self.theta[i] * x[i]).sum()
    }

    /// Learn from a verified forecast: the ensemble's change and misfit, the measured change
    /// `y`, the lead's `scale` ([`Learned::band`]).
    fn learn(&mut self, change: f64, misfit: f64, y: f64, scale: f64) {
        let x = [change, misfit, 1.0];
        let e = y - self.predict(change, misfit);
        let px: [f64; REGRESSORS] =
            std::array::from_fn(|i| (0..REGRESSORS).map(|j| self.p[i][j] * x[j]).sum());
        let denominator = FORGET + (0..REGRESSORS).map(|i| x[i] * px[i]).sum::<f64>();
        let k: [f64; REGRESSORS] = std::array::from_fn(|i| px[i] / denominator);
        // The weights stay within [0, W_MAX]: a model that counts against the data, or for
        // more than the data's own change, is one a few early verifications misled (a first
        // pass the model put late fits any slope).
        for (i, (theta, ki)) in self.theta.iter_mut().zip(k).enumerate() {
            *theta += ki * e;
            if i < 2 {
                *theta = theta.clamp(0.0, W_MAX);
            }
        }
        // P = (P − k·(xᵀP)) / λ, with xᵀP = pxᵀ (P symmetric).
        for (row, ki) in self.p.iter_mut().zip(k) {
            for (pij, pxj) in row.iter_mut().zip(px) {
                *pij = (*pij - ki * pxj) / FORGET;
            }
        }
        let scaled = e / scale;
        // The mean of the squared errors so far, then a running one over the memory: a few
        // verifications must not leave the band at the reading's error alone.
        self.verified += 1;
        let weight = (1.0 / self.verified as f64).max(1.0 - FORGET);
        self.error_var += weight * (scaled * scaled - self.error_var);
        if self.errors.len() == KEPT_ERRORS {
            self.errors.pop_front();
        }
        self.errors.push_back(scaled);
    }
}

/// The learned line a forecast of probe `k` at horizon `h` (an index into `horizons_s`, or
/// `horizons_s.len()` for the next layer's start) is made with, as an index into `lines`
/// (per probe and horizon, then per horizon over all probes): the probe's own once it has been
/// verified [`OWN_LINE_AFTER`] times; else the line all probes of this horizon taught together
/// (learned as many times faster); and while that has no verification yet, the pooled line of
/// the nearest shorter horizon that has one. A fixed horizon's first verification comes a whole
/// horizon after the first forecast, and the model's skill at a shorter lead is the best
/// evidence there is until then: on the GAMMA wall the 300 s forecasts made before any was
/// verified were persistence, and the 300 s RMS over the build was 292 °C against the open
/// loop's 120; with the 60 s line 125 °C (docs/PHYSICS.md "The live twin").
fn line(lines: &[Learned], k: usize, h: usize, horizons_s: &[f64]) -> usize {
    let n = horizons_s.len() + 1;
    let pooled = |h: usize| lines.len() - n + h;
    if lines[k * n + h].verified >= OWN_LINE_AFTER {
        return k * n + h;
    }
    if lines[pooled(h)].verified > 0 || h >= horizons_s.len() {
        return pooled(h);
    }
    (0..horizons_s.len())
        .filter(|&g| horizons_s[g] < horizons_s[h] && lines[pooled(g)].verified > 0)
        .max_by(|&a, &b| horizons_s[a].total_cmp(&horizons_s[b]))
        .map_or(pooled(h), pooled)
}

/// A layer the forecast puts at risk.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Alarm {
    pub made_at_s: f64,
    /// The layer at risk, counted from 1.
    pub layer: usize,
    pub criterion: String,
    /// The 95th percentile over the members of what the criterion judges, and its limit, in
    /// `unit`: the hottest metal the layer is laid on (°C: interpass, strength), or the longest
    /// melt pool it lays (mm: humping).
    pub predicted_p95: f64,
    pub limit: f64,
    pub unit: Unit,
    /// The dwell the program has before the layer, and the one that keeps it safe (None:
    /// more than an hour), s.
    pub programmed_dwell_s: f64,
    pub advised_dwell_s: Option<f64>,
}

impl Alarm {
    /// The dwell to add, s.
    pub fn extra_s(&self) -> Option<f64> {
        self.advised_dwell_s.map(|a| a - self.programmed_dwell_s)
    }

    /// The line printed on stderr.
    pub fn line(&self) -> String {
        let advice = match self.advised_dwell_s {
            Some(a) => format!(
                "advised dwell {a:.0} s (+{:.0} s)",
                a - self.programmed_dwell_s
            ),
            None => "no dwell up to an hour brings it under".into(),
        };
        let (at, layer, criterion) = (self.made_at_s, self.layer, &self.criterion);
        let what = match self.unit {
            Unit::Celsius => format!(
                "would start on metal at {:.0} °C (95 %), {criterion} limit {:.0} °C",
                self.predicted_p95, self.limit
            ),
            Unit::Millimetre => format!(
                "would lay a melt pool {:.1} mm long (95 %), {criterion} limit {:.1} mm",
                self.predicted_p95, self.limit
            ),
        };
        format!(
            "alarm at t = {at:.0} s: layer {layer} {what}; the program dwells {:.0} s, {advice}",
            self.programmed_dwell_s
        )
    }
}

/// What an alarm's numbers are in.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Unit {
    Celsius,
    Millimetre,
}

/// What a follow changes as it goes, beside the twin's state; a checkpoint keeps both
/// ([`Kept`]).
#[derive(Clone, Serialize, Deserialize)]
pub struct Progress {
    next_moment: usize,
    /// The last row fed: its time and readings (°C).
    last_row: Option<(f64, Vec<Option<f64>>)>,
    /// Per probe, its last reading (°C).
    last_seen: Vec<Option<f64>>,
    pub forecasts: Vec<Forecast>,
    /// Forecasts still waiting for their measurement.
    pending: Vec<usize>,
    pub alarms: Vec<Alarm>,
    /// Every layer start judged: (made at, layer from 1, 95th percentile °C), alarm or not.
    pub judged: Vec<(f64, usize, f64)>,
    pub settling: Vec<(f64, usize, f64, f64)>,
    /// Per probe and horizon, then per horizon over all probes, what the verified forecasts
    /// taught.
    learned: Vec<Learned>,
    pub rows: usize,
    pub readings: usize,
    /// Rows refused because they went back in time.
    pub back_in_time: usize,
    /// The program as the machine log says it ran, where the build has one.
    #[serde(default)]
    pub asrun: Option<AsRun>,
}

/// What a checkpoint keeps: the twin's state and the follow's progress. Written from borrows
/// ([`KeptRef`], [`Follower::kept`]), read back owned ([`KeptOwned`]): one layout, and the
/// members serialised where they are, not copied first (two copies of every member's field
/// were most of `follow`'s peak memory: docs/PERFORMANCE.md "`follow`'s memory").
#[derive(Serialize, Deserialize)]
pub struct Kept<S, P> {
    twin: S,
    progress: P,
}

pub type KeptRef<'a> = Kept<&'a super::State, &'a Progress>;
pub type KeptOwned = Kept<super::State, Progress>;

/// A build followed: the twin, the program's layers and the moments forecasts are made at.
pub struct Follower<'a> {
    pub twin: Twin<'a>,
    pub layers: Vec<Layer>,
    /// Build times forecasts are made at, ascending, with the layer that ends there.
    moments: Vec<(f64, Option<usize>)>,
    pub progress: Progress,
}

impl<'a> Follower<'a> {
    pub fn new(twin: Twin<'a>, deps: &[Deposit], probes: usize) -> Follower<'a> {
        // Per probe and horizon, then per horizon over all probes.
        let classes = (probes + 1) * (twin.settings.horizons_s.len() + 1);
        let learned = vec![Learned::new(twin.settings.reading_sd_k); classes];
        let progress = Progress {
            learned,
            next_moment: 0,
            last_row: None,
            last_seen: vec![None; probes],
            forecasts: Vec::new(),
            pending: Vec::new(),
            alarms: Vec::new(),
            judged: Vec::new(),
            settling: Vec::new(),
            rows: 0,
            readings: 0,
            back_in_time: 0,
            asrun: None,
        };
        Follower::from(twin, deps, progress)
    }

    /// A follow that goes on from a checkpoint.
    pub fn resume(mut twin: Twin<'a>, deps: &[Deposit], kept: KeptOwned) -> Follower<'a> {
        twin.state = kept.twin;
        Follower::from(twin, deps, kept.progress)
    }

    fn from(mut twin: Twin<'a>, deps: &[Deposit], progress: Progress) -> Follower<'a> {
        if let Some(a) = &progress.asrun {
            twin.reschedule(a.deps.clone());
        }
        let layers = layers(twin.deps());
        let (start, end) = (
            deps.first().map_or(0.0, |d| d.arc_start()),
            deps.last().map_or(0.0, |d| d.time),
        );
        let every = twin.settings.forecast_every_s;
        let mut moments: Vec<(f64, Option<usize>)> = (1..)
            .map(|k| k as f64 * every)
            .skip_while(|&t| t <= start)
            .take_while(|&t| t < end)
            .map(|t| (t, None))
            .collect();
        moments.extend(layer_ends(&layers));
        moments.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        Follower {
            twin,
            layers,
            moments,
            progress,
        }
    }

    /// Follow the machine log too: its rows rewrite the schedule ([`AsRun`]); the program
    /// was made at `power_w`.
    pub fn with_machine_log(mut self, power_w: f64) -> Follower<'a> {
        if self.progress.asrun.is_none() {
            self.progress.asrun = Some(AsRun::new(self.twin.deps().to_vec(), power_w));
        }
        self
    }

    /// A row of the machine log, before the probe row of the same time: where it moves the
    /// schedule, the twin runs the new one and the layers' ends and starts move with it (the
    /// regular forecasts stay where they were). A row without a machine log is ignored.
    pub fn machine(&mut self, row: MachineRow) {
        let Some(a) = self.progress.asrun.as_mut() else {
            return;
        };
        if !a.feed(row) {
            return;
        }
        self.twin.reschedule(a.deps.clone());
        self.layers = layers(self.twin.deps());
        let done = self.moments[..self.progress.next_moment].to_vec();
        let regular = self.moments[self.progress.next_moment..]
            .iter()
            .filter(|m| m.1.is_none())
            .copied();
        let now = self.data_s().unwrap_or(f64::NEG_INFINITY);
        // A layer end the log moved to before now (but not before the last row) is due at
        // once; one already judged is not judged again.
        let judged: Vec<usize> = done.iter().filter_map(|m| m.1).collect();
        let ends = layer_ends(&self.layers)
            .filter(|m| m.1.is_some_and(|k| !judged.contains(&k)))
            .map(|(t, k)| (t.max(now), k));
        let mut rest: Vec<(f64, Option<usize>)> = regular.chain(ends).collect();
        rest.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
        self.moments = done;
        self.moments.extend(rest);
    }

    /// The state to keep, borrowed.
    pub fn kept(&self) -> KeptRef<'_> {
        Kept {
            twin: &self.twin.state,
            progress: &self.progress,
        }
    }

    /// The build time of the last row fed, s.
    pub fn data_s(&self) -> Option<f64> {
        self.progress.last_row.as_ref().map(|r| r.0)
    }

    /// Feed one row: its time and per probe its reading in °C (None: no reading). A row at or
    /// before the last one's time is refused (counted). Returns the alarms it raised.
    pub fn feed(&mut self, t_s: f64, values: &[Option<f64>]) -> Result<Vec<Alarm>, Error> {
        if self.data_s().is_some_and(|last| t_s <= last) {
            self.progress.back_in_time += 1;
            return Ok(Vec::new());
        }
        let mut raised = Vec::new();
        // Forecasts due before this row are made from the readings before it.
        while let Some(&(at, layer)) = self.moments.get(self.progress.next_moment) {
            if at >= t_s {
                break;
            }
            self.twin.advance(at)?;
            raised.extend(self.forecast(at, layer)?);
            self.progress.next_moment += 1;
        }
        let readings: Vec<(usize, f64)> = values
            .iter()
            .enumerate()
            .filter_map(|(k, v)| v.map(|v| (k, v + C)))
            .collect();
        if self.twin.assimilate(t_s, &readings)? {
            for (k, (p, mean, sd)) in self.twin.parameters().into_iter().enumerate() {
                debug_assert_eq!(p, self.twin.priors[k].parameter);
                self.progress.settling.push((t_s, k, mean, sd));
            }
        }
        self.fill(t_s, values);
        for (k, v) in values.iter().enumerate() {
            if v.is_some() {
                self.progress.last_seen[k] = *v;
                self.progress.readings += 1;
            }
        }
        self.progress.rows += 1;
        self.progress.last_row = Some((t_s, values.to_vec()));
        Ok(raised)
    }

    /// Fill in the pending forecasts whose target lies up to `t_s`, between the last row and
    /// this one.
    fn fill(&mut self, t_s: f64, values: &[Option<f64>]) {
        let last = self.progress.last_row.clone();
        let forecasts = &mut self.progress.forecasts;
        let learned = &mut self.progress.learned;
        self.progress.pending.retain(|&i| {
            let f = &mut forecasts[i];
            if f.target_t_s > t_s {
                return true;
            }
            let now = values.get(f.probe).copied().flatten();
            let before = last
                .as_ref()
                .and_then(|(t, v)| v.get(f.probe).copied().flatten().map(|v| (*t, v)));
            f.measured_c = match (before, now) {
                (Some((t0, v0)), Some(v1)) if t_s > t0 => {
                    Some(v0 + (f.target_t_s - t0) / (t_s - t0) * (v1 - v0))
                }
                (_, Some(v1)) => Some(v1),
                (Some((_, v0)), None) => Some(v0),
                (None, None) => None,
            };
            if let (Some(m), Some(y0)) = (f.measured_c, f.persistence_c) {
                for line in [f.class, f.pooled] {
                    learned[line].learn(f.change_c, f.misfit_c, m - y0, lead_scale(f));
                }
            }
            false
        });
    }

    /// The forecasts made at `at` (the twin stands there), and at a layer's end the next
    /// layer's judgement.
    fn forecast(&mut self, at: f64, layer: Option<usize>) -> Result<Vec<Alarm>, Error> {
        // At a layer's end, the layer after it, though it start at once (a spiral's next
        // revolution: a lead of nothing, judged as it strikes).
        let next = match layer {
            Some(k) => (k + 1 < self.layers.len()).then_some(k + 1),
            None => self.layers.iter().position(|l| l.start_s > at),
        };
        let mut targets: Vec<(f64, Horizon)> = self
            .twin
            .settings
            .horizons_s
            .iter()
            .map(|&h| (at + h, Horizon::After(h)))
            .collect();
        if let Some(n) = next {
            targets.push((self.layers[n].start_s, Horizon::NextLayer));
        }
        targets.sort_by(|a, b| a.0.total_cmp(&b.0));
        let times: Vec<f64> = targets.iter().map(|t| t.0).collect();
        let probes = self.twin.r.probes.clone();
        let edge = self.twin.r.values.thermal.voxel_m;
        let read = |run: &ModelRun| -> Vec<Option<f64>> {
            probes.iter().map(|&p| probe_k(run, p, edge)).collect()
        };
        let ahead = self.twin.forecast(&times, &read)?;
        let now = self.twin.read_members(&read);
        let horizons = self.twin.settings.horizons_s.len();
        for ((target, horizon), (members, open)) in targets.iter().zip(&ahead) {
            for k in 0..probes.len() {
                let pairs: Vec<(f64, f64)> = members
                    .iter()
                    .zip(&now)
                    .filter_map(|(m, n)| Some((m[k]?, n[k]?)))
                    .collect();
                let (Some(open), false) = (open[k], pairs.len() < 2) else {
                    continue;
                };
                let ahead: Vec<f64> = pairs.iter().map(|p| p.0).collect();
                let (mean, sd) = (enkf::mean(&ahead), enkf::spread(&ahead));
                let then = enkf::mean(&pairs.iter().map(|p| p.1).collect::<Vec<_>>());
                let change = mean - then;
                let h = match horizon {
                    Horizon::After(h) => self
                        .twin
                        .settings
                        .horizons_s
                        .iter()
                        .position(|x| x == h)
                        .unwrap_or(0),
                    Horizon::NextLayer => horizons,
                };
                let (class, pooled) = (k * (horizons + 1) + h, probes.len() * (horizons + 1) + h);
                let lines = &self.progress.learned;
                let learned = &lines[line(lines, k, h, &self.twin.settings.horizons_s)];
                let persistence = self.progress.last_seen[k];
                let misfit = persistence.map_or(0.0, |y0| then - C - y0);
                let predicted = match persistence {
                    Some(y0) => y0 + C + learned.predict(change, misfit),
                    None => mean,
                };
                let scale = ((target - at) / 60.0).max(1e-3).sqrt();
                let (below, above) = learned.band(sd, scale, self.twin.innovation_var());
                // The band ends no lower than a reading can lie: the part does not cool below
                // its surroundings, and readings further below are dropped as not of the part
                // (`replay::BELOW_AMBIENT_K`). A wide band at a long lead reached -345 °C on
                // the GAMMA wall; no kept reading lies below the floor, so the band holds the
                // same readings.
                let floor = self.twin.r.values.thermal.ambient_k - replay::BELOW_AMBIENT_K;
                self.progress.pending.push(self.progress.forecasts.len());
                self.progress.forecasts.push(Forecast {
                    made_at_s: at,
                    target_t_s: *target,
                    probe: k,
                    horizon: *horizon,
                    predicted_c: predicted - C,
                    p05_c: (predicted - below).max(floor) - C,
                    p95_c: predicted + above - C,
                    open_loop_c: open - C,
                    persistence_c: persistence,
                    measured_c: None,
                    ensemble_c: mean - C,
                    change_c: change,
                    misfit_c: misfit,
                    class,
                    pooled,
                });
            }
        }
        let (Some(_), Some(n)) = (layer, next) else {
            return Ok(Vec::new());
        };
        let mut alarms = Vec::new();
        if let Some(limit) = self.twin.settings.tightest_limit() {
            alarms.extend(self.judge(at, n, limit)?);
        }
        if let Some(pool_m) = self.twin.settings.humping_pool_m {
            alarms.extend(self.judge_pool(at, n, pool_m)?);
        }
        Ok(alarms)
    }

    /// Layer `n` judged from `at` against `limit` (its criterion, K), at the 95th percentile over
    /// the members, as `dwell` judges it where it can: a layer after a pause (a wall's or a
    /// pad's next pass) by the hottest metal it is laid on as it starts, its advice the cooling
    /// that brings that under; a layer the program runs straight into (a spiral's next
    /// revolution, whose last points lie on metal laid a moment before it starts) by each of
    /// its points' preheat as the torch reaches it, read `lead` ahead as the dwell planner reads
    /// it, its advice the least dwell before the layer (in 5 s steps) after which the layer,
    /// run again, keeps under. An alarm where it is over.
    fn judge(
        &mut self,
        at: f64,
        n: usize,
        (criterion, limit): (&str, f64),
    ) -> Result<Option<Alarm>, Error> {
        let l = self.layers[n];
        let programmed = l.start_s - self.layers[n - 1].end_s;
        let deps = self.twin.deps().to_vec();
        let straight_on = programmed <= 1e-9;
        let beneath = |run: &ModelRun| -> f64 {
            (l.first..=l.last)
                .filter(|&i| deps[i].support.is_none_or(|s| s < run.laid()))
                .map(|i| run.temperature_beneath(i))
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let as_laid = |run: &ModelRun| -> f64 {
            (l.first..=l.last)
                .filter(|&i| crate::pipeline::risk::dwell_can_act(run.support(i)))
                .map(|i| run.points()[i].preheat)
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let p95 = |dwell_s: f64| -> Result<f64, Error> {
            let members = self
                .twin
                .through_layer((l.start_s, l.end_s), dwell_s, &as_laid)?;
            Ok(quantile(&members, 0.95))
        };
        let judged = match straight_on {
            true => p95(0.0)?,
            false => {
                let start = self.twin.forecast(&[l.start_s], &beneath)?;
                let Some((members, _)) = start.first() else {
                    return Ok(None);
                };
                quantile(members, 0.95)
            }
        };
        // A layer laid on no earlier one (a spiral's first revolution) has nothing to judge.
        if !judged.is_finite() {
            return Ok(None);
        }
        self.progress.judged.push((at, n + 1, judged - C));
        if judged <= limit {
            return Ok(None);
        }
        let extra = match straight_on {
            true => self.least_layer_dwell((l.start_s, l.end_s), &as_laid, limit)?,
            false => {
                self.twin
                    .dwell_until(l.start_s, &beneath, limit, DWELL_STEP_S, MAX_DWELL_S)?
            }
        };
        let alarm = Alarm {
            made_at_s: at,
            layer: n + 1,
            criterion: criterion.into(),
            predicted_p95: judged - C,
            limit: limit - C,
            unit: Unit::Celsius,
            programmed_dwell_s: programmed,
            advised_dwell_s: extra.map(|e| programmed + e),
        };
        self.progress.alarms.push(alarm.clone());
        Ok(Some(alarm))
    }
}

impl Follower<'_> {
    /// Layer `n` judged from `at` against the humping limit `pool_m`: the longest melt pool it
    /// lays (the deposits whose metal is above the solidus behind the torch, as the dwell
    /// planner measures it, `PointResult::pool_length`), at the 95th percentile over the
    /// members run through it; the advice the least dwell before it (in 5 s steps) after which
    /// the layer, run again, keeps under (a cooler part makes a shorter pool). An alarm where
    /// it is over.
    fn judge_pool(&mut self, at: f64, n: usize, pool_m: f64) -> Result<Option<Alarm>, Error> {
        let l = self.layers[n];
        let programmed = l.start_s - self.layers[n - 1].end_s;
        let longest = |run: &ModelRun| -> f64 {
            (l.first..=l.last)
                .map(|i| run.points()[i].pool_length)
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let p95 = |dwell_s: f64| -> Result<f64, Error> {
            let members = self
                .twin
                .through_layer((l.start_s, l.end_s), dwell_s, &longest)?;
            Ok(quantile(&members, 0.95))
        };
        let judged = p95(0.0)?;
        if !judged.is_finite() || judged <= pool_m {
            return Ok(None);
        }
        let extra = self.least_layer_dwell((l.start_s, l.end_s), &longest, pool_m)?;
        let alarm = Alarm {
            made_at_s: at,
            layer: n + 1,
            criterion: "humping".into(),
            predicted_p95: judged * 1e3,
            limit: pool_m * 1e3,
            unit: Unit::Millimetre,
            programmed_dwell_s: programmed,
            advised_dwell_s: extra.map(|e| programmed + e),
        };
        self.progress.alarms.push(alarm.clone());
        Ok(Some(alarm))
    }

    /// The least dwell before the layer from `layer_s.0` to `layer_s.1` (in 5 s steps, up to
    /// an hour) after which `read`'s 95th percentile over the members run through it is within
    /// `limit`. None where no dwell is: found at once where even the layer laid on the part
    /// brought to ambient is over (`Twin::through_layer_quenched`, the coolest any dwell leaves
    /// it), where the search cooled the members through some 8 700 s of dwells to say so (a
    /// melt pool longer than the limit on a wall too small to lose its heat between tracks:
    /// the e2e test's small wall followed in 33.3 s before, 1.4 s now).
    fn least_layer_dwell(
        &self,
        layer_s: (f64, f64),
        read: &(dyn Fn(&ModelRun) -> f64 + Sync),
        limit: f64,
    ) -> Result<Option<f64>, Error> {
        let coolest = self.twin.through_layer_quenched(layer_s, read)?;
        if quantile(&coolest, 0.95) > limit {
            return Ok(None);
        }
        let p95 = |dwell_s: f64| -> Result<f64, Error> {
            let members = self.twin.through_layer(layer_s, dwell_s, read)?;
            Ok(quantile(&members, 0.95))
        };
        least_dwell(|d| Ok(p95(d)? <= limit), DWELL_STEP_S, MAX_DWELL_S)
    }
}

/// The step the advised dwells are found in, s.
const DWELL_STEP_S: f64 = 5.0;
/// The longest dwell advised, s: past it, no advice.
const MAX_DWELL_S: f64 = 3600.0;

/// The least multiple of `step` up to `max` for which `safe` holds, `safe` being false at 0 and
/// monotone (a longer dwell never hotter): doubled from `step` until safe, then halved back in
/// between; None where `max` is not safe. About 2·log2(max/step) calls.
fn least_dwell(
    mut safe: impl FnMut(f64) -> Result<bool, Error>,
    step: f64,
    max: f64,
) -> Result<Option<f64>, Error> {
    let (mut unsafe_k, mut k) = (0u64, 1u64);
    loop {
        let d = (k as f64 * step).min(max);
        if safe(d)? {
            break;
        }
        if d >= max {
            return Ok(None);
        }
        unsafe_k = k;
        k *= 2;
    }
    let mut safe_k = k.min((max / step).ceil() as u64);
    while safe_k - unsafe_k > 1 {
        let mid = (safe_k + unsafe_k) / 2;
        match safe(mid as f64 * step)? {
            true => safe_k = mid,
            false => unsafe_k = mid,
        }
    }
    Ok(Some((safe_k as f64 * step).min(max)))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A line y = 0.4·x + 2 with noise: the learned weight and intercept come near it, the
    /// weight is kept within [0, W_MAX], and the band cut from the verified errors holds about
    /// 90 % of the next errors.
    #[test]
    fn a_learned_line_finds_the_weight_and_its_band_holds() {
        use rand::{Rng, SeedableRng};
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(7);
        let mut l = Learned::new(1.0);
        let (mut inside, mut n) = (0, 0);
        for k in 0..400 {
            let x: f64 = rng.random_range(-10.0..10.0);
            let y = 0.4 * x + 2.0 + rng.random_range(-1.0..1.0);
            if k >= 100 {
                let (below, above) = l.band(0.0, 1.0, 0.0);
                let f = l.predict(x, 0.0);
                inside += usize::from(f - below <= y && y <= f + above);
                n += 1;
            }
            l.learn(x, 0.0, y, 1.0);
        }
        assert!((l.theta[0] - 0.4).abs() < 0.05, "{:?}", l.theta);
        assert!((l.theta[2] - 2.0).abs() < 0.3, "{:?}", l.theta);
        let share = inside as f64 / n as f64;
        assert!((0.8..=0.97).contains(&share), "{share}");
        let mut wild = Learned::new(1.0);
        wild.learn(1.0, 1.0, 500.0, 1.0);
        assert!(wild.theta[0] <= W_MAX && wild.theta[1] <= W_MAX);
    }

    /// A horizon whose shared line has no verification yet takes the nearest shorter
    /// horizon's; the next layer's start, whose lead varies, keeps its own.
    #[test]
    fn a_horizon_not_yet_verified_borrows_the_nearest_shorter_ones_line() {
        // Two probes, horizons 60, 300 and 120 s and the next layer: per probe four lines,
        // then four pooled.
        let horizons = [60.0, 300.0, 120.0];
        let mut lines = vec![Learned::new(1.0); 3 * 4];
        let pooled = |h: usize| 8 + h;
        // Nothing verified: every forecast its own horizon's pooled line.
        assert_eq!(line(&lines, 1, 1, &horizons), pooled(1));
        lines[pooled(0)].verified = 1;
        assert_eq!(line(&lines, 1, 1, &horizons), pooled(0));
        lines[pooled(2)].verified = 3;
        // 120 s is nearer 300 s than 60 s is; 60 s has nothing shorter to borrow.
        assert_eq!(line(&lines, 1, 1, &horizons), pooled(2));
        assert_eq!(line(&lines, 0, 2, &horizons), pooled(2));
        // The next layer's start keeps its own pooled line (its lead varies).
        assert_eq!(line(&lines, 0, 3, &horizons), pooled(3));
        lines[pooled(1)].verified = 1;
        assert_eq!(line(&lines, 1, 1, &horizons), pooled(1));
        lines[4 + 1].verified = OWN_LINE_AFTER;
        assert_eq!(line(&lines, 1, 1, &horizons), 4 + 1);
    }

    /// Two tracks with travel between them are two layers, each from its first arc to its
    /// last deposit's end.
    #[test]
    fn tracks_after_travel_are_layers() {
        let d = |t: f64, x: f64, start: bool| Deposit {
            position: [x, 0.0, 0.0],
            time: t,
            arc_time: 1.0,
            heat: 100.0,
            width: 4e-3,
            height: 1e-3,
            axis: [0.0, 0.0, 1.0],
            support: None,
            start: start.then_some([x - 1e-3, 0.0, 0.0]),
            drop: None,
        };
        let deps = [
            d(1.0, 0.0, true),
            d(2.0, 1e-3, false),
            d(11.0, 0.0, true),
            d(12.0, 1e-3, false),
        ];
        let l = layers(&deps);
        assert_eq!(l.len(), 2);
        assert_eq!((l[0].first, l[0].last, l[1].first, l[1].last), (0, 1, 2, 3));
        assert_eq!((l[0].start_s, l[0].end_s, l[1].start_s), (0.0, 2.0, 10.0));
    }

    /// A spiral laid in one pass (no travel, no pause) is a layer a revolution: the helix's
    /// three revolutions, each starting at the deposit that first lies on the one below.
    #[test]
    fn a_spiral_is_a_layer_a_revolution() {
        let deps = thermal::schedule::helix(0.03, 40, 3, 2e-3, 5e-3, 10e-3, 1700.0);
        assert!(deps.iter().skip(1).all(|d| d.start.is_none()));
        let l = layers(&deps);
        let firsts: Vec<usize> = l.iter().map(|l| l.first).collect();
        let climbs: Vec<usize> = (1..deps.len())
            .filter(|&i| deps[i].support.is_some() && deps[i - 1].support.is_none())
            .collect();
        assert_eq!(
            climbs.len(),
            1,
            "the helix lies on the plate for its first revolution"
        );
        assert_eq!(l.len(), 3, "{firsts:?}");
        assert_eq!(firsts[1], climbs[0]);
        assert_eq!(l[2].first - l[1].first, 40);
        assert!(l.windows(2).all(|w| w[0].last + 1 == w[1].first));
    }

    /// The least safe dwell on a 5 s grid: found exactly for any threshold, None past the
    /// longest, in about 2·log2 of the range's calls.
    #[test]
    fn the_least_dwell_is_found_on_its_grid() {
        for need in [0.1, 5.0, 5.1, 37.0, 640.0, 3599.0] {
            let mut calls = 0;
            let got = least_dwell(
                |d| {
                    calls += 1;
                    Ok(d >= need)
                },
                5.0,
                3600.0,
            )
            .unwrap();
            assert_eq!(got, Some((need / 5.0).ceil() * 5.0), "{need}");
            assert!(calls <= 21, "{calls} calls for {need}");
        }
        assert_eq!(least_dwell(|_| Ok(false), 5.0, 3600.0).unwrap(), None);
    }
}
