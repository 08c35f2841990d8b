//! The bead model applied to a plan: per path point, the machine settings that lay its deposit
//! (Eq.7 under the scenario's modulation), the arc power and heat input, and the Bond number of
//! the deposit; and the points the process window cannot lay.

use super::params::{Material, Process};
use bead_model::bond::{bond_number, tilt_from_vertical};
use bead_model::heat_input::energy_per_length;
use bead_model::section::Section;
use planner::plan::PathPoint;

/// Per path point, SI.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bead {
    pub wfs_m_s: f64,
    pub travel_m_s: f64,
    pub power_w: f64,
    /// Heat into the part per length, J/m.
    pub heat_j_m: f64,
    pub bond: f64,
    /// Build direction from the vertical, rad.
    pub tilt_rad: f64,
}

impl Bead {
    /// The same deposit laid `pace` times slower: wire feed and travel speed divided together
    /// (Eq.7's height depends on their ratio alone), the power the slower wire feed gives, and the
    /// heat per length that follows.
    pub fn paced(&self, pace: f64, p: &Process) -> Bead {
        if pace == 1.0 {
            return *self;
        }
        let (wfs, travel) = (self.wfs_m_s / pace, self.travel_m_s / pace);
        let power = p.power.power(wfs);
        Bead {
            wfs_m_s: wfs,
            travel_m_s: travel,
            power_w: power,
            heat_j_m: energy_per_length(power, p.efficiency, travel),
            ..*self
        }
    }
}

#[derive(Debug, Clone)]
pub struct Beads {
    pub beads: Vec<Bead>,
    /// Path points whose deposit the window cannot lay.
    pub outside_window: Vec<usize>,
    /// What the window can lay, m.
    pub window_m: (f64, f64),
}

/// The beads of path `points` (a plan's, or a tube strategy's).
pub fn beads(p: &Process, m: &Material, points: &[PathPoint]) -> Beads {
    let window = p.window();
    let heights: Vec<f64> = points.iter().map(|q| q.deposit_mm * 1e-3).collect();
    let beads = points
        .iter()
        .zip(&heights)
        .map(|(q, &h)| {
            let (wfs, travel) = window.settings(h, p.modulation);
            let power = p.power.power(wfs);
            // R_deposit: the radius of the cap through the bead's edges and top.
            let area = Section::Rectangle.area(p.bead_width_m, h);
            let height = p
                .section
                .height(area, p.bead_width_m)
                .unwrap_or(p.bead_width_m / 2.0);
            let r = Section::cap_radius(p.bead_width_m, height.max(1e-9));
            Bead {
                wfs_m_s: wfs,
                travel_m_s: travel,
                power_w: power,
                heat_j_m: energy_per_length(power, p.efficiency, travel),
                bond: bond_number(m.density_kg_m3, r, m.surface_tension_n_m),
                tilt_rad: tilt_from_vertical([q.build.x, q.build.y, q.build.z]),
            }
        })
        .collect();
    Beads {
        beads,
        outside_window: window.outside(&heights, p.modulation),
        window_m: window.heights(p.modulation),
    }
}
