//! `RawScenario`: exactly what serde reads from a scenario TOML, units in the key names, every
//! default filled in. Nothing here is checked; [`super::Scenario::from_raw`] does that.

use crate::pipeline::params::documented as d;
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawScenario {
    pub part: RawPart,
    #[serde(default)]
    pub process: RawProcess,
    #[serde(default)]
    pub material: RawMaterial,
    #[serde(default)]
    pub thermal: RawThermal,
    #[serde(default)]
    pub dwell: RawDwell,
    #[serde(default)]
    pub planner: RawPlanner,
    #[serde(default)]
    pub bead: RawBead,
    #[serde(default)]
    pub output: RawOutput,
    #[serde(default)]
    pub skeleton: RawSkeleton,
    /// `[calibration] file`: a calibrate run's fitted values replace this file's.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub calibration: Option<super::calibration::RawCalibration>,
    /// `[toolpath] format = "path"`: the part's planned program to replay (`waamtwin replay`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub toolpath: Option<RawPlannedPath>,
}

/// `[toolpath]` of a part's scenario: a `plan` or `dwell` run's path.csv, replayed as laid.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawPlannedPath {
    pub file: String,
    pub format: String,
}

/// Skeleton arc AM (`waamtwin skeleton`; Radel et al. 2019): the part is `[part] mesh`, an OBJ
/// whose `l` lines are the skeleton's polylines.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawSkeleton {
    /// R_deposit of every polyline, unless `radii_mm` says otherwise.
    pub radius_mm: f64,
    /// Per polyline, in the file's order (optional).
    pub radii_mm: Vec<f64>,
    /// Per polyline: "none", "no_conflict", "low", "conflict" or "high" (default "none").
    pub priorities: Vec<String>,
    /// δ: the nominal increment, mm.
    pub increment_mm: f64,
    pub divergent_offset_deg: f64,
    pub convergent_offset_deg: f64,
    /// The contact tip to work distance kept (CTDWP).
    pub standoff_mm: f64,
    pub nozzle_radius_mm: f64,
    pub nozzle_length_mm: f64,
    pub max_collision_standoff_mm: f64,
    /// The drop's wire feed; its welding time follows from the drop's volume (k_w·4/3·π·R³).
    pub wfs_m_min: f64,
    /// The camera closes the loop on each drop's top (§2.4); the other loop is run beside it.
    pub closed_loop: bool,
    /// The camera's error on a drop's top (σ), mm.
    pub camera_noise_mm: f64,
    /// Each drop's height scatters by this share (σ).
    pub drop_height_noise: f64,
    /// Share of bad drops (a poor transfer), and the share of the height they reach.
    pub bad_drop_probability: f64,
    pub bad_drop_height: f64,
    pub seed: u64,
    /// The least wait after a drop before the next, s (the camera's).
    pub min_wait_s: f64,
    /// The longest wait for a drop to solidify before it is given up, s.
    pub max_wait_s: f64,
    /// Run the heat model drop by drop (solidification times, waits).
    pub heat: bool,
    pub max_drops: usize,
}

impl Default for RawSkeleton {
    /// The engine's (`SkeletonSettings::default`).
    fn default() -> Self {
        let k = crate::pipeline::skeleton::SkeletonSettings::default();
        let sl = k.slicer;
        Self {
            radius_mm: k.radius_mm,
            radii_mm: k.radii_mm,
            priorities: Vec::new(),
            increment_mm: sl.increment_mm,
            divergent_offset_deg: sl.divergent_offset_deg,
            convergent_offset_deg: sl.convergent_offset_deg,
            standoff_mm: sl.standoff_mm,
            nozzle_radius_mm: sl.nozzle_radius_mm,
            nozzle_length_mm: sl.nozzle_length_mm,
            max_collision_standoff_mm: sl.max_collision_standoff_mm,
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
        }
    }
}

#[derive(Debug, Clone, Default, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct RawPart {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mesh: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub shape: Option<String>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radius_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub top_radius_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub height_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bulge_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub top_slope_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub top_wave_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub top_waves: Option<u32>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub radius_y_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lean_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub neck_radius_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub neck_height_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub bend_radius_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub tube_radius_mm: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub edge_mm: Option<f64>,
    /// Which boundary loop is on the substrate; absent: the lowest one.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub lower_loop: Option<usize>,
    /// The unit of the mesh file's coordinates (an STL carries none); absent: "mm".
    #[serde(skip_serializing_if = "Option::is_none")]
    pub mesh_unit: Option<String>,
    /// Added to every vertex (after `mesh_unit`), mm; absent: none.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub offset_mm: Option<[f64; 3]>,
}

impl RawPart {
    /// The shape parameters by the names `planner::shapes::SIGNATURES` uses.
    pub fn shape_params(&self) -> [(&'static str, Option<f64>); 13] {
        [
            ("radius_mm", self.radius_mm),
            ("top_radius_mm", self.top_radius_mm),
            ("height_mm", self.height_mm),
            ("bulge_mm", self.bulge_mm),
            ("top_slope_mm", self.top_slope_mm),
            ("top_wave_mm", self.top_wave_mm),
            ("top_waves", self.top_waves.map(f64::from)),
            ("radius_y_mm", self.radius_y_mm),
            ("lean_mm", self.lean_mm),
            ("neck_radius_mm", self.neck_radius_mm),
            ("neck_height_mm", self.neck_height_mm),
            ("bend_radius_mm", self.bend_radius_mm),
            ("tube_radius_mm", self.tube_radius_mm),
        ]
    }
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawProcess {
    pub wire_diameter_mm: f64,
    pub bead_width_mm: f64,
    pub travel_speed_mm_s: f64,
    pub deposit_mm: f64,
    pub deposit_min_mm: f64,
    pub deposit_max_mm: f64,
    pub wfs_min_m_min: f64,
    pub wfs_max_m_min: f64,
    pub travel_min_mm_s: f64,
    pub travel_max_mm_s: f64,
    pub arc_power_w: f64,
    pub efficiency: f64,
    /// "wire_feed" (constant travel speed, the CTPP choice) or "travel_speed" (constant wire feed).
    pub modulation: String,
    /// The constant wire feed of "travel_speed" modulation; absent: Eq.7 at the nominal deposit.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub wfs_m_min: Option<f64>,
    /// "fixed" (arc_power_w) or "synergic" (the synergic line below, or the G3Si CMT default).
    pub power_model: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub synergic_wfs_m_min: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub synergic_current_a: Option<Vec<f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub synergic_voltage_v: Option<Vec<f64>>,
    /// "rectangle" (Eq.7), "parabolic" or "circular".
    pub bead_section: String,
}

impl Default for RawProcess {
    fn default() -> Self {
        Self {
            wire_diameter_mm: d::WIRE_DIAMETER_MM,
            bead_width_mm: d::BEAD_WIDTH_MM,
            travel_speed_mm_s: d::TRAVEL_SPEED_MM_S,
            deposit_mm: d::DEPOSIT_MM,
            deposit_min_mm: d::DEPOSIT_MIN_MM,
            deposit_max_mm: d::DEPOSIT_MAX_MM,
            wfs_min_m_min: d::WFS_MIN_M_MIN,
            wfs_max_m_min: d::WFS_MAX_M_MIN,
            travel_min_mm_s: d::TRAVEL_MIN_MM_S,
            travel_max_mm_s: d::TRAVEL_MAX_MM_S,
            arc_power_w: d::ARC_POWER_W,
            efficiency: d::EFFICIENCY,
            modulation: "wire_feed".into(),
            wfs_m_min: None,
            power_model: "fixed".into(),
            synergic_wfs_m_min: None,
            synergic_current_a: None,
            synergic_voltage_v: None,
            bead_section: "rectangle".into(),
        }
    }
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawMaterial {
    pub preset: String,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub density_kg_m3: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub specific_heat_j_kgk: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub conductivity_w_mk: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub surface_tension_n_m: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub melting_c: Option<f64>,
}

impl Default for RawMaterial {
    fn default() -> Self {
        Self {
            preset: "G3Si".into(),
            density_kg_m3: None,
            specific_heat_j_kgk: None,
            conductivity_w_mk: None,
            surface_tension_n_m: None,
            melting_c: None,
        }
    }
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawThermal {
    pub model: String,
    pub ambient_c: f64,
    pub convection_w_m2k: f64,
    pub emissivity: f64,
    /// x, y, thickness; absent: a plate fitted to the part (`pipeline::plate_fitted`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plate_mm: Option<[f64; 3]>,
    pub lead_mm: f64,
    /// Contact conductance between the plate and the table.
    pub table_contact_w_m2k: f64,
    /// The thin wall's plate cell; absent: the bead width, at most 5 mm
    /// ([`super::PLATE_CELL_MAX_MM`]).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub plate_cell_mm: Option<f64>,
    /// Shortest thin-wall node along the bead.
    pub node_mm: f64,
    /// Temperature of the metal as it arrives.
    pub deposit_c: f64,
    /// Length of bead behind the torch that the arc heats; absent: the bead width.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub footprint_mm: Option<f64>,
    /// Threshold of the per-point time-above count.
    pub hot_threshold_c: f64,
    /// "temperature" (G3Si tables) or "constant" (the material's constants).
    pub properties: String,
    /// Voxel edge of the voxel model.
    pub voxel_mm: f64,
    /// "box" or "disc" (of diameter plate_mm[0], which plate_mm[1] repeats; voxel model only).
    pub plate_shape: String,
    /// Voxel model: the plate's cells merged 2 × 2 × 2 away from the metal laid on it.
    pub coarse_plate: bool,
    /// Thin wall: the nodes far from the arc stepped at their own, longer rates.
    pub local_steps: bool,
    /// Thin wall: the plate's columns merged 2 × 2 and 4 × 4 away from the metal laid on it.
    pub merge_plate: bool,
    /// Voxel model: "cpu" or "gpu" (wgpu's compute shaders; a build with the `gpu` feature).
    pub device: String,
}

impl Default for RawThermal {
    fn default() -> Self {
        Self {
            model: "thin-wall".into(),
            ambient_c: d::AMBIENT_C,
            convection_w_m2k: d::CONVECTION_W_M2K,
            emissivity: d::EMISSIVITY,
            plate_mm: None,
            lead_mm: d::LEAD_MM,
            table_contact_w_m2k: d::TABLE_CONTACT_W_M2K,
            plate_cell_mm: None,
            node_mm: d::NODE_MM,
            deposit_c: d::DEPOSIT_C,
            footprint_mm: None,
            hot_threshold_c: d::HOT_THRESHOLD_C,
            properties: "temperature".into(),
            voxel_mm: d::VOXEL_MM,
            plate_shape: "box".into(),
            coarse_plate: false,
            local_steps: true,
            merge_plate: true,
            device: "cpu".into(),
        }
    }
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawDwell {
    pub interpass_max_c: f64,
    /// The layer beneath must be below this when the torch returns (strength of the wall).
    pub strength_loss_c: f64,
    /// Criteria in force: any of "interpass", "strength", "humping", "bond".
    pub criteria: Vec<String>,
    /// Where dwells may go: "revolution" (before each revolution's first preheat reading).
    pub policy: String,
    /// Longest single dwell.
    pub max_dwell_s: f64,
    /// Shortest dwell: a stop and restart of the arc that cools for less buys nothing.
    pub min_dwell_s: f64,
    /// Most arc stops a plan may make (every arc start after the first); absent: no limit.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub max_arc_stops: Option<usize>,
    /// Aim this far below a temperature limit.
    pub margin_c: f64,
    /// The cost of one arc stop in seconds of dwell, when reporting the trade-off.
    pub count_weight_s: f64,
    /// Path points this close to a closed part's closing point are in its closing zone; absent:
    /// three bead widths.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub closing_zone_mm: Option<f64>,
    /// Plan so every point meets the criteria at this quantile of `[calibration]`'s
    /// uncertainty; absent: at the mean.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub confidence: Option<f64>,
    /// Fresh parameter draws the final plan is checked under (with `confidence`).
    pub check_draws: usize,
    /// The draws' seed.
    pub check_seed: u64,
}

impl Default for RawDwell {
    fn default() -> Self {
        Self {
            interpass_max_c: d::INTERPASS_MAX_C,
            strength_loss_c: d::STRENGTH_LOSS_C,
            criteria: vec![
                "interpass".into(),
                "strength".into(),
                "humping".into(),
                "bond".into(),
            ],
            policy: "revolution".into(),
            max_dwell_s: d::MAX_DWELL_S,
            min_dwell_s: d::MIN_DWELL_S,
            max_arc_stops: None,
            margin_c: d::MARGIN_C,
            count_weight_s: d::COUNT_WEIGHT_S,
            closing_zone_mm: None,
            confidence: None,
            check_draws: 100,
            check_seed: 1,
        }
    }
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawPlanner {
    /// n_pts of CTPP §2.2.1: points on the lower boundary.
    pub n_points: usize,
    /// ε₀ of CTPP Eq.3: the largest gap between neighbouring generators before one is filled.
    pub gap_max_mm: f64,
    /// Deposits this close to the window count as inside it (Eq.6).
    pub deposit_tolerance_mm: f64,
    pub nozzle_radius_mm: f64,
    pub nozzle_standoff_mm: f64,
    pub nozzle_length_mm: f64,
    /// The largest turn of the tool about the direction of travel that resolves a collision.
    pub nozzle_max_rotation_deg: f64,
    /// The fastest that turn changes along the path.
    pub nozzle_rotation_rate_deg_mm: f64,
    /// R_tube of the collision check: the metal laid as a tube of this radius (0: its points).
    pub deposit_tube_radius_mm: f64,
    /// The arm (torch body, wrist) as a cylinder beyond the nozzle: radius (0: not checked),
    /// where it starts along the tool axis from the deposit, and its length.
    pub arm_radius_mm: f64,
    pub arm_from_mm: f64,
    pub arm_length_mm: f64,
    /// Chalvin et al. 2019 Fig. 10: θ_n, the torch tilted from the build direction in the
    /// feeding plane (positive pushes), and θ_t, square to it (positive to the left of the
    /// travel), degrees.
    pub torch_lead_deg: f64,
    pub torch_side_deg: f64,
    /// The fastest the tool axis may turn along the path, degrees per mm.
    pub tool_rate_max_deg_mm: f64,
}

impl Default for RawPlanner {
    /// The planner's own defaults (`PlanParams::default`).
    fn default() -> Self {
        let p = planner::plan::PlanParams::default();
        let (n, t) = (p.nozzle, p.torch);
        Self {
            n_points: p.n_points,
            gap_max_mm: p.gap_max_mm,
            deposit_tolerance_mm: p.tolerance_mm,
            nozzle_radius_mm: n.radius_mm,
            nozzle_standoff_mm: n.standoff_mm,
            nozzle_length_mm: n.length_mm,
            nozzle_max_rotation_deg: n.max_rotation_deg,
            nozzle_rotation_rate_deg_mm: n.rotation_rate_deg_mm,
            deposit_tube_radius_mm: n.tube_radius_mm,
            // An arm is checked where its radius is given: from 92 mm along the tool, 200 long.
            arm_radius_mm: 0.0,
            arm_from_mm: 92.0,
            arm_length_mm: 200.0,
            torch_lead_deg: t.lead_deg,
            torch_side_deg: t.side_deg,
            tool_rate_max_deg_mm: t.max_rate_deg_mm,
        }
    }
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawOutput {
    pub rerun: bool,
    pub mcap: bool,
    pub hdf5: bool,
    pub plots: bool,
    /// report.html, the page to open first (the plots inlined).
    pub report: bool,
    /// Most times the temperature field is kept (fewer on long paths: `record::frame_times`).
    pub frames: usize,
}

impl RawOutput {
    /// Whether any sink records the run (and builds its scene of every kept frame).
    pub fn records(&self) -> bool {
        self.rerun || self.mcap || self.hdf5 || self.plots || self.report
    }
}

impl Default for RawOutput {
    fn default() -> Self {
        Self {
            rerun: true,
            mcap: true,
            hdf5: true,
            plots: true,
            report: true,
            frames: 100,
        }
    }
}

#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields, default)]
pub struct RawBead {
    /// Bond numbers above this put the melt pool at risk (Radel et al. 2019: Bo < 1 holds).
    pub bond_max: f64,
    /// Hot-metal law: the bead's height drops by this share per kelvin of preheat above the
    /// reference (0: off).
    pub hot_height_loss_per_k: f64,
    pub hot_reference_c: f64,
    /// Contact tip to work distance as planned.
    pub stickout_mm: f64,
}

impl Default for RawBead {
    fn default() -> Self {
        Self {
            bond_max: d::BOND_MAX,
            hot_height_loss_per_k: d::HOT_HEIGHT_LOSS_PER_K,
            hot_reference_c: d::HOT_REFERENCE_C,
            stickout_mm: d::STICKOUT_MM,
        }
    }
}
