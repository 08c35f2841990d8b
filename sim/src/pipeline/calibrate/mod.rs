//! Calibration of a replay against its probes (no IO): up to three parameters fitted by least
//! squares ([`lm`]) over a fit window, each evaluation a run of the heat model stopped at the
//! window's end.
//!
//! A fit run stops at the end of the fit window: the model is the same up to there whatever
//! comes after, so a fit over the first half of a build costs half a build per run. Every
//! parameter acts from the first deposit on, so no fit run can start later than t = 0; but the
//! runs with the starting values and with the fitted ones are kept where they stopped
//! (checkpoints), and the held-out window is reached by going on from them rather than by two
//! runs from the start.
//!
//! A replay then a calibration from Rust, without a scenario file: a small wall's tracks on the
//! voxel model, "measured" by a thermocouple on the plate in a run at 80 % efficiency, and the
//! efficiency fitted back from 60 % on the first half of the build.
//!
//! ```
//! use sim::measured::{probes::Series, toolpath::Waypoint};
//! use sim::pipeline::calibrate::{Range, Task, calibrate};
//! use sim::pipeline::checkpoint::Checkpoints;
//! use sim::pipeline::params::{ThermalModel, ThermalSettings};
//! use sim::pipeline::replay::{Laying, Parameter, Replay};
//!
//! let track = |k: usize, t: f64, x: f64, on| {
//!     Waypoint { t_s: 20.0 * k as f64 + t, position_mm: [x, 0.0, 1.5 * (k + 1) as f64], on, power_w: None }
//! };
//! let path: Vec<Waypoint> =
//!     (0..6).flat_map(|k| [track(k, 0.0, -15.0, false), track(k, 6.0, 15.0, true)]).collect();
//! let laying = Laying { power_w: 1500.0, efficiency: 0.6, width_m: 4e-3, height_m: 1.5e-3, deposit_m: 2e-3 };
//! let thermal = ThermalSettings {
//!     model: ThermalModel::Voxel, plate_m: [0.06, 0.03, 0.008], plate_fit: false, ..Default::default()
//! };
//! let g3si = (thermal::material::Material::g3si(), None);
//! let thermocouple = vec![[0.0, 0.008, 0.0]]; // on the plate's top, 8 mm beside the wall, m
//! let r = Replay::new(&path, &laying, &thermal, g3si, Default::default(), thermocouple, 1.0)?;
//!
//! // The "measured" build: the same path at 80 % efficiency, its probe in °C.
//! let truth = r.values.with(&[Parameter::Efficiency], &[0.8]);
//! let (_, run) = r.run_kept(&truth, 120.0, &mut Checkpoints::off(), "")?;
//! let p = &run.probes[0];
//! let measured = Series {
//!     t_s: p.time.clone(),
//!     values: vec![p.temperature.iter().map(|k| Some(thermal::celsius(*k))).collect()],
//! };
//! let efficiency = (Parameter::Efficiency, Range { low: 0.3, high: 0.95 });
//! let task = Task { parameters: vec![efficiency], fit_s: [0.0, 60.0], end_s: 120.0, max_runs: 12 };
//! let c = calibrate(&r, &measured, &task, &mut Checkpoints::off())?;
//! assert!((c.fit.values[0] - 0.8).abs() < 0.01, "{:?}", c.fit);
//! # Ok::<(), sim::pipeline::Error>(())
//! ```

pub mod lm;

pub use lm::{Fit, Range, Settings, fit, fit_batched};

use super::Error;
use super::checkpoint::Checkpoints;
use super::replay::{self, Parameter, Replay, advance_kept};
use crate::measured::probes::Series;
use serde::{Deserialize, Serialize};
use thermal::run::ProbeTrace;
use thermal::schedule::Deposit;
use thermal::{HeatRun, ModelRun};

/// What to fit, where, and how many runs it may take.
#[derive(Debug, Clone, PartialEq)]
pub struct Task {
    pub parameters: Vec<(Parameter, Range)>,
    /// Build time the fit is judged over, s.
    pub fit_s: [f64; 2],
    /// Build time the end of the runs reaches (the held-out window's end), s.
    pub end_s: f64,
    pub max_runs: usize,
}

/// A finished calibration: the fit, and the probes' traces over the whole build at the
/// starting and at the fitted values.
#[derive(Debug, Clone)]
pub struct Calibrated {
    pub start: Vec<f64>,
    pub fit: Fit,
    /// Measured samples inside the fit window, and how many of them count as independent.
    pub samples: usize,
    pub independent: usize,
    pub before: Vec<ProbeTrace>,
    pub after: Vec<ProbeTrace>,
}

/// A run with `values` stopped at the end of the fit window: the probes' traces so far, and
/// the run itself to go on from (its checkpoint; `None` once the fit no longer needs it).
#[derive(Clone, Serialize, Deserialize)]
struct Stopped {
    values: Vec<f64>,
    traces: Vec<ProbeTrace>,
    run: Option<ModelRun>,
    deps: Vec<Deposit>,
}

impl Stopped {
    /// The traces alone: what a checkpoint keeps of an evaluation the fit cannot end at.
    fn light(&self) -> Stopped {
        Stopped {
            values: self.values.clone(),
            traces: self.traces.clone(),
            run: None,
            deps: Vec::new(),
        }
    }
}

/// Fit `task` to the measurements `m` (°C) of `r`'s probes, kept in `ck` as it goes.
pub fn calibrate(
    r: &Replay,
    m: &Series,
    task: &Task,
    ck: &mut Checkpoints<'_>,
) -> Result<Calibrated, Error> {
    let names: Vec<Parameter> = task.parameters.iter().map(|p| p.0).collect();
    let ranges: Vec<Range> = task.parameters.iter().map(|p| p.1).collect();
    let start: Vec<f64> = names.iter().map(|p| p.of(&r.values)).collect();
    let fit_w = task.fit_s;
    // Each evaluation of the fit is a stage of its own: a run that resumes takes those done
    // and the fit, deterministic, asks for them again in the same order.
    let evaluate = |k: usize, points: &[Vec<f64>], ck: &mut Checkpoints<'_>| {
        side_by_side(k, points, ck, |values, ck, progress| {
            stopped(r, &names, values, fit_w[1], ck, progress)
        })
    };
    let first = evaluate(0, std::slice::from_ref(&start), ck)?.remove(0);
    let samples = fit_samples(m, &first.traces, fit_w);
    if samples.is_empty() {
        return Err(Error::Measured(format!(
            "no probe reads inside the fit window {fit_w:?} s; expected some samples there"
        )));
    }
    let settings = Settings {
        max_runs: task.max_runs,
        independent: independent(m, &samples),
        ..Settings::default()
    };
    // The fit ends at a point it evaluated within its last iteration or the Jacobian after
    // it (at most 2n + 2 evaluations back, n parameters): keep that many stopped runs, and the
    // first (the starting values, as the fit put them), which `before` goes on from. An
    // evaluation that drops out is kept as its traces alone.
    let keep = 2 * names.len() + 3;
    let mut recent: Vec<(usize, Stopped)> = Vec::new();
    let mut first = Some(first);
    let mut k = 0;
    let found = fit_batched(&start, &ranges, settings, |points| {
        let runs = match first.take() {
            // The first evaluation is the run made above.
            Some(f) => vec![Stopped {
                values: points[0].clone(),
                ..f
            }],
            None => evaluate(k, points, ck)?,
        };
        let mut out = Vec::with_capacity(runs.len());
        for run in runs {
            out.push(residuals(m, &run.traces, &samples));
            recent.push((k, run));
            k += 1;
            if recent.len() > keep + 1 {
                let (gone, run) = recent.remove(1);
                ck.save(&format!("evaluation-{gone}"), &run.light());
            }
        }
        Ok::<_, Error>(out)
    })?;
    let before = recent.first().map(|r| r.1.clone());
    let after = recent
        .iter()
        .rev()
        .find(|s| s.1.values == found.values)
        .map(|r| r.1.clone());
    let (before, after) = match (before, after) {
        (Some(b), Some(a)) => (b, a),
        // Not reached while `keep` holds what the fit can end at; a run from the start if so.
        (b, a) => {
            let fresh =
                |values: &[f64]| stopped(r, &names, values, fit_w[1], &mut Checkpoints::off(), "");
            (
                b.map_or_else(|| fresh(&start), Ok)?,
                a.map_or_else(|| fresh(&found.values), Ok)?,
            )
        }
    };
    drop(recent);
    // The two runs on to the build's end, side by side (the one beside held to no checkpoint,
    // as `side_by_side`'s).
    let kept = ck.done::<Vec<ProbeTrace>>("after_to_end");
    let mut made = None;
    let before = rayon::in_place_scope(|scope| {
        if kept.is_none() {
            scope.spawn(|_| {
                let clock = std::time::Instant::now();
                let run = resumed(after, task.end_s, &mut Checkpoints::off(), "");
                made = Some(run.map(|t| (t, clock.elapsed().as_secs_f64())));
            });
        }
        ck.stage("before_to_end", |ck, progress| {
            resumed(before, task.end_s, ck, progress)
        })
    });
    let before = before?.0;
    let after = match (kept, made) {
        (Some((after, _)), _) => after,
        (None, Some(made)) => {
            let (after, spent_s) = made?;
            ck.keep_done("after_to_end", &after, spent_s);
            after
        }
        (None, None) => unreachable!("the run to the end is kept or made"),
    };
    Ok(Calibrated {
        start,
        fit: found,
        samples: samples.len(),
        independent: settings.independent,
        before,
        after,
    })
}

/// The evaluations `k`, `k + 1`, … of `points`, each a stage of its own (`evaluation-K`):
/// those an earlier run kept are taken, the first of the rest made on this thread (its work
/// in progress kept as it goes), the others beside it on the pool's other threads, each kept
/// once all are done (they hold no `Checkpoints`: a kill before then makes them again, as
/// `dwell`'s baselines do). A fit's Jacobian is n runs that do not depend on each other: on two
/// cores the GAMMA wall's calibration (three parameters) takes two rounds a Jacobian, not three.
/// The runs are the same whichever thread makes them, so the fit is too.
fn side_by_side(
    k: usize,
    points: &[Vec<f64>],
    ck: &mut Checkpoints<'_>,
    run: impl Fn(&[f64], &mut Checkpoints<'_>, &str) -> Result<Stopped, Error> + Sync,
) -> Result<Vec<Stopped>, Error> {
    let stage = |i: usize| format!("evaluation-{}", k + i);
    let mut done: Vec<Option<Stopped>> = (0..points.len())
        .map(|i| ck.done::<Stopped>(&stage(i)).map(|d| d.0))
        .collect();
    let missing: Vec<usize> = (0..points.len()).filter(|&i| done[i].is_none()).collect();
    let Some((&mine, others)) = missing.split_first() else {
        return Ok(done.into_iter().flatten().collect());
    };
    let mut made: Vec<Option<Result<(Stopped, f64), Error>>> =
        others.iter().map(|_| None).collect();
    let run = &run;
    let here = rayon::in_place_scope(|scope| {
        for (slot, &i) in made.iter_mut().zip(others) {
            let values = &points[i];
            scope.spawn(move |_| {
                let clock = std::time::Instant::now();
                let result = run(values, &mut Checkpoints::off(), "");
                *slot = Some(result.map(|s| (s, clock.elapsed().as_secs_f64())));
            });
        }
        ck.stage(&stage(mine), |ck, progress| {
            run(&points[mine], ck, progress)
        })
    });
    done[mine] = Some(here?.0);
    for (slot, &i) in made.into_iter().zip(others) {
        let (s, spent_s) = slot.expect("the scope ran every task")?;
        ck.keep_done(&stage(i), &s, spent_s);
        done[i] = Some(s);
    }
    Ok(done.into_iter().flatten().collect())
}

/// Run with `values` of `parameters` from the start until `until_s`, kept under `progress`.
fn stopped(
    r: &Replay,
    parameters: &[Parameter],
    values: &[f64],
    until_s: f64,
    ck: &mut Checkpoints<'_>,
    progress: &str,
) -> Result<Stopped, Error> {
    let (deps, mut run) = match ck.load::<(Vec<Deposit>, ModelRun)>(progress) {
        Some(kept) => kept,
        None => r.start(&r.values.with(parameters, values))?,
    };
    advance_kept(&mut run, &deps, until_s, ck, progress)?;
    Ok(Stopped {
        values: values.to_vec(),
        traces: run.clone().finish().probes,
        run: Some(run),
        deps,
    })
}

/// Go on from a stopped run to `until_s`: the probes' traces from the start.
fn resumed(
    s: Stopped,
    until_s: f64,
    ck: &mut Checkpoints<'_>,
    progress: &str,
) -> Result<Vec<ProbeTrace>, Error> {
    let (deps, mut run) = match ck.load::<(Vec<Deposit>, ModelRun)>(progress) {
        Some(kept) => kept,
        None => match s.run {
            Some(run) => (s.deps, run),
            None => {
                return Err(Error::Lost(
                    "calibrate: a run the fit ended at was not kept".into(),
                ));
            }
        },
    };
    advance_kept(&mut run, &deps, until_s, ck, progress)?;
    Ok(run.finish().probes)
}

/// The measured samples (probe, index) inside `window` where the first run predicts too.
fn fit_samples(m: &Series, traces: &[ProbeTrace], window: [f64; 2]) -> Vec<(usize, usize)> {
    let mut out = Vec::new();
    for (k, (values, trace)) in m.values.iter().zip(traces).enumerate() {
        for (j, (&t, v)) in m.t_s.iter().zip(values).enumerate() {
            let inside = t >= window[0] && t <= window[1];
            if inside && v.is_some() && replay::pair(&[t], &[*v], trace).len() == 1 {
                out.push((k, j));
            }
        }
    }
    out
}

/// Predicted − measured at each fit sample (°C); 0 where the model does not read.
fn residuals(m: &Series, traces: &[ProbeTrace], samples: &[(usize, usize)]) -> Vec<f64> {
    samples
        .iter()
        .map(|&(k, j)| {
            let (t, v) = (m.t_s[j], m.values[k][j]);
            replay::pair(&[t], &[v], &traces[k])
                .first()
                .map_or(0.0, |s| s.2 - s.1)
        })
        .collect()
}

/// Samples a second apart per probe: what the intervals count as independent (an IR camera at
/// 12.5 Hz sees the same cooling curve a dozen times a second).
fn independent(m: &Series, samples: &[(usize, usize)]) -> usize {
    let mut seconds: Vec<(usize, i64)> = samples
        .iter()
        .map(|&(k, j)| (k, m.t_s[j].floor() as i64))
        .collect();
    seconds.dedup();
    seconds.len()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measured::toolpath::Waypoint;
    use crate::pipeline::checkpoint::Store;
    use crate::pipeline::params::{ThermalModel, ThermalSettings};
    use crate::pipeline::replay::Laying;
    use std::cell::Cell;
    use std::collections::BTreeMap;

    /// A store in memory that keeps a run's state every `every`-th time one is offered, and
    /// logs what it was told in order: the first n entries of the log are what a run killed
    /// after them left.
    #[derive(Default)]
    struct Log {
        kept: BTreeMap<String, Vec<u8>>,
        log: Vec<(String, Option<Vec<u8>>)>,
        asked: Cell<usize>,
        every: usize,
    }

    impl Store for Log {
        fn due(&self) -> bool {
            self.asked.set(self.asked.get() + 1);
            self.asked.get().is_multiple_of(self.every)
        }
        fn load(&mut self, stage: &str) -> Option<Vec<u8>> {
            self.kept.get(stage).cloned()
        }
        fn save(&mut self, stage: &str, bytes: &[u8]) {
            self.kept.insert(stage.to_string(), bytes.to_vec());
            self.log.push((stage.to_string(), Some(bytes.to_vec())));
        }
        fn remove(&mut self, stage: &str) {
            self.kept.remove(stage);
            self.log.push((stage.to_string(), None));
        }
        fn unreadable(&mut self, stage: &str, why: &str) {
            panic!("the state kept under {stage} does not read: {why}");
        }
    }

    /// The doc example's wall, "measured" at 80 % efficiency and 30 W/(m² K).
    fn wall() -> (Replay, Series, Task) {
        let track = |k: usize, t: f64, x: f64, on| Waypoint {
            t_s: 20.0 * k as f64 + t,
            position_mm: [x, 0.0, 1.5 * (k + 1) as f64],
            on,
            power_w: None,
        };
        let path: Vec<Waypoint> = (0..6)
            .flat_map(|k| [track(k, 0.0, -15.0, false), track(k, 6.0, 15.0, true)])
            .collect();
        let laying = Laying {
            power_w: 1500.0,
            efficiency: 0.6,
            width_m: 4e-3,
            height_m: 1.5e-3,
            deposit_m: 2e-3,
        };
        let thermal = ThermalSettings {
            model: ThermalModel::Voxel,
            plate_m: [0.06, 0.03, 0.008],
            plate_fit: false,
            ..Default::default()
        };
        let g3si = (thermal::material::Material::g3si(), None);
        let probe = vec![[0.0, 0.008, 0.0]];
        let r = Replay::new(
            &path,
            &laying,
            &thermal,
            g3si,
            Default::default(),
            probe,
            1.0,
        )
        .unwrap();
        let names = [Parameter::Efficiency, Parameter::Convection];
        let truth = r.values.with(&names, &[0.8, 30.0]);
        let (_, run) = r
            .run_kept(&truth, 120.0, &mut Checkpoints::off(), "")
            .unwrap();
        let p = &run.probes[0];
        let measured = Series {
            t_s: p.time.clone(),
            values: vec![
                p.temperature
                    .iter()
                    .map(|k| Some(thermal::celsius(*k)))
                    .collect(),
            ],
        };
        let range = |low, high| Range { low, high };
        let task = Task {
            parameters: vec![
                (Parameter::Efficiency, range(0.3, 0.95)),
                (Parameter::Convection, range(5.0, 100.0)),
            ],
            fit_s: [0.0, 60.0],
            end_s: 120.0,
            max_runs: 10,
        };
        (r, measured, task)
    }

    /// A calibration killed part-way, at several places (among them inside a Jacobian whose
    /// runs are made side by side), goes on from what it kept to the fit and the traces of one
    /// run that was never killed, on two threads and on one.
    #[test]
    fn a_killed_calibration_resumes_to_the_same_fit() {
        let (r, m, task) = wall();
        let on = |threads: usize, store: &mut Log| {
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            pool.install(|| calibrate(&r, &m, &task, &mut Checkpoints::to(store)).unwrap())
        };
        let mut whole = Log {
            every: 40,
            ..Log::default()
        };
        let once = on(2, &mut whole);
        assert!(once.fit.runs >= 7, "{:?}", once.fit);
        assert!((once.fit.values[0] - 0.8).abs() < 0.02, "{:?}", once.fit);
        let stages = |log: &[(String, Option<Vec<u8>>)], name: &str| {
            log.iter().filter(|(s, _)| s.starts_with(name)).count()
        };
        assert!(stages(&whole.log, "evaluation-") >= once.fit.runs);
        assert!(
            stages(&whole.log, "evaluation-1.run") > 0,
            "no run kept in progress"
        );
        let n = whole.log.len();
        for (threads, cut) in [(2, n / 4), (2, n / 2), (1, 3 * n / 4), (2, n - 1)] {
            let mut left = Log {
                every: 40,
                ..Log::default()
            };
            for (stage, bytes) in &whole.log[..cut] {
                match bytes {
                    Some(b) => left.kept.insert(stage.clone(), b.clone()),
                    None => left.kept.remove(stage),
                };
            }
            let again = on(threads, &mut left);
            assert_eq!(again.fit, once.fit, "killed after {cut} of {n} entries");
            // Debug's text: a trace's NaN (no cell yet) equals itself there.
            let text = |t: &[ProbeTrace]| format!("{t:?}");
            assert_eq!(text(&again.before), text(&once.before));
            assert_eq!(text(&again.after), text(&once.after));
        }
        assert_eq!(
            on(
                1,
                &mut Log {
                    every: 40,
                    ..Log::default()
                }
            )
            .fit,
            once.fit
        );
    }
}
