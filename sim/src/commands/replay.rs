//! `waamtwin replay SCENARIO -o DIR`: a toolpath the machine ran, heated by the voxel model, and
//! held against what the part measured: probes.csv (every sample where both read), passes.csv
//! (each pass of the torch as each probe saw it), replay.json (agreement per probe and over
//! all), probes.png (measured and predicted against time), run.rrd and run.mcap (the probes as
//! series). The file contract is in `scenarios/README.md`.

use super::checkpoint;
use crate::error::{Error, Result};
use crate::measured::{gcode, machine_log, probes, table, toolpath};
use crate::output::RunDir;
use crate::pipeline::checkpoint::Checkpoints;
use crate::pipeline::replay::{
    self, Compared, Pass, Replay, Replayed, doubts, in_celsius, overall, sampling_interval,
};
use crate::pipeline::resolution::{self, Warning};
use crate::progress::Stage;
use crate::scenario::Scenario;
use crate::scenario::replay::{MaterialSpec, Probes, ReplayScenario, ToolpathFormat};
use serde_json::json;
use std::fmt::Write;
use std::path::Path;
use thermal::material::Material;

/// The replay of scenario `s`, its files read: the toolpath, the materials; the probes kept
/// every `every_s`.
pub(crate) fn set_up(s: &ReplayScenario, every_s: f64) -> Result<Replay> {
    let path = waypoints(s)?;
    super::cost::check_deposits(
        &s.toolpath.display().to_string(),
        replay::count(&path, &s.laying),
        // The metre's conversion noise rounded away, as the scenario's checks show a value.
        (s.laying.deposit_m * 1e12).round() / 1e9,
        longest_segment(&path),
    )?;
    let probes = s.probes.as_ref().map_or(Vec::new(), |p| {
        p.points.iter().map(|q| q.position_m).collect()
    });
    let materials = (
        material_of(&s.material)?,
        s.plate_material.as_ref().map(material_of).transpose()?,
    );
    Replay::new(
        &path, &s.laying, &s.thermal, materials, s.source, probes, every_s,
    )
    .map_err(|e| Error::from(e).context(s.toolpath.display()))
}

/// The longest deposited segment of `path`: its end's time, s, and its length, mm.
fn longest_segment(path: &[toolpath::Waypoint]) -> (f64, f64) {
    path.windows(2)
        .filter(|w| w[1].on)
        .map(|w| {
            let d = (0..3).map(|k| (w[1].position_mm[k] - w[0].position_mm[k]).powi(2));
            (w[1].t_s, d.sum::<f64>().sqrt())
        })
        .fold((0.0, 0.0), |a, b| if b.1 > a.1 { b } else { a })
}

/// The probes' names, in the scenario's order.
pub(crate) fn names(p: &Probes) -> Vec<String> {
    p.points.iter().map(|q| q.name.clone()).collect()
}

/// What the readings `m` of `p` (`dropped` of them below ambient), compared as `compared` on
/// the replay `r`, give reason to doubt: their clock, the file's unit, and probes with no
/// reading or none compared ([`doubts`]).
pub(crate) fn doubts(
    p: &Probes,
    (m, dropped): (&probes::Series, usize),
    compared: &[Compared],
    r: &Replay,
) -> Vec<Warning> {
    let first_arc_s = r.deps.first().map_or(0.0, |d| d.arc_start());
    let last_s = r.deps.last().map_or(0.0, |d| d.time);
    let ambient_k = r.values.thermal.ambient_k;
    let clock = doubts::clock(&m.t_s, first_arc_s, last_s);
    let met: Vec<doubts::Met<'_>> = p
        .points
        .iter()
        .zip(&m.values)
        .map(|(q, v)| doubts::Met {
            name: &q.name,
            position_mm: q.position_m.map(|x| x * 1e3),
            column: q.column,
            read: v.iter().any(Option::is_some),
            // Readings that miss the build leave a probe unread for that, not for its place.
            compared: clock.is_some()
                || compared
                    .iter()
                    .any(|c| c.name == q.name && c.agreement.is_some()),
        })
        .collect();
    clock
        .into_iter()
        .chain(doubts::unit(m, dropped, p.kelvin, ambient_k, first_arc_s))
        .chain(doubts::probes(&met))
        .collect()
}

/// The longest the model cools past the build's last deposit to meet the last reading, s:
/// 116 days, `toolpath.time_offset_s`'s bound. Readings further on are on another clock (Unix
/// time, a logger's own), and their replay would cool the part for weeks.
pub(crate) const MOST_COOLING_S: f64 = 1e7;

/// What a refusal of readings on another clock expects instead (`replay`, `calibrate`,
/// `follow`).
pub(crate) fn one_clock_expected() -> String {
    format!(
        "expected readings on the toolpath's clock, within {MOST_COOLING_S:.0e} s of its end (a \
         time column of Unix or a logger's own time less the build's start; \
         toolpath.time_offset_s moves the path by up to {MOST_COOLING_S:.0e} s)"
    )
}

/// Refused where the readings `m` of `p` end more than [`MOST_COOLING_S`] after `r`'s last
/// deposit: the file and the path are on two clocks.
pub(crate) fn on_one_clock(p: &Probes, m: &probes::Series, r: &Replay) -> Result<()> {
    let (Some(&first), Some(&last)) = (m.t_s.first(), m.t_s.last()) else {
        return Ok(());
    };
    let start = r.deps.first().map_or(0.0, |d| d.arc_start());
    let end = r.deps.last().map_or(0.0, |d| d.time);
    if last - end <= MOST_COOLING_S {
        return Ok(());
    }
    Err(Error::input(format!(
        "{}: readings from {first} s to {last} s, the toolpath's deposits from {start:.1} s to \
         {end:.1} s: its last reading {:.3e} s after the build; {}",
        p.file.display(),
        last - end,
        one_clock_expected()
    )))
}

pub fn run(scenario: &Path, out: &Path, resume: checkpoint::Options) -> Result<String> {
    // A part's scenario with its planned path.csv: the plan replayed as laid.
    if std::fs::read_to_string(scenario).is_ok_and(|t| Scenario::is_planned_path(&t)) {
        return super::replay_plan::run(scenario, out, resume);
    }
    let s = ReplayScenario::load(scenario)?;
    let (measured, dropped) = match &s.probes {
        Some(p) => {
            let (m, dropped) = measured(p, s.thermal.ambient_k)?;
            (Some(m), dropped)
        }
        None => (None, 0),
    };
    let every_s = measured.as_ref().map_or(1.0, |m| sampling_interval(&m.t_s));
    let r = set_up(&s, every_s)?;
    if let (Some(p), Some(m)) = (&s.probes, &measured) {
        on_one_clock(p, m, &r)?;
    }
    let end_s = r.deps.last().map_or(0.0, |d| d.time).max(
        measured
            .as_ref()
            .and_then(|m| m.t_s.last().copied())
            .unwrap_or(0.0),
    );
    super::cost::check_replay(
        &scenario.display().to_string(),
        &r,
        end_s,
        super::cost::Keeps {
            readings: measured.as_ref().map_or(0, readings),
            ..super::cost::Keeps::ONE_RUN
        },
        "thermal.voxel_mm",
    )?;
    let mut dir = RunDir::create(out)?;
    let print = checkpoint::of_run("replay", &s.to_json(), &r.deps);
    let mut folder = checkpoint::Folder::open(out, "replay", print, resume)?;
    let mut ck = Checkpoints::to(&mut folder);
    let names = s.probes.as_ref().map(names).unwrap_or_default();
    let replayed = {
        let _stage = Stage::start("heating the replayed toolpath");
        r.replay(
            measured.as_ref().map(|m| (names.as_slice(), m)),
            s.window_s,
            &mut ck,
        )?
    };
    let Replayed {
        deps,
        result,
        wall_s,
        window_s: window,
        compared,
        ..
    } = replayed;
    let build_s = deps.last().map_or(0.0, |d| d.time);
    dir.write("passes.csv", passes_csv(&compared).as_bytes())?;
    dir.write("probes.csv", probes_csv(&compared).as_bytes())?;
    // The model that ran, and its cells: a thin-wall replay was written as "voxel" with no
    // voxels.
    let (model, voxels, wall_nodes) = match result.cells {
        thermal::Cells::Voxel { voxels, .. } => ("voxel", Some(voxels), None),
        thermal::Cells::ThinWall { wall_nodes, .. } => ("thin-wall", None, Some(wall_nodes)),
    };
    let metal = resolution::metal(&result, &deps);
    let after: Vec<_> = metal
        .and_then(resolution::Metal::warning)
        .into_iter()
        .chain(match (&s.probes, &measured) {
            (Some(p), Some(m)) => doubts(p, (m, dropped), &compared, &r),
            _ => Vec::new(),
        })
        .collect();
    for w in &after {
        eprintln!("{}", w.line);
    }
    // As simulate's thermal.json.
    let before = resolution::before_run(&r.values.thermal, &deps, "thermal.voxel_mm");
    let warnings = super::simulate::warnings_json(&before, &after);
    let overall = overall(&compared);
    dir.write_json(
        "replay.json",
        &json!({
            "model": model,
            "deposits": deps.len(),
            "voxels": voxels,
            "wall_nodes": wall_nodes,
            "metal_mm3": metal.map(|m| m.mm3()[0]),
            "beads_mm3": metal.map(|m| m.mm3()[1]),
            "warnings": warnings,
            "steps": result.steps,
            "build_s": build_s,
            "wall_s": wall_s,
            "balance_error": result.balance_error,
            "window_s": window,
            "readings_below_ambient": dropped,
            "rms_c": overall.map(|o| o.0),
            "samples": overall.map(|o| o.1),
            "probes": compared.iter().map(|c| json!({
                "name": c.name,
                "samples": c.agreement.as_ref().map(|a| a.samples),
                "rms_c": c.agreement.as_ref().map(|a| a.rms_c),
                "max_abs_c": c.agreement.as_ref().map(|a| a.max_abs_c),
                "max_at_s": c.agreement.as_ref().map(|a| a.max_at_s),
                "bias_c": c.agreement.as_ref().map(|a| a.bias_c),
                "passes": c.passes.len(),
                "peak": pass_errors(c, |p| p.peak),
                "before_next_pass": pass_errors(c, |p| p.before_next),
            })).collect::<Vec<_>>(),
        }),
    )?;
    #[cfg(feature = "recording")]
    if !compared.is_empty() {
        let title = scenario
            .file_stem()
            .map_or("replay".into(), |n| n.to_string_lossy().into_owned());
        let series: Vec<(&str, &[crate::pipeline::replay::Sample])> = compared
            .iter()
            .map(|c| (c.name.as_str(), c.samples.as_slice()))
            .collect();
        crate::record::probe_plot(&mut dir, "probes.png", &title, &series, s.window_s)?;
        let positions = s.probes.as_ref().map_or(Vec::new(), |p| {
            p.points
                .iter()
                .map(|q| q.position_m.map(|x| x * 1e3))
                .collect()
        });
        let recorded: Vec<crate::record::replay::ProbeSeries> = compared
            .iter()
            .zip(&positions)
            .map(|(c, &position_mm)| crate::record::replay::ProbeSeries {
                name: &c.name,
                position_mm,
                samples: &c.samples,
            })
            .collect();
        crate::record::replay::write(&mut dir, &title, &tracks(&deps), &recorded)?;
    }
    dir.finish("replay", s.to_json())?;
    folder.close()?;
    Ok(summary(&deps, build_s, wall_s, &compared, overall))
}

pub(crate) fn read(path: &Path) -> Result<String> {
    std::fs::read_to_string(path)
        .map_err(|e| Error::input(format!("cannot read {}: {e}", path.display())))
}

/// The laid path as polylines, one a track (mm).
#[cfg(feature = "recording")]
pub(crate) fn tracks(deps: &[thermal::schedule::Deposit]) -> Vec<Vec<[f64; 3]>> {
    let mut out: Vec<Vec<[f64; 3]>> = Vec::new();
    for (i, d) in deps.iter().enumerate() {
        let mm = |p: [f64; 3]| p.map(|x| x * 1e3);
        let paused = i > 0 && d.arc_start() > deps[i - 1].time + 1e-9;
        if i == 0 || d.start.is_some() || paused {
            out.push(vec![mm(thermal::schedule::segment_start(deps, i))]);
        }
        if let Some(t) = out.last_mut() {
            t.push(mm(d.position));
        }
    }
    out
}

/// The toolpath as waypoints, from its file in its format.
pub(crate) fn waypoints(s: &ReplayScenario) -> Result<Vec<toolpath::Waypoint>> {
    let (text, file) = (read(&s.toolpath)?, s.toolpath.display().to_string());
    let mut path = match &s.format {
        ToolpathFormat::Events => toolpath::event_series(&text, &file)?,
        ToolpathFormat::MachineLog => {
            machine_log::waypoints(&text, &file, &machine_log::Columns::default())?
        }
        ToolpathFormat::Gcode(d) => gcode::waypoints(&text, &file, d)?,
    };
    if s.flag_starts {
        toolpath::flags_start_segments(&mut path);
    }
    for w in &mut path {
        w.position_mm[2] += s.z_offset_mm;
        w.t_s += s.time_offset_s;
    }
    Ok(path)
}

pub fn material_of(spec: &MaterialSpec) -> Result<Material> {
    let t = match spec {
        MaterialSpec::G3Si => return Ok(Material::g3si()),
        MaterialSpec::In718 => return Ok(Material::in718()),
        MaterialSpec::Tables(t) => t,
    };
    let load = |path: &Path, scale: f64| -> Result<Vec<(f64, f64)>> {
        let rows = table::rows(&read(path)?, &path.display().to_string())?;
        Ok(rows.into_iter().map(|(k, v)| (k, v * scale)).collect())
    };
    let cp = load(&t.specific_heat, t.specific_heat_scale)?;
    let k = load(&t.conductivity, t.conductivity_scale)?;
    Material::from_tables(
        t.density_kg_m3,
        &cp,
        &k,
        t.solidus_k,
        t.liquidus_k,
        t.latent_j_kg,
    )
    .map_err(|e| Error::input(format!("material {}: {e}", t.name)))
}

/// The readings a probe series holds (a probe's time with a value).
pub(crate) fn readings(s: &probes::Series) -> usize {
    s.values.iter().map(|v| v.iter().flatten().count()).sum()
}

/// The measured series in °C, and how many readings lay below ambient (dropped).
pub(crate) fn measured(p: &Probes, ambient_k: f64) -> Result<(probes::Series, usize)> {
    let columns: Vec<usize> = p.points.iter().map(|q| q.column).collect();
    let file = p.file.display().to_string();
    let text = read(&p.file)?;
    if let Some((n, c, cell)) =
        probes::unit_against_header(&text, p.time_column, &columns, p.kelvin)
    {
        return Err(Error::input(format!(
            "{file} line {n}: {}",
            probes::unit_against(c, &cell, p.kelvin)
        )));
    }
    let mut s = probes::series(&text, &file, p.time_column, &columns)?;
    let dropped = in_celsius(&mut s, p.kelvin, ambient_k);
    Ok((s, dropped))
}

/// RMS and mean of predicted − measured of one quantity of a probe's passes, as JSON.
fn pass_errors(c: &Compared, of: impl Fn(&Pass) -> Option<(f64, f64)>) -> serde_json::Value {
    match replay::errors(c.passes.iter().filter_map(of)) {
        Some((rms, bias)) => json!({"rms_c": rms, "bias_c": bias}),
        None => serde_json::Value::Null,
    }
}

/// Per probe and pass: the peaks and the temperatures before the next pass.
fn passes_csv(c: &[Compared]) -> String {
    let mut out = String::from(
        "probe,pass,start_s,measured_peak_c,predicted_peak_c,measured_before_next_c,\
         predicted_before_next_c\n",
    );
    let cell = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.2}"));
    for p in c {
        for (k, pass) in p.passes.iter().enumerate() {
            let _ = writeln!(
                out,
                "{},{k},{:.3},{},{},{},{}",
                p.name,
                pass.start_s,
                cell(pass.peak.map(|x| x.0)),
                cell(pass.peak.map(|x| x.1)),
                cell(pass.before_next.map(|x| x.0)),
                cell(pass.before_next.map(|x| x.1)),
            );
        }
    }
    out
}

pub(crate) fn probes_csv(c: &[Compared]) -> String {
    let mut out = String::from("probe,t_s,measured_c,predicted_c\n");
    for p in c {
        for (t, m, pr) in &p.samples {
            let _ = writeln!(out, "{},{t:.4},{m:.2},{pr:.2}", p.name);
        }
    }
    out
}

fn summary(
    deps: &[thermal::schedule::Deposit],
    build_s: f64,
    wall_s: f64,
    c: &[Compared],
    overall: Option<(f64, usize)>,
) -> String {
    let mut line = format!(
        "{} deposits, build {build_s:.0} s, heated in {wall_s:.1} s",
        deps.len()
    );
    if let Some((rms, n)) = overall {
        let worst = c
            .iter()
            .filter_map(|c| c.agreement.as_ref().map(|a| (a.rms_c, &c.name)))
            .fold(
                (0.0, ""),
                |w, (r, n)| if r > w.0 { (r, n.as_str()) } else { w },
            );
        let _ = write!(
            line,
            "; probes: RMS {rms:.0} °C over {n} samples (worst {} at {:.0} °C)",
            worst.1, worst.0
        );
    }
    line
}
