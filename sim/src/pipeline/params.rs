//! The engine's parameters: plain SI structs (geometry in mm) that a scenario file fills in, or
//! a caller writes directly. Physical inputs have no `Default`: they come from the user.

use bead_model::as_built::HotMetalLaw;
use bead_model::heat_input::ArcPower;
use bead_model::section::Section;
use bead_model::window::{Modulation, Window};

/// Everything the engine needs beyond the plan.
#[derive(Debug, Clone, PartialEq)]
pub struct Params {
    pub process: Process,
    pub material: Material,
    pub thermal: ThermalSettings,
    pub dwell: DwellSettings,
    pub bead: BeadSettings,
}

/// Deposition process, SI.
#[derive(Debug, Clone, PartialEq)]
pub struct Process {
    pub modulation: Modulation,
    pub power: ArcPower,
    pub section: Section,
    pub wire_diameter_m: f64,
    pub bead_width_m: f64,
    pub travel_speed_m_s: f64,
    pub deposit_m: f64,
    pub deposit_min_m: f64,
    pub deposit_max_m: f64,
    pub wfs_min_m_s: f64,
    pub wfs_max_m_s: f64,
    pub travel_min_m_s: f64,
    pub travel_max_m_s: f64,
    pub arc_power_w: f64,
    pub efficiency: f64,
}

/// Material constants, SI (temperatures in K). The density and surface tension serve both
/// property modes; the rest only the constant-property mode (`[thermal] properties`).
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    pub name: String,
    pub density_kg_m3: f64,
    pub specific_heat_j_kgk: f64,
    pub conductivity_w_mk: f64,
    pub surface_tension_n_m: f64,
    pub melting_k: f64,
}

impl Material {
    /// The constants of a preset (`thermal::material::G3SI`, the one definition of the metal):
    /// k follows from the room-temperature diffusivity, α = k/(ρ c_p); the melting point is the
    /// solidus, where the temperature-dependent tables start to melt.
    pub fn preset(p: &thermal::material::Preset) -> Material {
        Material {
            name: p.name.into(),
            density_kg_m3: p.density_kg_m3,
            specific_heat_j_kgk: p.specific_heat_j_kgk,
            conductivity_w_mk: p.diffusivity_m2_s * p.density_kg_m3 * p.specific_heat_j_kgk,
            surface_tension_n_m: p.surface_tension_n_m,
            melting_k: p.solidus_k,
        }
    }

    pub fn diffusivity_m2_s(&self) -> f64 {
        self.conductivity_w_mk / (self.density_kg_m3 * self.specific_heat_j_kgk)
    }
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ThermalModel {
    /// The thin wall (`thermal::wall`): `model = "thin-wall"`.
    ThinWall,
    Voxel,
}

/// Thermal boundary conditions and model settings, SI (K).
#[derive(Debug, Clone, PartialEq)]
pub struct ThermalSettings {
    pub table_contact_w_m2k: f64,
    pub plate_cell_m: f64,
    pub node_m: f64,
    pub deposit_k: f64,
    pub footprint_m: f64,
    pub hot_threshold_k: f64,
    /// Temperature-dependent G3Si tables, or the material's constants.
    pub temperature_dependent: bool,
    pub voxel_m: f64,
    pub model: ThermalModel,
    pub ambient_k: f64,
    pub convection_w_m2k: f64,
    pub emissivity: f64,
    pub plate_m: [f64; 3],
    /// `plate_m` is the least plate, grown in x and y to the part's footprint on it plus
    /// [`super::PLATE_MARGIN_M`] a side ([`super::plate_fitted`]); false: the plate the user gave.
    pub plate_fit: bool,
    /// The plate is a disc of diameter `plate_m[0]`.
    pub plate_disc: bool,
    pub lead_m: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct DwellSettings {
    pub interpass_max_k: f64,
    /// None: that criterion is off.
    pub interpass: bool,
    pub strength_loss_k: Option<f64>,
    pub humping: bool,
    pub bond: bool,
    pub max_dwell_s: f64,
    /// Shortest dwell planned: an arc stop that cools for less buys nothing.
    pub min_dwell_s: f64,
    /// Most arc stops a plan may make (`pipeline::arc_stops`); None: no limit.
    pub max_arc_stops: Option<usize>,
    pub margin_k: f64,
    pub count_weight_s: f64,
    /// Radius of the closing zone around a closing point, mm.
    pub closing_zone_mm: f64,
}

/// Bead-model settings beyond the process: risk threshold and the hot-metal law.
#[derive(Debug, Clone, PartialEq)]
pub struct BeadSettings {
    pub bond_max: f64,
    pub hot_metal: HotMetalLaw,
    pub stickout_m: f64,
}

impl Process {
    /// The machine limits as a process window.
    pub fn window(&self) -> Window {
        Window {
            wire_diameter: self.wire_diameter_m,
            width: self.bead_width_m,
            wfs_min: self.wfs_min_m_s,
            wfs_max: self.wfs_max_m_s,
            travel_min: self.travel_min_m_s,
            travel_max: self.travel_max_m_s,
        }
    }
}
