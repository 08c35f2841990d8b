//! Replay scenarios: a toolpath the machine ran (not a CTPP plan), the process and material it
//! ran with, the heat model's settings (the `[thermal]` section of every scenario), and the
//! probes the part was measured with. Every key is documented in `scenarios/README.md`; file
//! paths are relative to the scenario's folder.

use super::{Checker, RawThermal, ThermalSettings, toml_error};
use crate::error::{Error, Result};
use crate::pipeline::replay::Laying;
use serde::{Deserialize, Serialize};
use std::path::{Path, PathBuf};
use thermal::ZERO_CELSIUS_K as KELVIN;

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawReplay {
    pub toolpath: RawToolpath,
    pub process: RawLaying,
    pub material: RawTables,
    /// The plate's own material, in the same form (voxel model only); absent: the deposit's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plate_material: Option<RawTables>,
    #[serde(default)]
    pub thermal: RawThermal,
    pub probes: Option<RawProbes>,
    #[serde(default)]
    pub compare: RawCompare,
    pub calibrate: Option<RawCalibrate>,
    /// How `follow` runs the twin on this build.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub live: Option<RawLive>,
    /// `[calibration] file`: a calibrate run's fitted values replace this file's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub calibration: Option<super::calibration::RawCalibration>,
}

/// `[live]`: the twin's ensemble, its filter, its forecasts and its alarms.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawLive {
    #[serde(default = "sixteen")]
    pub ensemble: usize,
    /// A reading's error (the sensor's and how well one voxel stands for it), °C.
    #[serde(default = "five")]
    pub reading_sd_c: f64,
    /// Gaspari–Cohn half-width of the field's correction around a sensor (zero beyond twice
    /// it), mm.
    #[serde(default = "twenty_five")]
    pub localisation_mm: f64,
    /// Relaxation of the spread to its prior (RTPS, 0 none, 1 all): the inflation.
    #[serde(default = "half")]
    pub relaxation: f64,
    /// Least build time between two analyses, s.
    #[serde(default = "one")]
    pub assimilate_every_s: f64,
    /// Least build time between two updates of the parameters, s.
    #[serde(default = "thirty")]
    pub parameters_every_s: f64,
    #[serde(default = "thirty")]
    pub forecast_every_s: f64,
    #[serde(default = "horizons")]
    pub forecast_horizons_s: Vec<f64>,
    /// Wall-clock seconds without a new reading before the source is said to stall.
    #[serde(default = "thirty")]
    pub stall_s: f64,
    /// The interpass limit the alarms judge the next layer's start by, °C.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub interpass_max_c: Option<f64>,
    /// The strength limit the alarms judge it by too (the lower of the two binds), °C.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub strength_loss_c: Option<f64>,
    /// The humping limit the alarms judge the next layer's melt pool by, mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub humping_pool_mm: Option<f64>,
    /// The twin's voxel edge where it is not `[thermal] voxel_mm` (a coarser grid keeps an
    /// ensemble ahead of the cell), mm.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub voxel_mm: Option<f64>,
    /// The twin's plate coarsened away from the metal laid on it (`[thermal] coarse_plate`);
    /// on by default: the plate is most of a small part's cells, and the ensemble runs them
    /// all many times over.
    #[serde(default = "yes")]
    pub coarse_plate: bool,
    /// A calibration.json whose fitted values and intervals are the prior instead of
    /// `[calibrate]`'s ranges.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub prior: Option<String>,
    #[serde(default = "one_u64")]
    pub seed: u64,
    /// `[live.opcua]`: the probes read from an OPC UA server instead of the probe file.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub opcua: Option<RawOpcua>,
    /// `[live.machine_log]`: the machine's state beside the probes in the probe file's rows.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub machine_log: Option<RawMachineLog>,
}

/// `[live.machine_log]`: where the probe file's rows (or the OPC UA nodes `arc_on`,
/// `voltage_v`, `current_a`, `power_w`) say what the machine did.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawMachineLog {
    /// The log's own file (followed as the probe file is), where it is not the probe file's
    /// rows; its columns are then that file's, its times in `time_column`.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub file: Option<String>,
    #[serde(default)]
    pub time_column: usize,
    /// The arc's state (on where above `arc_on_above`): a flag, or the current.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub arc_on_column: Option<usize>,
    #[serde(default = "half")]
    pub arc_on_above: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub voltage_v_column: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub current_a_column: Option<usize>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub power_w_column: Option<usize>,
}

/// `[live.opcua]`: where the cell publishes its sensors.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawOpcua {
    /// `opc.tcp://HOST:PORT/PATH`.
    pub endpoint: String,
    /// The Unix time of the program's t = 0, s: a value's source timestamp less it is its
    /// build time.
    pub time_origin_unix_s: f64,
    /// One node id per probe, by the probe's name (`tc1 = "ns=2;s=tc1"`).
    pub nodes: std::collections::BTreeMap<String, String>,
    /// How often the server is asked to publish what changed, ms.
    #[serde(default = "hundred")]
    pub publishing_interval_ms: f64,
}

fn hundred() -> f64 {
    100.0
}

fn five() -> f64 {
    5.0
}
fn twenty_five() -> f64 {
    25.0
}
fn half() -> f64 {
    0.5
}
fn thirty() -> f64 {
    30.0
}
fn horizons() -> Vec<f64> {
    vec![60.0, 300.0]
}
fn one_u64() -> u64 {
    1
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawToolpath {
    pub file: String,
    /// "events": `t_s, x_mm, y_mm, z_mm, on`; "machine_log": a logger's CSV with `t_s`,
    /// `weld_voltage_v`, `weld_current_a`, `weld_on`, `x_mm`, `y_mm`, `z_mm` columns.
    #[serde(default = "events")]
    pub format: String,
    #[serde(default = "one")]
    pub deposit_mm: f64,
    /// Added to every z of the file: a logged torch height is not the bead's top.
    #[serde(default)]
    pub z_offset_mm: f64,
    /// Added to every time of the file: puts it on the probes' clock.
    #[serde(default)]
    pub time_offset_s: f64,
    /// Events: whether a waypoint's `on` is the segment's ending there ("ending_here", GAMMA's)
    /// or starting there ("starting_here", the event-series convention ORNL's file follows).
    #[serde(default = "ending_here")]
    pub on_flag: String,
    /// G-code: the codes that strike and stop the arc.
    #[serde(default = "m3")]
    pub arc_on: String,
    #[serde(default = "m5")]
    pub arc_off: String,
    /// G-code: "mm/min" (the standard) or "mm/s".
    #[serde(default = "per_minute")]
    pub feed_unit: String,
    /// G-code: speed of moves with the arc off, where the controller travels faster than the
    /// programmed feed.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub travel_mm_s: Option<f64>,
}

fn m3() -> String {
    "M3".into()
}

fn m5() -> String {
    "M5".into()
}

fn per_minute() -> String {
    "mm/min".into()
}

fn ending_here() -> String {
    "ending_here".into()
}

fn arc() -> String {
    "arc".into()
}

fn events() -> String {
    "events".into()
}

fn one() -> f64 {
    1.0
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawLaying {
    /// "arc" (a double ellipsoid sized by the bead) or "laser" (a Gaussian on the surface).
    #[serde(default = "arc")]
    pub source: String,
    /// The laser's 1/e² radius.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub beam_radius_mm: Option<f64>,
    pub power_w: f64,
    /// Arc efficiency or laser absorptivity.
    pub efficiency: f64,
    pub bead_width_mm: f64,
    pub layer_height_mm: f64,
}

/// A preset ("G3Si") or a material from property tables (two columns: T in K, value; comma or
/// space separated), which then needs every key but `preset`.
#[derive(Debug, Clone, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawTables {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub preset: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub density_kg_m3: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub specific_heat_table: Option<String>,
    /// "J/(kg K)" or "J/(g K)".
    #[serde(skip_serializing_if = "Option::is_none")]
    pub specific_heat_unit: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conductivity_table: Option<String>,
    /// "W/(m K)" or "W/(mm K)".
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conductivity_unit: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub solidus_c: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub liquidus_c: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub latent_j_kg: Option<f64>,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawProbes {
    pub file: String,
    /// "C" or "K".
    pub unit: String,
    #[serde(default)]
    pub time_column: usize,
    pub points: Vec<RawProbe>,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawProbe {
    pub name: String,
    pub column: usize,
    pub x_mm: f64,
    pub y_mm: f64,
    pub z_mm: f64,
}

#[derive(Debug, Clone, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawCompare {
    /// Build time over which agreement is judged, s (default: the whole build).
    pub window_s: Option<[f64; 2]>,
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawCalibrate {
    /// Up to three of "efficiency", "convection_w_m2k", "emissivity", "table_contact_w_m2k",
    /// each with its search range.
    pub parameters: Vec<RawParameter>,
    pub fit_s: Option<[f64; 2]>,
    pub holdout_s: Option<[f64; 2]>,
    #[serde(default = "sixteen")]
    pub max_runs: usize,
}

fn yes() -> bool {
    true
}

fn sixteen() -> usize {
    16
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawParameter {
    pub name: String,
    pub low: f64,
    pub high: f64,
}

pub use crate::pipeline::replay::Parameter;

/// A parameter to fit and its range.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Fitted {
    pub parameter: Parameter,
    pub range: crate::pipeline::calibrate::Range,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Calibrate {
    pub parameters: Vec<Fitted>,
    pub fit_s: Option<[f64; 2]>,
    pub holdout_s: Option<[f64; 2]>,
    pub max_runs: usize,
}

/// A probe as the command uses it: where it is (m) and which column it reads.
#[derive(Debug, Clone, PartialEq)]
pub struct Probe {
    pub name: String,
    pub column: usize,
    pub position_m: [f64; 3],
}

#[derive(Debug, Clone, PartialEq)]
pub struct Probes {
    pub file: PathBuf,
    pub kelvin: bool,
    pub time_column: usize,
    pub points: Vec<Probe>,
}

/// How the toolpath file is written.
#[derive(Debug, Clone, PartialEq)]
pub enum ToolpathFormat {
    Events,
    MachineLog,
    Gcode(crate::measured::gcode::Dialect),
}

fn gcode_dialect(t: &RawToolpath, c: &Checker) -> Result<crate::measured::gcode::Dialect> {
    let feed_scale = match t.feed_unit.as_str() {
        "mm/min" => 1.0 / 60.0,
        "mm/s" => 1.0,
        other => {
            return Err(c.fail(
                "toolpath",
                "feed_unit",
                format!("\"{other}\""),
                "\"mm/min\" or \"mm/s\"",
            ));
        }
    };
    if let Some(v) = t.travel_mm_s {
        c.positive("toolpath", "travel_mm_s", v, 1e5)?;
    }
    for (key, code) in [("arc_on", &t.arc_on), ("arc_off", &t.arc_off)] {
        let b = code.as_bytes();
        let ok = b.len() >= 2
            && b[0].is_ascii_uppercase()
            && code[1..].parse::<f64>().is_ok_and(|x| x.is_finite());
        if !ok {
            return Err(c.fail(
                "toolpath",
                key,
                format!("\"{code}\""),
                "a G-code word: a capital letter and a number, e.g. \"M101\"",
            ));
        }
    }
    Ok(crate::measured::gcode::Dialect {
        arc_on: t.arc_on.clone(),
        arc_off: t.arc_off.clone(),
        feed_scale,
        travel_mm_s: t.travel_mm_s,
    })
}

/// Where the replay's material comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum MaterialSpec {
    /// G3Si (ER70S-6 class) on a low-carbon steel plate: `thermal::material::Material::g3si`.
    G3Si,
    /// IN718, the GAMMA authors' tables: `thermal::material::Material::in718`.
    In718,
    Tables(Tables),
}

/// The material's tables, resolved.
#[derive(Debug, Clone, PartialEq)]
pub struct Tables {
    pub name: String,
    pub density_kg_m3: f64,
    pub specific_heat: PathBuf,
    /// Multiplies the file's values into J/(kg K).
    pub specific_heat_scale: f64,
    pub conductivity: PathBuf,
    /// Multiplies the file's values into W/(m K).
    pub conductivity_scale: f64,
    pub solidus_k: f64,
    pub liquidus_k: f64,
    pub latent_j_kg: f64,
}

#[derive(Debug, Clone)]
pub struct ReplayScenario {
    pub toolpath: PathBuf,
    pub format: ToolpathFormat,
    pub z_offset_mm: f64,
    pub time_offset_s: f64,
    /// An event's `on` holds for the segment starting at it.
    pub flag_starts: bool,
    pub laying: Laying,
    pub source: thermal::voxel::HeatSource,
    pub material: MaterialSpec,
    /// The plate's own material, where it is not the deposit's.
    pub plate_material: Option<MaterialSpec>,
    pub thermal: ThermalSettings,
    pub probes: Option<Probes>,
    pub window_s: Option<[f64; 2]>,
    pub calibrate: Option<Calibrate>,
    /// `[live]`, checked; None where the scenario has none (`follow` then takes the defaults).
    pub live: Option<Live>,
    /// `[calibration] file`: what it carried in (already in the values above) and what not.
    pub calibration: Option<super::calibration::Carried>,
    pub raw: RawReplay,
}

/// `[live]`, checked, in SI where the engine takes it.
#[derive(Debug, Clone, PartialEq)]
pub struct Live {
    pub twin: crate::pipeline::twin::Settings,
    pub stall_s: f64,
    pub voxel_m: Option<f64>,
    pub coarse_plate: bool,
    /// The calibration.json to take the prior from.
    pub prior: Option<PathBuf>,
    /// Where the probes are read from when not from the probe file.
    pub opcua: Option<Opcua>,
    pub machine_log: Option<MachineLog>,
}

/// `[live.opcua]`, checked.
#[derive(Debug, Clone, PartialEq)]
pub struct Opcua {
    pub endpoint: String,
    pub time_origin_unix_s: f64,
    /// (slot in a row, node id) for each signal the server publishes, in slot order: a probe
    /// by its index, a machine signal after the probes ([`Signal`]).
    pub nodes: Vec<(usize, String)>,
    pub publishing_interval_s: f64,
}

/// A machine signal's slot after the probes in a row.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Signal {
    ArcOn = 0,
    VoltageV = 1,
    CurrentA = 2,
    PowerW = 3,
}

impl Signal {
    pub const ALL: [Signal; 4] = [
        Signal::ArcOn,
        Signal::VoltageV,
        Signal::CurrentA,
        Signal::PowerW,
    ];
    pub fn key(self) -> &'static str {
        ["arc_on", "voltage_v", "current_a", "power_w"][self as usize]
    }
}

/// `[live.machine_log]`, checked: the columns of the probe file (None: not logged), and the
/// arc's threshold.
#[derive(Debug, Clone, PartialEq)]
pub struct MachineLog {
    /// Per [`Signal`], its column.
    pub columns: [Option<usize>; 4],
    pub arc_on_above: f64,
    /// Its own file and that file's time column, where it is not in the probe file's rows.
    pub file: Option<(PathBuf, usize)>,
}

impl ReplayScenario {
    pub fn load(path: &Path) -> Result<ReplayScenario> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::input(format!("cannot read scenario {}: {e}", path.display())))?;
        let base = path.parent().unwrap_or(Path::new("."));
        let s = ReplayScenario::parse(&text, &path.display().to_string(), base)?;
        super::calibration::tell(s.calibration.as_ref());
        Ok(s)
    }

    pub fn parse(text: &str, file: &str, base: &Path) -> Result<ReplayScenario> {
        let mut raw: RawReplay =
            toml::from_str(text).map_err(|e| toml_error(&e, text, file, true))?;
        let calibration = super::calibration::apply(
            raw.calibration.as_ref(),
            base,
            &raw.process.source,
            &[],
            &mut raw.process.efficiency,
            &mut raw.thermal,
        )?;
        let c = Checker {
            text,
            file,
            lines: true,
        };
        let p = &raw.process;
        let laying = Laying {
            power_w: p.power_w,
            efficiency: p.efficiency,
            width_m: p.bead_width_mm * 1e-3,
            height_m: p.layer_height_mm * 1e-3,
            deposit_m: raw.toolpath.deposit_mm * 1e-3,
        };
        laying.check().map_err(|e| c.invalid(e))?;
        c.range(
            "toolpath",
            "z_offset_mm",
            raw.toolpath.z_offset_mm,
            -1000.0,
            1000.0,
            "a height in [-1000, 1000] mm",
        )?;
        c.range(
            "toolpath",
            "time_offset_s",
            raw.toolpath.time_offset_s,
            -1e7,
            1e7,
            "a time in [-1e7, 1e7] s",
        )?;
        let format = match raw.toolpath.format.as_str() {
            "events" => ToolpathFormat::Events,
            "machine_log" => ToolpathFormat::MachineLog,
            "gcode" => ToolpathFormat::Gcode(gcode_dialect(&raw.toolpath, &c)?),
            other => {
                return Err(c.fail(
                    "toolpath",
                    "format",
                    format!("\"{other}\""),
                    "\"events\" (t_s, x_mm, y_mm, z_mm, on), \"machine_log\" or \"gcode\" (\"path\", \
                     a plan's path.csv, is replayed by `waamtwin replay` on the part's own scenario)",
                ));
            }
        };
        let thermal = super::thermal(&raw.thermal, p.bead_width_mm, &c)?;
        Ok(ReplayScenario {
            toolpath: super::resolve(base, &raw.toolpath.file),
            format,
            z_offset_mm: raw.toolpath.z_offset_mm,
            time_offset_s: raw.toolpath.time_offset_s,
            flag_starts: match raw.toolpath.on_flag.as_str() {
                "ending_here" => false,
                "starting_here" => true,
                other => {
                    return Err(c.fail(
                        "toolpath",
                        "on_flag",
                        format!("\"{other}\""),
                        "\"ending_here\" or \"starting_here\"",
                    ));
                }
            },
            laying,
            source: source(p, &c)?,
            material: tables(&raw.material, "material", &c, base)?,
            plate_material: match &raw.plate_material {
                Some(m) => Some(plate_material(m, &raw.thermal, &c, base)?),
                None => None,
            },
            thermal,
            probes: raw
                .probes
                .as_ref()
                .map(|p| probes(p, &c, base))
                .transpose()?,
            window_s: window(&raw.compare, &c)?,
            calibrate: match &raw.calibrate {
                Some(k) => Some(calibrate(k, &raw, &thermal_start(&raw), &c)?),
                None => None,
            },
            live: raw
                .live
                .as_ref()
                .map(|l| live(l, raw.probes.as_ref(), &c, base))
                .transpose()?,
            calibration,
            raw,
        })
    }

    pub fn to_json(&self) -> serde_json::Value {
        let mut v = serde_json::to_value(&self.raw).unwrap_or_default();
        if let (Some(c), Some(o)) = (&self.calibration, v.as_object_mut()) {
            o.insert("calibration".into(), c.to_json());
        }
        v
    }
}

/// `[plate_material]`: a material as `[material]` gives one, for the voxel model's plate.
fn plate_material(
    m: &RawTables,
    thermal: &RawThermal,
    c: &Checker,
    base: &Path,
) -> Result<MaterialSpec> {
    if thermal.model != "voxel" {
        return Err(c.fail_text(
            "plate_material",
            "preset",
            format!(
                "a plate of its own material with thermal.model = \"{}\"; expected \
                 thermal.model = \"voxel\" (the thin wall is one material throughout)",
                thermal.model
            ),
        ));
    }
    tables(m, "plate_material", c, base)
}

fn tables(m: &RawTables, section: &str, c: &Checker, base: &Path) -> Result<MaterialSpec> {
    if let Some(p) = &m.preset {
        let others = m.name.is_some()
            || m.density_kg_m3.is_some()
            || m.specific_heat_table.is_some()
            || m.conductivity_table.is_some();
        return match (p.as_str(), others) {
            ("G3Si", false) => Ok(MaterialSpec::G3Si),
            ("IN718", false) => Ok(MaterialSpec::In718),
            ("G3Si" | "IN718", true) => Err(c.fail_text(
                section,
                "preset",
                format!("preset = \"{p}\" with table keys beside it; expected one or the other"),
            )),
            (other, _) => Err(c.fail(
                section,
                "preset",
                format!("\"{other}\""),
                "\"G3Si\" or \"IN718\", or tables instead of a preset",
            )),
        };
    }
    let need = |key: &str| {
        c.fail_text(
            section,
            key,
            format!("{key} is missing; expected a preset or every table key"),
        )
    };
    let text = |v: &Option<String>, key: &str| v.clone().ok_or_else(|| need(key));
    let number = |v: Option<f64>, key: &str| v.ok_or_else(|| need(key));
    let m = Resolved {
        name: text(&m.name, "name")?,
        density_kg_m3: number(m.density_kg_m3, "density_kg_m3")?,
        specific_heat_table: text(&m.specific_heat_table, "specific_heat_table")?,
        specific_heat_unit: text(&m.specific_heat_unit, "specific_heat_unit")?,
        conductivity_table: text(&m.conductivity_table, "conductivity_table")?,
        conductivity_unit: text(&m.conductivity_unit, "conductivity_unit")?,
        solidus_c: number(m.solidus_c, "solidus_c")?,
        liquidus_c: number(m.liquidus_c, "liquidus_c")?,
        latent_j_kg: number(m.latent_j_kg, "latent_j_kg")?,
    };
    let m = &m;
    c.positive(section, "density_kg_m3", m.density_kg_m3, 30_000.0)?;
    c.range(
        section,
        "solidus_c",
        m.solidus_c,
        0.0,
        3500.0,
        "a temperature in [0, 3500] °C",
    )?;
    c.range(
        section,
        "liquidus_c",
        m.liquidus_c,
        m.solidus_c + 1.0,
        3500.0,
        "above solidus_c",
    )?;
    c.range(
        section,
        "latent_j_kg",
        m.latent_j_kg,
        0.0,
        1e7,
        "a latent heat in [0, 1e7] J/kg",
    )?;
    let cp = match m.specific_heat_unit.as_str() {
        "J/(kg K)" => 1.0,
        "J/(g K)" => 1e3,
        other => {
            return Err(c.fail(
                section,
                "specific_heat_unit",
                format!("\"{other}\""),
                "\"J/(kg K)\" or \"J/(g K)\"",
            ));
        }
    };
    let k = match m.conductivity_unit.as_str() {
        "W/(m K)" => 1.0,
        "W/(mm K)" => 1e3,
        other => {
            return Err(c.fail(
                section,
                "conductivity_unit",
                format!("\"{other}\""),
                "\"W/(m K)\" or \"W/(mm K)\"",
            ));
        }
    };
    Ok(MaterialSpec::Tables(Tables {
        name: m.name.clone(),
        density_kg_m3: m.density_kg_m3,
        specific_heat: super::resolve(base, &m.specific_heat_table),
        specific_heat_scale: cp,
        conductivity: super::resolve(base, &m.conductivity_table),
        conductivity_scale: k,
        solidus_k: m.solidus_c + KELVIN,
        liquidus_k: m.liquidus_c + KELVIN,
        latent_j_kg: m.latent_j_kg,
    }))
}

/// The table keys once all are there.
struct Resolved {
    name: String,
    density_kg_m3: f64,
    specific_heat_table: String,
    specific_heat_unit: String,
    conductivity_table: String,
    conductivity_unit: String,
    solidus_c: f64,
    liquidus_c: f64,
    latent_j_kg: f64,
}

fn probes(p: &RawProbes, c: &Checker, base: &Path) -> Result<Probes> {
    let kelvin = match p.unit.as_str() {
        "C" => false,
        "K" => true,
        other => {
            return Err(c.fail("probes", "unit", format!("\"{other}\""), "\"C\" or \"K\""));
        }
    };
    if p.points.is_empty() {
        return Err(c.fail_text("probes", "points", "points is empty; expected at least one"));
    }
    let mut points = Vec::with_capacity(p.points.len());
    for (k, q) in p.points.iter().enumerate() {
        let xyz = [q.x_mm, q.y_mm, q.z_mm];
        if !xyz.iter().all(|v| v.is_finite()) || q.column == p.time_column {
            return Err(c.fail_text(
                "probes",
                "points",
                format!(
                    "points[{k}] ({}) at {xyz:?} mm, column {}; expected finite coordinates and \
                     a column other than the time column {}",
                    q.name, q.column, p.time_column
                ),
            ));
        }
        points.push(Probe {
            name: q.name.clone(),
            column: q.column,
            position_m: xyz.map(|v| v * 1e-3),
        });
    }
    Ok(Probes {
        file: super::resolve(base, &p.file),
        kelvin,
        time_column: p.time_column,
        points,
    })
}

fn source(p: &RawLaying, c: &Checker) -> Result<thermal::voxel::HeatSource> {
    use thermal::voxel::HeatSource;
    match (p.source.as_str(), p.beam_radius_mm) {
        ("arc", None) => Ok(HeatSource::DoubleEllipsoid),
        ("laser", Some(r)) => {
            c.positive("process", "beam_radius_mm", r, 100.0)?;
            Ok(HeatSource::Gaussian { radius: r * 1e-3 })
        }
        ("laser", None) => Err(c.fail_text(
            "process",
            "source",
            "source = \"laser\" without beam_radius_mm; expected the beam's 1/e² radius",
        )),
        ("arc", Some(_)) => Err(c.fail_text(
            "process",
            "beam_radius_mm",
            "beam_radius_mm with source = \"arc\"; expected it only for a laser",
        )),
        (other, _) => Err(c.fail(
            "process",
            "source",
            format!("\"{other}\""),
            "\"arc\" or \"laser\"",
        )),
    }
}

/// No `[live]`: the documented defaults.
impl Default for Live {
    fn default() -> Live {
        Live {
            twin: crate::pipeline::twin::Settings::default(),
            stall_s: 30.0,
            voxel_m: None,
            coarse_plate: true,
            prior: None,
            opcua: None,
            machine_log: None,
        }
    }
}

/// `[live]`, each key checked.
fn live(l: &RawLive, probes: Option<&RawProbes>, c: &Checker, base: &Path) -> Result<Live> {
    c.positive("live", "stall_s", l.stall_s, 1e6)?;
    if let Some(v) = l.voxel_mm {
        c.positive("live", "voxel_mm", v, 100.0)?;
    }
    let mut horizons_s = l.forecast_horizons_s.clone();
    horizons_s.sort_by(f64::total_cmp);
    horizons_s.dedup();
    let twin = crate::pipeline::twin::Settings {
        ensemble: l.ensemble,
        reading_sd_k: l.reading_sd_c,
        localisation_m: l.localisation_mm * 1e-3,
        relaxation: l.relaxation,
        assimilate_every_s: l.assimilate_every_s,
        parameters_every_s: l.parameters_every_s,
        forecast_every_s: l.forecast_every_s,
        horizons_s,
        interpass_max_k: l.interpass_max_c.map(|v| v + KELVIN),
        strength_loss_k: l.strength_loss_c.map(|v| v + KELVIN),
        humping_pool_m: l.humping_pool_mm.map(|v| v * 1e-3),
        seed: l.seed,
    };
    twin.check().map_err(|e| c.invalid(e))?;
    Ok(Live {
        twin,
        stall_s: l.stall_s,
        voxel_m: l.voxel_mm.map(|v| v * 1e-3),
        coarse_plate: l.coarse_plate,
        prior: l.prior.as_ref().map(|p| super::resolve(base, p)),
        opcua: l.opcua.as_ref().map(|o| opcua(o, probes, c)).transpose()?,
        machine_log: l
            .machine_log
            .as_ref()
            .map(|m| machine_log(m, l.opcua.is_some(), c, base))
            .transpose()?,
    })
}

/// `[live.machine_log]`: the arc's state at least (from the file, or from the OPC UA node
/// `arc_on`), and the power from `power_w` or from both of `voltage_v` and `current_a`.
fn machine_log(m: &RawMachineLog, opcua: bool, c: &Checker, base: &Path) -> Result<MachineLog> {
    const SECTION: &str = "live.machine_log";
    if m.file.is_some() && opcua {
        return Err(c.fail_text(
            SECTION,
            "file",
            "file with [live.opcua]; expected one source of the machine's signals: the OPC UA \
             nodes, or a file",
        ));
    }
    if m.arc_on_column.is_none() && !opcua {
        return Err(c.fail_text(
            SECTION,
            "arc_on_column",
            "arc_on_column missing; expected the log's column of the arc's state",
        ));
    }
    let columns = [
        m.arc_on_column,
        m.voltage_v_column,
        m.current_a_column,
        m.power_w_column,
    ];
    if m.file.is_some() && columns.contains(&Some(m.time_column)) {
        return Err(c.fail(
            SECTION,
            "time_column",
            m.time_column,
            "a column other than the signals' own",
        ));
    }
    if m.voltage_v_column.is_some() != m.current_a_column.is_some() {
        return Err(c.fail_text(
            SECTION,
            "voltage_v_column",
            "voltage_v_column and current_a_column go together (the power is V·I)",
        ));
    }
    if !m.arc_on_above.is_finite() {
        return Err(c.fail(
            SECTION,
            "arc_on_above",
            m.arc_on_above,
            "a finite threshold",
        ));
    }
    Ok(MachineLog {
        columns: [
            m.arc_on_column,
            m.voltage_v_column,
            m.current_a_column,
            m.power_w_column,
        ],
        arc_on_above: m.arc_on_above,
        file: m
            .file
            .as_ref()
            .map(|f| (super::resolve(base, f), m.time_column)),
    })
}

/// `[live.opcua]`: an `opc.tcp` endpoint, a time origin, and a node for known probes only.
fn opcua(o: &RawOpcua, probes: Option<&RawProbes>, c: &Checker) -> Result<Opcua> {
    const SECTION: &str = "live.opcua";
    if !o.endpoint.starts_with("opc.tcp://") {
        return Err(c.fail(
            SECTION,
            "endpoint",
            format!("\"{}\"", o.endpoint),
            "an opc.tcp://HOST:PORT address",
        ));
    }
    c.range(
        SECTION,
        "time_origin_unix_s",
        o.time_origin_unix_s,
        0.0,
        1e11,
        "a Unix time in s",
    )?;
    c.range(
        SECTION,
        "publishing_interval_ms",
        o.publishing_interval_ms,
        1.0,
        60_000.0,
        "1 to 60000 ms",
    )?;
    let names: Vec<&str> = probes.map_or(Vec::new(), |p| {
        p.points.iter().map(|q| q.name.as_str()).collect()
    });
    let mut nodes = Vec::with_capacity(o.nodes.len());
    for (name, node) in &o.nodes {
        let machine = Signal::ALL
            .iter()
            .find(|s| s.key() == name)
            .map(|s| names.len() + *s as usize);
        let Some(k) = names.iter().position(|n| n == name).or(machine) else {
            return Err(c.fail_text(
                SECTION,
                "nodes",
                format!(
                    "nodes.{name}: no probe or machine signal of that name; expected one of \
                     [probes] points ({}) or arc_on, voltage_v, current_a, power_w",
                    names.join(", ")
                ),
            ));
        };
        if node.trim().is_empty() {
            return Err(c.fail_text(
                SECTION,
                "nodes",
                format!("nodes.{name} is empty; expected a node id such as \"ns=2;s={name}\""),
            ));
        }
        nodes.push((k, node.clone()));
    }
    if nodes.is_empty() {
        return Err(c.fail_text(
            SECTION,
            "nodes",
            "nodes is empty; expected a node id for at least one probe",
        ));
    }
    nodes.sort();
    Ok(Opcua {
        endpoint: o.endpoint.clone(),
        time_origin_unix_s: o.time_origin_unix_s,
        nodes,
        publishing_interval_s: o.publishing_interval_ms * 1e-3,
    })
}

/// The scenario's own values of the parameters a calibration may fit, where it starts.
fn thermal_start(raw: &RawReplay) -> [f64; 4] {
    [
        raw.process.efficiency,
        raw.thermal.convection_w_m2k,
        raw.thermal.emissivity,
        raw.thermal.table_contact_w_m2k,
    ]
}

fn calibrate(
    k: &RawCalibrate,
    raw: &RawReplay,
    start: &[f64; 4],
    c: &Checker,
) -> Result<Calibrate> {
    if raw.probes.is_none() {
        return Err(c.fail_text(
            "calibrate",
            "parameters",
            "parameters given, but no [probes] to fit them to",
        ));
    }
    if k.parameters.is_empty() || k.parameters.len() > 3 {
        return Err(c.fail(
            "calibrate",
            "parameters",
            format!("{} parameters", k.parameters.len()),
            "one to three",
        ));
    }
    let mut out: Vec<Fitted> = Vec::new();
    for p in &k.parameters {
        let Some(at) = Parameter::ALL.iter().position(|q| q.key() == p.name) else {
            return Err(c.fail(
                "calibrate",
                "parameters",
                format!("\"{}\"", p.name),
                "\"efficiency\", \"convection_w_m2k\", \"emissivity\" or \"table_contact_w_m2k\"",
            ));
        };
        let parameter = Parameter::ALL[at];
        let [lo, hi] = parameter.limits();
        let good = p.low.is_finite()
            && p.high.is_finite()
            && lo <= p.low
            && p.low < p.high
            && p.high <= hi;
        if !good
            || !(p.low..=p.high).contains(&start[at])
            || out.iter().any(|f| f.parameter == parameter)
        {
            return Err(c.fail(
                "calibrate",
                "parameters",
                format!("{} in [{}, {}] from {}", p.name, p.low, p.high, start[at]),
                &format!(
                    "a range within [{lo}, {hi}] holding the scenario's own value, each \
                     parameter once"
                ),
            ));
        }
        out.push(Fitted {
            parameter,
            range: crate::pipeline::calibrate::Range {
                low: p.low,
                high: p.high,
            },
        });
    }
    if k.max_runs < 2 * out.len() + 2 {
        return Err(c.fail(
            "calibrate",
            "max_runs",
            k.max_runs,
            &format!(
                "at least {} (a step and the Jacobian at its end)",
                2 * out.len() + 2
            ),
        ));
    }
    let windows = [("fit_s", k.fit_s), ("holdout_s", k.holdout_s)];
    for (key, w) in windows {
        if let Some([a, b]) = w
            && !(a.is_finite() && b.is_finite() && b > a)
        {
            return Err(c.fail(
                "calibrate",
                key,
                format!("[{a}, {b}]"),
                "[start, end] in seconds, end after start",
            ));
        }
    }
    Ok(Calibrate {
        parameters: out,
        fit_s: k.fit_s,
        holdout_s: k.holdout_s,
        max_runs: k.max_runs,
    })
}

fn window(w: &RawCompare, c: &Checker) -> Result<Option<[f64; 2]>> {
    match w.window_s {
        Some([a, b]) if !(a.is_finite() && b.is_finite() && b > a) => Err(c.fail(
            "compare",
            "window_s",
            format!("[{a}, {b}]"),
            "[start, end] in seconds, end after start",
        )),
        other => Ok(other),
    }
}

#[cfg(test)]
mod tests {
    use super::ReplayScenario;
    use std::path::Path;

    const GOOD: &str = "[toolpath]\nfile = \"p.csv\"\n[process]\npower_w = 500.0\nefficiency = 0.5\n\
        bead_width_mm = 2.0\nlayer_height_mm = 0.75\n[material]\nname = \"IN718\"\n\
        density_kg_m3 = 8190.0\nspecific_heat_table = \"cp.txt\"\nspecific_heat_unit = \"J/(g K)\"\n\
        conductivity_table = \"k.txt\"\nconductivity_unit = \"W/(mm K)\"\nsolidus_c = 1260.0\n\
        liquidus_c = 1336.0\nlatent_j_kg = 2.7e5\n[thermal]\nmodel = \"voxel\"\n";

    #[test]
    fn a_good_scenario_resolves_its_files_and_units() {
        let s = ReplayScenario::parse(GOOD, "r.toml", Path::new("/data")).unwrap();
        assert_eq!(s.toolpath, Path::new("/data/p.csv"));
        let super::MaterialSpec::Tables(t) = &s.material else {
            panic!("tables expected")
        };
        assert_eq!(t.specific_heat_scale, 1e3);
        assert_eq!(t.conductivity_scale, 1e3);
        let preset = GOOD.replace("name = \"IN718\"", "preset = \"G3Si\"\nname = \"IN718\"");
        let e = ReplayScenario::parse(&preset, "r.toml", Path::new(".")).unwrap_err();
        assert!(e.message.contains("one or the other"), "{}", e.message);
        let missing = GOOD.replace("latent_j_kg = 2.7e5\n", "");
        let e = ReplayScenario::parse(&missing, "r.toml", Path::new(".")).unwrap_err();
        assert!(
            e.message.contains("latent_j_kg is missing"),
            "{}",
            e.message
        );
        assert!((s.laying.width_m - 2e-3).abs() < 1e-15);
        assert!(s.probes.is_none());
    }

    /// `[plate_material]` takes the forms `[material]` does, on the voxel model only; its
    /// errors name its own section.
    #[test]
    fn a_plate_of_its_own_material() {
        let s = ReplayScenario::parse(GOOD, "r.toml", Path::new(".")).unwrap();
        assert!(s.plate_material.is_none());
        let steel = format!("{GOOD}[plate_material]\npreset = \"G3Si\"\n");
        let s = ReplayScenario::parse(&steel, "r.toml", Path::new(".")).unwrap();
        assert_eq!(s.plate_material, Some(super::MaterialSpec::G3Si));
        let e = ReplayScenario::parse(
            &steel.replace("model = \"voxel\"", "model = \"thin-wall\""),
            "r.toml",
            Path::new("."),
        )
        .unwrap_err();
        assert!(
            e.message.contains("thermal.model = \"voxel\""),
            "{}",
            e.message
        );
        let bad = format!("{GOOD}[plate_material]\npreset = \"A36\"\n");
        let e = ReplayScenario::parse(&bad, "r.toml", Path::new(".")).unwrap_err();
        assert!(e.message.contains("plate_material.preset"), "{}", e.message);
        assert!(e.message.contains("\"A36\""), "{}", e.message);
    }

    #[test]
    fn bad_values_name_their_key_and_line() {
        let bad = GOOD.replace("efficiency = 0.5", "efficiency = 1.5");
        let e = ReplayScenario::parse(&bad, "r.toml", Path::new(".")).unwrap_err();
        assert!(
            e.message
                .contains("r.toml line 5: process.efficiency = 1.5"),
            "{}",
            e.message
        );
        // The thin wall replays too, on a box plate.
        let fe = GOOD.replace("model = \"voxel\"", "model = \"thin-wall\"");
        assert!(ReplayScenario::parse(&fe, "r.toml", Path::new(".")).is_ok());
        let unit = GOOD.replace("W/(mm K)", "W/mK");
        let e = ReplayScenario::parse(&unit, "r.toml", Path::new(".")).unwrap_err();
        assert!(e.message.contains("material.conductivity_unit = \"W/mK\""));
        let laser = GOOD.replace("power_w = 500.0", "source = \"laser\"\npower_w = 500.0");
        let e = ReplayScenario::parse(&laser, "r.toml", Path::new(".")).unwrap_err();
        assert!(
            e.message.contains("without beam_radius_mm"),
            "{}",
            e.message
        );
        let beam = laser.replace("power_w = 500.0", "beam_radius_mm = 1.0\npower_w = 500.0");
        let s = ReplayScenario::parse(&beam, "r.toml", Path::new(".")).unwrap();
        assert_eq!(
            s.source,
            thermal::voxel::HeatSource::Gaussian { radius: 1e-3 }
        );
        let unknown = GOOD.replace("[thermal]", "[thermal]\nvoxels = 3");
        let e = ReplayScenario::parse(&unknown, "r.toml", Path::new(".")).unwrap_err();
        assert!(
            e.message.contains("unknown field `voxels`"),
            "{}",
            e.message
        );
        assert_eq!(e.exit_code(), 2);
    }

    #[test]
    fn calibration_parameters_are_checked() {
        let probes = "[probes]\nfile = \"ir.csv\"\nunit = \"K\"\n\
            points = [{ name = \"a\", column = 1, x_mm = 0.0, y_mm = 0.0, z_mm = 1.0 }]\n";
        let with = |cal: &str| format!("{GOOD}{probes}[calibrate]\n{cal}");
        let ok = with("parameters = [{ name = \"efficiency\", low = 0.2, high = 0.9 }]\n");
        let s = ReplayScenario::parse(&ok, "r.toml", Path::new(".")).unwrap();
        assert_eq!(s.calibrate.unwrap().parameters.len(), 1);
        for (cal, needle) in [
            (
                "parameters = [{ name = \"density\", low = 1.0, high = 2.0 }]",
                "calibrate.parameters = \"density\"",
            ),
            (
                "parameters = [{ name = \"efficiency\", low = 0.6, high = 0.9 }]",
                "efficiency in [0.6, 0.9] from 0.5",
            ),
            ("parameters = []", "0 parameters; expected one to three"),
            (
                "parameters = [{ name = \"efficiency\", low = 0.2, high = 0.9 }]\nmax_runs = 2",
                "calibrate.max_runs = 2",
            ),
        ] {
            let e = ReplayScenario::parse(&with(cal), "r.toml", Path::new(".")).unwrap_err();
            assert!(e.message.contains(needle), "{needle}: {}", e.message);
        }
    }

    /// `[calibration] file` replaces the replay's values by their names; an efficiency fitted
    /// under another heat source stays out, listed with the reason.
    #[test]
    fn a_calibration_carries_into_a_replay() {
        let dir = std::env::temp_dir().join(format!("waamtwin-cal-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        std::fs::write(
            dir.join("cal.json"),
            r#"{"parameters": [
                {"name": "efficiency", "value": 0.7, "low": 0.2, "high": 0.95, "ci95": [0.6, 0.8]},
                {"name": "emissivity", "value": 0.35, "low": 0.05, "high": 0.9}],
                "heat_source": "arc"}"#,
        )
        .unwrap();
        let with = format!("{GOOD}[calibration]\nfile = \"cal.json\"\n");
        let s = ReplayScenario::parse(&with, "r.toml", &dir).unwrap();
        assert_eq!(s.laying.efficiency, 0.7);
        assert_eq!(s.thermal.emissivity, 0.35);
        let json = s.to_json();
        assert_eq!(json["process"]["efficiency"], 0.7);
        assert_eq!(json["calibration"]["applied"][0]["scenario_value"], 0.5);
        assert_eq!(
            json["calibration"]["calibration_unused"],
            serde_json::json!([])
        );

        let laser = with.replace(
            "power_w = 500.0",
            "source = \"laser\"\nbeam_radius_mm = 1.0\npower_w = 500.0",
        );
        let s = ReplayScenario::parse(&laser, "r.toml", &dir).unwrap();
        assert_eq!(
            s.laying.efficiency, 0.5,
            "a laser keeps its own absorptivity"
        );
        assert_eq!(s.thermal.emissivity, 0.35);
        let unused = &s.to_json()["calibration"]["calibration_unused"];
        assert_eq!(unused[0]["name"], "efficiency");
        assert!(
            unused[0]["why"].as_str().unwrap().contains("arc"),
            "{unused}"
        );

        let missing = with.replace("cal.json", "none.json");
        let e = ReplayScenario::parse(&missing, "r.toml", &dir).unwrap_err();
        assert!(e.message.contains("none.json"), "{}", e.message);
        assert_eq!(e.exit_code(), 2);
        std::fs::remove_dir_all(&dir).ok();
    }
}
