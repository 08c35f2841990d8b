//! A lower bound on the arc stops of any cooling plan of a build (no IO): how far a plan is from
//! the best possible.
//!
//! **The argument.** Lay the build from a cold start at deposit `a` (the part and everything
//! laid before `a` at ambient, [`thermal::HeatRun::quench`]) without a break, at one pace, and
//! let `F(a)` be the earliest deadline of a point that then breaks a criterion: a stop must come
//! at or before it. A point's preheat is read during deposit `j` (the torch `lead` upstream of
//! it): a dwell before `j` can still cool its substrate, one after cannot, so its deadline is
//! `j`; a point that can be laid as a drop (in the closing zone) is read again as its drop
//! strikes, so its deadline is the point itself; a pool too long or too heavy is the point's own,
//! its deadline the point.
//!
//! Heat conduction obeys a comparison principle: a part that starts cooler stays cooler under
//! the same heat input (the heat equation is monotone; so are the thin wall's backward-Euler
//! M-matrix steps and the voxel model's explicit steps at the stability limit, and the losses
//! grow with temperature). Any real plan reaches a stop with the part at or above ambient, so
//! whatever breaks from a cold start breaks in the plan too: a plan whose stops are
//! `p_1 < p_2 < …` has `p_{i+1} ≤ F(p_i)`. `F` grows with `a` (a stretch started earlier is
//! hotter where a later one starts cold), so the greedy plan that stops exactly at each deadline,
//! `g_{i+1} = F(g_i)`, has `p_i ≤ g_i` for every i, and no plan ends with fewer stops than it: the
//! count of the greedy's stops is a lower bound. Every deposit is laid about once: a stretch's
//! run keeps a copy of itself every [`COPY_EVERY`] deposits, and the next cold start is the
//! last copy before the deadline laid on to it (a preheat read during deposit j sets the
//! deadline j once j is laid, so the state at the deadline has passed by the time it is known).
//!
//! **What it rests on**, besides the comparison principle: the paces tried (every stretch at
//! the planned pace and, where the power falls with the wire feed, the slowest the window
//! allows, taking the later deadline; a plan that changes pace inside a stretch is not covered),
//! drops no longer than 1.5 bead widths ([`super::pace::Pacing::drops`]) and only in the closing
//! zone, and the criteria judged without the planner's margin. A point that breaks a criterion
//! even right after a cold start at its own deposit (no stop can cure it) sets no deadline.

use super::dwell::Search;
use super::dwell::judged_at;
use super::risk::judge;
use thermal::schedule::{Deposit, arc_lengths};
use thermal::{HeatRun, ThermalError};

/// The fewest arc stops any plan of the build can make, and where the greedy plan of the
/// argument stops.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct StopsBound {
    /// The lower bound on the arc stops (every arc start after the first).
    pub stops: usize,
    /// The deposits before which the greedy plan stops, in order.
    pub at: Vec<usize>,
    /// The paces every stretch was laid at.
    pub paces: Vec<f64>,
    /// Points that break a criterion even laid right after a cold start at their own deposit.
    pub incurable: Vec<usize>,
    /// Deposits laid to find it, in whole builds.
    pub cost_builds: f64,
}

/// The greedy bound of the module doc on `fresh` (a run of any heat model at the start of the
/// build), `zone` the first point where drops may be laid (the closing zone's), `lead` where the
/// model reads preheat.
pub fn arc_stops_lower_bound<R: HeatRun>(
    s: &Search,
    deps: &[Deposit],
    lead: f64,
    zone: Option<usize>,
    fresh: R,
) -> Result<StopsBound, ThermalError> {
    greedy(s, deps, lead, zone, fresh, COPY_EVERY)
}

/// [`arc_stops_lower_bound`], each stretch keeping a copy of its run every `copy_every`
/// deposits (`usize::MAX`: none, every cold start laid again from the one before).
fn greedy<R: HeatRun>(
    s: &Search,
    deps: &[Deposit],
    lead: f64,
    zone: Option<usize>,
    fresh: R,
    copy_every: usize,
) -> Result<StopsBound, ThermalError> {
    let n = deps.len();
    let judged = judged_at(deps, lead);
    let along = arc_lengths(deps);
    let drop_reach = 1.5 * deps.first().map_or(0.0, |d| d.width);
    let mut paces = vec![1.0];
    let slowest = s.pacing.slowest(0..n);
    if slowest > 1.0 && s.pacing.cools(0..n, slowest) {
        paces.push(slowest);
    }
    let stretch = Stretch {
        s,
        judged: &judged,
        along: &along,
        drop_reach,
        zone: zone.unwrap_or(usize::MAX),
        copy_every,
    };
    let mut bound = StopsBound {
        stops: 0,
        at: Vec::new(),
        paces: paces.clone(),
        incurable: Vec::new(),
        cost_builds: 0.0,
    };
    let mut laid = 0usize;
    let (mut a, mut start) = (0, fresh);
    loop {
        // The latest deadline over the paces tried, the pace that reached it and the stretch's
        // last copy before it.
        let mut best: Option<(usize, f64, (usize, R))> = None;
        let mut reaches_end = false;
        for &pace in &paces {
            match stretch.deadline(&start, a, pace, &mut laid, &mut bound.incurable)? {
                None => {
                    reaches_end = true;
                    break;
                }
                Some((f, copy)) if best.as_ref().is_none_or(|b| f > b.0) => {
                    best = Some((f, pace, copy))
                }
                Some(_) => {}
            }
        }
        let Some((f, pace, (from, copy))) = best.filter(|_| !reaches_end) else {
            break;
        };
        // The state of the stretch up to its deadline, cooled to ambient: the next cold start
        // (the deposits from the copy on laid as the stretch laid them, so the same state).
        start = copy;
        for i in from..f {
            start.deposit_burning(i, 0.0, s.pacing.burn(i, pace, None))?;
        }
        laid += f - from;
        start.quench();
        bound.stops += 1;
        bound.at.push(f);
        a = f;
    }
    bound.incurable.sort_unstable();
    bound.incurable.dedup();
    bound.cost_builds = laid as f64 / n.max(1) as f64;
    Ok(bound)
}

/// Deposits between two copies a stretch keeps of its run: a copy costs about what a deposit's
/// step does (the run's state copied against a solve near the arc), and the next cold start lays
/// at most this many deposits again from the last one.
const COPY_EVERY: usize = 16;

/// A stretch's deadline and its last copy before it (the deposit the copy lays next, the run).
type Deadline<R> = (usize, (usize, R));

/// How a stretch from a cold start is laid and judged.
struct Stretch<'a> {
    s: &'a Search<'a>,
    /// Per deposit, the points read during its arc, and itself (its pool).
    judged: &'a [Vec<usize>],
    /// Deposited path length at each deposit, m.
    along: &'a [f64],
    /// How far along the path a drop struck at a stretch's start reaches, m.
    drop_reach: f64,
    /// The first point where drops may be laid.
    zone: usize,
    /// Deposits between two copies the stretch keeps of its run.
    copy_every: usize,
}

impl Stretch<'_> {
    /// The earliest deadline of the points that break a criterion when the build is laid
    /// without a break at `pace` from `cold` (deposit `a` next), with the stretch's last copy
    /// before it (the deposit it would lay next, and the run); `None` if it reaches the end.
    fn deadline<R: HeatRun>(
        &self,
        cold: &R,
        a: usize,
        pace: f64,
        laid: &mut usize,
        incurable: &mut Vec<usize>,
    ) -> Result<Option<Deadline<R>>, ThermalError> {
        let mut run = cold.clone();
        let mut copy: Option<(usize, R)> = None;
        let mut earliest: Option<usize> = None;
        for j in a..self.judged.len() {
            if earliest.is_some_and(|m| j > m) {
                break;
            }
            // The loop stops at the deadline at the latest, so the last copy is before it.
            if j > a && (j - a).is_multiple_of(self.copy_every) {
                copy = Some((j, run.clone()));
            }
            run.deposit_burning(j, 0.0, self.s.pacing.burn(j, pace, None))?;
            *laid += 1;
            for &k in &self.judged[j] {
                if self.drop_covers(a, k) || judge(self.s.criteria, &run.points()[k], 0.0).is_none()
                {
                    continue;
                }
                let due = self.due(j, k);
                if due <= a {
                    // Broken even right after a cold start at its deadline: no stop cures it.
                    incurable.push(k);
                } else {
                    earliest = Some(earliest.map_or(due, |m| m.min(due)));
                }
            }
        }
        // No copy yet, or a deadline before it (none is known to fall behind the deposit that
        // sets it, but the argument does not need that): from the cold start again.
        Ok(earliest.map(|f| match copy {
            Some(c) if c.0 <= f => (f, c),
            _ => (f, (a, cold.clone())),
        }))
    }

    /// The last deposit before which a stop still helps point k, judged at deposit j: j for a
    /// preheat read during j's arc, k itself for its own pool or where k can be a drop.
    fn due(&self, j: usize, k: usize) -> usize {
        if k == j || k >= self.zone { k } else { j }
    }

    /// A drop struck at `a` (in the closing zone) reads k as it strikes, cold.
    fn drop_covers(&self, a: usize, k: usize) -> bool {
        a >= self.zone && self.along[k] - self.along[a] < self.drop_reach
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pipeline::Build;

    /// A closed dome R 25 mm on the thin wall, its interpass limit low enough for many stops.
    fn dome() -> Build {
        crate::pipeline::test_parts::dome(25.0, "[dwell]\ninterpass_max_c = 150.0\n")
    }

    /// The next cold start taken from a copy the stretch kept, laid on to the deadline, is the
    /// state laid again from the stretch's own cold start: the same stops, at the same points,
    /// for fewer deposits laid.
    #[test]
    fn a_cold_start_from_a_copy_is_the_one_laid_again() {
        let b = dome();
        let bound = |every: usize| {
            let model = b.heat_model(&b.deposits, Vec::new());
            let run = model.start(&b.deposits).unwrap();
            let pacing = b.pacing();
            let search = b.search(&pacing);
            greedy(&search, &b.deposits, model.lead(), None, run, every).unwrap()
        };
        let again = bound(usize::MAX);
        assert!(again.stops >= 3, "too few stops to tell: {:?}", again.at);
        for every in [1, 5, COPY_EVERY] {
            let copied = bound(every);
            assert_eq!(
                (copied.stops, &copied.at),
                (again.stops, &again.at),
                "every {every}"
            );
            assert_eq!(copied.incurable, again.incurable);
            assert!(copied.cost_builds < again.cost_builds, "every {every}");
        }
    }
}
