//! From a plan and its beads to the thermal models' input: the deposition schedule and the thin-wall
//! settings. Units change here: the plan is in mm, the thermal models in SI.

use crate::beads::Beads;
use crate::scenario::Scenario;
use planner::plan::Plan;
use thermal::material::Material;
use thermal::network::Surroundings;
use thermal::schedule::Deposit;
use thermal::wall::{Plate, WallSettings};

/// Cell layers through the plate's thickness (see the model comparison in PHYSICS.md).
const PLATE_LAYERS: usize = 3;

/// Longest time step of the thermal model during dwells and cooling, s.
const MAX_COOLING_STEP_S: f64 = 30.0;

/// One deposit per path point; `dwell_s[i]` pauses the arc before point i.
pub fn schedule(s: &Scenario, pl: &Plan, b: &Beads, dwell_s: &[f64]) -> Vec<Deposit> {
    let n_gen = pl.generators.len();
    let mut t = 0.0;
    pl.points
        .iter()
        .enumerate()
        .map(|(i, q)| {
            let seg_m = if i == 0 {
                s.process.bead_width_m
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
                heat: s.process.efficiency * bead.power_w * arc,
                width: s.process.bead_width_m,
                height: (q.deposit_mm * 1e-3).max(1e-5),
                axis: [q.tool.x, q.tool.y, q.tool.z],
                // The spiral lays point i on the same generator one revolution earlier.
                support: (q.layer > 0 && i >= n_gen).then(|| i - n_gen),
            }
        })
        .collect()
}

pub fn material(s: &Scenario) -> Material {
    let m = &s.material;
    if s.thermal.temperature_dependent {
        Material::g3si()
    } else {
        Material::constant(
            m.density_kg_m3,
            m.specific_heat_j_kgk,
            m.conductivity_w_mk,
            m.melting_k,
            0.0,
        )
    }
}

pub fn wall_settings(s: &Scenario, deposits: &[Deposit], snapshot_times: Vec<f64>) -> WallSettings {
    let t = &s.thermal;
    let centre = plate_centre(deposits);
    WallSettings {
        material: material(s),
        surroundings: Surroundings {
            ambient_k: t.ambient_k,
            convection_w_m2k: t.convection_w_m2k,
            emissivity: t.emissivity,
            table_w_m2k: t.table_contact_w_m2k,
        },
        plate: Plate {
            size: t.plate_m,
            centre,
            cell: t.plate_cell_m,
            layers: PLATE_LAYERS,
        },
        min_node: t.node_m,
        deposit_temperature: t.deposit_k,
        footprint: t.footprint_m,
        lead: t.lead_m,
        hot_threshold: t.hot_threshold_k,
        max_step: MAX_COOLING_STEP_S,
        snapshot_times,
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
