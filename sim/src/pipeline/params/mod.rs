//! The engine's parameters: plain SI structs (geometry in mm) that a scenario file fills in, or
//! a caller writes directly. The settings a user may leave out have their documented defaults
//! here ([`documented`], in the interface's units, and `Default` on the settings in SI): the
//! scenario reader takes its defaults from the same constants. The process's and the
//! material's defaults are the documented G3Si CMT process and G3Si (a user's machine and metal
//! will differ: set them). Each type checks itself against the documented ranges
//! (`check`, [`Invalid`] naming the key in the interface's units); [`super::build`] checks
//! before it plans.

use bead_model::as_built::HotMetalLaw;
use bead_model::heat_input::ArcPower;
use bead_model::section::Section;
use bead_model::window::{Modulation, Window};

mod check;
pub use check::{Invalid, planning};

/// Everything the engine needs beyond the plan.
#[derive(Debug, Clone, PartialEq)]
pub struct Params {
    pub process: Process,
    pub material: Material,
    pub thermal: ThermalSettings,
    pub dwell: DwellSettings,
    pub bead: BeadSettings,
}

impl Default for Params {
    /// The documented defaults: the G3Si CMT process on G3Si, for its 5 mm bead.
    fn default() -> Self {
        Params {
            process: Process::default(),
            material: Material::default(),
            thermal: ThermalSettings::default(),
            dwell: DwellSettings::default(),
            bead: BeadSettings::default(),
        }
    }
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

impl Default for Material {
    /// G3Si ([`thermal::material::G3SI`]).
    fn default() -> Self {
        Material::preset(&thermal::material::G3SI)
    }
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

/// The defaults of the settings a scenario may leave out, in the interface's units
/// (scenarios/README.md documents each): one definition, which `ThermalSettings::default()`,
/// `DwellSettings::default()`, `BeadSettings::default()` and the scenario reader share.
pub mod documented {
    /// The bead's width the footprint, plate cell and closing zone follow where it is not given.
    pub const BEAD_WIDTH_MM: f64 = 5.0;
    pub const AMBIENT_C: f64 = 20.0;
    pub const CONVECTION_W_M2K: f64 = 15.0;
    pub const EMISSIVITY: f64 = 0.6;
    pub const LEAD_MM: f64 = 10.0;
    pub const TABLE_CONTACT_W_M2K: f64 = 100.0;
    pub const NODE_MM: f64 = 3.0;
    pub const DEPOSIT_C: f64 = 1550.0;
    pub const HOT_THRESHOLD_C: f64 = 600.0;
    pub const VOXEL_MM: f64 = 2.0;
    /// A common 250 mm square stock plate, grown to fit a larger part (`plate_fitted`).
    pub const PLATE_MM: [f64; 3] = [250.0, 250.0, 10.0];
    /// The thin wall's plate cell is the bead's width, at most this. A wall on cells wider than
    /// itself loses its foot's heat into a cell's whole capacity at once: on the GAMMA wall (a
    /// 2 mm bead) 5 mm cells ran the temperatures before each pass 18 % of the rise below the
    /// voxel model's, 2 mm cells 2.6 % (docs/PHYSICS.md).
    pub const PLATE_CELL_MAX_MM: f64 = 5.0;
    pub const INTERPASS_MAX_C: f64 = 200.0;
    pub const STRENGTH_LOSS_C: f64 = 550.0;
    pub const MAX_DWELL_S: f64 = 600.0;
    pub const MIN_DWELL_S: f64 = 5.0;
    pub const MARGIN_C: f64 = 2.0;
    pub const COUNT_WEIGHT_S: f64 = 0.0;
    /// The closing zone's radius, in bead widths.
    pub const CLOSING_ZONE_BEADS: f64 = 3.0;
    /// Radel et al. 2019: Bo < 1 holds the melt pool.
    pub const BOND_MAX: f64 = 1.0;
    pub const HOT_HEIGHT_LOSS_PER_K: f64 = 0.0;
    pub const HOT_REFERENCE_C: f64 = 20.0;
    pub const HOT_MIN_FACTOR: f64 = 0.5;
    pub const STICKOUT_MM: f64 = 15.0;
    /// Thin wall's local time stepping (docs/PHYSICS.md "Local time stepping"): every node
    /// within this of the torch (and of the lead and footprint, two nodes beyond) takes every
    /// step; level m steps every 2^(m−1) s, up to 2048 s, where the torch as scheduled comes no
    /// nearer than 50 mm·√2^(m−1) before its next step and the period is at most 2.5 % of the
    /// time since the torch was last near, and a node moves at most 1 K in one of its steps
    /// (the rate of its last step times the period). 25 mm read the dome R 200 12 % of the
    /// rise off; without the bound on the change the dome R 400 read 12 % off at the plate's
    /// edge of the near zone.
    pub const LOCAL_NEAR_MM: f64 = 50.0;
    pub const LOCAL_PERIOD_S: f64 = 1.0;
    pub const LOCAL_LEVELS: u8 = 12;
    pub const LOCAL_AGE_SHARE: f64 = 0.025;
    /// A node of level ≥ 1 moves at most this far in one of its steps, K.
    pub const LOCAL_CHANGE_K: f64 = 1.0;
    /// The process: a G3Si CMT process on a 1 mm wire, its wire feed modulated at a constant
    /// travel speed (the CTPP choice), a fixed arc power, Eq.7's rectangular section.
    pub const WIRE_DIAMETER_MM: f64 = 1.0;
    pub const TRAVEL_SPEED_MM_S: f64 = 10.0;
    pub const DEPOSIT_MM: f64 = 2.0;
    pub const DEPOSIT_MIN_MM: f64 = 1.8;
    pub const DEPOSIT_MAX_MM: f64 = 2.2;
    pub const WFS_MIN_M_MIN: f64 = 1.5;
    pub const WFS_MAX_M_MIN: f64 = 10.0;
    pub const TRAVEL_MIN_MM_S: f64 = 2.0;
    pub const TRAVEL_MAX_MM_S: f64 = 25.0;
    pub const ARC_POWER_W: f64 = 2000.0;
    pub const EFFICIENCY: f64 = 0.85;
}

const MM: f64 = 1e-3;

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
    /// Voxel model: the plate's cells merged 2 × 2 × 2 away from the metal laid on it
    /// (`thermal::voxel::VoxelSettings::coarse_plate`).
    pub coarse_plate: bool,
    /// Thin wall: the nodes far from the arc stepped at their own, longer rates
    /// (`thermal::rates`); false: every node at every step (the reference).
    pub local_steps: bool,
    /// Thin wall: the plate's columns merged away from the metal laid on it
    /// (`thermal::wall::WallSettings::merge_plate`); false: the uniform grid (the reference).
    pub merge_plate: bool,
    /// Voxel model: where it steps (`[thermal] device`).
    pub device: thermal::voxel::Device,
}

impl Default for ThermalSettings {
    /// The documented defaults for the default bead: the thin wall, G3Si's temperature tables,
    /// on a 250 × 250 × 10 mm plate grown to fit the part.
    fn default() -> Self {
        ThermalSettings::for_bead(documented::BEAD_WIDTH_MM)
    }
}

impl ThermalSettings {
    /// The documented defaults for a bead `width_mm` wide: the footprint is its width, the
    /// thin wall's plate cell its width up to [`documented::PLATE_CELL_MAX_MM`].
    pub fn for_bead(width_mm: f64) -> Self {
        use documented as d;
        ThermalSettings {
            table_contact_w_m2k: d::TABLE_CONTACT_W_M2K,
            plate_cell_m: width_mm.min(d::PLATE_CELL_MAX_MM) * MM,
            node_m: d::NODE_MM * MM,
            deposit_k: thermal::kelvin(d::DEPOSIT_C),
            footprint_m: width_mm * MM,
            hot_threshold_k: thermal::kelvin(d::HOT_THRESHOLD_C),
            temperature_dependent: true,
            voxel_m: d::VOXEL_MM * MM,
            model: ThermalModel::ThinWall,
            ambient_k: thermal::kelvin(d::AMBIENT_C),
            convection_w_m2k: d::CONVECTION_W_M2K,
            emissivity: d::EMISSIVITY,
            plate_m: d::PLATE_MM.map(|v| v * MM),
            plate_fit: true,
            plate_disc: false,
            lead_m: d::LEAD_MM * MM,
            coarse_plate: false,
            local_steps: true,
            merge_plate: true,
            device: Default::default(),
        }
    }
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

impl Default for DwellSettings {
    /// Every criterion on, a 200 °C interpass limit aimed 2 °C under, for the default bead.
    fn default() -> Self {
        DwellSettings::for_bead(documented::BEAD_WIDTH_MM)
    }
}

impl DwellSettings {
    /// The documented defaults, the closing zone three widths of a bead `width_mm` wide.
    pub fn for_bead(width_mm: f64) -> Self {
        use documented as d;
        DwellSettings {
            interpass_max_k: thermal::kelvin(d::INTERPASS_MAX_C),
            interpass: true,
            strength_loss_k: Some(thermal::kelvin(d::STRENGTH_LOSS_C)),
            humping: true,
            bond: true,
            max_dwell_s: d::MAX_DWELL_S,
            min_dwell_s: d::MIN_DWELL_S,
            max_arc_stops: None,
            margin_k: d::MARGIN_C,
            count_weight_s: d::COUNT_WEIGHT_S,
            closing_zone_mm: d::CLOSING_ZONE_BEADS * width_mm,
        }
    }
}

impl Default for BeadSettings {
    /// Bo < 1, the hot-metal law off, a 15 mm stickout.
    fn default() -> Self {
        use documented as d;
        BeadSettings {
            bond_max: d::BOND_MAX,
            hot_metal: HotMetalLaw {
                reference_k: thermal::kelvin(d::HOT_REFERENCE_C),
                height_loss_per_k: d::HOT_HEIGHT_LOSS_PER_K,
                min_factor: d::HOT_MIN_FACTOR,
            },
            stickout_m: d::STICKOUT_MM * MM,
        }
    }
}

impl Default for Process {
    /// The documented process ([`documented`]).
    fn default() -> Self {
        use documented as d;
        const M_MIN: f64 = 1.0 / 60.0;
        Process {
            modulation: Modulation::WireFeed {
                travel: d::TRAVEL_SPEED_MM_S * MM,
            },
            power: ArcPower::Fixed {
                watts: d::ARC_POWER_W,
            },
            section: Section::Rectangle,
            wire_diameter_m: d::WIRE_DIAMETER_MM * MM,
            bead_width_m: d::BEAD_WIDTH_MM * MM,
            travel_speed_m_s: d::TRAVEL_SPEED_MM_S * MM,
            deposit_m: d::DEPOSIT_MM * MM,
            deposit_min_m: d::DEPOSIT_MIN_MM * MM,
            deposit_max_m: d::DEPOSIT_MAX_MM * MM,
            wfs_min_m_s: d::WFS_MIN_M_MIN * M_MIN,
            wfs_max_m_s: d::WFS_MAX_M_MIN * M_MIN,
            travel_min_m_s: d::TRAVEL_MIN_MM_S * MM,
            travel_max_m_s: d::TRAVEL_MAX_MM_S * MM,
            arc_power_w: d::ARC_POWER_W,
            efficiency: d::EFFICIENCY,
        }
    }
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
