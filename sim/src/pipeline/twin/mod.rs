//! The live twin (no IO): an ensemble of heat-model runs of a replay's program, each with its
//! own values of the uncertain parameters, corrected from every probe reading as it arrives
//! ([`enkf`]: parameters and the field around the sensor), and run ahead to forecast the probes
//! and the next layer ([`follow`]). Beside it, the open loop: the scenario's values, corrected
//! by nothing, the yardstick a forecast is held against.
//!
//! A member is a whole [`ModelRun`]: its field, its clock, its losses; its efficiency scales the
//! heat of the deposits it lays ([`replay::advance_scaled`]). Every member lays the same
//! program at the same times, so their active cells are the same cells, and a cell's index
//! names the same place in each: what lets the filter read one variable across the members.

pub mod asrun;
pub mod enkf;
pub mod follow;

use super::Error;
use super::calibrate::Range;
use super::replay::{self, Parameter, Replay, Values};
use rand::{Rng, SeedableRng};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use thermal::{HeatRun, ModelRun};

/// How the twin filters and forecasts (`[live]`, scenarios/README.md), SI.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    pub ensemble: usize,
    /// A reading's error: the sensor's and how well one cell stands for it, K.
    pub reading_sd_k: f64,
    /// Gaspari–Cohn half-width of a reading's reach into the field, m.
    pub localisation_m: f64,
    /// RTPS relaxation of the spread toward the prior's, 0–1.
    pub relaxation: f64,
    /// Least build time between two analyses, s.
    pub assimilate_every_s: f64,
    /// Least build time between two updates of the parameters, s.
    pub parameters_every_s: f64,
    pub forecast_every_s: f64,
    /// Ascending.
    pub horizons_s: Vec<f64>,
    /// The interpass limit an alarm judges the next layer's start by, K.
    pub interpass_max_k: Option<f64>,
    /// The strength limit (`[dwell] strength_loss_c`'s: the layer beneath below it when the
    /// torch returns), judged as the interpass limit is, K.
    pub strength_loss_k: Option<f64>,
    /// The humping limit: a melt pool longer than this (m) is at risk (`[dwell]`'s π·W).
    pub humping_pool_m: Option<f64>,
    pub seed: u64,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            ensemble: 16,
            reading_sd_k: 5.0,
            localisation_m: 0.025,
            relaxation: 0.5,
            assimilate_every_s: 1.0,
            parameters_every_s: 30.0,
            forecast_every_s: 30.0,
            horizons_s: vec![60.0, 300.0],
            interpass_max_k: None,
            strength_loss_k: None,
            humping_pool_m: None,
            seed: 1,
        }
    }
}

impl Settings {
    /// The limit an alarm judges the next layer's start by: the lower of the interpass and the
    /// strength limits in force, with its criterion's name (both bound the metal the layer is
    /// laid on, as `dwell` judges them; humping, the pool's length, is judged on its own:
    /// `humping_pool_m`).
    pub fn tightest_limit(&self) -> Option<(&'static str, f64)> {
        [
            ("interpass", self.interpass_max_k),
            ("strength", self.strength_loss_k),
        ]
        .into_iter()
        .filter_map(|(name, k)| k.map(|k| (name, k)))
        .min_by(|a, b| a.1.total_cmp(&b.1))
    }
}

/// One uncertain parameter's prior: a normal of `mean` and `sd` cut to `range`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Uncertain {
    pub parameter: Parameter,
    pub range: Range,
    pub mean: f64,
    pub sd: f64,
}

impl Uncertain {
    /// `[calibrate]`'s range as the prior: centred on the scenario's value, a quarter of the
    /// range wide (so that the members span about the range).
    pub fn from_range(parameter: Parameter, range: Range, value: f64) -> Uncertain {
        Uncertain {
            parameter,
            range,
            mean: value,
            sd: (range.high - range.low) / 4.0,
        }
    }

    fn unit(&self, x: f64) -> f64 {
        (x - self.range.low) / (self.range.high - self.range.low)
    }

    fn value(&self, u: f64) -> f64 {
        self.range.low + u.clamp(0.0, 1.0) * (self.range.high - self.range.low)
    }

    /// The filter's coordinate: the logit of the share of the range. A bound is never reached
    /// (members clamped at it would all agree, and an ensemble that agrees learns nothing).
    fn logit(&self, x: f64) -> f64 {
        let u = self.unit(x).clamp(EDGE, 1.0 - EDGE);
        (u / (1.0 - u)).ln()
    }

    fn of_logit(&self, z: f64) -> f64 {
        self.value(1.0 / (1.0 + (-z).exp()))
    }
}

/// Memory of the innovations' running variance per reading assimilated.
const INNOVATION_MEMORY: f64 = 0.999;

/// How near a bound a parameter may come, as a share of its range.
const EDGE: f64 = 1e-3;

/// The least spread the filter leaves a parameter, as a share of its prior spread: the
/// parameters have no dynamics of their own, so without a floor their spread only shrinks
/// and the ensemble stops learning them (what additive inflation of parameters is for).
const PARAMETER_FLOOR: f64 = 0.2;

/// One member: its parameters' values (in the order of the twin's priors) and its run.
#[derive(Clone, Serialize, Deserialize)]
struct Member {
    values: Vec<f64>,
    run: ModelRun,
}

/// What of the twin changes as it runs: its members, the open loop, the clock of its filter.
#[derive(Clone, Serialize, Deserialize)]
pub struct State {
    members: Vec<Member>,
    open_loop: ModelRun,
    last_analysis_s: f64,
    last_learned_s: f64,
    /// Running variance of the innovations (K²): the model's error at the sensors.
    innovation_var: f64,
    /// Per parameter, the least spread of its logit ([`PARAMETER_FLOOR`] of the prior's).
    floor: Vec<f64>,
    pub analyses: usize,
    /// Readings assimilated, and their innovations' sum of squares (K²).
    pub assimilated: usize,
    pub innovation_sq: f64,
}

/// The twin: a replay's program run by an ensemble.
pub struct Twin<'a> {
    r: &'a Replay,
    /// The schedule the members run: the program, or what the machine log made of it
    /// ([`asrun`]).
    deps: Vec<thermal::schedule::Deposit>,
    pub settings: Settings,
    pub priors: Vec<Uncertain>,
    pub state: State,
}

/// The scenario's values with `priors`' parameters at `x`.
fn values_of(r: &Replay, priors: &[Uncertain], x: &[f64]) -> Values {
    let parameters: Vec<Parameter> = priors.iter().map(|u| u.parameter).collect();
    r.values.with(&parameters, x)
}

/// Standard normal draws (Box–Muller on ChaCha's uniforms: the same on every platform).
pub(crate) fn normals(rng: &mut rand_chacha::ChaCha8Rng, n: usize) -> Vec<f64> {
    (0..n)
        .map(|_| {
            let (u1, u2): (f64, f64) = (rng.random(), rng.random());
            (-2.0 * (1.0 - u1).ln()).sqrt() * (std::f64::consts::TAU * u2).cos()
        })
        .collect()
}

/// The voxel a probe at `p` (m) reads: the replay's (within one voxel edge), else the nearest
/// active one within 1.5 edges. A twin's coarser grid may lay a one-voxel wall whose centres
/// lie a whole edge from its face, where a camera's points are (the GAMMA wall at 2 mm).
pub fn probe_voxel(model: &thermal::voxel::VoxelModel, p: [f64; 3], edge: f64) -> Option<u32> {
    model.voxel_near(p).or_else(|| {
        model
            .voxels_within(p, 1.5 * edge)
            .into_iter()
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .map(|(v, _)| v)
    })
}

/// The temperature `run` has at probe `p` (m), K ([`probe_voxel`]'s), where one is active
/// there.
pub fn probe_k(run: &ModelRun, p: [f64; 3], edge: f64) -> Option<f64> {
    match run {
        ModelRun::Voxel(v) => probe_voxel(v.model(), p, edge).map(|c| v.model().temperature(c)),
        ModelRun::ThinWall(_) => None,
    }
}

impl<'a> Twin<'a> {
    /// Draw the members from `priors` (seeded: the same members every run) and start them
    /// and the open loop at the program's first arc. The replay's probes are read from the
    /// members' fields, not traced (`r.probes` only says where).
    pub fn new(
        r: &'a Replay,
        settings: Settings,
        priors: Vec<Uncertain>,
    ) -> Result<Twin<'a>, Error> {
        if r.values.thermal.model != super::params::ThermalModel::Voxel {
            return Err(Error::Measured(
                "the twin corrects the voxel model's field; expected [thermal] model = \"voxel\""
                    .into(),
            ));
        }
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(settings.seed);
        let quiet = Replay {
            probes: Vec::new(),
            ..r.clone()
        };
        let draws: Vec<Vec<f64>> = (0..settings.ensemble)
            .map(|_| {
                let z = normals(&mut rng, priors.len());
                priors
                    .iter()
                    .zip(z)
                    .map(|(u, z)| u.value(u.unit(u.mean) + z * u.sd / (u.range.high - u.range.low)))
                    .collect()
            })
            .collect();
        let members = draws
            .into_par_iter()
            .map(|values| {
                let (_, run) = quiet.start(&values_of(r, &priors, &values))?;
                Ok(Member { values, run })
            })
            .collect::<Result<Vec<Member>, Error>>()?;
        let (_, open_loop) = quiet.start(&r.values)?;
        let floor = priors
            .iter()
            .enumerate()
            .map(|(k, u)| {
                let z: Vec<f64> = members.iter().map(|m| u.logit(m.values[k])).collect();
                PARAMETER_FLOOR * enkf::spread(&z)
            })
            .collect();
        Ok(Twin {
            r,
            deps: r.deps.clone(),
            settings,
            priors,
            state: State {
                members,
                open_loop,
                last_analysis_s: f64::NEG_INFINITY,
                last_learned_s: f64::NEG_INFINITY,
                innovation_var: 0.0,
                floor,
                analyses: 0,
                assimilated: 0,
                innovation_sq: 0.0,
            },
        })
    }

    /// The running variance of the innovations, K²: the twin's error at the sensors.
    pub fn innovation_var(&self) -> f64 {
        self.state.innovation_var
    }

    /// The build time the twin stands at, s.
    pub fn now(&self) -> f64 {
        self.state.open_loop.now()
    }

    /// A member's heat against the schedule's, from its values: its efficiency over the
    /// scenario's (1 where the efficiency is not uncertain).
    fn heat_scale(&self) -> impl Fn(&[f64]) -> f64 + Sync + use<> {
        let eff = self.r.values.efficiency;
        let at = self
            .priors
            .iter()
            .position(|u| u.parameter == Parameter::Efficiency);
        move |values: &[f64]| at.map_or(1.0, |k| values[k] / eff)
    }

    /// The schedule the members run.
    pub fn deps(&self) -> &[thermal::schedule::Deposit] {
        &self.deps
    }

    /// Run the members on `deps` from now on: the same deposits, those not yet laid at other
    /// times and heats (a machine log's word, [`asrun`]).
    pub fn reschedule(&mut self, deps: Vec<thermal::schedule::Deposit>) {
        debug_assert_eq!(deps.len(), self.deps.len());
        self.deps = deps;
    }

    /// Run the members and the open loop on to `t_s` (the schedule's deposits up to then).
    pub fn advance(&mut self, t_s: f64) -> Result<(), Error> {
        let (deps, scale) = (&self.deps, self.heat_scale());
        let state = &mut self.state;
        // The open loop last, at the schedule's own heat: one program with the members, so
        // one batch on a GPU.
        let scales: Vec<f64> = state.members.iter().map(|m| scale(&m.values)).collect();
        let runs = state
            .members
            .iter_mut()
            .map(|m| &mut m.run)
            .chain([&mut state.open_loop])
            .collect();
        thermal::run::together(runs, |k, run| {
            let s = scales.get(k).copied().unwrap_or(1.0);
            replay::advance_scaled(run, deps, t_s, s, &mut |_| {})
        })?;
        Ok(())
    }

    /// Per prior parameter: the ensemble's mean and spread, in the parameter's unit.
    pub fn parameters(&self) -> Vec<(Parameter, f64, f64)> {
        (0..self.priors.len())
            .map(|k| {
                let x: Vec<f64> = self.state.members.iter().map(|m| m.values[k]).collect();
                (self.priors[k].parameter, enkf::mean(&x), enkf::spread(&x))
            })
            .collect()
    }

    /// Assimilate the readings taken at `t_s` (probe, K), the ensemble run on to `t_s` first.
    /// Readings closer than `assimilate_every_s` after the last analysis only move the clock.
    /// Whether an analysis was made.
    pub fn assimilate(&mut self, t_s: f64, readings: &[(usize, f64)]) -> Result<bool, Error> {
        self.advance(t_s)?;
        let every = self.settings.assimilate_every_s;
        if readings.is_empty() || t_s < self.state.last_analysis_s + every {
            return Ok(false);
        }
        self.state.last_analysis_s = t_s;
        self.state.analyses += 1;
        let learn = t_s >= self.state.last_learned_s + self.settings.parameters_every_s;
        if learn {
            self.state.last_learned_s = t_s;
        }
        // The parameters' logits, per parameter, per member.
        let mut params: Vec<Vec<f64>> = (0..self.priors.len())
            .map(|k| {
                let u = &self.priors[k];
                self.state
                    .members
                    .iter()
                    .map(|m| u.logit(m.values[k]))
                    .collect()
            })
            .collect();
        let params_before: Vec<f64> = params.iter().map(|x| enkf::spread(x)).collect();
        let (c, r2) = (
            self.settings.localisation_m,
            self.settings.reading_sd_k.powi(2),
        );
        let ambient = self.r.values.thermal.ambient_k;
        for &(k, y) in readings {
            let p = self.r.probes[k];
            let ModelRun::Voxel(first) = &self.state.members[0].run else {
                continue;
            };
            let Some(at) = probe_voxel(first.model(), p, self.r.values.thermal.voxel_m) else {
                continue;
            };
            let region = first.model().voxels_within(p, 2.0 * c);
            let read = |v: u32| -> Vec<f64> {
                self.state
                    .members
                    .iter()
                    .map(|m| match &m.run {
                        ModelRun::Voxel(r) => r.model().temperature(v),
                        ModelRun::ThinWall(_) => f64::NAN,
                    })
                    .collect()
            };
            let hx = read(at);
            if learn {
                // What the reading says of a parameter is weighed by the model's own error at
                // the sensors (the innovations' running variance), not the thermocouple's:
                // the field's error is no noise that averages out over readings.
                let r_model = r2.max(self.state.innovation_var);
                let ones = vec![1.0; params.len()];
                enkf::assimilate(&mut params, &ones, &hx, y, r_model);
            }
            let mut field: Vec<Vec<f64>> = region.iter().map(|&(v, _)| read(v)).collect();
            let before: Vec<f64> = field.iter().map(|x| enkf::spread(x)).collect();
            let rho: Vec<f64> = region
                .iter()
                .map(|&(_, d)| enkf::gaspari_cohn(d, c))
                .collect();
            let Some(d) = enkf::assimilate(&mut field, &rho, &hx, y, r2) else {
                continue;
            };
            self.state.assimilated += 1;
            self.state.innovation_sq += d * d;
            self.state.innovation_var = match self.state.assimilated {
                1 => d * d,
                _ => {
                    INNOVATION_MEMORY * self.state.innovation_var
                        + (1.0 - INNOVATION_MEMORY) * d * d
                }
            };
            enkf::relax(&mut field, &before, self.settings.relaxation);
            for (j, m) in self.state.members.iter_mut().enumerate() {
                let ModelRun::Voxel(run) = &mut m.run else {
                    continue;
                };
                for (x, &(v, _)) in field.iter().zip(&region) {
                    // A correction never takes metal below the room it stands in, nor past
                    // the tables' end.
                    run.model_mut()
                        .set_temperature(v, x[j].clamp(ambient - 50.0, 3999.0));
                }
            }
        }
        if !learn {
            return Ok(true);
        }
        enkf::relax(&mut params, &params_before, self.settings.relaxation);
        enkf::at_least(&mut params, &self.state.floor);
        for (j, m) in self.state.members.iter_mut().enumerate() {
            for (k, u) in self.priors.iter().enumerate() {
                m.values[k] = u.of_logit(params[k][j]);
            }
            let v = values_of(self.r, &self.priors, &m.values);
            let t = &v.thermal;
            m.run
                .set_losses(t.convection_w_m2k, t.emissivity, t.table_contact_w_m2k);
        }
        Ok(true)
    }

    /// `read` of every member as it stands.
    pub fn read_members<T>(&self, read: &dyn Fn(&ModelRun) -> T) -> Vec<T> {
        self.state.members.iter().map(|m| read(&m.run)).collect()
    }

    /// Run a copy of every member and of the open loop through `targets` (ascending, none
    /// before now), reading `read` at each: per target, the members' values and the open
    /// loop's. The twin itself does not move.
    pub fn forecast<T: Send>(
        &self,
        targets: &[f64],
        read: &(dyn Fn(&ModelRun) -> T + Sync),
    ) -> Result<Vec<(Vec<T>, T)>, Error> {
        let (deps, scale) = (&self.deps, self.heat_scale());
        let runs: Vec<(ModelRun, f64)> = self
            .state
            .members
            .iter()
            .map(|m| (m.run.clone(), scale(&m.values)))
            .chain([(self.state.open_loop.clone(), 1.0)])
            .collect();
        let (mut runs, scales): (Vec<ModelRun>, Vec<f64>) = runs.into_iter().unzip();
        let per_run = thermal::run::together(runs.iter_mut().collect(), |k, run| {
            targets
                .iter()
                .map(|&t| {
                    replay::advance_scaled(run, deps, t, scales[k], &mut |_| {})?;
                    Ok(read(run))
                })
                .collect::<Result<Vec<T>, Error>>()
        })?;
        let mut per_run: Vec<std::vec::IntoIter<T>> =
            per_run.into_iter().map(|v| v.into_iter()).collect();
        let open = per_run.pop().expect("the open loop's run");
        let mut members = per_run;
        Ok(open
            .map(|o| {
                let m: Vec<T> = members
                    .iter_mut()
                    .map(|it| it.next().expect("a value per target"))
                    .collect();
                (m, o)
            })
            .collect())
    }

    /// Per member, `read` once it has run to `start_s`, cooled `dwell_s` with the arc off and
    /// run on through the program to `end_s + dwell_s`: what a dwell before the layer from
    /// `start_s` to `end_s` would make of it. The program after the dwell is laid back to back
    /// (its own pauses inside the layer dropped: this is for a layer the program runs without
    /// one, a spiral's revolution). The twin itself does not move.
    pub fn through_layer(
        &self,
        layer_s: (f64, f64),
        dwell_s: f64,
        read: &(dyn Fn(&ModelRun) -> f64 + Sync),
    ) -> Result<Vec<f64>, Error> {
        self.through_layer_after(layer_s, Before::Dwell(dwell_s), read)
    }

    /// Per member, `read` once it has run to `start_s`, all its metal and the plate been
    /// brought to ambient (`HeatRun::quench`) and it has run on through the program to
    /// `end_s`: the coolest any dwell before the layer could leave it. Where the layer is over
    /// a limit even so, no dwell brings it under (a cooler part makes a lower preheat and a
    /// shorter pool: the assumption the dwell search makes too). The twin itself does not move.
    pub fn through_layer_quenched(
        &self,
        layer_s: (f64, f64),
        read: &(dyn Fn(&ModelRun) -> f64 + Sync),
    ) -> Result<Vec<f64>, Error> {
        self.through_layer_after(layer_s, Before::Quenched, read)
    }

    fn through_layer_after(
        &self,
        (start_s, end_s): (f64, f64),
        before: Before,
        read: &(dyn Fn(&ModelRun) -> f64 + Sync),
    ) -> Result<Vec<f64>, Error> {
        let (deps, scale) = (&self.deps, self.heat_scale());
        let members = &self.state.members;
        let mut runs: Vec<ModelRun> = members.iter().map(|m| m.run.clone()).collect();
        thermal::run::together(runs.iter_mut().collect(), |k, run| {
            let s = scale(&members[k].values);
            replay::advance_scaled(run, deps, start_s, s, &mut |_| {})?;
            let dwell_s = match before {
                Before::Dwell(d) => d,
                Before::Quenched => {
                    run.quench();
                    0.0
                }
            };
            if dwell_s > 0.0 {
                run.cool(dwell_s)?;
            }
            replay::advance_scaled(run, deps, end_s + dwell_s, s, &mut |_| {})?;
            Ok(read(run))
        })
    }

    /// The members cooled from `from_s` with the arc off, `step_s` at a time up to `max_s`,
    /// until `read`'s 95th percentile over them is at most `limit`: the dwell that takes (s),
    /// or None where `max_s` is not enough. The members are first run to `from_s` on copies.
    pub fn dwell_until(
        &self,
        from_s: f64,
        read: &(dyn Fn(&ModelRun) -> f64 + Sync),
        limit: f64,
        step_s: f64,
        max_s: f64,
    ) -> Result<Option<f64>, Error> {
        let (deps, scale) = (&self.deps, self.heat_scale());
        let members = &self.state.members;
        let mut runs: Vec<ModelRun> = members.iter().map(|m| m.run.clone()).collect();
        thermal::run::together(runs.iter_mut().collect(), |k, run| {
            let s = scale(&members[k].values);
            replay::advance_scaled(run, deps, from_s, s, &mut |_| {})
        })?;
        let mut waited = 0.0;
        loop {
            let values: Vec<f64> = runs.iter().map(read).collect();
            if quantile(&values, 0.95) <= limit {
                return Ok(Some(waited));
            }
            if waited >= max_s {
                return Ok(None);
            }
            thermal::run::together(runs.iter_mut().collect(), |_, r| r.cool(step_s))?;
            waited += step_s;
        }
    }
}

/// What the members go through between a layer's start and their running through it.
#[derive(Clone, Copy)]
enum Before {
    /// A dwell of so many seconds with the arc off.
    Dwell(f64),
    /// Brought to ambient at once.
    Quenched,
}

/// The q-quantile of `v` (linear between order statistics), NaN-free input.
pub fn quantile(v: &[f64], q: f64) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let x = q * (s.len() - 1) as f64;
    let (i, f) = (x.floor() as usize, x - x.floor());
    match s.get(i + 1) {
        Some(&b) => s[i] + f * (b - s[i]),
        None => s[i],
    }
}

#[cfg(test)]
mod tests {
    use super::follow::Follower;
    use super::*;
    use crate::pipeline::replay::{Laying, fixtures};
    use thermal::ZERO_CELSIUS_K as C;
    use thermal::material::Material;
    use thermal::voxel::HeatSource;

    /// Eight tracks of 30 mm one way on a small plate, two thermocouples beside the wall.
    fn wall() -> Replay {
        let path = fixtures::tracks(8, 15.0, 5.0, 15.0);
        let laying = Laying {
            power_w: 1500.0,
            efficiency: 0.8,
            width_m: 4e-3,
            height_m: 1.5e-3,
            deposit_m: 2e-3,
        };
        let thermal = fixtures::voxel_settings([50e-3, 30e-3, 6e-3]);
        let probes = vec![[-8e-3, 6e-3, 0.0], [8e-3, 6e-3, 0.0]];
        Replay::new(
            &path,
            &laying,
            &thermal,
            (Material::g3si(), None),
            HeatSource::DoubleEllipsoid,
            probes,
            0.5,
        )
        .unwrap()
    }

    /// The prior the tests' twins hold: the efficiency 0.8 ± 0.1 in [0.3, 0.95].
    fn efficiency_prior() -> Uncertain {
        Uncertain {
            parameter: Parameter::Efficiency,
            range: Range {
                low: 0.3,
                high: 0.95,
            },
            mean: 0.8,
            sd: 0.1,
        }
    }

    /// What the dwell search's shortcut (`Twin::through_layer_quenched`, `follow`'s advice)
    /// stands on: a track laid on the part brought to ambient reads a lower preheat and a
    /// shorter melt pool, member by member, than laid after no dwell, half a minute's or an
    /// hour's.
    #[test]
    fn a_track_laid_on_the_quenched_part_is_the_coolest_any_dwell_leaves() {
        let r = wall();
        let prior = efficiency_prior();
        let settings = Settings {
            ensemble: 4,
            ..Settings::default()
        };
        let twin = Twin::new(&r, settings, vec![prior]).unwrap();
        let d = &r.deps;
        let starts: Vec<usize> = (1..d.len())
            .filter(|&i| d[i].arc_start() - d[i - 1].time > 1.0)
            .collect();
        let (first, last) = (starts[4], starts[5] - 1);
        let layer_s = (d[first].arc_start(), d[last].time);
        // The mean, not the hottest: on this small wall the hottest preheat is the track's own
        // heat ahead of the torch, the same after any dwell.
        let preheat = |run: &ModelRun| -> f64 {
            (first..=last).map(|i| run.points()[i].preheat).sum::<f64>() / (last + 1 - first) as f64
        };
        let pool = |run: &ModelRun| -> f64 {
            (first..=last)
                .map(|i| run.points()[i].pool_length)
                .fold(f64::NEG_INFINITY, f64::max)
        };
        type Read<'r> = &'r (dyn Fn(&ModelRun) -> f64 + Sync);
        let reads: [(&str, Read); 2] = [("preheat K", &preheat), ("pool m", &pool)];
        for (name, read) in reads {
            let coolest = twin.through_layer_quenched(layer_s, read).unwrap();
            let after: Vec<Vec<f64>> = [0.0, 30.0, 3600.0]
                .iter()
                .map(|&dwell_s| twin.through_layer(layer_s, dwell_s, read).unwrap())
                .collect();
            for (dwell_s, a) in [0.0, 30.0, 3600.0].iter().zip(&after) {
                for (c, a) in coolest.iter().zip(a) {
                    assert!(c <= a, "{name}: quenched {c:.4}, after {dwell_s} s {a:.4}");
                }
            }
            // Not a bound by being equal: with no dwell the track is laid on hot metal.
            assert!(
                coolest.iter().zip(&after[0]).all(|(c, h)| c < h),
                "{name}: quenched {coolest:?}, no dwell {:?}, an hour {:?}",
                after[0],
                after[2]
            );
        }
    }

    /// A follow kept part-way (its state written from borrows, `Follower::kept`) and read back
    /// owned goes on as the follow that was not stopped: the same forecasts, analyses and
    /// learned values to the bit. The command's resume test cannot tell a state that no longer
    /// reads (its stage starts again, to the same files); this one can.
    #[test]
    fn a_kept_follow_read_back_goes_on_as_the_one_not_stopped() {
        let r = wall();
        let (deps, mut truth) = r
            .start(&r.values.with(&[Parameter::Efficiency], &[0.6]))
            .unwrap();
        let settings = Settings {
            ensemble: 4,
            forecast_every_s: 5.0,
            horizons_s: vec![5.0],
            ..Settings::default()
        };
        let prior = efficiency_prior();
        let twin = || Twin::new(&r, settings.clone(), vec![prior]).unwrap();
        let rows: Vec<(f64, Vec<Option<f64>>)> = (1..=60)
            .map(|k| {
                let t = 0.5 * k as f64;
                replay::advance(&mut truth, &deps, t).unwrap();
                let row = r
                    .probes
                    .iter()
                    .map(|&p| probe_k(&truth, p, 2e-3).map(|k| k - C));
                (t, row.collect())
            })
            .collect();
        let mut whole = Follower::new(twin(), &r.deps, 2);
        let mut bytes = Vec::new();
        for (k, (t, row)) in rows.iter().enumerate() {
            whole.feed(*t, row).unwrap();
            if k == 29 {
                bytes = postcard::to_stdvec(&whole.kept()).unwrap();
            }
        }
        let kept: follow::KeptOwned = postcard::from_bytes(&bytes).unwrap();
        let mut resumed = Follower::resume(twin(), &r.deps, kept);
        for (t, row) in &rows[30..] {
            resumed.feed(*t, row).unwrap();
        }
        assert!(whole.progress.forecasts.len() > 5);
        let json = |f: &Follower| {
            let learned: Vec<(f64, f64)> = f.twin.parameters().iter().map(|p| (p.1, p.2)).collect();
            serde_json::to_string(&(&f.progress, learned, f.twin.state.analyses)).unwrap()
        };
        assert_eq!(json(&whole), json(&resumed));
    }

    /// An identical-twin experiment, the standard check of a filter: readings made by the
    /// model itself at efficiency 0.55 (the truth), a twin whose prior believes 0.8 ± 0.1.
    /// The twin's efficiency moves toward the truth and its 10 s forecasts come nearer the
    /// truth's readings than the open loop's (at 0.8, corrected by nothing).
    #[test]
    fn an_identical_twin_learns_the_efficiency_and_forecasts_better_than_the_open_loop() {
        let r = wall();
        let truth_values = r.values.with(&[Parameter::Efficiency], &[0.55]);
        let (deps, mut truth) = r.start(&truth_values).unwrap();
        let settings = Settings {
            ensemble: 12,
            reading_sd_k: 1.0,
            localisation_m: 0.02,
            parameters_every_s: 5.0,
            forecast_every_s: 10.0,
            horizons_s: vec![10.0],
            ..Settings::default()
        };
        let prior = efficiency_prior();
        let twin = Twin::new(&r, settings, vec![prior]).unwrap();
        let mut f = Follower::new(twin, &r.deps, 2);
        let end = deps.last().unwrap().time + 20.0;
        let mut t = 0.5;
        while t <= end {
            replay::advance(&mut truth, &deps, t).unwrap();
            let readings: Vec<Option<f64>> = r
                .probes
                .iter()
                .map(|&p| probe_k(&truth, p, 2e-3).map(|k| k - C))
                .collect();
            f.feed(t, &readings).unwrap();
            t += 0.5;
        }
        let (_, learned, _) = f.twin.parameters()[0];
        assert!(
            learned < 0.7,
            "efficiency {learned:.3}: not moved from 0.8 toward 0.55"
        );
        let (mut twin_sq, mut open_sq, mut n) = (0.0, 0.0, 0);
        for x in f.progress.forecasts.iter().filter(|x| x.made_at_s > 40.0) {
            if let Some(m) = x.measured_c {
                twin_sq += (x.ensemble_c - m).powi(2);
                open_sq += (x.open_loop_c - m).powi(2);
                n += 1;
            }
        }
        assert!(n > 10, "{n} forecasts verified");
        let (twin, open) = ((twin_sq / n as f64).sqrt(), (open_sq / n as f64).sqrt());
        assert!(
            twin < 0.5 * open,
            "10 s forecasts: twin {twin:.2} °C, open loop {open:.2} °C"
        );
    }
}
