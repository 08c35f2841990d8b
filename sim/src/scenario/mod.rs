//! Scenario files: [`RawScenario`] is what serde reads; [`Scenario`] is checked and in SI units
//! (geometry stays in mm: the planner is geometry, and works in mm). Only a `Scenario` reaches
//! the models. Every key and default is documented in `scenarios/README.md`.

pub mod calibration;
mod raw;
pub mod replay;

pub use raw::*;

use crate::error::{Error, Result};
pub use crate::pipeline::params::{
    BeadSettings, DwellSettings, Material, Params, Process, ThermalModel, ThermalSettings,
};
use bead_model::as_built::HotMetalLaw;
use bead_model::heat_input::{ArcPower, SynergicLine};
use bead_model::section::Section;
use bead_model::window::Modulation;
use planner::mesh::LowerLoop;
use planner::plan::PlanParams;
use planner::shapes::Shape;
use std::fmt::Display;
use std::path::{Path, PathBuf};
use thermal::ZERO_CELSIUS_K as KELVIN;
use thermal::voxel::Device;

/// `[skeleton]`, checked, is the engine's own settings type.
pub use crate::pipeline::skeleton::SkeletonSettings;

const MM: f64 = 1e-3;
/// The plate where `[thermal] plate_mm` is left out (`pipeline::plate_fitted` grows it).
const DEFAULT_PLATE_MM: [f64; 3] = crate::pipeline::params::documented::PLATE_MM;
const M_MIN: f64 = 1.0 / 60.0;
/// The thin wall's plate cell where `[thermal] plate_cell_mm` is left out: the bead's width, at
/// most this (`documented::PLATE_CELL_MAX_MM`, where the reason is).
pub const PLATE_CELL_MAX_MM: f64 = crate::pipeline::params::documented::PLATE_CELL_MAX_MM;

/// Where the part's mid-surface comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum PartSource {
    Mesh(PathBuf),
    Shape { shape: Shape, edge_mm: f64 },
}

#[derive(Debug, Clone, PartialEq)]
pub struct PartSpec {
    pub source: PartSource,
    pub lower: LowerLoop,
    /// Millimetres a unit of the mesh file (`[part] mesh_unit`; 1 for a library shape).
    pub mm_per_unit: f64,
    /// Added to every vertex once scaled (`[part] offset_mm`), mm.
    pub offset_mm: [f64; 3],
}

/// The units a mesh file may be drawn in (`[part] mesh_unit`), with their millimetres.
pub const MESH_UNITS: [(&str, f64); 4] = [("mm", 1.0), ("cm", 10.0), ("m", 1000.0), ("in", 25.4)];

#[derive(Debug, Clone, PartialEq)]
pub struct PlannerSettings {
    pub n_points: usize,
    pub gap_max_mm: f64,
    pub deposit_tolerance_mm: f64,
    pub nozzle: planner::collision::Nozzle,
    pub torch: planner::frame::Torch,
}

#[derive(Debug, Clone)]
pub struct Scenario {
    pub part: PartSpec,
    pub process: Process,
    pub material: Material,
    pub thermal: ThermalSettings,
    pub dwell: DwellSettings,
    pub planner: PlannerSettings,
    pub bead: BeadSettings,
    pub output: RawOutput,
    pub skeleton: SkeletonSettings,
    /// `[calibration] file`: what it carried in (already in the sections above) and what not.
    pub calibration: Option<calibration::Carried>,
    /// `[dwell] confidence`: plan at that quantile of the calibration's uncertainty.
    pub confidence: Option<crate::pipeline::confidence::Settings>,
    /// `[toolpath] format = "path"`: the path.csv of a plan of this part, to replay as laid.
    pub planned_path: Option<PathBuf>,
    /// The resolved input, echoed into `manifest.json`.
    pub raw: RawScenario,
}

impl Scenario {
    /// Read and check a scenario file; relative mesh paths are resolved against its folder.
    pub fn load(path: &Path) -> Result<Scenario> {
        let s = Scenario::read(path)?;
        if s.planned_path.is_some() {
            return Err(Error::input(format!(
                "{}: a planned path to replay ([toolpath] format = \"path\"), not a part to \
                 plan; run it with `waamtwin replay`",
                path.display()
            )));
        }
        Ok(s)
    }

    /// A part's scenario with `[toolpath] format = "path"`: the scenario, and its path.csv.
    pub fn load_planned(path: &Path) -> Result<(Scenario, PathBuf)> {
        let s = Scenario::read(path)?;
        match s.planned_path.clone() {
            Some(p) => Ok((s, p)),
            None => Err(Error::input(format!(
                "{}: no [toolpath]; expected file = a path.csv and format = \"path\"",
                path.display()
            ))),
        }
    }

    /// The file read and parsed (paths in it resolved against its folder), and what its
    /// calibration left out said on stderr.
    fn read(path: &Path) -> Result<Scenario> {
        let text = std::fs::read_to_string(path)
            .map_err(|e| Error::input(format!("cannot read scenario {}: {e}", path.display())))?;
        let base = path.parent().unwrap_or(Path::new("."));
        let s = Scenario::parse(&text, &path.display().to_string(), base)?;
        calibration::tell(s.calibration.as_ref());
        Ok(s)
    }

    /// Whether scenario text is a part's with a planned path to replay (`[toolpath] format =
    /// "path"`), which `replay` runs instead of a measured toolpath.
    pub fn is_planned_path(text: &str) -> bool {
        text.parse::<toml::Table>().is_ok_and(|t| {
            t.get("toolpath")
                .and_then(|p| p.get("format"))
                .and_then(|f| f.as_str())
                == Some("path")
        })
    }

    /// Parse scenario text; `file` names it in messages, with the line of the key.
    pub fn parse(text: &str, file: &str, base: &Path) -> Result<Scenario> {
        Scenario::parse_with(text, file, base, true, &[])
    }

    /// Parse scenario text that no user wrote (a study case: a base scenario with overrides):
    /// `what` names it in messages, and no line is given, since the user has no such file.
    /// `kept`: the `section.key`s the case sets, which a `[calibration]` does not replace.
    pub fn parse_generated(
        text: &str,
        what: &str,
        base: &Path,
        kept: &[String],
    ) -> Result<Scenario> {
        Scenario::parse_with(text, what, base, false, kept)
    }

    fn parse_with(
        text: &str,
        file: &str,
        base: &Path,
        lines: bool,
        kept: &[String],
    ) -> Result<Scenario> {
        let measured_toolpath = text.parse::<toml::Table>().is_ok_and(|t| {
            t.get("toolpath")
                .is_some_and(|p| p.get("format").and_then(|f| f.as_str()) != Some("path"))
        });
        if measured_toolpath {
            return Err(Error::input(format!(
                "{file}: a replay scenario (it has [toolpath]), not a part to plan; run it with \
                 `waamtwin replay`"
            )));
        }
        let mut raw: RawScenario =
            toml::from_str(text).map_err(|e| toml_error(&e, text, file, lines))?;
        let calibration = calibration::apply(
            raw.calibration.as_ref(),
            base,
            "arc",
            kept,
            &mut raw.process.efficiency,
            &mut raw.thermal,
        )?;
        let c = Checker { text, file, lines };
        Scenario::from_raw(raw, calibration, &c, base)
    }

    /// One small conversion per section, each naming its own keys in its errors.
    fn from_raw(
        raw: RawScenario,
        calibration: Option<calibration::Carried>,
        c: &Checker,
        base: &Path,
    ) -> Result<Scenario> {
        let width = raw.process.bead_width_mm;
        let s = Scenario {
            part: part_spec(&raw.part, c, base)?,
            process: process(&raw.process, c)?,
            material: material(&raw.material, c)?,
            thermal: thermal(&raw.thermal, width, c)?,
            dwell: dwell(&raw.dwell, width, c)?,
            planner: planner(&raw.planner),
            bead: bead(&raw.bead, c)?,
            output: raw.output.clone(),
            skeleton: skeleton(&raw.skeleton, c)?,
            confidence: confidence(&raw.dwell, calibration.as_ref(), c)?,
            planned_path: raw.toolpath.as_ref().map(|t| resolve(base, &t.file)),
            calibration,
            raw,
        };
        crate::pipeline::params::planning(&s.plan_params()).map_err(|e| c.invalid(e))?;
        Ok(s)
    }

    /// What the engine needs beyond the plan.
    pub fn params(&self) -> Params {
        Params {
            process: self.process.clone(),
            material: self.material.clone(),
            thermal: self.thermal.clone(),
            dwell: self.dwell.clone(),
            bead: self.bead.clone(),
        }
    }

    /// What the CTPP planner needs.
    pub fn plan_params(&self) -> PlanParams {
        // The deposit window in the file's own mm (the process holds it in m: a round trip
        // would put 1.8 mm at 1.8000000000000003).
        let p = &self.raw.process;
        PlanParams {
            n_points: self.planner.n_points,
            gap_max_mm: self.planner.gap_max_mm,
            deposit_mm: p.deposit_mm,
            deposit_min_mm: p.deposit_min_mm,
            deposit_max_mm: p.deposit_max_mm,
            tolerance_mm: self.planner.deposit_tolerance_mm,
            nozzle: self.planner.nozzle,
            torch: self.planner.torch,
        }
    }

    pub fn to_json(&self) -> serde_json::Value {
        let mut v = serde_json::to_value(&self.raw).unwrap_or(serde_json::Value::Null);
        if let (Some(c), Some(o)) = (&self.calibration, v.as_object_mut()) {
            o.insert("calibration".into(), c.to_json());
        }
        v
    }

    /// A short name for plots and recordings: the library shape or the mesh file.
    pub fn title(&self) -> String {
        match &self.part.source {
            PartSource::Shape { .. } => self.raw.part.shape.clone().unwrap_or_default(),
            PartSource::Mesh(p) => p
                .file_name()
                .map_or("part".into(), |n| n.to_string_lossy().into_owned()),
        }
    }
}

fn process(p: &RawProcess, c: &Checker) -> Result<Process> {
    let modulation = match p.modulation.as_str() {
        "wire_feed" => Modulation::WireFeed {
            travel: p.travel_speed_mm_s * MM,
        },
        "travel_speed" => {
            let wfs = match p.wfs_m_min {
                Some(w) => w * M_MIN,
                None => bead_model::eq7::wire_feed(
                    p.deposit_mm * MM,
                    p.wire_diameter_mm * MM,
                    p.bead_width_mm * MM,
                    p.travel_speed_mm_s * MM,
                ),
            };
            Modulation::TravelSpeed { wfs }
        }
        other => {
            return Err(c.fail(
                "process",
                "modulation",
                format!("\"{other}\""),
                "\"wire_feed\" or \"travel_speed\"",
            ));
        }
    };
    let power = match p.power_model.as_str() {
        "fixed" => ArcPower::Fixed {
            watts: p.arc_power_w,
        },
        "synergic" => {
            let line = match (
                &p.synergic_wfs_m_min,
                &p.synergic_current_a,
                &p.synergic_voltage_v,
            ) {
                (None, None, None) => SynergicLine::g3si_cmt_1mm(),
                (Some(w), Some(i), Some(u)) => SynergicLine {
                    wfs: w.iter().map(|x| x * M_MIN).collect(),
                    current_a: i.clone(),
                    voltage_v: u.clone(),
                },
                _ => {
                    return Err(c.fail("process", "synergic_wfs_m_min", "(incomplete)", "all three of synergic_wfs_m_min, synergic_current_a, synergic_voltage_v, or none"));
                }
            };
            line.validate()
                .map_err(|e| c.fail("process", "synergic_wfs_m_min", "(table)", &e))?;
            ArcPower::Synergic(line)
        }
        other => {
            return Err(c.fail(
                "process",
                "power_model",
                format!("\"{other}\""),
                "\"fixed\" or \"synergic\"",
            ));
        }
    };
    let section = match p.bead_section.as_str() {
        "rectangle" => Section::Rectangle,
        "parabolic" => Section::Parabolic,
        "circular" => Section::Circular,
        other => {
            return Err(c.fail(
                "process",
                "bead_section",
                format!("\"{other}\""),
                "\"rectangle\", \"parabolic\" or \"circular\"",
            ));
        }
    };
    let process = Process {
        modulation,
        power,
        section,
        wire_diameter_m: p.wire_diameter_mm * MM,
        bead_width_m: p.bead_width_mm * MM,
        travel_speed_m_s: p.travel_speed_mm_s * MM,
        deposit_m: p.deposit_mm * MM,
        deposit_min_m: p.deposit_min_mm * MM,
        deposit_max_m: p.deposit_max_mm * MM,
        wfs_min_m_s: p.wfs_min_m_min * M_MIN,
        wfs_max_m_s: p.wfs_max_m_min * M_MIN,
        travel_min_m_s: p.travel_min_mm_s * MM,
        travel_max_m_s: p.travel_max_mm_s * MM,
        arc_power_w: p.arc_power_w,
        efficiency: p.efficiency,
    };
    process.check().map_err(|e| c.invalid(e))?;
    Ok(process)
}

/// The variable that names the folder of the measured builds.
pub const DATA_VAR: &str = "WAAMTWIN_DATA";

/// Where a scenario's `$WAAMTWIN_DATA/…` paths lead: the folder [`DATA_VAR`] names; else
/// `../shared/validation-data` from the working directory (a checkout's root, the shared data
/// beside it), where that exists; else the first `shared/validation-data` beside the scenario's
/// folder or one of its parents (a scenario inside a checkout, run from anywhere); else the
/// first, which a missing file's message then names.
pub fn data_dir(base: &Path) -> PathBuf {
    if let Some(d) = std::env::var_os(DATA_VAR) {
        return PathBuf::from(d);
    }
    let beside_cwd = PathBuf::from("../shared/validation-data");
    if beside_cwd.is_dir() {
        return beside_cwd;
    }
    let absolute = std::path::absolute(base).unwrap_or_else(|_| base.to_path_buf());
    absolute
        .ancestors()
        .map(|a| a.join("shared/validation-data"))
        .find(|d| d.is_dir())
        .unwrap_or(beside_cwd)
}

/// A file a scenario names: `$WAAMTWIN_DATA/…` under [`data_dir`], an absolute path as it is,
/// anything else beside the scenario file (`base`).
pub fn resolve(base: &Path, file: impl AsRef<Path>) -> PathBuf {
    let file = file.as_ref();
    match file.strip_prefix(format!("${DATA_VAR}")) {
        Ok(rest) => data_dir(base).join(rest),
        Err(_) => base.join(file),
    }
}

/// `[thermal]`; the footprint defaults to the bead width.
fn thermal(t: &RawThermal, bead_width_mm: f64, c: &Checker) -> Result<ThermalSettings> {
    let model = match t.model.as_str() {
        // "fe", the first contract's name (shared/interface.md keeps its names stable), is
        // read as the thin wall too; every output says "thin-wall".
        "thin-wall" | "fe" => ThermalModel::ThinWall,
        "voxel" => ThermalModel::Voxel,
        other => {
            return Err(c.fail(
                "thermal",
                "model",
                format!("\"{other}\""),
                "\"thin-wall\" or \"voxel\"",
            ));
        }
    };
    let plate_fit = t.plate_mm.is_none();
    let plate_mm = t.plate_mm.unwrap_or(DEFAULT_PLATE_MM);
    let plate_disc = match (t.plate_shape.as_str(), model) {
        ("box", _) => false,
        ("disc", ThermalModel::Voxel) if plate_mm[0] == plate_mm[1] => true,
        ("disc", ThermalModel::Voxel) => {
            return Err(c.fail(
                "thermal",
                "plate_mm",
                format!("{plate_mm:?}"),
                "a disc's diameter twice: [d, d, thickness]",
            ));
        }
        ("disc", ThermalModel::ThinWall) => {
            return Err(c.fail(
                "thermal",
                "plate_shape",
                "\"disc\"",
                "\"box\" with model = \"thin-wall\" (the thin wall's plate is a grid of cells)",
            ));
        }
        (other, _) => {
            return Err(c.fail(
                "thermal",
                "plate_shape",
                format!("\"{other}\""),
                "\"box\" or \"disc\"",
            ));
        }
    };
    if let Some(cell) = t.plate_cell_mm {
        c.range(
            "thermal",
            "plate_cell_mm",
            cell,
            0.5,
            100.0,
            "between 0.5 and 100",
        )?;
    }
    let temperature_dependent = match t.properties.as_str() {
        "temperature" => true,
        "constant" => false,
        other => {
            return Err(c.fail(
                "thermal",
                "properties",
                format!("\"{other}\""),
                "\"temperature\" or \"constant\"",
            ));
        }
    };
    let device = match (t.device.as_str(), model) {
        ("cpu", _) => Device::Cpu,
        ("gpu", ThermalModel::Voxel) => Device::Gpu,
        ("gpu", _) => {
            return Err(c.fail(
                "thermal",
                "device",
                "\"gpu\" with model = \"thin-wall\"",
                "\"cpu\" (the GPU runs the voxel model: model = \"voxel\")",
            ));
        }
        (other, _) => {
            return Err(c.fail(
                "thermal",
                "device",
                format!("\"{other}\""),
                "\"cpu\" or \"gpu\"",
            ));
        }
    };
    if device == Device::Gpu && t.coarse_plate {
        return Err(c.fail(
            "thermal",
            "coarse_plate",
            "true with device = \"gpu\"",
            "false (the coarsened plate steps on the CPU alone)",
        ));
    }
    let settings = ThermalSettings {
        table_contact_w_m2k: t.table_contact_w_m2k,
        plate_cell_m: t
            .plate_cell_mm
            .unwrap_or(bead_width_mm.min(PLATE_CELL_MAX_MM))
            * MM,
        node_m: t.node_mm * MM,
        deposit_k: t.deposit_c + KELVIN,
        footprint_m: t.footprint_mm.unwrap_or(bead_width_mm) * MM,
        hot_threshold_k: t.hot_threshold_c + KELVIN,
        temperature_dependent,
        voxel_m: t.voxel_mm * MM,
        model,
        ambient_k: t.ambient_c + KELVIN,
        convection_w_m2k: t.convection_w_m2k,
        emissivity: t.emissivity,
        plate_m: plate_mm.map(|v| v * MM),
        plate_fit,
        plate_disc,
        lead_m: t.lead_mm * MM,
        coarse_plate: t.coarse_plate,
        local_steps: t.local_steps,
        merge_plate: t.merge_plate,
        device,
    };
    settings.check().map_err(|e| c.invalid(e))?;
    Ok(settings)
}

/// `[dwell] confidence`: the quantile, and the calibration's applied parameters as a normal
/// distribution about the values the scenario runs at (their covariance, else their standard
/// deviations alone).
fn confidence(
    d: &RawDwell,
    cal: Option<&calibration::Carried>,
    c: &Checker,
) -> Result<Option<crate::pipeline::confidence::Settings>> {
    let Some(q) = d.confidence else {
        return Ok(None);
    };
    c.range("dwell", "confidence", q, 0.5, 1.0, "a quantile in [0.5, 1)")?;
    if q >= 1.0 {
        return Err(c.fail("dwell", "confidence", q, "a quantile in [0.5, 1)"));
    }
    if !(1..=10_000).contains(&d.check_draws) {
        return Err(c.fail("dwell", "check_draws", d.check_draws, "1 to 10000"));
    }
    let none = |why: &str| {
        c.fail_text(
            "dwell",
            "confidence",
            format!("confidence = {q} {why}; expected a [calibration] file with its fit's spread"),
        )
    };
    let Some(cal) = cal else {
        return Err(none("without a [calibration]"));
    };
    let (fits, cov) = cal.applied_fits();
    if fits.is_empty() {
        return Err(none("with no calibrated parameter applied"));
    }
    let sd: Vec<f64> = fits
        .iter()
        .map(|f| {
            f.sd.ok_or_else(|| none(&format!("with no spread for {}", f.parameter.key())))
        })
        .collect::<Result<_>>()?;
    let n = fits.len();
    let covariance = cov.unwrap_or_else(|| {
        (0..n)
            .map(|i| {
                (0..n)
                    .map(|j| if i == j { sd[i] * sd[i] } else { 0.0 })
                    .collect()
            })
            .collect()
    });
    Ok(Some(crate::pipeline::confidence::Settings {
        confidence: q,
        check_draws: d.check_draws,
        seed: d.check_seed,
        uncertainty: crate::pipeline::confidence::Uncertainty {
            parameters: fits.iter().map(|f| f.parameter).collect(),
            mean: cal.applied.iter().map(|a| a.2).collect(),
            covariance,
            bounds: fits
                .iter()
                .map(|f| {
                    let [lo, hi] = f.parameter.limits();
                    [f.low.max(lo), f.high.min(hi)]
                })
                .collect(),
        },
    }))
}

/// `[dwell]`; the closing zone defaults to three bead widths.
fn dwell(d: &RawDwell, bead_width_mm: f64, c: &Checker) -> Result<DwellSettings> {
    for (k, name) in d.criteria.iter().enumerate() {
        if !["interpass", "strength", "humping", "bond"].contains(&name.as_str()) {
            return Err(c.fail(
                "dwell",
                "criteria",
                format!("[{}]", d.criteria.join(", ")),
                &format!(
                    "names among interpass, strength, humping, bond (entry {k} is \"{name}\")"
                ),
            ));
        }
    }
    if d.policy != "revolution" {
        return Err(c.fail(
            "dwell",
            "policy",
            format!("\"{}\"", d.policy),
            "\"revolution\" (dwells before a revolution's first preheat reading)",
        ));
    }
    let on = |n: &str| d.criteria.iter().any(|x| x == n);
    let settings = DwellSettings {
        interpass_max_k: d.interpass_max_c + KELVIN,
        interpass: on("interpass"),
        strength_loss_k: on("strength").then_some(d.strength_loss_c + KELVIN),
        humping: on("humping"),
        bond: on("bond"),
        max_dwell_s: d.max_dwell_s,
        min_dwell_s: d.min_dwell_s,
        max_arc_stops: d.max_arc_stops,
        margin_k: d.margin_c,
        count_weight_s: d.count_weight_s,
        closing_zone_mm: d
            .closing_zone_mm
            .unwrap_or(crate::pipeline::params::documented::CLOSING_ZONE_BEADS * bead_width_mm),
    };
    settings.check().map_err(|e| c.invalid(e))?;
    Ok(settings)
}

fn planner(pl: &RawPlanner) -> PlannerSettings {
    PlannerSettings {
        n_points: pl.n_points,
        gap_max_mm: pl.gap_max_mm,
        deposit_tolerance_mm: pl.deposit_tolerance_mm,
        nozzle: planner::collision::Nozzle {
            radius_mm: pl.nozzle_radius_mm,
            standoff_mm: pl.nozzle_standoff_mm,
            length_mm: pl.nozzle_length_mm,
            max_rotation_deg: pl.nozzle_max_rotation_deg,
            rotation_rate_deg_mm: pl.nozzle_rotation_rate_deg_mm,
            tube_radius_mm: pl.deposit_tube_radius_mm,
            // A radius of 0 is no arm; any other is checked ([`crate::pipeline::params::planning`]).
            arm: (pl.arm_radius_mm != 0.0).then_some(planner::collision::Arm {
                radius_mm: pl.arm_radius_mm,
                from_mm: pl.arm_from_mm,
                length_mm: pl.arm_length_mm,
            }),
        },
        torch: planner::frame::Torch {
            lead_deg: pl.torch_lead_deg,
            side_deg: pl.torch_side_deg,
            max_rate_deg_mm: pl.tool_rate_max_deg_mm,
        },
    }
}

fn skeleton(k: &RawSkeleton, c: &Checker) -> Result<SkeletonSettings> {
    const S: &str = "skeleton";
    let priorities = k
        .priorities
        .iter()
        .map(|p| {
            planner::saam::Priority::parse(p).ok_or_else(|| {
                c.fail(
                    S,
                    "priorities",
                    format!("{p:?}"),
                    "one of \"none\", \"no_conflict\", \"low\", \"conflict\", \"high\"",
                )
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let settings = SkeletonSettings {
        radius_mm: k.radius_mm,
        radii_mm: k.radii_mm.clone(),
        priorities,
        slicer: planner::saam::SlicerSettings {
            increment_mm: k.increment_mm,
            divergent_offset_deg: k.divergent_offset_deg,
            convergent_offset_deg: k.convergent_offset_deg,
            nozzle_radius_mm: k.nozzle_radius_mm,
            standoff_mm: k.standoff_mm,
            nozzle_length_mm: k.nozzle_length_mm,
            max_collision_standoff_mm: k.max_collision_standoff_mm,
        },
        wfs_m_min: k.wfs_m_min,
        closed_loop: k.closed_loop,
        camera_noise_mm: k.camera_noise_mm,
        drop_height_noise: k.drop_height_noise,
        bad_drop_probability: k.bad_drop_probability,
        bad_drop_height: k.bad_drop_height,
        seed: k.seed,
        min_wait_s: k.min_wait_s,
        max_wait_s: k.max_wait_s,
        heat: k.heat,
        max_drops: k.max_drops,
    };
    settings.check().map_err(|e| c.invalid(e))?;
    Ok(settings)
}

fn bead(b: &RawBead, c: &Checker) -> Result<BeadSettings> {
    let settings = BeadSettings {
        bond_max: b.bond_max,
        hot_metal: HotMetalLaw {
            reference_k: b.hot_reference_c + KELVIN,
            height_loss_per_k: b.hot_height_loss_per_k,
            min_factor: crate::pipeline::params::documented::HOT_MIN_FACTOR,
        },
        stickout_m: b.stickout_mm * MM,
    };
    settings.check().map_err(|e| c.invalid(e))?;
    Ok(settings)
}

fn part_spec(p: &RawPart, c: &Checker, base: &Path) -> Result<PartSpec> {
    let lower = p.lower_loop.map(LowerLoop::Index).unwrap_or_default();
    let source = match (&p.mesh, &p.shape) {
        (Some(_), Some(_)) => {
            return Err(c.fail(
                "part",
                "shape",
                "given with part.mesh",
                "either mesh or shape, not both",
            ));
        }
        (None, None) => {
            return Err(Error::input(format!(
                "{}: [part] needs a mesh = \"file\" or a shape = \"name\"",
                c.file
            )));
        }
        (Some(mesh), None) => {
            let path = resolve(base, mesh);
            if !path.is_file() {
                return Err(c.fail(
                    "part",
                    "mesh",
                    format!("\"{mesh}\""),
                    &format!("an existing mesh file ({} not found)", path.display()),
                ));
            }
            if planner::io::MeshFormat::from_extension(mesh).is_none() {
                return Err(c.fail(
                    "part",
                    "mesh",
                    format!("\"{mesh}\""),
                    "a .stl, .obj or .ply file",
                ));
            }
            PartSource::Mesh(path)
        }
        (None, Some(name)) => {
            let shape = shape(name, p, c)?;
            let edge_mm = p.edge_mm.unwrap_or(2.0);
            c.positive("part", "edge_mm", edge_mm, 100.0)?;
            let size = shape.extent_mm();
            if size / edge_mm > 2000.0 {
                return Err(c.fail(
                    "part",
                    "edge_mm",
                    edge_mm,
                    &format!(
                        "at least {:.3} mm for a part of {size:.0} mm (at most 2000 edges across)",
                        size / 2000.0
                    ),
                ));
            }
            PartSource::Shape { shape, edge_mm }
        }
    };
    if let (Some(_), Some(edge)) = (&p.mesh, p.edge_mm) {
        return Err(c.fail(
            "part",
            "edge_mm",
            edge,
            "no edge_mm with a mesh file (it is meshed already)",
        ));
    }
    let mm_per_unit = match (&p.mesh_unit, &p.mesh) {
        (None, _) => 1.0,
        (Some(u), Some(_)) => MESH_UNITS
            .iter()
            .find(|(name, _)| name == u)
            .map(|&(_, mm)| mm)
            .ok_or_else(|| {
                c.fail(
                    "part",
                    "mesh_unit",
                    format!("\"{u}\""),
                    "\"mm\", \"cm\", \"m\" or \"in\"",
                )
            })?,
        (Some(u), None) => {
            return Err(c.fail(
                "part",
                "mesh_unit",
                format!("\"{u}\""),
                "no mesh_unit with a library shape (its sizes are in mm)",
            ));
        }
    };
    let offset_mm = p.offset_mm.unwrap_or([0.0; 3]);
    if let Some(v) = offset_mm
        .iter()
        .find(|v| !(v.is_finite() && v.abs() <= 1e5))
    {
        return Err(c.fail("part", "offset_mm", v, "three numbers within ±100000 mm"));
    }
    Ok(PartSpec {
        source,
        lower,
        mm_per_unit,
        offset_mm,
    })
}

/// A library shape from `[part]`; its parameters are checked by the planner's shape table.
fn shape(name: &str, p: &RawPart, c: &Checker) -> Result<Shape> {
    Shape::from_params(name, &p.shape_params()).map_err(|e| c.fail_text("part", e.key(), &e))
}

fn material(m: &RawMaterial, c: &Checker) -> Result<Material> {
    let mut mat = match m.preset.as_str() {
        "G3Si" | "g3si" => Material::preset(&thermal::material::G3SI),
        other => return Err(c.fail("material", "preset", format!("\"{other}\""), "\"G3Si\"")),
    };
    if let Some(v) = m.density_kg_m3 {
        mat.density_kg_m3 = v;
    }
    if let Some(v) = m.specific_heat_j_kgk {
        mat.specific_heat_j_kgk = v;
    }
    if let Some(v) = m.conductivity_w_mk {
        mat.conductivity_w_mk = v;
    }
    if let Some(v) = m.surface_tension_n_m {
        mat.surface_tension_n_m = v;
    }
    if let Some(v) = m.melting_c {
        mat.melting_k = v + KELVIN;
    }
    mat.check().map_err(|e| c.invalid(e))?;
    Ok(mat)
}

/// Checks values and words the error with the file, the line and the key.
struct Checker<'a> {
    text: &'a str,
    /// Whether `text` is the user's file, whose lines a message may name.
    lines: bool,
    file: &'a str,
}

impl Checker<'_> {
    /// An error whose text begins with the key ("key = value; expected …").
    fn fail_text(&self, section: &str, key: &str, text: impl Display) -> Error {
        Error::input(format!(
            "{}{}: {section}.{text}",
            self.file,
            self.at(section, key)
        ))
    }

    /// " line N" where the user's file sets the key.
    fn at(&self, section: &str, key: &str) -> String {
        match locate(self.text, section, key).filter(|_| self.lines) {
            Some(l) => format!(" line {l}"),
            None => String::new(),
        }
    }

    fn fail(&self, section: &str, key: &str, value: impl Display, expected: &str) -> Error {
        let at = self.at(section, key);
        Error::input(format!(
            "{}{at}: {section}.{key} = {value}; expected {expected}",
            self.file
        ))
    }

    /// The engine's verdict on a value ([`crate::pipeline::params::Invalid`]), at its line.
    fn invalid(&self, e: crate::pipeline::params::Invalid) -> Error {
        self.fail(e.section, e.key, e.value, &e.expected)
    }

    fn positive(&self, section: &str, key: &str, v: f64, max: f64) -> Result<()> {
        if v.is_finite() && v > 0.0 && v <= max {
            Ok(())
        } else {
            Err(self.fail(section, key, v, &format!("a number in (0, {max}]")))
        }
    }

    fn range(
        &self,
        section: &str,
        key: &str,
        v: f64,
        lo: f64,
        hi: f64,
        expected: &str,
    ) -> Result<()> {
        if v.is_finite() && (lo..=hi).contains(&v) {
            Ok(())
        } else {
            Err(self.fail(section, key, v, expected))
        }
    }
}

/// A TOML or type error, with the line (and its text) where the file has one.
fn toml_error(e: &toml::de::Error, text: &str, file: &str, lines: bool) -> Error {
    // A missing field's span is the whole table: no line says more than the message.
    let line = e
        .span()
        .filter(|_| lines && !e.message().starts_with("missing field"))
        .map(|s| line_of(text, s.start));
    let at = match line {
        Some(l) => format!(
            " line {l} ({})",
            text.lines().nth(l - 1).unwrap_or("").trim()
        ),
        None => String::new(),
    };
    Error::input(format!("{file}{at}: {}", e.message()))
}

fn line_of(text: &str, byte: usize) -> usize {
    text[..byte.min(text.len())]
        .bytes()
        .filter(|&b| b == b'\n')
        .count()
        + 1
}

/// The 1-based line where `key` is set inside `[section]`, if the file sets it.
fn locate(text: &str, section: &str, key: &str) -> Option<usize> {
    let mut current = String::new();
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if let Some(h) = t.strip_prefix('[') {
            current = h.trim_end_matches(']').trim().to_string();
            continue;
        }
        if current == section
            && let Some(rest) = t.strip_prefix(key)
            && rest.trim_start().starts_with('=')
        {
            return Some(i + 1);
        }
    }
    None
}

#[cfg(test)]
mod tests;
