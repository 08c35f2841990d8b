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
use thermal::{PointResult, Support, celsius};

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
    /// Where the pool's edge lies (the solidus), K: what a preheat is measured against when a
    /// pool's size is to be cured ([`preheat_to_cure`]).
    pub melting_k: f64,
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
            melting_k: p.material.melting_k,
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

impl Criteria {
    /// What point `p` breaks of `risk`, in the interface's units: the value against its limit
    /// (`preheat 214.3 °C over the 200 °C interpass limit`, `melt pool 16.9 mm over the 15.7 mm
    /// humping limit`). The outputs named every first point at risk an interpass overheat, a
    /// pool too long read "preheat 144 °C over the 200 °C limit".
    pub fn breach(&self, p: &PointResult, risk: Risk) -> String {
        let limit_c = |l: Option<f64>| l.map_or(f64::NAN, celsius);
        match risk {
            Risk::Interpass => {
                let (t, limit) = (celsius(p.preheat), limit_c(self.interpass_max_k));
                let d = decimals_over(t, limit);
                format!("preheat {t:.d$} °C over the {limit:.0} °C interpass limit")
            }
            Risk::Strength => {
                let (t, limit) = (celsius(p.preheat), limit_c(self.strength_loss_k));
                let d = decimals_over(t, limit);
                format!("preheat {t:.d$} °C over the {limit:.0} °C strength-loss limit")
            }
            Risk::Humping => {
                let pool = p.pool_length * 1e3;
                let limit = self.humping_pool_m.map_or(f64::NAN, |l| l * 1e3);
                let d = decimals_over(pool, limit);
                format!("melt pool {pool:.d$} mm over the {limit:.d$} mm humping limit")
            }
            Risk::Bond => {
                let (bo, max) = self.bond.map_or((f64::NAN, f64::NAN), |b| {
                    let bo = bond_number(b.density_kg_m3, p.pool_radius, b.surface_tension_n_m);
                    (bo, b.max)
                });
                format!(
                    "Bond number {bo:.2} of a pool {:.1} mm in radius over the limit {max:.2}",
                    p.pool_radius * 1e3
                )
            }
        }
    }
}

/// The decimals, one to three, at which `value` reads above `limit` rounded alike: a value a
/// hair over its limit read "melt pool 15.7 mm over the 15.7 mm humping limit" (a canister's
/// 15.748 mm against π × 5 mm) or "preheat 200.0 °C over the 200 °C interpass limit".
fn decimals_over(value: f64, limit: f64) -> usize {
    (1..=3)
        .find(|&d| {
            let f = 10f64.powi(d as i32);
            (value * f).round() > (limit * f).round()
        })
        .unwrap_or(1)
}

/// The preheat under which point `p` no longer breaks `risk`, K: what a dwell that cools the
/// metal beneath it must reach. The temperature limits are their own answer (less `margin_k`).
/// A pool too long (humping) or too heavy (Bond) shrinks as the preheat falls: in Rosenthal's
/// moving point source on a thick plate the melt isotherm trails the arc by
/// L = q / (2π k (T_m − T_0)), so the pool's length scales as 1/(T_m − T_0) (Rosenthal 1946, the
/// trailing solution along the centre line); taking its other sizes to scale alike, the radius
/// of the half sphere of its volume does too and the Bond number (∝ R²) as 1/(T_m − T_0)². The
/// preheat that brings the pool to the limit follows from the one it had. `None` where no preheat
/// cures it (the pool is too long even on metal at absolute zero by that law, or the criterion is
/// off).
pub fn preheat_to_cure(c: &Criteria, p: &PointResult, risk: Risk, margin_k: f64) -> Option<f64> {
    let pool = |ratio: f64| {
        // No margin: the law only steers the search's tries, each judged in the model (an aim
        // 3 % below the limit cost the demo 5 more arc stops, 170 against 165).
        let t = c.melting_k - (c.melting_k - p.preheat) * ratio;
        (t > 0.0).then_some(t)
    };
    match risk {
        Risk::Interpass => c.interpass_max_k.map(|t| t - margin_k),
        Risk::Strength => c.strength_loss_k.map(|t| t - margin_k),
        Risk::Humping => c.humping_pool_m.and_then(|l| pool(p.pool_length / l)),
        Risk::Bond => c.bond.and_then(|b| {
            let bo = bond_number(b.density_kg_m3, p.pool_radius, b.surface_tension_n_m);
            pool((bo / b.max).sqrt())
        }),
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::scenario::Scenario;
    use thermal::HeatRun;

    /// Each first point at risk is named by what it breaks, against that criterion's own limit.
    #[test]
    fn a_breach_names_its_criterion_and_limit() {
        let c = Criteria {
            interpass_max_k: Some(473.15),
            strength_loss_k: Some(823.15),
            humping_pool_m: Some(std::f64::consts::PI * 5e-3),
            bond: Some(BondLimit {
                max: 0.8,
                density_kg_m3: 7800.0,
                surface_tension_n_m: 1.2,
            }),
            melting_k: 1700.0,
        };
        let p = PointResult {
            preheat: 417.3,
            peak: 2000.0,
            pool_length: 16.9e-3,
            pool_radius: 4.0e-3,
            time_above: 1.0,
        };
        // Bond: ρ g R² / σ = 7800 × 9.81 × 16e-6 / 1.2 = 1.02.
        for (risk, said) in [
            (
                Risk::Humping,
                "melt pool 16.9 mm over the 15.7 mm humping limit",
            ),
            (
                Risk::Interpass,
                "preheat 144.2 °C over the 200 °C interpass limit",
            ),
            (
                Risk::Strength,
                "preheat 144.2 °C over the 550 °C strength-loss limit",
            ),
            (
                Risk::Bond,
                "Bond number 1.02 of a pool 4.0 mm in radius over the limit 0.80",
            ),
        ] {
            assert_eq!(c.breach(&p, risk), said);
        }
        // A hair over the limit reads over it.
        let close = PointResult {
            preheat: 473.19,
            pool_length: 15.748e-3,
            ..p
        };
        assert_eq!(
            c.breach(&close, Risk::Humping),
            "melt pool 15.75 mm over the 15.71 mm humping limit"
        );
        assert_eq!(
            c.breach(&close, Risk::Interpass),
            "preheat 200.04 °C over the 200 °C interpass limit"
        );
    }

    /// A leaning dome on an elliptic base (`scenarios/leaning_elliptic_dome.toml`, 70 × 45 mm,
    /// 110 mm tall, lean 30 mm): revolutions unequal in length around the part and in height from
    /// side to side, the generators sparser round the seam than the lead. On both models only the
    /// revolutions at the top lie in part on metal just laid, and the closing zone the planner
    /// and the outputs use starts there. Judged from the end of the reading deposit's segment
    /// rather than the torch, the seam point of every revolution from the second on was "just
    /// laid" (this test fails so, checked), and the closing zone began at revolution 1.
    #[test]
    fn just_laid_only_at_the_top_of_a_leaning_elliptic_dome() {
        let root = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        let path = root.join("scenarios/leaning_elliptic_dome.toml");
        let text = std::fs::read_to_string(&path).unwrap();
        for model in ["thin-wall", "voxel"] {
            let text = format!("{text}[thermal]\nmodel = \"{model}\"\n");
            let s = Scenario::parse(&text, "leaning", &root).unwrap();
            let part = crate::part::load_part(&s.part).unwrap();
            let b = super::super::Build::new(
                super::super::plan(&part, &s.plan_params()).unwrap(),
                s.params(),
            );
            let run = b
                .heat_model(b.deposits(), vec![])
                .start(b.deposits())
                .unwrap();
            let pl = &b.plan;
            let revolutions = pl.points.last().unwrap().layer + 1;
            let just_laid: Vec<usize> = (0..pl.points.len())
                .filter(|&k| run.support(k) == Support::JustLaid)
                .collect();
            let lowest = just_laid.iter().map(|&k| pl.points[k].layer).min().unwrap();
            assert!(
                lowest + 6 >= revolutions,
                "{model}: a point of revolution {lowest} of {revolutions} lies on metal just laid"
            );
            let from = just_laid_from(pl, |k| run.support(k)).expect("a closing zone");
            assert_eq!(pl.points[from].layer, lowest, "{model}");
            // The closing zone holds every point just laid and the closing point's surroundings.
            let zone = closing_zone(pl, 15.0, |k| run.support(k));
            assert!(just_laid.iter().all(|&k| zone[k]), "{model}");
        }
    }
}
