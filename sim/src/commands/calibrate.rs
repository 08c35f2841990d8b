//! `waamtwin calibrate REPLAY.toml -o DIR [--fit T0:T1] [--holdout T0:T1]`: fit up to three of
//! the replay's parameters (efficiency, convection, emissivity, table contact) to its probes by
//! least squares over the fit window, and judge the fitted model on the held-out window
//! (the engine: [`crate::pipeline::calibrate`]). calibration.json, probes.csv (the fitted model
//! at every sample), probes.png.

use super::checkpoint;
use super::replay::{doubts, measured, names, on_one_clock, probes_csv, set_up};
use crate::error::{Error, Result};
use crate::output::RunDir;
use crate::pipeline::calibrate::{self, Task};
use crate::pipeline::checkpoint::Checkpoints;
use crate::pipeline::replay::{compare, overall, sampling_interval};
use crate::progress::Stage;
use crate::scenario::replay::ReplayScenario;
use serde_json::json;
use std::path::Path;
use std::time::Instant;
use thermal::run::ProbeTrace;

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
    let (m, dropped) = measured(p, s.thermal.ambient_k)?;
    let r = set_up(&s, sampling_interval(&m.t_s))?;
    on_one_clock(p, &m, &r)?;
    let end_s = r
        .deps
        .last()
        .map_or(0.0, |d| d.time)
        .max(*m.t_s.last().unwrap_or(&0.0));
    let fit_w = fit_flag.or(cal.fit_s).unwrap_or([0.0, end_s / 2.0]);
    let hold_w = holdout_flag
        .or(cal.holdout_s)
        .unwrap_or([end_s / 2.0, end_s]);
    // At most `max_runs` runs to the fit window's end, and the start and the fit run whole.
    // Held at once: the runs the fit may end at (2n + 4 for n parameters, `calibrate`'s
    // `keep`) and those made side by side, one a thread.
    let held = 2 * cal.parameters.len() + 4 + rayon::current_num_threads();
    super::cost::check_replay(
        &name.to_string(),
        &r,
        end_s,
        super::cost::Keeps {
            copies: held as f64,
            runs: cal.max_runs as f64 * (fit_w[1] / end_s.max(1e-9)).min(1.0) + 2.0,
            readings: super::replay::readings(&m),
            ..super::cost::Keeps::ONE_RUN
        },
        "thermal.voxel_mm",
    )?;
    let mut dir = RunDir::create(out)?;
    let task = Task {
        parameters: cal
            .parameters
            .iter()
            .map(|c| (c.parameter, c.range))
            .collect(),
        fit_s: fit_w,
        end_s,
        max_runs: cal.max_runs,
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
    let done =
        calibrate::calibrate(&r, &m, &task, &mut ck).map_err(|e| Error::from(e).context(name))?;
    drop(stage);
    let wall_s = clock.elapsed().as_secs_f64();
    let (fit, start) = (&done.fit, &done.start);
    let names_p = names(p);
    let judge =
        |traces: &[ProbeTrace], w: [f64; 2]| overall(&compare(&names_p, &m, traces, w, &[]));
    let [fit_before, fit_after, hold_before, hold_after] = [
        judge(&done.before, fit_w),
        judge(&done.after, fit_w),
        judge(&done.before, hold_w),
        judge(&done.after, hold_w),
    ];
    let rms = |o: Option<(f64, usize)>| o.map(|o| o.0);
    let compared = compare(&names_p, &m, &done.after, [0.0, end_s], &[]);
    // A probe that read nothing gave the fit nothing, a unit read wrong a fit to the wrong
    // temperatures: said as the replay says them.
    let warnings = doubts(p, (&m, dropped), &compared, &r);
    for w in &warnings {
        eprintln!("{}", w.line);
    }
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
            // The fitted values' covariance, in `parameters`' order and units (null where the
            // data do not constrain some combination).
            "covariance": fit.covariance,
            // What `efficiency` is the efficiency of: a scenario with another heat source
            // does not take it (scenario::calibration).
            "heat_source": s.raw.process.source,
            "warnings": super::simulate::warnings_json(&[], &warnings),
            "fit_s": fit_w,
            "holdout_s": hold_w,
            "rms_fit_c": rms(fit_after),
            "rms_fit_before_c": rms(fit_before),
            "rms_holdout_c": rms(hold_after),
            "rms_holdout_before_c": rms(hold_before),
            "fit_samples": done.samples,
            "independent_samples": done.independent,
            "runs": fit.runs + 2,
            // The two runs that judge the held-out window went on from the fit's end.
            "resumed_from_checkpoint": 2,
            "iterations": fit.iterations,
            "wall_s": wall_s,
        }),
    )?;
    #[cfg(feature = "recording")]
    {
        let series: Vec<(&str, &[crate::pipeline::replay::Sample])> = compared
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
    let values: Vec<String> = task
        .parameters
        .iter()
        .map(|p| p.0)
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
