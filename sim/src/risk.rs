//! Collapse-risk criteria per path point, each switchable in `[dwell]`:
//!
//! - interpass: the preheat above the interpass limit (200 °C by default, a common choice for
//!   steel WAAM);
//! - strength: the layer beneath still above a strength-loss temperature when the torch returns
//!   (550 °C by default: carbon steel keeps about 60 % of its yield strength there, EN 1993-1-2
//!   Table 3.1);
//! - humping: a melt pool longer than π times the bead width (the Rayleigh–Plateau limit of a
//!   liquid cylinder, the usual humping criterion);
//! - bond: the Bond number of the pool (R the radius of the half sphere of its volume) above the
//!   bead model's threshold (Radel et al. 2019).
//!
//! The interpass and strength limits concern a layer on a layer: points laid on the plate are
//! not judged by them, nor are points laid on the bead being laid at a closing point (where a
//! revolution is no longer than a thin-wall node and no dwell can come between them).

use crate::scenario::Scenario;
use bead_model::bond::bond_number;
use planner::plan::Plan;
use thermal::wall::{PointResult, Support};

/// Why a point is at risk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Risk {
    Interpass,
    Strength,
    Humping,
    Bond,
}

impl Risk {
    pub fn as_str(self) -> &'static str {
        match self {
            Risk::Interpass => "interpass",
            Risk::Strength => "strength",
            Risk::Humping => "humping",
            Risk::Bond => "bond",
        }
    }
}

/// The first criterion point `p` breaks, if any. `margin_k` tightens the temperature limits.
pub fn judge(s: &Scenario, p: &PointResult, support: Support, margin_k: f64) -> Option<Risk> {
    let d = &s.dwell;
    if support == Support::Deposit {
        if d.interpass && p.preheat > d.interpass_max_k - margin_k {
            return Some(Risk::Interpass);
        }
        if let Some(t) = d.strength_loss_k
            && p.preheat > t - margin_k
        {
            return Some(Risk::Strength);
        }
    }
    if d.humping && p.pool_length > std::f64::consts::PI * s.process.bead_width_m {
        return Some(Risk::Humping);
    }
    if d.bond
        && p.pool_radius.is_finite()
        && bond_number(
            s.material.density_kg_m3,
            p.pool_radius,
            s.material.surface_tension_n_m,
        ) > s.bead.bond_max
    {
        return Some(Risk::Bond);
    }
    None
}

/// Per path point: whether it lies in the closing zone, within `[dwell] closing_zone_mm` of a
/// closed part's closing point, where revolutions get short enough that the torch heats a
/// revolution's own substrate (none on an open part).
pub fn closing_zone(s: &Scenario, pl: &Plan) -> Vec<bool> {
    pl.points
        .iter()
        .map(|q| {
            pl.closing_point
                .is_some_and(|c| (q.position - c).norm() < s.dwell.closing_zone_mm)
        })
        .collect()
}
