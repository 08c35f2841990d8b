//! `waamtwin calibrate REPLAY.toml -o DIR [--fit T0:T1] [--holdout T0:T1]`: fit up to three of
//! the replay's parameters (efficiency, convection, emissivity, table contact) to its probes by
//! least squares over the fit window, and judge the fitted model on the held-out window.
//! calibration.json, probes.csv (the fitted model at every sample), probes.png.
//!
//! A fit run stops at the end of the fit window: the model is the same up to there whatever
//! comes after, so a fit over the first half of a build costs half a build per run. Every
//! parameter acts from the first deposit on, so no fit run can start later than t = 0; but the
//! runs with the starting values and with the fitted ones are kept where they stopped
//! (checkpoints), and the held-out window is reached by going on from them rather than by two
//! runs from the start.

use super::checkpoint;
use super::replay::{
    Replay, advance_kept, compare, material_of, measured, overall, probes_csv, sampling_interval,
    waypoints,
};
use crate::error::{Error, Result};
use crate::measured::probes::Series;
use crate::output::RunDir;
use crate::pipeline::calibrate::{self, Range, Settings};
use crate::pipeline::checkpoint::Checkpoints;
use crate::pipeline::replay;
use crate::progress::Stage;
use crate::scenario::ThermalSettings;
use crate::scenario::replay::{Parameter, ReplayScenario};
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::path::Path;
use std::time::Instant;
use thermal::run::ProbeTrace;
use thermal::schedule::Deposit;
use thermal::{HeatRun, ModelRun};

/// The scenario's efficiency and thermal settings with `values` of `parameters` put in.
fn with(s: &ReplayScenario, parameters: &[Parameter], values: &[f64]) -> (f64, ThermalSettings) {
    let (mut l, mut t) = (s.laying.efficiency, s.thermal.clone());
    for (p, &v) in parameters.iter().zip(values) {
        match p {
            Parameter::Efficiency => l = v,
            Parameter::Convection => t.convection_w_m2k = v,
            Parameter::Emissivity => t.emissivity = v,
            Parameter::TableContact => t.table_contact_w_m2k = v,
        }
    }
    (l, t)
}

/// A run with `values` of `parameters` stopped at the end of the fit window: the probes' traces
/// so far, and the run itself to go on from (its checkpoint; `None` once the fit no longer
/// needs it).
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

/// Run with `values` of `parameters` from the start until `until_s`, kept under `progress`.
fn stopped(
    r: &Replay,
    parameters: &[Parameter],
    values: &[f64],
    until_s: f64,
    ck: &mut Checkpoints<'_>,
    progress: &str,
) -> Result<Stopped> {
    let (deps, mut run) = match ck.load::<(Vec<Deposit>, ModelRun)>(progress) {
        Some(kept) => kept,
        None => {
            let (efficiency, thermal) = with(r.s, parameters, values);
            r.start(efficiency, &thermal)?
        }
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
) -> Result<Vec<ProbeTrace>> {
    let (deps, mut run) = match ck.load::<(Vec<Deposit>, ModelRun)>(progress) {
        Some(kept) => kept,
        None => match s.run {
            Some(run) => (s.deps, run),
            None => {
                return Err(Error::failure(
                    "calibrate: a run the fit ended at was not kept (a bug)",
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

/// "T0:T1" in seconds.
pub fn window(text: &str, flag: &str) -> Result<[f64; 2]> {
    let parsed = text
        .split_once(':')
        .and_then(|(a, b)| Some([a.trim().parse::<f64>().ok()?, b.trim().parse::<f64>().ok()?]));
    match parsed {
        Some([a, b]) if a.is_finite() && b.is_finite() && b > a => Ok([a, b]),
        _ => Err(Error::input(format!(
            "{flag} {text}; expected T0:T1 in seconds of build time, T1 after T0"
        ))),
    }
}

pub fn run(
    scenario: &Path,
    out: &Path,
    fit_flag: Option<[f64; 2]>,
    holdout_flag: Option<[f64; 2]>,
    resume: checkpoint::Options,
) -> Result<String> {
    let s = ReplayScenario::load(scenario)?;
    let name = scenario.display();
    let Some(cal) = &s.calibrate else {
        return Err(Error::input(format!(
            "{name}: no [calibrate] section; expected the parameters to fit"
        )));
    };
    let Some(p) = &s.probes else {
        return Err(Error::input(format!(
            "{name}: no [probes]; a calibration needs measurements"
        )));
    };
    let path = waypoints(&s)?;
    let (m, _) = measured(p, s.thermal.ambient_k)?;
    let end_s = path
        .last()
        .map_or(0.0, |w| w.t_s)
        .max(*m.t_s.last().unwrap_or(&0.0));
    let fit_w = fit_flag.or(cal.fit_s).unwrap_or([0.0, end_s / 2.0]);
    let hold_w = holdout_flag
        .or(cal.holdout_s)
        .unwrap_or([end_s / 2.0, end_s]);
    let r = Replay {
        s: &s,
        deps: replay::deposits(&path, &s.laying),
        material: material_of(&s.material)?,
        plate_material: s.plate_material.as_ref().map(material_of).transpose()?,
        every_s: sampling_interval(&m.t_s),
    };
    let mut dir = RunDir::create(out)?;
    let names: Vec<Parameter> = cal.parameters.iter().map(|c| c.parameter).collect();
    let ranges: Vec<Range> = cal.parameters.iter().map(|c| c.range).collect();
    let start: Vec<f64> = {
        let (l, t) = (&s.laying, &s.thermal);
        names
            .iter()
            .map(|p| match p {
                Parameter::Efficiency => l.efficiency,
                Parameter::Convection => t.convection_w_m2k,
                Parameter::Emissivity => t.emissivity,
                Parameter::TableContact => t.table_contact_w_m2k,
            })
            .collect()
    };
    // The windows decide where the runs stop: part of what the checkpoints are of.
    let windows = format!("{fit_w:?} {hold_w:?}");
    let print = checkpoint::fingerprint(&[
        b"calibrate",
        s.to_json().to_string().as_bytes(),
        &postcard::to_stdvec(&r.deps).unwrap_or_default(),
        windows.as_bytes(),
    ]);
    let mut folder = checkpoint::Folder::open(out, "calibrate", print, resume)?;
    let mut ck = Checkpoints::to(&mut folder);
    let clock = Instant::now();
    let stage = Stage::start("calibrating: each step a run of the heat model");
    // Each evaluation of the fit is a stage of its own: a run that resumes takes those done
    // and the fit, deterministic, asks for them again in the same order.
    let evaluate = |k: usize, values: &[f64], ck: &mut Checkpoints<'_>| {
        ck.stage(&format!("evaluation-{k}"), |ck, progress| {
            stopped(&r, &names, values, fit_w[1], ck, progress)
        })
        .map(|done| done.0)
    };
    let first = evaluate(0, &start, &mut ck)?;
    let samples = fit_samples(&m, &first.traces, fit_w);
    if samples.is_empty() {
        return Err(Error::input(format!(
            "{name}: no probe reads inside the fit window {fit_w:?} s; expected some samples there"
        )));
    }
    let settings = Settings {
        max_runs: cal.max_runs,
        independent: independent(&m, &samples),
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
    let fit = calibrate::fit(&start, &ranges, settings, |values| {
        let run = match first.take() {
            // The first evaluation is the run made above.
            Some(f) => Stopped {
                values: values.to_vec(),
                ..f
            },
            None => evaluate(k, values, &mut ck)?,
        };
        let residuals = residuals(&m, &run.traces, &samples);
        recent.push((k, run));
        k += 1;
        if recent.len() > keep + 1 {
            let (gone, run) = recent.remove(1);
            ck.save(&format!("evaluation-{gone}"), &run.light());
        }
        Ok::<_, Error>(residuals)
    })?;
    let before = recent.first().map(|r| r.1.clone());
    let after = recent
        .iter()
        .rev()
        .find(|s| s.1.values == fit.values)
        .map(|r| r.1.clone());
    let (before, after) = match (before, after) {
        (Some(b), Some(a)) => (b, a),
        // Not reached while `keep` holds what the fit can end at; a run from the start if so.
        (b, a) => {
            let fresh = |values: &[f64], ck: &mut Checkpoints<'_>| {
                stopped(&r, &names, values, fit_w[1], ck, "")
            };
            (
                b.map_or_else(|| fresh(&start, &mut Checkpoints::off()), Ok)?,
                a.map_or_else(|| fresh(&fit.values, &mut Checkpoints::off()), Ok)?,
            )
        }
    };
    drop(recent);
    let (before, _) = ck.stage("before_to_end", |ck, progress| {
        resumed(before, end_s, ck, progress)
    })?;
    let (after, _) = ck.stage("after_to_end", |ck, progress| {
        resumed(after, end_s, ck, progress)
    })?;
    drop(stage);
    let wall_s = clock.elapsed().as_secs_f64();
    let judge = |traces: &[ProbeTrace], w: [f64; 2]| overall(&compare(p, &m, traces, w, &[]));
    let [fit_before, fit_after, hold_before, hold_after] = [
        judge(&before, fit_w),
        judge(&after, fit_w),
        judge(&before, hold_w),
        judge(&after, hold_w),
    ];
    let rms = |o: Option<(f64, usize)>| o.map(|o| o.0);
    let compared = compare(p, &m, &after, [0.0, end_s], &[]);
    dir.write("probes.csv", probes_csv(&compared).as_bytes())?;
    let parameters: Vec<serde_json::Value> = cal
        .parameters
        .iter()
        .enumerate()
        .map(|(i, c)| {
            json!({
                "name": c.parameter.key(),
                "start": start[i],
                "value": fit.values[i],
                "low": c.range.low,
                "high": c.range.high,
                "ci95": fit.ci95[i],
                "sensitivity_c_per_unit": fit.sensitivity[i],
            })
        })
        .collect();
    dir.write_json(
        "calibration.json",
        &json!({
            "parameters": parameters,
            "fit_s": fit_w,
            "holdout_s": hold_w,
            "rms_fit_c": rms(fit_after),
            "rms_fit_before_c": rms(fit_before),
            "rms_holdout_c": rms(hold_after),
            "rms_holdout_before_c": rms(hold_before),
            "fit_samples": samples.len(),
            "independent_samples": settings.independent,
            "runs": fit.runs + 2,
            // The two runs that judge the held-out window went on from the fit's end.
            "resumed_from_checkpoint": 2,
            "iterations": fit.iterations,
            "wall_s": wall_s,
        }),
    )?;
    #[cfg(feature = "recording")]
    {
        let series: Vec<(&str, &[replay::Sample])> = compared
            .iter()
            .map(|c| (c.name.as_str(), c.samples.as_slice()))
            .collect();
        let title = format!(
            "{} calibrated",
            scenario
                .file_stem()
                .map_or("replay".into(), |n| n.to_string_lossy())
        );
        crate::record::probe_plot(&mut dir, "probes.png", &title, &series, Some(fit_w))?;
    }
    dir.finish("calibrate", s.to_json())?;
    folder.close()?;
    let values: Vec<String> = names
        .iter()
        .zip(&fit.values)
        .map(|(p, v)| format!("{} {v:.3}", p.key()))
        .collect();
    let f = |o: Option<f64>| o.map_or("-".into(), |v| format!("{v:.0}"));
    Ok(format!(
        "{}; RMS over the fit window {} → {} °C, held out {} → {} °C; {} runs (2 resumed at the \
         fit's end), {wall_s:.0} s",
        values.join(", "),
        f(rms(fit_before)),
        f(rms(fit_after)),
        f(rms(hold_before)),
        f(rms(hold_after)),
        fit.runs + 2
    ))
}
