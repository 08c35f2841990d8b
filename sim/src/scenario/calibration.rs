//! `[calibration] file`: what a `calibrate` run learned, carried into any scenario (issue 29).
//!
//! A calibration.json's fitted values replace the scenario's own by their physical name
//! (`efficiency` — a laser's absorptivity —, `convection_w_m2k`, `emissivity`,
//! `table_contact_w_m2k`), whatever model the scenario runs: both heat models take all four.
//! What cannot be carried is listed with the reason (`calibration_unused`), never dropped in
//! silence: a name this waamtwin does not know, an efficiency fitted under another heat source
//! (a laser's absorptivity is not an arc's efficiency), a value a study case sets itself.
//! The fit's covariance comes along, in the order of the fitted parameters, for plans drawn at a
//! confidence.

use crate::error::{Error, Result};
use crate::pipeline::replay::Parameter;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};

/// `[calibration]` as serde reads it.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawCalibration {
    /// A `calibrate` run's calibration.json, relative to the scenario's folder.
    pub file: String,
    /// Each value this many of its standard deviations to the hot side (more heat in, less
    /// lost), cut at its range: a plan checked against a machine hotter than the fit's mean.
    #[serde(default, skip_serializing_if = "is_zero")]
    pub hot_side_sd: f64,
}

fn is_zero(x: &f64) -> bool {
    *x == 0.0
}

/// One fitted value of a calibration.json.
#[derive(Debug, Clone, PartialEq)]
pub struct Fitted {
    pub parameter: Parameter,
    pub value: f64,
    pub low: f64,
    pub high: f64,
    /// Its standard deviation: the covariance's diagonal where there is one, else the 95 %
    /// interval's half-width / 1.96 (None: the fit gave neither).
    pub sd: Option<f64>,
    /// Its 95 % interval as the fit cut it at the bounds.
    pub ci95: Option<[f64; 2]>,
}

/// A calibration.json, read and checked.
#[derive(Debug, Clone, PartialEq)]
pub struct CalibrationFile {
    pub path: PathBuf,
    /// The parameters this waamtwin knows, in the file's order.
    pub fitted: Vec<Fitted>,
    /// The covariance of `fitted` (rows and columns in its order), where the file has one over
    /// exactly those.
    pub covariance: Option<Vec<Vec<f64>>>,
    /// "arc" or "laser" where the file says (older files do not).
    pub heat_source: Option<String>,
    /// Names the file fits that this waamtwin does not know, with their values.
    pub unknown: Vec<(String, f64)>,
}

/// What a scenario took from its calibration, and what it could not.
#[derive(Debug, Clone, PartialEq)]
pub struct Carried {
    pub file: CalibrationFile,
    /// The values were moved this many standard deviations to the hot side.
    pub hot_side_sd: f64,
    /// (parameter, the scenario's value, the calibrated value it now runs at).
    pub applied: Vec<(Parameter, f64, f64)>,
    /// (name, value, why it is not used).
    pub unused: Vec<(String, f64, String)>,
}

impl Carried {
    /// The uncertain parameters that were applied, with their spread, and their covariance
    /// where the file has one (rows in `applied`'s order).
    pub fn applied_fits(&self) -> (Vec<&Fitted>, Option<Vec<Vec<f64>>>) {
        let index: Vec<usize> = self
            .applied
            .iter()
            .filter_map(|a| self.file.fitted.iter().position(|f| f.parameter == a.0))
            .collect();
        let fits = index.iter().map(|&i| &self.file.fitted[i]).collect();
        let cov = self.file.covariance.as_ref().map(|c| {
            index
                .iter()
                .map(|&i| index.iter().map(|&j| c[i][j]).collect())
                .collect()
        });
        (fits, cov)
    }

    /// For manifest.json: the file, what was applied and `calibration_unused`.
    pub fn to_json(&self) -> serde_json::Value {
        serde_json::json!({
            "file": self.file.path.display().to_string(),
            "hot_side_sd": self.hot_side_sd,
            "applied": self.applied.iter().map(|(p, before, after)| serde_json::json!({
                "name": p.key(), "scenario_value": before, "value": after,
            })).collect::<Vec<_>>(),
            "calibration_unused": self.unused.iter().map(|(name, value, why)| serde_json::json!({
                "name": name, "value": value, "why": why,
            })).collect::<Vec<_>>(),
        })
    }

    /// A line for stderr where something was not carried.
    pub fn notice(&self) -> Option<String> {
        (!self.unused.is_empty()).then(|| {
            let list: Vec<String> = self
                .unused
                .iter()
                .map(|(n, v, why)| format!("{n} = {v} ({why})"))
                .collect();
            format!(
                "{}: not used: {}",
                self.file.path.display(),
                list.join("; ")
            )
        })
    }
}

#[derive(Deserialize)]
struct JsonFile {
    parameters: Vec<JsonParameter>,
    #[serde(default)]
    covariance: Option<Vec<Vec<f64>>>,
    #[serde(default)]
    heat_source: Option<String>,
}

#[derive(Deserialize)]
struct JsonParameter {
    name: String,
    value: f64,
    low: f64,
    high: f64,
    #[serde(default)]
    ci95: Option<[f64; 2]>,
}

/// Most parameters a calibration.json may list: the file is read whole, but nothing is sized
/// by what it claims.
const MAX_PARAMETERS: usize = 64;

/// The parameter a calibration.json names: its scenario key, or `absorptivity` (a laser's
/// efficiency).
fn parameter_named(name: &str) -> Option<Parameter> {
    if name == "absorptivity" {
        return Some(Parameter::Efficiency);
    }
    Parameter::ALL.into_iter().find(|p| p.key() == name)
}

/// Read and check a calibration.json; errors name the file and the field.
pub fn read(path: &Path) -> Result<CalibrationFile> {
    let name = path.display();
    let text = std::fs::read_to_string(path)
        .map_err(|e| Error::input(format!("cannot read calibration {name}: {e}")))?;
    parse(&text, path)
}

/// [`read`] of text already read; `path` names it.
pub fn parse(text: &str, path: &Path) -> Result<CalibrationFile> {
    let name = path.display();
    let json: JsonFile = serde_json::from_str(text)
        .map_err(|e| Error::input(format!("{name}: {e}; expected a calibration.json")))?;
    if json.parameters.len() > MAX_PARAMETERS {
        return Err(Error::input(format!(
            "{name}: {} parameters; expected at most {MAX_PARAMETERS}",
            json.parameters.len()
        )));
    }
    let (mut fitted, mut unknown, mut rows) = (Vec::new(), Vec::new(), Vec::new());
    for (k, p) in json.parameters.iter().enumerate() {
        if !(p.low < p.high && (p.low..=p.high).contains(&p.value) && p.value.is_finite()) {
            return Err(Error::input(format!(
                "{name}: parameters[{k}] {} = {} in [{}, {}]; expected a value inside its range",
                p.name, p.value, p.low, p.high
            )));
        }
        let Some(parameter) = parameter_named(&p.name) else {
            unknown.push((p.name.clone(), p.value));
            continue;
        };
        let [lo, hi] = parameter.limits();
        if !(lo..=hi).contains(&p.value) {
            return Err(Error::input(format!(
                "{name}: parameters[{k}] {} = {}; expected a value in [{lo}, {hi}]",
                p.name, p.value
            )));
        }
        if fitted.iter().any(|f: &Fitted| f.parameter == parameter) {
            return Err(Error::input(format!(
                "{name}: parameters[{k}] {} is fitted twice; expected each once",
                p.name
            )));
        }
        rows.push(k);
        fitted.push(Fitted {
            parameter,
            value: p.value,
            low: p.low,
            high: p.high,
            sd: p.ci95.map(|[a, b]| ((b - a) / (2.0 * 1.96)).max(0.0)),
            ci95: p.ci95,
        });
    }
    let n = json.parameters.len();
    let covariance = match json.covariance {
        None => None,
        Some(c) if c.len() == n && c.iter().all(|r| r.len() == n) => {
            let kept: Vec<Vec<f64>> = rows
                .iter()
                .map(|&i| rows.iter().map(|&j| c[i][j]).collect())
                .collect();
            if kept.iter().flatten().any(|x| !x.is_finite())
                || (0..kept.len()).any(|i| kept[i][i] < 0.0)
            {
                return Err(Error::input(format!(
                    "{name}: covariance has a negative variance or a value that is not a \
                     number; expected the fit's covariance"
                )));
            }
            Some(kept)
        }
        Some(c) => {
            return Err(Error::input(format!(
                "{name}: covariance is {}×{}; expected {n}×{n}, one row and column per parameter",
                c.len(),
                c.first().map_or(0, |r| r.len())
            )));
        }
    };
    if let Some(c) = &covariance {
        for (i, f) in fitted.iter_mut().enumerate() {
            f.sd = Some(c[i][i].sqrt());
        }
    }
    match json.heat_source.as_deref() {
        None | Some("arc" | "laser") => {}
        Some(other) => {
            return Err(Error::input(format!(
                "{name}: heat_source = \"{other}\"; expected \"arc\" or \"laser\""
            )));
        }
    }
    Ok(CalibrationFile {
        path: path.to_path_buf(),
        fitted,
        covariance,
        heat_source: json.heat_source,
        unknown,
    })
}

/// Carry `file` into a scenario whose heat source is `heat_source`: `set(parameter, value)`
/// puts a value in and returns the scenario's own. `kept` lists the `section.key`s that must
/// keep their value (a study case's overrides).
pub fn carry(
    file: CalibrationFile,
    heat_source: &str,
    kept: &[String],
    hot_side_sd: f64,
    set: &mut dyn FnMut(Parameter, f64) -> f64,
) -> Result<Carried> {
    if !(hot_side_sd.is_finite() && hot_side_sd.abs() <= 10.0) {
        return Err(Error::input(format!(
            "calibration.hot_side_sd = {hot_side_sd}; expected a number of standard deviations \
             in [-10, 10]"
        )));
    }
    let mut applied = Vec::new();
    let mut unused: Vec<(String, f64, String)> = file
        .unknown
        .iter()
        .map(|(n, v)| {
            (
                n.clone(),
                *v,
                "not a parameter this waamtwin knows".to_string(),
            )
        })
        .collect();
    for f in &file.fitted {
        let key = f.parameter.key();
        let section_key = format!("{}.{key}", section_of(f.parameter));
        if kept.contains(&section_key) {
            unused.push((
                key.into(),
                f.value,
                format!("the study case sets {section_key} itself"),
            ));
            continue;
        }
        if f.parameter == Parameter::Efficiency
            && let Some(fitted_under) = &file.heat_source
            && fitted_under != heat_source
        {
            unused.push((
                key.into(),
                f.value,
                format!(
                    "fitted under a {fitted_under}; this scenario's heat source is a {heat_source}"
                ),
            ));
            continue;
        }
        let value = if hot_side_sd == 0.0 {
            f.value
        } else {
            let Some(sd) = f.sd else {
                return Err(Error::input(format!(
                    "calibration.hot_side_sd = {hot_side_sd} but {} gives no spread for {key} \
                     (no covariance, no ci95); expected a calibration.json with its fit's spread",
                    file.path.display()
                )));
            };
            (f.value + hot_side_sd * heating_sign(f.parameter) * sd).clamp(f.low, f.high)
        };
        let before = set(f.parameter, value);
        applied.push((f.parameter, before, value));
    }
    Ok(Carried {
        file,
        hot_side_sd,
        applied,
        unused,
    })
}

/// The loaders' line on stderr where a calibration left something out.
pub fn tell(carried: Option<&Carried>) {
    if let Some(line) = carried.and_then(|c| c.notice()) {
        eprintln!("{line}");
    }
}

/// `[calibration]` of a scenario (None: no section) read from its folder `base` and carried
/// into its raw efficiency and thermal section, before they are checked.
pub fn apply(
    raw: Option<&RawCalibration>,
    base: &Path,
    heat_source: &str,
    kept: &[String],
    efficiency: &mut f64,
    thermal: &mut super::RawThermal,
) -> Result<Option<Carried>> {
    let Some(k) = raw else {
        return Ok(None);
    };
    let file = read(&super::resolve(base, &k.file))?;
    carry(file, heat_source, kept, k.hot_side_sd, &mut |p, x| {
        set_in(efficiency, thermal, p, x)
    })
    .map(Some)
}

/// Which way a parameter moves the heat: +1 where more of it heats the part (the efficiency),
/// −1 where it cools it (the losses).
pub fn heating_sign(p: Parameter) -> f64 {
    match p {
        Parameter::Efficiency => 1.0,
        _ => -1.0,
    }
}

/// The scenario section a parameter's key lives in.
pub fn section_of(p: Parameter) -> &'static str {
    match p {
        Parameter::Efficiency => "process",
        _ => "thermal",
    }
}

/// `set` for a scenario's own sections: the process's efficiency and the thermal losses.
pub fn set_in(efficiency: &mut f64, thermal: &mut super::RawThermal, p: Parameter, x: f64) -> f64 {
    let slot = match p {
        Parameter::Efficiency => efficiency,
        Parameter::Convection => &mut thermal.convection_w_m2k,
        Parameter::Emissivity => &mut thermal.emissivity,
        Parameter::TableContact => &mut thermal.table_contact_w_m2k,
    };
    std::mem::replace(slot, x)
}

#[cfg(test)]
mod tests {
    use super::*;

    const FILE: &str = r#"{
        "parameters": [
            {"name": "efficiency", "value": 0.6, "low": 0.2, "high": 0.95, "ci95": [0.5, 0.7]},
            {"name": "wire_stickout_mm", "value": 12.0, "low": 5.0, "high": 20.0},
            {"name": "convection_w_m2k", "value": 30.0, "low": 5.0, "high": 150.0}
        ],
        "covariance": [[0.0004, 0.0, -0.01], [0.0, 1.0, 0.0], [-0.01, 0.0, 9.0]],
        "heat_source": "laser"
    }"#;

    fn file() -> CalibrationFile {
        parse(FILE, Path::new("cal.json")).unwrap()
    }

    #[test]
    fn known_parameters_keep_their_covariance_and_unknown_ones_are_listed() {
        let f = file();
        assert_eq!(f.fitted.len(), 2);
        assert_eq!(f.unknown, vec![("wire_stickout_mm".to_string(), 12.0)]);
        assert_eq!(
            f.covariance,
            Some(vec![vec![0.0004, -0.01], vec![-0.01, 9.0]])
        );
        // The diagonal wins over the interval (0.02, not 0.051).
        assert!((f.fitted[0].sd.unwrap() - 0.02).abs() < 1e-12);
        assert!((f.fitted[1].sd.unwrap() - 3.0).abs() < 1e-12);
    }

    #[test]
    fn a_laser_absorptivity_is_not_an_arc_efficiency() {
        let (mut eta, mut t) = (0.8, super::super::RawThermal::default());
        let carried = carry(file(), "arc", &[], 0.0, &mut |p, x| {
            set_in(&mut eta, &mut t, p, x)
        })
        .unwrap();
        assert_eq!(eta, 0.8);
        assert_eq!(t.convection_w_m2k, 30.0);
        assert_eq!(carried.applied.len(), 1);
        let names: Vec<&str> = carried.unused.iter().map(|u| u.0.as_str()).collect();
        assert_eq!(names, ["wire_stickout_mm", "efficiency"]);
        assert!(
            carried.unused[1].2.contains("laser"),
            "{:?}",
            carried.unused
        );
        // The covariance follows what was applied.
        let (fits, cov) = carried.applied_fits();
        assert_eq!(fits.len(), 1);
        assert_eq!(cov, Some(vec![vec![9.0]]));

        let (mut eta, mut t) = (0.8, super::super::RawThermal::default());
        let carried = carry(
            file(),
            "laser",
            &["thermal.convection_w_m2k".into()],
            0.0,
            &mut |p, x| set_in(&mut eta, &mut t, p, x),
        )
        .unwrap();
        assert_eq!((eta, t.convection_w_m2k), (0.6, 15.0));
        assert_eq!(carried.applied, vec![(Parameter::Efficiency, 0.8, 0.6)]);
        assert!(carried.notice().unwrap().contains("study case"));

        // One standard deviation to the hot side: more efficiency, less convection.
        let (mut eta, mut t) = (0.8, super::super::RawThermal::default());
        carry(file(), "laser", &[], 1.0, &mut |p, x| {
            set_in(&mut eta, &mut t, p, x)
        })
        .unwrap();
        assert!((eta - 0.62).abs() < 1e-12 && (t.convection_w_m2k - 27.0).abs() < 1e-12);
    }

    #[test]
    fn bad_files_name_what_is_wrong() {
        let p = Path::new("c.json");
        let bad = |t: &str| parse(t, p).unwrap_err().to_string();
        assert!(bad("{}").contains("parameters"));
        let out =
            r#"{"parameters": [{"name": "emissivity", "value": 2.0, "low": 0.0, "high": 3.0}]}"#;
        assert!(bad(out).contains("emissivity = 2"), "{}", bad(out));
        let cov = r#"{"parameters": [{"name": "emissivity", "value": 0.5, "low": 0.1, "high": 0.9}],
                      "covariance": [[1.0, 0.0]]}"#;
        assert!(bad(cov).contains("1×2"), "{}", bad(cov));
        let twice = r#"{"parameters": [{"name": "efficiency", "value": 0.5, "low": 0.1, "high": 0.9},
                        {"name": "absorptivity", "value": 0.5, "low": 0.1, "high": 0.9}]}"#;
        assert!(bad(twice).contains("twice"), "{}", bad(twice));
    }
}
