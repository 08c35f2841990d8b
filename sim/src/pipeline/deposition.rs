//! From a plan and its beads to the heat models' input: the deposition schedule and the model
//! with its settings. Units change here: the plan is in mm, the heat models in SI.

use super::beads::{Bead, Beads};
use super::params::{Material, Process, ThermalModel, ThermalSettings};
use planner::plan::Plan;
use thermal::network::Surroundings;
use thermal::rates::LocalSteps;
use thermal::schedule::{Deposit, DropPart};
use thermal::voxel::VoxelSettings;
use thermal::wall::WallSettings;
use thermal::{HeatModel, Plate};

/// Cell layers through the plate's thickness (see the model comparison in PHYSICS.md).
pub(crate) const PLATE_LAYERS: usize = 3;

/// Longest time step of the thin wall during dwells and cooling, s.
const MAX_COOLING_STEP_S: f64 = 30.0;

/// The voxel model's explicit step as a share of its stability limit.
pub(crate) const VOXEL_COURANT: f64 = 0.9;

/// How the build is cooled, per path point: what the dwell planner decides. Empty vectors (or
/// shorter ones) mean no dwell, the planned pace, no drop.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Cooling {
    /// The arc's pause before the point, s.
    pub dwell_s: Vec<f64>,
    /// Wire feed and travel speed divided by this (1: as planned; [`super::pace`]).
    pub pace: Vec<f64>,
    /// Laid as part of a drop ([`DropPart`]): the closing strategy of skeleton arc AM.
    pub drop: Vec<Option<DropPart>>,
}

impl Cooling {
    /// Dwells alone.
    pub fn dwells(dwell_s: &[f64]) -> Cooling {
        Cooling {
            dwell_s: dwell_s.to_vec(),
            ..Cooling::default()
        }
    }

    /// No dwell, the planned pace and no drop at each of `n` points.
    pub fn none(n: usize) -> Cooling {
        Cooling {
            dwell_s: vec![0.0; n],
            pace: vec![1.0; n],
            drop: vec![None; n],
        }
    }

    pub fn dwell(&self, i: usize) -> f64 {
        self.dwell_s.get(i).copied().unwrap_or(0.0)
    }

    pub fn pace(&self, i: usize) -> f64 {
        self.pace.get(i).copied().unwrap_or(1.0)
    }

    pub fn drop_part(&self, i: usize) -> Option<DropPart> {
        self.drop.get(i).copied().flatten()
    }

    /// Whether the arc strikes anew before point i: after a dwell, or for a drop (even with no
    /// wait before it).
    pub fn strikes(&self, i: usize) -> bool {
        self.dwell(i) > 0.0 || matches!(self.drop_part(i), Some(DropPart::Strikes { .. }))
    }

    /// Every arc start after the first: each dwell and each drop.
    pub fn arc_stops(&self) -> usize {
        let n = self.dwell_s.len().max(self.drop.len());
        (1..n).filter(|&i| self.strikes(i)).count()
    }

    pub fn total_dwell_s(&self) -> f64 {
        self.dwell_s.iter().sum()
    }

    /// Points laid at another pace than planned.
    pub fn slowed(&self) -> usize {
        self.pace.iter().filter(|&&k| k != 1.0).count()
    }

    /// Drops struck.
    pub fn drops(&self) -> usize {
        self.drop
            .iter()
            .filter(|d| matches!(d, Some(DropPart::Strikes { .. })))
            .count()
    }
}

/// One deposit per path point, cooled as `cooling` says: a dwell pauses the arc before a point,
/// a pace slows it down ([`Bead::paced`]), a drop is laid standing.
pub fn schedule(p: &Process, pl: &Plan, b: &Beads, cooling: &Cooling) -> Vec<Deposit> {
    let n_gen = pl.generators.len();
    let mut t = 0.0;
    pl.points
        .iter()
        .enumerate()
        .map(|(i, q)| {
            let arc = burn(p, &b.beads[i], segment_m(p, pl, i), cooling.pace(i));
            t += cooling.dwell(i) + arc.arc_time;
            Deposit {
                position: [
                    q.position.x * 1e-3,
                    q.position.y * 1e-3,
                    q.position.z * 1e-3,
                ],
                time: t,
                arc_time: arc.arc_time,
                heat: arc.heat,
                width: p.bead_width_m,
                height: (q.deposit_mm * 1e-3).max(1e-5),
                axis: [q.build.x, q.build.y, q.build.z],
                // The spiral lays point i on the same generator one revolution earlier.
                support: (q.layer > 0 && i >= n_gen).then(|| i - n_gen),
                start: None,
                drop: cooling.drop_part(i),
            }
        })
        .collect()
}

/// The length of bead point i lays, m: from the previous point (the first lays one bead width).
pub fn segment_m(p: &Process, pl: &Plan, i: usize) -> f64 {
    if i == 0 {
        p.bead_width_m
    } else {
        (pl.points[i].position - pl.points[i - 1].position).norm() * 1e-3
    }
}

/// How a bead segment of `seg_m` burns at `pace`: the arc time at the paced travel speed, and the
/// share η of the paced power over it (the drop flag is the caller's).
pub fn burn(p: &Process, bead: &Bead, seg_m: f64, pace: f64) -> thermal::Burn {
    let bead = bead.paced(pace, p);
    let arc = seg_m / bead.travel_m_s;
    thermal::Burn {
        arc_time: arc,
        heat: p.efficiency * bead.power_w * arc,
        drop: None,
    }
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
    let plate = plate_of(t, deposits);
    match t.model {
        ThermalModel::ThinWall => HeatModel::ThinWall(WallSettings {
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
            watch_metal: false,
            local_steps: t.local_steps.then(|| local_steps(t)),
            merge_plate: t.merge_plate,
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
            watch_metal: false,
            courant: VOXEL_COURANT,
            probes: vec![],
            probe_every: 0.0,
            source: thermal::voxel::HeatSource::DoubleEllipsoid,
            coarse_plate: t.coarse_plate,
            device: t.device,
        }),
    }
}

/// The thin wall's local time stepping for these settings: the near zone holds the lead and the
/// footprint two nodes beyond.
fn local_steps(t: &ThermalSettings) -> LocalSteps {
    use super::params::documented as d;
    let near = (d::LOCAL_NEAR_MM * 1e-3).max(t.lead_m.max(t.footprint_m) + 2.0 * t.node_m);
    LocalSteps {
        near,
        period: d::LOCAL_PERIOD_S,
        levels: d::LOCAL_LEVELS,
        age_share: d::LOCAL_AGE_SHARE,
        change: Some(d::LOCAL_CHANGE_K),
    }
}

/// The plate `t` describes, centred under the deposits laid on it.
pub(crate) fn plate_of(t: &ThermalSettings, deposits: &[Deposit]) -> Plate {
    Plate {
        size: t.plate_m,
        centre: plate_centre(deposits),
        cell: t.plate_cell_m,
        layers: PLATE_LAYERS,
        disc: t.plate_disc,
        material: None,
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

#[cfg(test)]
mod tests {
    use super::Cooling;
    use thermal::schedule::DropPart;

    /// Every arc start after the first is an arc stop: a dwell, or a drop struck (even with no
    /// wait); a drop going on is not.
    #[test]
    fn arc_stops_are_dwells_and_drops_struck() {
        let mut c = Cooling::none(6);
        c.dwell_s[0] = 3.0; // before the first arc: no stop
        c.dwell_s[2] = 10.0;
        c.drop[4] = Some(DropPart::Strikes { deposits: 2 });
        c.drop[5] = Some(DropPart::Continues);
        assert_eq!(c.arc_stops(), 2);
        assert_eq!(c.drops(), 1);
    }
}
