//! From a plan and its beads to the heat models' input: the deposition schedule and the model
//! with its settings. Units change here: the plan is in mm, the heat models in SI.

use super::beads::Beads;
use super::params::{Material, Process, ThermalModel, ThermalSettings};
use planner::plan::Plan;
use thermal::network::Surroundings;
use thermal::schedule::Deposit;
use thermal::voxel::VoxelSettings;
use thermal::wall::WallSettings;
use thermal::{HeatModel, Plate};

/// Cell layers through the plate's thickness (see the model comparison in PHYSICS.md).
const PLATE_LAYERS: usize = 3;

/// Longest time step of the thin wall during dwells and cooling, s.
const MAX_COOLING_STEP_S: f64 = 30.0;

/// The voxel model's explicit step as a share of its stability limit.
const VOXEL_COURANT: f64 = 0.9;

/// One deposit per path point; `dwell_s[i]` pauses the arc before point i.
pub fn schedule(p: &Process, pl: &Plan, b: &Beads, dwell_s: &[f64]) -> Vec<Deposit> {
    let n_gen = pl.generators.len();
    let mut t = 0.0;
    pl.points
        .iter()
        .enumerate()
        .map(|(i, q)| {
            let seg_m = if i == 0 {
                p.bead_width_m
            } else {
                (q.position - pl.points[i - 1].position).norm() * 1e-3
            };
            let bead = &b.beads[i];
            let arc = seg_m / bead.travel_m_s;
            t += dwell_s.get(i).copied().unwrap_or(0.0) + arc;
            Deposit {
                position: [
                    q.position.x * 1e-3,
                    q.position.y * 1e-3,
                    q.position.z * 1e-3,
                ],
                time: t,
                arc_time: arc,
                heat: p.efficiency * bead.power_w * arc,
                width: p.bead_width_m,
                height: (q.deposit_mm * 1e-3).max(1e-5),
                axis: [q.tool.x, q.tool.y, q.tool.z],
                // The spiral lays point i on the same generator one revolution earlier.
                support: (q.layer > 0 && i >= n_gen).then(|| i - n_gen),
                start: None,
            }
        })
        .collect()
}

/// The heat models' material: the G3Si tables with the given density, or constants.
pub fn material(m: &Material, t: &ThermalSettings) -> thermal::material::Material {
    if t.temperature_dependent {
        let mut tables = thermal::material::Material::g3si();
        tables.density = m.density_kg_m3;
        tables
    } else {
        thermal::material::Material::constant(
            m.density_kg_m3,
            m.specific_heat_j_kgk,
            m.conductivity_w_mk,
            m.melting_k,
            0.0,
        )
    }
}

/// The chosen heat model on `deposits`, keeping the field at `snapshot_times` and the
/// temperature of the deposits in `traces` at every step.
pub fn heat_model(
    m: &Material,
    t: &ThermalSettings,
    deposits: &[Deposit],
    snapshot_times: Vec<f64>,
    traces: Vec<usize>,
) -> HeatModel {
    heat_model_of(material(m, t), t, deposits, snapshot_times, traces)
}

/// [`heat_model`] with the heat models' own material (tables read from files, say).
pub fn heat_model_of(
    material: thermal::material::Material,
    t: &ThermalSettings,
    deposits: &[Deposit],
    snapshot_times: Vec<f64>,
    traces: Vec<usize>,
) -> HeatModel {
    let surroundings = Surroundings {
        ambient_k: t.ambient_k,
        convection_w_m2k: t.convection_w_m2k,
        emissivity: t.emissivity,
        table_w_m2k: t.table_contact_w_m2k,
    };
    let plate = Plate {
        size: t.plate_m,
        centre: plate_centre(deposits),
        cell: t.plate_cell_m,
        layers: PLATE_LAYERS,
        disc: t.plate_disc,
        material: None,
    };
    match t.model {
        ThermalModel::Fe => HeatModel::ThinWall(WallSettings {
            material,
            surroundings,
            plate,
            min_node: t.node_m,
            deposit_temperature: t.deposit_k,
            footprint: t.footprint_m,
            lead: t.lead_m,
            hot_threshold: t.hot_threshold_k,
            max_step: MAX_COOLING_STEP_S,
            probes: vec![],
            probe_every: 0.0,
            snapshot_times,
            traces,
            trace_hottest: false,
        }),
        ThermalModel::Voxel => HeatModel::Voxel(VoxelSettings {
            material,
            surroundings,
            plate,
            size: t.voxel_m,
            deposit_temperature: t.deposit_k,
            lead: t.lead_m,
            hot_threshold: t.hot_threshold_k,
            snapshot_times,
            traces,
            trace_hottest: false,
            courant: VOXEL_COURANT,
            probes: vec![],
            probe_every: 0.0,
            source: thermal::voxel::HeatSource::DoubleEllipsoid,
        }),
    }
}

/// The plate is centred under the first revolution (the deposits laid on it), m.
pub fn plate_centre(deposits: &[Deposit]) -> [f64; 2] {
    let first: Vec<&Deposit> = deposits.iter().filter(|d| d.support.is_none()).collect();
    let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
    for d in &first {
        for k in 0..2 {
            lo[k] = lo[k].min(d.position[k]);
            hi[k] = hi[k].max(d.position[k]);
        }
    }
    if first.is_empty() {
        [0.0, 0.0]
    } else {
        [(lo[0] + hi[0]) / 2.0, (lo[1] + hi[1]) / 2.0]
    }
}
