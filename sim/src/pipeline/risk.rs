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
//! Every point is judged by every criterion in force ([`judge`]): near a closing point a
//! revolution is no longer than the torch's reach, and a point laid on the bead being laid now
//! reads the arc's own heat; it is at risk as much as any, and the outputs say so. The dwell
//! planner acts on the layer-on-layer limits only where a dwell can come between the metal and
//! the point laid on it ([`dwell_can_act`]): on an earlier revolution, not on the plate's first
//! layer (an overheated plate is reported, not dwelled for), not on metal just laid.

use super::params::Params;
use bead_model::bond::bond_number;
use planner::plan::Plan;
use thermal::{PointResult, Support};

/// The criteria in force, each `None` when switched off. SI, temperatures in K.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Criteria {
    /// The interpass limit on a layer laid on a layer.
    pub interpass_max_k: Option<f64>,
    /// The strength-loss limit on the same.
    pub strength_loss_k: Option<f64>,
    /// Melt pools longer than this hump, m.
    pub humping_pool_m: Option<f64>,
    pub bond: Option<BondLimit>,
}

/// The Bond number of the pool, Bo = ρ g R² / σ, must stay at or below `max`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BondLimit {
    pub max: f64,
    pub density_kg_m3: f64,
    pub surface_tension_n_m: f64,
}

impl Criteria {
    /// The criteria a parameter set switches on (`[dwell] criteria`).
    pub fn new(p: &Params) -> Criteria {
        let d = &p.dwell;
        Criteria {
            interpass_max_k: d.interpass.then_some(d.interpass_max_k),
            strength_loss_k: d.strength_loss_k,
            humping_pool_m: d
                .humping
                .then_some(std::f64::consts::PI * p.process.bead_width_m),
            bond: d.bond.then_some(BondLimit {
                max: p.bead.bond_max,
                density_kg_m3: p.material.density_kg_m3,
                surface_tension_n_m: p.material.surface_tension_n_m,
            }),
        }
    }
}

/// Why a point is at risk.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
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

/// The first criterion point `p` breaks, if any, whatever it is laid on. `margin_k` tightens the
/// temperature limits.
pub fn judge(c: &Criteria, p: &PointResult, margin_k: f64) -> Option<Risk> {
    judged(c, p, true, margin_k)
}

/// Whether a dwell before a point can change what the layer-on-layer limits (interpass,
/// strength) judge of it: it lies on an earlier revolution, not on the plate's first layer nor on
/// metal laid while its preheat was read.
pub fn dwell_can_act(support: Support) -> bool {
    support == Support::Deposit
}

/// [`judge`] as the dwell planner sees it: the layer-on-layer limits only where a dwell can act.
pub fn judge_for_dwell(
    c: &Criteria,
    p: &PointResult,
    support: Support,
    margin_k: f64,
) -> Option<Risk> {
    judged(c, p, dwell_can_act(support), margin_k)
}

fn judged(c: &Criteria, p: &PointResult, on_a_layer: bool, margin_k: f64) -> Option<Risk> {
    if on_a_layer {
        if c.interpass_max_k.is_some_and(|t| p.preheat > t - margin_k) {
            return Some(Risk::Interpass);
        }
        if c.strength_loss_k.is_some_and(|t| p.preheat > t - margin_k) {
            return Some(Risk::Strength);
        }
    }
    if c.humping_pool_m.is_some_and(|l| p.pool_length > l) {
        return Some(Risk::Humping);
    }
    if let Some(b) = c.bond
        && p.pool_radius.is_finite()
        && bond_number(b.density_kg_m3, p.pool_radius, b.surface_tension_n_m) > b.max
    {
        return Some(Risk::Bond);
    }
    None
}

/// Per path point: whether it lies in a closed part's closing zone, where revolutions get short
/// enough that the torch heats a revolution's own substrate: within `radius_mm` of the closing
/// point, or at or after [`just_laid_from`] (`support`: what each point lies on). None on an
/// open part whose revolutions stay long.
pub fn closing_zone(pl: &Plan, radius_mm: f64, support: impl Fn(usize) -> Support) -> Vec<bool> {
    let from = just_laid_from(pl, support).unwrap_or(usize::MAX);
    pl.points
        .iter()
        .enumerate()
        .map(|(i, q)| {
            i >= from
                || pl
                    .closing_point
                    .is_some_and(|c| (q.position - c).norm() < radius_mm)
        })
        .collect()
}

/// The first point of the last run of revolutions that each have a point laid on metal just laid
/// (the top of a closed part, where a revolution is not much longer than the torch's reach), if
/// the last revolution has one. A revolution with none ends the run: a stray point of a long
/// revolution (an unequal seam, say) does not start a closing strategy half-way up the part.
pub fn just_laid_from(pl: &Plan, support: impl Fn(usize) -> Support) -> Option<usize> {
    let mut from = None;
    let mut end = pl.points.len();
    while end > 0 {
        let layer = pl.points[end - 1].layer;
        let first = pl.points[..end]
            .iter()
            .rposition(|q| q.layer != layer)
            .map_or(0, |k| k + 1);
        if !(first..end).any(|k| support(k) == Support::JustLaid) {
            break;
        }
        from = Some(first);
        end = first;
    }
    from
}
