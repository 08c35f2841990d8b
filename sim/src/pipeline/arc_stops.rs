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

/// The build time of `plan`, dwells, paces and drops included, s.
pub fn build_time_s(b: &Build, plan: &DwellPlan) -> f64 {
    let build = super::deposition::schedule(&b.params.process, &b.plan, &b.beads, &plan.cooling);
    build.last().map_or(0.0, |d| d.time)
}

/// Which plan the planner hands over ([`never_worse`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Kept {
    Search,
    RevolutionDwell,
}

impl Kept {
    pub fn name(self) -> &'static str {
        match self {
            Kept::Search => "search",
            Kept::RevolutionDwell => "revolution_dwell",
        }
    }
}

/// The search's plan, unless the revolution-dwell policy's plan (`revolution`) leaves no point
/// at risk and the search's does, or beats it on both build time and arc stops: a plan is never
/// worse on both counts than one dwell per revolution where that is safe.
pub fn never_worse(b: &Build, search: DwellPlan, revolution: &DwellPlan) -> (DwellPlan, Kept) {
    let safe = |p: &DwellPlan| p.unresolved.is_empty();
    let beaten = arc_stops(revolution) < arc_stops(&search)
        && build_time_s(b, revolution) < build_time_s(b, &search);
    if safe(revolution) && (!safe(&search) || beaten) {
        (revolution.clone(), Kept::RevolutionDwell)
    } else {
        (search, Kept::Search)
    }
}

fn tried(b: &Build, weight_s: f64, plan: &DwellPlan) -> Tried {
    let c = &plan.cooling;
    Tried {
        weight_s,
        arc_stops: arc_stops(plan),
        total_dwell_s: c.total_dwell_s(),
        build_time_s: build_time_s(b, plan),
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
    /// Every plan made on the way, in the order made.
    pub tried: Vec<Tried>,
    /// The fewest stops any plan can make ([`super::bound`]): a budget under it is answered
    /// without a search.
    pub bound: super::bound::StopsBound,
}

/// A plan within `max_stops` arc stops, in at most three dwell plans: none where the budget is
/// under the lower bound on arc stops (the plan at the scenario's own weight is returned, the
/// budget reported as unmet, citing the bound); else the scenario's weight, then the heaviest of
/// [`WEIGHTS_S`] (the fewest stops weighing finds), then, if the heaviest meets the budget and the
/// lightest does not, one weight between them (their geometric mean), the lightest that meets it
/// kept. Each plan is a whole search, so the run costs at most three plain dwell plans and a
/// bound (about two builds).
pub fn within_budget(b: &Build, max_stops: usize) -> Result<Budgeted, ThermalError> {
    let bound = b.arc_stops_lower_bound()?;
    let own = b.params.dwell.count_weight_s;
    let heaviest = WEIGHTS_S[WEIGHTS_S.len() - 1].max(own);
    let mut made: Vec<(f64, DwellPlan)> = vec![(own, b.plan_dwells_weighted(own)?)];
    let meets = |p: &DwellPlan| arc_stops(p) <= max_stops;
    if max_stops >= bound.stops && !meets(&made[0].1) && heaviest > own {
        made.push((heaviest, b.plan_dwells_weighted(heaviest)?));
        if meets(&made[1].1) {
            let middle = (own.max(WEIGHTS_S[1]) * heaviest).sqrt();
            made.push((middle, b.plan_dwells_weighted(middle)?));
        }
    }
    let tried = made.iter().map(|(w, p)| tried(b, *w, p)).collect();
    // The lightest weight that meets the budget, else the fewest stops.
    let (weight_s, plan) = made
        .iter()
        .filter(|(_, p)| meets(p))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .or_else(|| made.iter().min_by_key(|(_, p)| arc_stops(p)))
        .cloned()
        .expect("one plan at least");
    Ok(Budgeted {
        met: meets(&plan),
        plan,
        weight_s,
        tried,
        bound,
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
