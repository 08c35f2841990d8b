//! The arc-stop budget (no IO): every dwell stops the arc and strikes it again, the defect CTPP
//! exists to remove, so a plan is judged by its arc stops as well as by its build time.
//!
//! The dwell planner weighs an arc stop as `count_weight_s` seconds of dwell: at 0 it spends
//! the least dwell (many short stops inside revolutions); the heavier the weight, the more it
//! prefers one dwell before a revolution to several inside it. A budget is met by trying
//! heavier weights until the plan stops the arc no more often than allowed; the plans on the
//! way are real plans, and those that no other beats on both counts make the Pareto front.
//! The heavier the weight, the more the planner also slows revolutions down instead of stopping
//! the arc ([`super::pace`]); a closing zone laid as drops stops the arc once a drop whatever the
//! weight.

use super::Build;
use super::dwell::DwellPlan;
use thermal::ThermalError;

/// The weights tried, s of dwell per arc stop: from none to more than any dwell the planner
/// would trade.
pub const WEIGHTS_S: [f64; 6] = [0.0, 10.0, 30.0, 100.0, 300.0, 1000.0];

/// One plan of the front.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Tried {
    pub weight_s: f64,
    pub arc_stops: usize,
    pub total_dwell_s: f64,
    /// The build with the plan's dwells, paces and drops, s.
    pub build_time_s: f64,
    /// Points laid slower than planned.
    pub slowed_points: usize,
    pub drops: usize,
    /// The closing strategy ([`super::dwell::Closing::name`]).
    pub closing: String,
}

/// The arc starts after the first: each dwell and each drop.
pub fn arc_stops(plan: &DwellPlan) -> usize {
    plan.cooling.arc_stops()
}

fn tried(b: &Build, weight_s: f64, plan: &DwellPlan) -> Tried {
    let c = &plan.cooling;
    let build = super::deposition::schedule(&b.params.process, &b.plan, &b.beads, c);
    Tried {
        weight_s,
        arc_stops: arc_stops(plan),
        total_dwell_s: c.total_dwell_s(),
        build_time_s: build.last().map_or(0.0, |d| d.time),
        slowed_points: c.slowed(),
        drops: c.drops(),
        closing: plan.closing.name().into(),
    }
}

/// A plan within an arc-stop budget, or the one with the fewest stops found.
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct Budgeted {
    pub plan: DwellPlan,
    pub weight_s: f64,
    /// The plan stops the arc at most the budget's times.
    pub met: bool,
    /// Every plan made on the way, lightest weight first.
    pub tried: Vec<Tried>,
}

/// The lightest weight of [`WEIGHTS_S`] (from the scenario's own up) whose plan stops the arc
/// at most `max_stops` times: the least dwell within the budget that weighing can find.
pub fn within_budget(b: &Build, max_stops: usize) -> Result<Budgeted, ThermalError> {
    let own = b.params.dwell.count_weight_s;
    let weights = std::iter::once(own).chain(WEIGHTS_S.into_iter().filter(|&w| w > own));
    let mut best: Option<(f64, DwellPlan)> = None;
    let mut made = Vec::new();
    for w in weights {
        let plan = b.plan_dwells_weighted(w)?;
        made.push(tried(b, w, &plan));
        let fewer = best
            .as_ref()
            .is_none_or(|(_, p)| arc_stops(&plan) < arc_stops(p));
        let met = arc_stops(&plan) <= max_stops;
        if fewer || met {
            best = Some((w, plan));
        }
        if met {
            break;
        }
    }
    let (weight_s, plan) = best.expect("one weight at least");
    Ok(Budgeted {
        met: arc_stops(&plan) <= max_stops,
        plan,
        weight_s,
        tried: made,
    })
}

/// Plans at every weight of [`WEIGHTS_S`] (those in `known` reused).
pub fn front(b: &Build, known: &[Tried]) -> Result<Vec<Tried>, ThermalError> {
    let mut out = Vec::new();
    for w in WEIGHTS_S {
        match known.iter().find(|t| t.weight_s == w) {
            Some(t) => out.push(t.clone()),
            None => out.push(tried(b, w, &b.plan_dwells_weighted(w)?)),
        }
    }
    Ok(out)
}

/// Whether `t` is on the Pareto front of `all`: no other plan has fewer or as many arc stops
/// and a shorter build, or fewer stops and as short a build.
pub fn on_front(t: &Tried, all: &[Tried]) -> bool {
    !all.iter().any(|o| {
        (o.arc_stops <= t.arc_stops && o.build_time_s < t.build_time_s - 1e-6)
            || (o.arc_stops < t.arc_stops && o.build_time_s <= t.build_time_s + 1e-6)
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn t(stops: usize, build: f64) -> Tried {
        Tried {
            weight_s: 0.0,
            arc_stops: stops,
            total_dwell_s: 0.0,
            build_time_s: build,
            slowed_points: 0,
            drops: 0,
            closing: "not_needed".into(),
        }
    }

    /// The front keeps the plans no other beats on both counts, ties included once beaten.
    #[test]
    fn the_front_is_the_plans_nothing_beats() {
        let all = [
            t(100, 1000.0),
            t(60, 1100.0),
            t(60, 1200.0),
            t(30, 1150.0),
            t(40, 1150.0),
            t(20, 2000.0),
        ];
        let on: Vec<bool> = all.iter().map(|x| on_front(x, &all)).collect();
        // (60, 1200) is beaten by (60, 1100); (40, 1150) by (30, 1150).
        assert_eq!(on, [true, true, false, true, false, true]);
    }
}
