//! A replay set up once and run at any parameters: what replay, calibrate and follow share.
//!
//! The schedule is cut once (its supports found once, binned); a run at another
//! efficiency rescales its heat (η·P·t is linear in η), one at other losses builds its model
//! with them. The measurements come in as a [`Series`] the commands read; nothing here touches
//! a file.

use super::compare::{Agreement, Pass, Sample, agreement, pair, pass_starts, passes};
use super::schedule::{Laying, deposits};
use crate::measured::probes::Series;
use crate::measured::toolpath::Waypoint;
use crate::pipeline::Error;
use crate::pipeline::checkpoint::Checkpoints;
use crate::pipeline::deposition::heat_model_of;
use crate::pipeline::params::ThermalSettings;
use thermal::ZERO_CELSIUS_K as C;
use thermal::material::Material;
use thermal::run::{ProbeTrace, RunResult};
use thermal::schedule::Deposit;
use thermal::voxel::HeatSource;
use thermal::{HeatRun, ModelRun};

/// A parameter a calibration fits and the twin learns.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Parameter {
    Efficiency,
    Convection,
    Emissivity,
    TableContact,
}

impl Parameter {
    pub const ALL: [Parameter; 4] = [
        Parameter::Efficiency,
        Parameter::Convection,
        Parameter::Emissivity,
        Parameter::TableContact,
    ];

    /// Its key, as in the scenario's sections.
    pub fn key(self) -> &'static str {
        match self {
            Parameter::Efficiency => "efficiency",
            Parameter::Convection => "convection_w_m2k",
            Parameter::Emissivity => "emissivity",
            Parameter::TableContact => "table_contact_w_m2k",
        }
    }

    /// The widest range it may be searched over.
    pub fn limits(self) -> [f64; 2] {
        match self {
            Parameter::Efficiency | Parameter::Emissivity => [0.01, 1.0],
            Parameter::Convection | Parameter::TableContact => [0.0, 10_000.0],
        }
    }

    /// Its value in `v`.
    pub fn of(self, v: &Values) -> f64 {
        match self {
            Parameter::Efficiency => v.efficiency,
            Parameter::Convection => v.thermal.convection_w_m2k,
            Parameter::Emissivity => v.thermal.emissivity,
            Parameter::TableContact => v.thermal.table_contact_w_m2k,
        }
    }

    /// `v` with this parameter at `x`.
    pub fn set(self, v: &mut Values, x: f64) {
        match self {
            Parameter::Efficiency => v.efficiency = x,
            Parameter::Convection => v.thermal.convection_w_m2k = x,
            Parameter::Emissivity => v.thermal.emissivity = x,
            Parameter::TableContact => v.thermal.table_contact_w_m2k = x,
        }
    }
}

/// The values a replay runs at: the arc efficiency (or absorptivity) and the heat model's
/// settings, losses included.
#[derive(Debug, Clone, PartialEq)]
pub struct Values {
    pub efficiency: f64,
    pub thermal: ThermalSettings,
}

impl Values {
    /// These values with `parameters` at `x`.
    pub fn with(&self, parameters: &[Parameter], x: &[f64]) -> Values {
        let mut v = self.clone();
        for (p, &x) in parameters.iter().zip(x) {
            p.set(&mut v, x);
        }
        v
    }
}

/// A replay's fixed inputs: what every run of it shares.
#[derive(Debug, Clone)]
pub struct Replay {
    /// The path laid at the scenario's values.
    pub deps: Vec<Deposit>,
    /// The scenario's own values (what an open loop runs at).
    pub values: Values,
    pub material: Material,
    /// The plate's own material, where it is not the deposit's.
    pub plate_material: Option<Material>,
    pub source: HeatSource,
    /// Where the probes are, m.
    pub probes: Vec<[f64; 3]>,
    /// How often the probes are kept, s.
    pub every_s: f64,
}

impl Replay {
    /// The replay of `path` laid as `laying` says, heated with `thermal`: an error where no
    /// segment lays metal.
    pub fn new(
        path: &[Waypoint],
        laying: &Laying,
        thermal: &ThermalSettings,
        materials: (Material, Option<Material>),
        source: HeatSource,
        probes: Vec<[f64; 3]>,
        every_s: f64,
    ) -> Result<Replay, Error> {
        let deps = deposits(path, laying);
        if deps.is_empty() {
            return Err(Error::Measured(
                "no segment of the toolpath lays metal (every `on` is 0); expected at least one"
                    .into(),
            ));
        }
        Ok(Replay {
            deps,
            values: Values {
                efficiency: laying.efficiency,
                thermal: thermal.clone(),
            },
            material: materials.0,
            plate_material: materials.1,
            source,
            probes,
            every_s,
        })
    }

    /// The schedule at `efficiency`: the scenario's, its heat rescaled.
    pub fn deposits_at(&self, efficiency: f64) -> Vec<Deposit> {
        let scale = efficiency / self.values.efficiency;
        self.deps
            .iter()
            .map(|d| Deposit {
                heat: d.heat * scale,
                ..*d
            })
            .collect()
    }

    /// The model for the whole path at `v`, at the first arc: what [`super::advance`] drives,
    /// and a clone of it a checkpoint to go on from.
    pub fn start(&self, v: &Values) -> Result<(Vec<Deposit>, ModelRun), Error> {
        let deps = self.deposits_at(v.efficiency);
        let mut model = heat_model_of(self.material.clone(), &v.thermal, &deps, vec![], vec![]);
        model.set_probes(self.probes.clone(), self.every_s);
        model.set_source(self.source);
        model.set_plate_material(self.plate_material.clone());
        let run = model.start(&deps)?;
        Ok((deps, run))
    }

    /// Heat the path at `v` from the start until `until_s` (cooling after the last deposit if
    /// that comes later; deposits after it left out): the deposits laid and what the model
    /// made of them. The run is kept under `progress` as it goes, and taken from there.
    pub fn run_kept(
        &self,
        v: &Values,
        until_s: f64,
        ck: &mut Checkpoints<'_>,
        progress: &str,
    ) -> Result<(Vec<Deposit>, RunResult), Error> {
        let (deps, mut run) = match ck.load::<(Vec<Deposit>, ModelRun)>(progress) {
            Some(kept) => kept,
            None => self.start(v)?,
        };
        advance_kept(&mut run, &deps, until_s, ck, progress)?;
        let laid = run.laid();
        Ok((deps[..laid].to_vec(), run.finish()))
    }
}

/// What a replay found ([`Replay::replay`]).
#[derive(Debug, Clone)]
pub struct Replayed {
    /// The deposits laid, and what the model made of them.
    pub deps: Vec<Deposit>,
    pub result: RunResult,
    /// Wall-clock seconds of the heat run.
    pub wall_s: f64,
    /// The run's end: the last deposit or the last reading, whichever is later, s.
    pub until_s: f64,
    /// The window the agreement is judged over, s.
    pub window_s: [f64; 2],
    /// Per probe, its readings against the model ([`compare`]); empty without readings.
    pub compared: Vec<Compared>,
}

impl Replay {
    /// The replay command's work: the path heated at the scenario's values until its last
    /// deposit or the last reading, whichever is later, and each probe named in `measured`
    /// (its names, the series in °C) held against its readings over `window_s` (absent: the
    /// whole run). The heat run is kept under the stage `heat`, and taken from there.
    pub fn replay(
        &self,
        measured: Option<(&[String], &Series)>,
        window_s: Option<[f64; 2]>,
        ck: &mut Checkpoints<'_>,
    ) -> Result<Replayed, Error> {
        let end_s = self.deps.last().map_or(0.0, |d| d.time);
        let until_s = measured
            .and_then(|(_, m)| m.t_s.last().copied())
            .map_or(end_s, |t| t.max(end_s));
        let ((deps, result), wall_s) = ck.stage("heat", |ck, progress| {
            self.run_kept(&self.values, until_s, ck, progress)
        })?;
        let window_s = window_s.unwrap_or([0.0, until_s]);
        let compared = match measured {
            Some((names, m)) => compare(names, m, &result.probes, window_s, &pass_starts(&deps)),
            None => Vec::new(),
        };
        Ok(Replayed {
            deps,
            result,
            wall_s,
            until_s,
            window_s,
            compared,
        })
    }
}

/// [`super::advance`] with `run` (on `deps`) kept under `progress` when the interval has passed.
pub fn advance_kept(
    run: &mut ModelRun,
    deps: &[Deposit],
    until_s: f64,
    ck: &mut Checkpoints<'_>,
    progress: &str,
) -> Result<(), Error> {
    super::advance_observed(run, deps, until_s, &mut |r| {
        ck.save_if_due(progress, || (deps, r));
    })?;
    Ok(())
}

/// Readings this far below ambient are not of the part (an IR camera reads 80 K from a pixel
/// that metal only partly fills): they count as no reading.
pub const BELOW_AMBIENT_K: f64 = 5.0;

/// A series as read, put in °C (`kelvin`: the file's unit) and rid of readings below ambient;
/// how many were dropped.
pub fn in_celsius(s: &mut Series, kelvin: bool, ambient_k: f64) -> usize {
    let floor_c = ambient_k - C - BELOW_AMBIENT_K;
    let mut dropped = 0;
    for v in s.values.iter_mut().flatten() {
        if let Some(x) = v {
            if kelvin {
                *x -= C;
            }
            if *x < floor_c {
                *v = None;
                dropped += 1;
            }
        }
    }
    dropped
}

/// The measured series' shortest step: the model keeps its probes at least that often.
pub fn sampling_interval(t_s: &[f64]) -> f64 {
    t_s.windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min)
        .min(1.0)
}

/// One probe's comparison.
#[derive(Debug, Clone)]
pub struct Compared {
    pub name: String,
    pub samples: Vec<Sample>,
    pub agreement: Option<Agreement>,
    /// Each pass of the torch as this probe saw it.
    pub passes: Vec<Pass>,
}

/// Each named probe's measurements against its trace, judged over `window`, its passes cut
/// at `starts`.
pub fn compare(
    names: &[String],
    m: &Series,
    traces: &[ProbeTrace],
    window: [f64; 2],
    starts: &[f64],
) -> Vec<Compared> {
    names
        .iter()
        .zip(&m.values)
        .zip(traces)
        .map(|((name, values), trace)| {
            let samples = pair(&m.t_s, values, trace);
            Compared {
                name: name.clone(),
                agreement: agreement(&samples, (window[0], window[1])),
                passes: passes(&samples, starts),
                samples,
            }
        })
        .collect()
}

/// RMS over every sample of every probe in the window, and how many.
pub fn overall(c: &[Compared]) -> Option<(f64, usize)> {
    let (sq, n) = c
        .iter()
        .filter_map(|c| c.agreement.as_ref())
        .fold((0.0, 0), |(sq, n), a| {
            (sq + a.rms_c * a.rms_c * a.samples as f64, n + a.samples)
        });
    (n > 0).then(|| ((sq / n as f64).sqrt(), n))
}
