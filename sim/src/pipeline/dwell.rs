//! The cooling planner: where to pause the arc, where to slow it down and how to close a closed
//! part, so that no risk criterion is broken, in the least build time, each arc stop weighed as
//! `count_weight_s` seconds; and the baselines it is judged against.
//!
//! The search walks the build once, revolution by revolution, from checkpoints of the thermal run
//! (a clone of its state). A revolution is simulated as planned, then at the pace of the one
//! before it; if both break a criterion, remedies are sized and the cheapest kept:
//!
//! - slowing down ([`super::pace`]), where the power falls with the wire feed: the revolution and
//!   the stretch before it (whose metal it lies on) laid again at the smallest of a few paces
//!   that keeps both safe, the arc kept on; its cost is the longer arc time;
//! - one dwell before the revolution's first preheat reading (the deposit during whose arc the
//!   torch is `lead_mm` upstream of its first point), so that the whole revolution is laid on
//!   metal that has cooled: the smallest such dwell, from a few simulations of that revolution;
//! - dwells inside the revolution, each just before the deposit whose arc would break a
//!   criterion, as short as keeps it safe.
//!
//! Near a closing point revolutions get shorter than the torch's reach: a point is laid on metal
//! laid while its own preheat was read, and no dwell can come between the two. From the first
//! revolution with such a point, or the first within `closing_zone_mm` of the closing point that
//! dwells leave at risk (the closing zone), the planner tries, in order: going on as before (the
//! zone is safe under every criterion), the heat input ramped down (the zone at the
//! slowest pace the window allows, the least power, where the power falls with the wire feed),
//! and drops (every point laid standing after a wait until the metal beneath it is under the
//! limit, as skeleton arc AM lays its nodes). It says which ([`Closing`]), and which points none
//! keeps safe.

use super::checkpoint::Checkpoints;
use super::deposition::Cooling;
use super::pace::Pacing;
use super::params::DwellSettings;
use super::risk::{Criteria, Risk, judge, judge_for_dwell, preheat_to_cure};
use bead_model::bond::bond_number;
use planner::plan::Plan;
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use thermal::schedule::{Deposit, DropPart, read_points, strike_readings};
use thermal::{CoolingSteps, HeatModel, HeatRun, Support, ThermalError};

/// What a dwell search judges by, aims for and may do.
#[derive(Debug, Clone, Copy)]
pub struct Search<'a> {
    pub criteria: &'a Criteria,
    pub dwell: &'a DwellSettings,
    /// The cooling of the excess above it is close to exponential, K.
    pub ambient_k: f64,
    /// How each point burns at another pace, or as a drop.
    pub pacing: &'a Pacing<'a>,
    /// The remedies a revolution may get.
    pub policy: Policy,
    /// Set by whoever waits on this search when it no longer wants the result (the work beside
    /// it failed): the search ends before its next revolution with [`ThermalError::Stopped`].
    pub stop: Option<&'a std::sync::atomic::AtomicBool>,
}

/// The remedies the planner may give a revolution outside the closing zone.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum Policy {
    /// The cheapest of slowing down, one dwell before it and dwells inside it.
    Search,
    /// One dwell before it, the shortest that keeps the whole revolution safe (one arc stop a
    /// revolution): the yardstick a search's plan must not lose to on both build time and arc
    /// stops.
    RevolutionDwell,
}

impl Search<'_> {
    fn judge(&self, p: &thermal::PointResult, support: Support, margin_k: f64) -> Option<Risk> {
        judge_for_dwell(self.criteria, p, support, margin_k)
    }

    /// The temperature the search aims below, K: the lowest temperature limit in force, less the
    /// margin (none in force: no temperature to aim at).
    fn target_k(&self) -> f64 {
        let c = self.criteria;
        c.interpass_max_k
            .into_iter()
            .chain(c.strength_loss_k)
            .fold(f64::INFINITY, f64::min)
            - self.dwell.margin_k
    }

    /// The preheat a dwell must bring the metal under so that none of `points` breaks the
    /// criterion it breaks now in `run`, each criterion by its own measure
    /// ([`super::risk::preheat_to_cure`]: a temperature limit, or the preheat at which a pool
    /// too long or too heavy shrinks to its limit), K. The lowest of them.
    fn aim_k(&self, run: &impl HeatRun, points: impl IntoIterator<Item = usize>) -> f64 {
        points
            .into_iter()
            .filter_map(|k| {
                let p = &run.points()[k];
                let risk = self.judge(p, run.support(k), self.dwell.margin_k)?;
                preheat_to_cure(self.criteria, p, risk, self.dwell.margin_k)
            })
            .fold(f64::INFINITY, f64::min)
            .min(self.target_k())
    }

    /// Lay deposit i after `dwell` at `pace`.
    fn lay<R: HeatRun>(
        &self,
        run: &mut R,
        i: usize,
        dwell: f64,
        pace: f64,
    ) -> Result<(), ThermalError> {
        run.deposit_burning(i, dwell, self.pacing.burn(i, pace, None))
    }

    /// Lay deposits `from..to` at `pace`, the first after `dwell` seconds.
    fn advance<R: HeatRun>(
        &self,
        run: &mut R,
        from: usize,
        to: usize,
        dwell: f64,
        pace: f64,
    ) -> Result<(), ThermalError> {
        for i in from..to {
            self.lay(run, i, if i == from { dwell } else { 0.0 }, pace)?;
        }
        Ok(())
    }
}

/// Tries of one revolution's dwell search before it gives up at the longest dwell.
const MAX_TRIES: usize = 8;

/// The paces tried to slow a revolution down, besides the slowest the window allows.
const PACES: [f64; 4] = [1.25, 1.5, 2.0, 3.0];

/// The point search copies its run every this many deposits.
const CHECKPOINT_EVERY: usize = 16;

/// A deposit whose judged points lie on metal this far below the limit is laid without a copy
/// (the arc warms the metal ahead of it by less than this over one deposit).
const PREDICT_MARGIN_K: f64 = 50.0;

/// A drop's wait is found to this, s.
const DROP_WAIT_STEP_S: f64 = 0.5;

/// A revolution and where its dwell goes.
#[derive(Debug, Clone, Copy)]
struct Revolution {
    /// Its points.
    first: usize,
    end: usize,
    /// Its dwell goes before this deposit; it is simulated from here to the next one's.
    dwell_at: usize,
    /// The plan's layer number.
    layer: usize,
    /// The points whose preheats are read in its stretch, judged with it: its own, less any
    /// read in the next one's stretch, and the revolution before's last ones read in its own
    /// (a point and the next revolution's first can be read during one deposit's arc, where
    /// the revolutions shrink: the dwell before that deposit cools both). Judged by the points
    /// of the revolution, such a point was judged by no stretch, before its preheat was read
    /// and never after: a small dome's revolution-dwell plan, called safe, read 212.5 °C in a
    /// fresh run at the last point before its closing zone.
    judged_from: usize,
    judged_end: usize,
}

impl Revolution {
    fn judged(&self) -> std::ops::Range<usize> {
        self.judged_from..self.judged_end
    }
}

fn revolutions(pl: &Plan, deps: &[Deposit], lead: f64) -> Vec<Revolution> {
    let layers: Vec<usize> = pl.points.iter().map(|q| q.layer).collect();
    revolutions_read(&layers, &read_points(deps, lead))
}

/// The revolutions of points on `layers`, each point's preheat read during deposit `read[k]`
/// (none: before the path starts).
fn revolutions_read(layers: &[usize], read: &[Option<usize>]) -> Vec<Revolution> {
    let mut revs: Vec<Revolution> = Vec::new();
    for (i, &layer) in layers.iter().enumerate() {
        if i == 0 || layer != layers[i - 1] {
            revs.push(Revolution {
                first: i,
                end: i + 1,
                dwell_at: read[i].unwrap_or(0),
                layer,
                judged_from: i,
                judged_end: i + 1,
            });
        } else {
            revs.last_mut().expect("revolution").end = i + 1;
        }
    }
    // The points read in each stretch: back from a revolution's first point while the point
    // before it is read at or after its dwell (never past the revolution before's first).
    for r in 1..revs.len() {
        let (floor, at) = (revs[r - 1].first + 1, revs[r].dwell_at);
        let mut from = revs[r].first;
        while from > floor && read[from - 1].unwrap_or(0) >= at {
            from -= 1;
        }
        revs[r].judged_from = from;
    }
    for r in 0..revs.len() {
        revs[r].judged_end = revs.get(r + 1).map_or(layers.len(), |n| n.judged_from);
    }
    revs
}

/// How the planner closed a closed part, where revolutions get too short for a dwell to act.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub enum Closing {
    /// No point is laid on metal just laid (an open part), or the closing zone is safe as the
    /// revolutions before it were planned.
    NotNeeded,
    /// From point `from` on, the heat input ramped down: every point at `pace`, the slowest the
    /// process window allows there.
    RampDown { from: usize, pace: f64 },
    /// From point `from` on, every point laid as a drop after a wait until the metal beneath it
    /// is under the limit (capped at the longest dwell).
    Drops {
        from: usize,
        count: usize,
        longest_wait_s: f64,
    },
}

impl Closing {
    pub fn name(&self) -> &'static str {
        match self {
            Closing::NotNeeded => "not_needed",
            Closing::RampDown { .. } => "ramp_down",
            Closing::Drops { .. } => "drops",
        }
    }
}

#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct DwellPlan {
    /// Per deposit: the dwell before it, its pace, whether it is a drop.
    pub cooling: Cooling,
    /// Per deposit, why its dwell or pace was planned.
    pub reason: Vec<Option<Risk>>,
    /// Points no remedy keeps safe.
    pub unresolved: Vec<usize>,
    /// Deposits simulated by the search, in whole builds.
    pub cost_builds: f64,
    pub closing: Closing,
    /// Revolutions (by layer) outside the closing zone that no dwell before them (up to
    /// `max_dwell_s`) keeps safe under the revolution-dwell policy, and the criterion left broken.
    #[serde(default)]
    pub uncured: Vec<(usize, Risk)>,
}

impl DwellPlan {
    pub fn dwell_s(&self) -> &[f64] {
        &self.cooling.dwell_s
    }
}

/// The first risky point among `points`, with the hottest preheat among them.
fn check(
    s: &Search,
    run: &impl HeatRun,
    range: std::ops::Range<usize>,
    margin: f64,
) -> (Option<(usize, Risk)>, f64) {
    let mut first = None;
    let mut hottest = f64::NEG_INFINITY;
    for i in range {
        let p = &run.points()[i];
        let support = run.support(i);
        if support == Support::Deposit {
            hottest = hottest.max(p.preheat);
        }
        if first.is_none()
            && let Some(r) = s.judge(p, support, margin)
        {
            first = Some((i, r));
        }
    }
    (first, hottest)
}

/// `base` cooled for `d` seconds with the steps one `cool(d)` takes (1, 2, 4 … s up to the
/// longest step, then what is left; or equal steps), carried on from the longest state in
/// `cache` on that sequence: a search trying longer and longer dwells cools on instead of
/// starting over, and the dwell it settles on gives the state a fresh run with that dwell gives
/// (the same bits on the thin wall; the voxel model's last partial step may round differently).
fn cooled<R: HeatRun>(base: &R, cache: &mut Vec<(f64, R)>, d: f64) -> Result<R, ThermalError> {
    let boundary = last_whole_step(base.cooling_steps(), d);
    let (from, mut run) = cache
        .iter()
        .filter(|c| c.0 <= boundary)
        .max_by(|a, b| a.0.total_cmp(&b.0))
        .map_or_else(|| (0.0, base.clone()), |c| (c.0, c.1.clone()));
    if boundary > from {
        run.cool(boundary - from)?;
        cache.push((boundary, run.clone()));
    }
    run.cool(d - boundary)?;
    Ok(run)
}

/// Where the last whole step of a cooling of `d` seconds in `steps` ends, s: a cooling of any
/// longer dwell passes through the same state there.
fn last_whole_step(steps: CoolingSteps, d: f64) -> f64 {
    match steps {
        CoolingSteps::Doubling { max } => {
            let (mut boundary, mut dt) = (0.0, 1.0f64);
            while boundary + dt <= d + 1e-9 {
                boundary += dt;
                dt = (dt * 2.0).min(max);
            }
            boundary
        }
        CoolingSteps::Fixed { step } => ((d + 1e-9) / step).floor() * step,
    }
}

/// Drop from `cache` the cooled states no later try of a dwell search can start from, after a
/// try of dwell `d` that passed (later tries are shorter) or failed (later tries are longer:
/// of the states at or below `d`, only the longest is kept).
fn keep_between<R>(cache: &mut Vec<(f64, R)>, d: f64, passed: bool) {
    if passed {
        cache.retain(|c| c.0 <= d);
    } else {
        let floor = cache
            .iter()
            .map(|c| c.0)
            .filter(|&k| k <= d)
            .fold(0.0, f64::max);
        cache.retain(|c| c.0 >= floor);
    }
}

/// Per deposit, the points whose preheat is read during its arc, and itself (its pool).
pub(super) fn judged_at(deps: &[Deposit], lead: f64) -> Vec<Vec<usize>> {
    let mut at: Vec<Vec<usize>> = (0..deps.len()).map(|i| vec![i]).collect();
    for (k, j) in read_points(deps, lead).into_iter().enumerate() {
        if let Some(j) = j
            && j != k
        {
            at[j].push(k);
        }
    }
    at
}

/// A dwell before a deposit: the deposit, the dwell (s) and why.
type PointDwell = (usize, f64, Risk);

/// The run after point dwells, the dwells, and the points no dwell keeps safe.
type PointDwells<R> = (R, Vec<PointDwell>, Vec<usize>);

/// The run after a trial, the revolution's first risky point and its hottest preheat.
type Trial<R> = (R, Option<(usize, Risk)>, f64);

/// Point dwells over the deposits of `range` laid at `pace` from `start`: each deposit is tried
/// without a dwell, and given the shortest one that keeps the points judged at it safe when it is
/// not. `last`: the last point dwell found (0 for none), where the next search starts.
fn point_dwells<R: HeatRun>(
    s: &Search,
    judged: &[Vec<usize>],
    start: &R,
    (range, pace): (std::ops::Range<usize>, f64),
    last: &mut f64,
    simulated: &mut f64,
) -> Result<PointDwells<R>, ThermalError> {
    let mut x = start.clone();
    let mut dwells = Vec::new();
    let mut unresolved = Vec::new();
    let risk_at = |r: &R, i: usize| -> (Option<Risk>, f64) {
        let mut hottest = f64::NEG_INFINITY;
        let mut first = None;
        for &k in &judged[i] {
            let p = &r.points()[k];
            if r.support(k) == Support::Deposit {
                hottest = hottest.max(p.preheat);
            }
            if first.is_none() {
                first = s.judge(p, r.support(k), s.dwell.margin_k);
            }
        }
        (first, hottest)
    };
    // Most deposits are safe and need no copy of the run: one laid on metal well below the
    // limit is laid in place; the run is copied every CHECKPOINT_EVERY deposits, and a
    // misprediction replays from the last copy.
    let target = s.target_k();
    let (mut cp, mut cp_at) = (start.clone(), range.start);
    let replay = |cp: &R, from: usize, to: usize, dwells: &[PointDwell]| {
        let mut y = cp.clone();
        for j in from..to {
            let d = dwells.iter().find(|p| p.0 == j).map_or(0.0, |p| p.1);
            s.lay(&mut y, j, d, pace)?;
        }
        Ok::<R, ThermalError>(y)
    };
    let end = range.end;
    for i in range {
        if i - cp_at >= CHECKPOINT_EVERY {
            cp = x.clone();
            cp_at = i;
        }
        let cool = judged[i].iter().all(|&k| {
            x.support(k) != Support::Deposit || x.temperature_beneath(k) < target - PREDICT_MARGIN_K
        });
        if cool {
            s.lay(&mut x, i, 0.0, pace)?;
            *simulated += 1.0;
            if risk_at(&x, i).0.is_none() {
                continue;
            }
            x = replay(&cp, cp_at, i, &dwells)?;
            *simulated += (i - cp_at) as f64;
        }
        let mut trial = x.clone();
        s.lay(&mut trial, i, 0.0, pace)?;
        *simulated += 1.0;
        let Some(why) = risk_at(&trial, i).0 else {
            x = trial;
            continue;
        };
        let mut cache = Vec::new();
        let aim = s.aim_k(&trial, judged[i].iter().copied());
        // A point's dwell is near its neighbour's, most often: they lie on metal laid alike.
        let pass = shortest_dwell(s, Guess::after(*last, 5.0), aim, |d| {
            let mut t = cooled(&x, &mut cache, d)?;
            s.lay(&mut t, i, 0.0, pace)?;
            *simulated += 1.0;
            let (r, hot) = risk_at(&t, i);
            Ok((t, r.is_none(), hot))
        })?;
        match pass {
            Some((d, t)) => {
                let (d, t) = match s.dwell.count_weight_s > 0.0 {
                    true => longer_dwell(
                        s,
                        judged,
                        (&x, &mut cache),
                        (i, end),
                        pace,
                        (d, t),
                        simulated,
                    )?,
                    false => (d, t),
                };
                dwells.push((i, d, why));
                *last = d;
                x = t;
            }
            None => {
                let mut t = cooled(&x, &mut cache, s.dwell.max_dwell_s)?;
                s.lay(&mut t, i, 0.0, pace)?;
                dwells.push((i, s.dwell.max_dwell_s, why));
                unresolved.extend(
                    judged[i]
                        .iter()
                        .copied()
                        .filter(|&k| s.judge(&t.points()[k], t.support(k), 0.0).is_some()),
                );
                x = t;
            }
        }
    }
    Ok((x, dwells, unresolved))
}

/// Where an arc stop is weighed (`count_weight_s` > 0), a dwell before deposit i longer than
/// the shortest safe one (`shortest`: the dwell and the run after laying i) may pay: it
/// postpones the next stop. The shortest is doubled, up to three times, each laid on without a
/// break until the next deposit that would need a dwell (or the stretch's end, `end`), and the
/// dwell of least cost per deposit it carries the build, (dwell + weight) / deposits, is kept;
/// the doubling stops at the first that does not pay (cooling slows as the metal nears ambient).
fn longer_dwell<R: HeatRun>(
    s: &Search,
    judged: &[Vec<usize>],
    (x, cache): (&R, &mut Vec<(f64, R)>),
    (i, end): (usize, usize),
    pace: f64,
    shortest: (f64, R),
    simulated: &mut f64,
) -> Result<(f64, R), ThermalError> {
    let w = s.dwell.count_weight_s;
    // The first deposit after i laid on from `t` that would need a dwell, else `end`.
    let reach = |t: &R, simulated: &mut f64| -> Result<usize, ThermalError> {
        let mut y = t.clone();
        for (j, at_j) in judged.iter().enumerate().take(end).skip(i + 1) {
            s.lay(&mut y, j, 0.0, pace)?;
            *simulated += 1.0;
            let risky = at_j.iter().any(|&k| {
                s.judge(&y.points()[k], y.support(k), s.dwell.margin_k)
                    .is_some()
            });
            if risky {
                return Ok(j);
            }
        }
        Ok(end)
    };
    let rate = |d: f64, r: usize| (d + w) / (r - i) as f64;
    let r0 = reach(&shortest.1, simulated)?;
    let first_rate = rate(shortest.0, r0);
    let (mut best, mut best_rate, mut best_reach) = (shortest, first_rate, r0);
    for _ in 0..3 {
        let d = (2.0 * best.0).min(s.dwell.max_dwell_s);
        if best_reach >= end || d <= best.0 {
            break;
        }
        let mut t = cooled(x, cache, d)?;
        s.lay(&mut t, i, 0.0, pace)?;
        *simulated += 1.0;
        let r = reach(&t, simulated)?;
        if rate(d, r) >= best_rate {
            break;
        }
        (best, best_rate, best_reach) = ((d, t), rate(d, r), r);
    }
    Ok(best)
}

/// One way to make a revolution safe, and what it costs.
struct Remedy<R> {
    run: R,
    /// The run before the stretch (the stretch before it as this remedy lays it).
    before: R,
    /// The pace its stretch is laid at.
    pace: f64,
    dwells: Vec<PointDwell>,
    unresolved: Vec<usize>,
    /// Build time it adds, with each arc stop weighed, s.
    cost_s: f64,
}

/// Plan the cooling of the build `deps` (its schedule as planned) on `run`, a fresh run of any
/// heat model on it; `lead` is where the model reads preheat.
pub fn plan_dwells<R: HeatRun + Serialize + DeserializeOwned>(
    s: &Search,
    pl: &Plan,
    deps: &[Deposit],
    lead: f64,
    run: R,
) -> Result<DwellPlan, ThermalError> {
    plan_dwells_kept(s, pl, deps, lead, run, &mut Checkpoints::off(), "")
}

/// [`plan_dwells`], keeping the search's state under `stage` between two revolutions (when
/// `ck` says the interval has passed) and going on from the state kept there. The closing
/// strategy, planned last, is not kept part-way.
pub fn plan_dwells_kept<R: HeatRun + Serialize + DeserializeOwned>(
    s: &Search,
    pl: &Plan,
    deps: &[Deposit],
    lead: f64,
    run: R,
    ck: &mut Checkpoints<'_>,
    stage: &str,
) -> Result<DwellPlan, ThermalError> {
    let n = deps.len();
    let revs = revolutions(pl, deps, lead);
    // The closing zone: from the revolutions at the top that each lie in part on metal just
    // laid (`risk::just_laid_from`).
    let zone = super::risk::just_laid_from(pl, |k| run.support(k))
        .and_then(|first| revs.iter().position(|rev| rev.first == first));
    let judged = judged_at(deps, lead);
    let mut p = Planner {
        s,
        deps,
        judged: &judged,
        revs,
        n,
        plan: DwellPlan {
            cooling: Cooling::none(n),
            reason: vec![None; n],
            unresolved: vec![],
            cost_builds: 0.0,
            closing: Closing::NotNeeded,
            uncured: vec![],
        },
        run,
        cursor: 0,
        pace: 1.0,
        before: None,
        last_dwell: 0.0,
        last_point_dwell: 0.0,
        simulated: 0,
    };
    // The closing zone starts earlier where a revolution near the closing point (within
    // `closing_zone_mm`) is left with points no dwell keeps safe: the revolution is planned again
    // from a copy of the search taken before it.
    let near = super::risk::closing_zone(pl, s.dwell.closing_zone_mm, |k| p.run.support(k));
    let mut zone = zone;
    let until = zone.unwrap_or(p.revs.len());
    let mut from = 0;
    if let Some(k) = ck.load::<KeptOwned<R>>(stage) {
        from = k.next;
        zone = k.zone;
        p.resume(k);
    }
    for r in from..until {
        if r > from {
            ck.save_if_due(stage, || p.kept(r, zone));
        }
        if s.stop
            .is_some_and(|f| f.load(std::sync::atomic::Ordering::Relaxed))
        {
            return Err(ThermalError::Stopped {
                time_s: p.run.now(),
            });
        }
        let rev = p.revs[r];
        let copy = near[rev.first..rev.end]
            .iter()
            .any(|&z| z)
            .then(|| p.clone());
        let left = p.plan.unresolved.len();
        p.revolution(r)?;
        if let Some(copy) = copy
            && p.plan.unresolved.len() > left
        {
            p.restore(copy);
            zone = Some(r);
            break;
        }
    }
    if let Some(r) = zone {
        p.closing(r)?;
    }
    p.plan.cost_builds = p.simulated as f64 / n.max(1) as f64;
    Ok(p.plan)
}

/// The search's state between two revolutions as a checkpoint keeps it: [`Planner`] without
/// what it borrows or derives from the build. Written from borrows ([`KeptRef`]), read back
/// owned ([`KeptOwned`]): one layout, so the two cannot drift apart.
#[derive(Serialize, Deserialize)]
struct Kept<P, R, B> {
    next: usize,
    zone: Option<usize>,
    plan: P,
    run: R,
    cursor: usize,
    pace: f64,
    before: B,
    last_dwell: f64,
    last_point_dwell: f64,
    simulated: usize,
}

type Before<R> = Option<(R, std::ops::Range<usize>)>;
type KeptRef<'a, R> = Kept<&'a DwellPlan, &'a R, &'a Before<R>>;
type KeptOwned<R> = Kept<DwellPlan, R, Before<R>>;

/// The search's state as it walks the build.
#[derive(Clone)]
struct Planner<'a, R> {
    s: &'a Search<'a>,
    deps: &'a [Deposit],
    judged: &'a [Vec<usize>],
    revs: Vec<Revolution>,
    n: usize,
    plan: DwellPlan,
    /// The run, laid up to `cursor`.
    run: R,
    cursor: usize,
    /// The pace the path is laid at now.
    pace: f64,
    /// The run before the last stretch was laid, and that stretch: slowing a revolution down
    /// lays it again.
    before: Before<R>,
    /// The last dwell found before a revolution, and inside one: where the next searches start.
    last_dwell: f64,
    last_point_dwell: f64,
    simulated: usize,
}

impl<R: HeatRun> Planner<'_, R> {
    /// The state to keep before revolution `next`.
    fn kept(&self, next: usize, zone: Option<usize>) -> KeptRef<'_, R> {
        Kept {
            next,
            zone,
            plan: &self.plan,
            run: &self.run,
            cursor: self.cursor,
            pace: self.pace,
            before: &self.before,
            last_dwell: self.last_dwell,
            last_point_dwell: self.last_point_dwell,
            simulated: self.simulated,
        }
    }

    /// Go on from a kept state.
    fn resume(&mut self, k: KeptOwned<R>) {
        self.plan = k.plan;
        self.run = k.run;
        self.cursor = k.cursor;
        self.pace = k.pace;
        self.before = k.before;
        self.last_dwell = k.last_dwell;
        self.last_point_dwell = k.last_point_dwell;
        self.simulated = k.simulated;
    }

    /// Go back to `copy`, keeping the count of what was simulated since.
    fn restore(&mut self, copy: Self) {
        let simulated = self.simulated;
        *self = copy;
        self.simulated = simulated;
    }

    /// Where revolution r's stretch ends: the next one's dwell point.
    fn segment_end(&self, r: usize) -> usize {
        let rev = self.revs[r];
        self.revs
            .get(r + 1)
            .map_or(self.n, |x| x.dwell_at)
            .max(rev.dwell_at)
    }

    /// Lay up to `to` at the pace of now.
    fn catch_up(&mut self, to: usize) -> Result<(), ThermalError> {
        if self.cursor < to {
            let from = self.cursor;
            self.s.advance(&mut self.run, from, to, 0.0, self.pace)?;
            self.plan.cooling.pace[from..to].fill(self.pace);
            self.simulated += to - from;
            self.cursor = to;
        }
        Ok(())
    }

    /// Plan revolution r: laid as planned, or at the pace of the revolution before it, if either
    /// keeps it safe; else the cheapest remedy that does.
    fn revolution(&mut self, r: usize) -> Result<(), ThermalError> {
        if self.s.policy == Policy::RevolutionDwell {
            return self.revolution_dwell(r);
        }
        let (s, rev) = (self.s, self.revs[r]);
        let seg_end = self.segment_end(r);
        self.catch_up(rev.dwell_at)?;
        let stretch = rev.dwell_at..seg_end;
        let segment = |pace: f64| Segment {
            s,
            judged: self.judged,
            rev,
            seg_end,
            pace,
        };
        // The paces that failed.
        let mut failed: Vec<f64> = Vec::new();
        let mut unrested = None;
        let mut tried = vec![1.0];
        if self.pace != 1.0 {
            tried.push(self.pace);
        }
        for k in tried {
            let trial = segment(k).trial(self.run.clone(), &mut self.simulated)?;
            if trial.1.is_none() {
                let start = self.run.clone();
                return self.keep(stretch, k, trial.0, None, start);
            }
            failed.push(k);
            // The trial at the planned pace: the dwell remedy starts from it.
            unrested = unrested.or(Some(trial));
        }
        let unrested = unrested.expect("a risky trial at the planned pace");
        let why = unrested.1.expect("a risky trial").1;
        let slowest = s.pacing.slowest(stretch.clone());
        // The dwell remedy first: its cost bounds what slowing down may cost.
        let dwelled = self.dwells(segment(1.0), &unrested, why)?;
        let mut remedies = Vec::new();
        // Slowing down: the smallest of a few paces up to the slowest that keeps the revolution
        // safe with the arc on. Safety is not monotone in the pace (slow enough, the arc heats
        // the metal ahead of it), so the paces are tried in turn, not bisected. Only where the
        // power falls with the wire feed: at a fixed power slowing down puts more heat into a
        // revolution at the same rate, and measured it never made one safe (docs/PHYSICS.md).
        // A pace whose build time, known before it is laid, exceeds the dwell remedy's that
        // leaves no point at risk is not laid: it could not be the cheapest (nor could a slower
        // one, which costs more), and laying it again lays the stretch before with its dwells,
        // whose cooling is most of a large part's search.
        for k in PACES
            .iter()
            .copied()
            .filter(|&k| k < slowest)
            .chain([slowest])
        {
            if k <= 1.0 || failed.contains(&k) || !s.pacing.cools(stretch.clone(), k) {
                continue;
            }
            if dwelled.unresolved.is_empty() && self.slowing_cost_s(segment(k)) > dwelled.cost_s {
                break;
            }
            match self.slowed(segment(k))? {
                Some((x, cost_s, before)) => {
                    remedies.push(Remedy {
                        run: x,
                        before,
                        pace: k,
                        dwells: vec![],
                        unresolved: vec![],
                        cost_s,
                    });
                    break;
                }
                None => failed.push(k),
            }
        }
        remedies.push(dwelled);
        // The cheapest that keeps every point safe, else the one that leaves fewest at risk.
        let best = remedies
            .into_iter()
            .min_by(|a, b| {
                (a.unresolved.len(), a.cost_s)
                    .partial_cmp(&(b.unresolved.len(), b.cost_s))
                    .expect("finite costs")
            })
            .expect("a remedy");
        for &(i, d, why) in &best.dwells {
            self.plan.cooling.dwell_s[i] = d;
            self.plan.reason[i] = Some(why);
        }
        if let [(i, d, _)] = best.dwells[..]
            && i == rev.dwell_at
        {
            self.last_dwell = d;
        }
        self.plan.unresolved.extend(best.unresolved);
        if best.pace != 1.0
            && let Some((_, before)) = &self.before
        {
            // Slowing down slowed the stretch before this one too.
            for i in before.clone() {
                self.plan.cooling.pace[i] = self.plan.cooling.pace[i].max(best.pace);
            }
        }
        self.keep(stretch, best.pace, best.run, Some(why), best.before)
    }

    /// Plan revolution r with one dwell before it at most: none if it is safe as planned, else
    /// the shortest that keeps every point of it safe, else the longest, its revolution and the
    /// criterion still broken recorded (`uncured`).
    fn revolution_dwell(&mut self, r: usize) -> Result<(), ThermalError> {
        let (s, rev) = (self.s, self.revs[r]);
        let seg_end = self.segment_end(r);
        self.catch_up(rev.dwell_at)?;
        let stretch = rev.dwell_at..seg_end;
        let segment = Segment {
            s,
            judged: self.judged,
            rev,
            seg_end,
            pace: 1.0,
        };
        let start = self.run.clone();
        let unrested = segment.trial(start.clone(), &mut self.simulated)?;
        let Some((_, why)) = unrested.1 else {
            return self.keep(stretch, 1.0, unrested.0, None, start);
        };
        let (d, x) = self.rested(&segment, &start, &unrested)?;
        self.plan.cooling.dwell_s[rev.dwell_at] = d;
        self.plan.reason[rev.dwell_at] = Some(why);
        self.last_dwell = d;
        self.keep(stretch, 1.0, x, Some(why), start)?;
        let (left, _) = check(s, &self.run, rev.judged(), 0.0);
        if let Some((_, risk)) = left {
            self.plan.uncured.push((rev.layer, risk));
            self.plan.unresolved.extend(rev.judged().filter(|&k| {
                s.judge(&self.run.points()[k], self.run.support(k), 0.0)
                    .is_some()
            }));
        }
        Ok(())
    }

    /// Revolution r laid at `segment`'s pace, and the stretch before it too (from a copy of the
    /// run taken before that stretch, with its dwells): the metal a revolution lies on was laid
    /// in the stretch before, so slowing both lengthens the time between laying a point's
    /// substrate and reading its preheat, while the power falls with the wire feed. The run and
    /// the build time it adds, or `None` if a point of either revolution is at risk.
    fn slowed(&mut self, segment: Segment) -> Result<Option<(R, f64, R)>, ThermalError> {
        let (s, k) = (self.s, segment.pace);
        let cost_s = self.slowing_cost_s(segment);
        let start = match &self.before {
            Some((run, before)) => {
                let mut x = run.clone();
                for i in before.clone() {
                    let pace = self.plan.cooling.pace[i].max(k);
                    s.lay(&mut x, i, self.plan.cooling.dwell_s[i], pace)?;
                }
                self.simulated += before.len();
                x
            }
            None => self.run.clone(),
        };
        let (x, risk, _) = segment.trial(start.clone(), &mut self.simulated)?;
        let before_safe = self.revs[..]
            .iter()
            .rev()
            .find(|rv| rv.judged_end <= segment.rev.judged_from)
            .is_none_or(|rv| check(s, &x, rv.judged(), s.dwell.margin_k).0.is_none());
        Ok((risk.is_none() && before_safe).then_some((x, cost_s, start)))
    }

    /// The build time [`Planner::slowed`] adds at `segment`'s pace: its stretch and the stretch
    /// before it laid slower, s (known before either is laid).
    fn slowing_cost_s(&self, segment: Segment) -> f64 {
        let (s, k) = (self.s, segment.pace);
        let stretch = segment.rev.dwell_at..segment.seg_end;
        let mut cost_s = s.pacing.extra_time_s(stretch, 1.0, k);
        if let Some((_, before)) = &self.before {
            for i in before.clone() {
                let planned = self.plan.cooling.pace[i];
                cost_s += s.pacing.extra_time_s(i..i + 1, planned, planned.max(k));
            }
        }
        cost_s
    }

    /// Keep `run`, the stretch laid at `pace` (up to its first risky point, or whole) from
    /// `before`, and lay what is left of it.
    fn keep(
        &mut self,
        stretch: std::ops::Range<usize>,
        pace: f64,
        run: R,
        why: Option<Risk>,
        before: R,
    ) -> Result<(), ThermalError> {
        self.before = Some((before, stretch.clone()));
        if pace != 1.0 {
            self.plan.reason[stretch.start] = self.plan.reason[stretch.start].or(why);
        }
        self.pace = pace;
        self.plan.cooling.pace[stretch.clone()].fill(pace);
        self.run = run;
        // A trial that stopped at its first risky point leaves the stretch unfinished.
        if self.run.laid() < stretch.end {
            let from = self.run.laid();
            self.s
                .advance(&mut self.run, from, stretch.end, 0.0, self.pace)?;
            self.simulated += stretch.end - from;
        }
        self.cursor = stretch.end;
        Ok(())
    }

    /// The dwell remedy of a revolution's stretch at its segment's pace: dwells inside it just
    /// where they are needed (the least dwell), or one dwell before it (one arc stop), sized only
    /// when stops carry a weight or the point dwells cannot make it safe.
    fn dwells(
        &mut self,
        segment: Segment,
        unrested: &Trial<R>,
        why: Risk,
    ) -> Result<Remedy<R>, ThermalError> {
        let s = self.s;
        let w = s.dwell.count_weight_s;
        let (rev, seg_end) = (segment.rev, segment.seg_end);
        let mut point_sim = 0.0;
        let (xp, point, point_unresolved) = point_dwells(
            s,
            self.judged,
            &self.run,
            (rev.dwell_at..seg_end, segment.pace),
            &mut self.last_point_dwell,
            &mut point_sim,
        )?;
        self.simulated += point_sim as usize;
        let point_cost = point.iter().map(|p| p.1).sum::<f64>() + w * point.len() as f64;
        let whole = if w > 0.0 || !point_unresolved.is_empty() {
            let guess = self.last_dwell;
            segment.smallest_dwell(
                &self.run,
                unrested,
                guess,
                &mut Vec::new(),
                &mut self.simulated,
            )?
        } else {
            None
        };
        Ok(match whole {
            Some((d, x)) if d + w < point_cost || !point_unresolved.is_empty() => Remedy {
                run: x,
                before: self.run.clone(),
                pace: segment.pace,
                dwells: vec![(rev.dwell_at, d, why)],
                unresolved: vec![],
                cost_s: d + w,
            },
            _ => Remedy {
                run: xp,
                before: self.run.clone(),
                pace: segment.pace,
                dwells: point,
                unresolved: point_unresolved,
                cost_s: point_cost,
            },
        })
    }

    /// The points from `first` on that break a criterion, judged in full (none exempt).
    fn at_risk(&self, first: usize) -> Vec<usize> {
        (first..self.n)
            .filter(|&i| judge(self.s.criteria, &self.run.points()[i], 0.0).is_some())
            .collect()
    }

    /// Plan the closing zone, from revolution `zone` on: as before if that keeps it safe, else the
    /// heat input ramped down, else drops.
    fn closing(&mut self, zone: usize) -> Result<(), ThermalError> {
        let (first, judged) = (self.revs[zone].first, self.revs[zone].judged_from);
        let start = self.clone();
        for r in zone..self.revs.len() {
            self.revolution(r)?;
        }
        if self.at_risk(judged).is_empty() {
            self.plan.closing = Closing::NotNeeded;
            return Ok(());
        }
        // The heat input ramped down: the zone at the slowest pace the window allows there,
        // where that lowers the power (not at a fixed power).
        let pace = self.s.pacing.slowest(first..self.n).max(self.pace);
        if self.s.pacing.cools(first..self.n, pace) {
            self.restore(start.clone());
            self.lead_in(zone)?;
            self.pace = pace;
            self.catch_up(self.n)?;
            if self.at_risk(judged).is_empty() {
                self.plan.closing = Closing::RampDown { from: first, pace };
                return Ok(());
            }
        }
        // Drops: each after a wait until the ring beneath it is under the limit.
        self.restore(start);
        self.lead_in(zone)?;
        let s = self.s;
        let mut longest = 0.0f64;
        let drops = s.pacing.drops(first);
        for drop in &drops {
            let (wait, run) = self.drop_wait(drop.clone())?;
            self.run = run;
            let parts = drop.clone().map(|i| match i == drop.start {
                true => DropPart::Strikes {
                    deposits: drop.len(),
                },
                false => DropPart::Continues,
            });
            for (i, part) in drop.clone().zip(parts) {
                self.run
                    .deposit_burning(i, 0.0, s.pacing.burn(i, 1.0, Some(part)))?;
                self.plan.cooling.drop[i] = Some(part);
                self.plan.cooling.pace[i] = 1.0;
            }
            self.simulated += drop.len();
            self.plan.cooling.dwell_s[drop.start] = wait;
            self.plan.reason[drop.start] = (wait > 0.0).then_some(Risk::Interpass);
            longest = longest.max(wait);
            // The drop's Bond number, from the cap its metal makes (Radel et al. 2019, Eq.1).
            if let Some(b) = s.criteria.bond {
                let r = s.pacing.drop_cap(drop.clone()).radius;
                if bond_number(b.density_kg_m3, r, b.surface_tension_n_m) > b.max {
                    self.plan.unresolved.extend(drop.clone());
                }
            }
        }
        self.cursor = self.n;
        let risky = self.at_risk(judged);
        self.plan.unresolved.extend(risky);
        self.plan.unresolved.sort_unstable();
        self.plan.unresolved.dedup();
        self.plan.closing = Closing::Drops {
            from: first,
            count: drops.len(),
            longest_wait_s: longest,
        };
        Ok(())
    }

    /// `segment` laid from `start` after the shortest dwell that keeps it safe, or after the
    /// longest dwell where none does: the dwell and the run. `unrested`: its trial with none.
    fn rested(
        &mut self,
        segment: &Segment,
        start: &R,
        unrested: &Trial<R>,
    ) -> Result<(f64, R), ThermalError> {
        let (guess, mut cache) = (self.last_dwell, Vec::new());
        let smallest =
            segment.smallest_dwell(start, unrested, guess, &mut cache, &mut self.simulated)?;
        match smallest {
            Some(pass) => Ok(pass),
            None => {
                let max = self.s.dwell.max_dwell_s;
                let cool = cooled(start, &mut cache, max)?;
                Ok((max, segment.trial(cool, &mut self.simulated)?.0))
            }
        }
    }

    /// Lay from the closing zone's dwell point to its first point, the points of the revolution
    /// before read there (its [`Revolution::judged`] ones before `first`) kept safe by the
    /// shortest dwell at the dwell point that does so, as a revolution's dwell keeps its points;
    /// laid as they were planned, they went unjudged.
    fn lead_in(&mut self, zone: usize) -> Result<(), ThermalError> {
        let rev = self.revs[zone];
        if self.cursor != rev.dwell_at || rev.judged_from >= rev.first {
            return self.catch_up(rev.first);
        }
        let segment = Segment {
            s: self.s,
            judged: self.judged,
            rev: Revolution {
                end: rev.first,
                judged_end: rev.first,
                ..rev
            },
            seg_end: rev.first,
            pace: self.pace,
        };
        let start = self.run.clone();
        let unrested = segment.trial(start.clone(), &mut self.simulated)?;
        let (dwell, run, why) = match unrested.1 {
            None => (0.0, unrested.0, None),
            Some((_, why)) => {
                let (d, x) = self.rested(&segment, &start, &unrested)?;
                (d, x, Some(why))
            }
        };
        // A trial stops at its first risky point: lay what it left.
        let mut run = run;
        for i in run.laid().max(rev.dwell_at)..rev.first {
            self.s.lay(&mut run, i, 0.0, self.pace)?;
            self.simulated += 1;
        }
        self.run = run;
        self.plan.cooling.dwell_s[rev.dwell_at] = dwell;
        self.plan.reason[rev.dwell_at] = why;
        self.plan.cooling.pace[rev.dwell_at..rev.first].fill(self.pace);
        self.cursor = rev.first;
        Ok(())
    }

    /// The shortest wait (to [`DROP_WAIT_STEP_S`], at most the longest dwell) after which the ring
    /// beneath `drop` (the metal its points lie on, laid before it) is under the target, and
    /// the run after it: cooled as one `cool(wait)` cools, so that a fresh run of the plan reads
    /// what the search read.
    fn drop_wait(&self, drop: std::ops::Range<usize>) -> Result<(f64, R), ThermalError> {
        let (s, target) = (self.s, self.s.target_k());
        // What the drop would read if it struck now: its hottest.
        let ring = |run: &R| {
            strike_readings(self.deps, drop.start, drop.len(), |k| {
                run.temperature_beneath(k)
            })
            .into_iter()
            .map(|r| r.1)
            .fold(f64::NEG_INFINITY, f64::max)
        };
        if ring(&self.run) <= target {
            return Ok((0.0, self.run.clone()));
        }
        let max = s.dwell.max_dwell_s;
        let mut cache = Vec::new();
        let (mut fail, mut pass) = (0.0, None);
        let mut d = DROP_WAIT_STEP_S;
        while pass.is_none() {
            let x = cooled(&self.run, &mut cache, d)?;
            if ring(&x) <= target {
                pass = Some((d, x));
            } else if d >= max {
                return Ok((max, x));
            } else {
                fail = d;
                d = (2.0 * d).min(max);
            }
        }
        let (mut hi, mut best) = pass.expect("a pass");
        while hi - fail > DROP_WAIT_STEP_S {
            let mid = (0.5 * (fail + hi) / DROP_WAIT_STEP_S).round() * DROP_WAIT_STEP_S;
            if mid <= fail || mid >= hi {
                break;
            }
            let x = cooled(&self.run, &mut cache, mid)?;
            if ring(&x) <= target {
                (hi, best) = (mid, x);
            } else {
                fail = mid;
            }
        }
        Ok((hi, best))
    }
}

/// One revolution's stretch of deposits, from its dwell point to the next one's, laid at a pace.
#[derive(Clone, Copy)]
struct Segment<'a> {
    s: &'a Search<'a>,
    judged: &'a [Vec<usize>],
    rev: Revolution,
    seg_end: usize,
    pace: f64,
}

impl Segment<'_> {
    /// Lay the stretch on `x`, the run at its dwell point with any dwell before it already cooled
    /// (laying a deposit after a dwell cools, then lays it), stopping at the first risky point of
    /// the revolution: failing trials are cheap.
    fn trial<R: HeatRun>(&self, mut x: R, simulated: &mut usize) -> Result<Trial<R>, ThermalError> {
        let (s, rev) = (self.s, self.rev);
        for i in rev.dwell_at..self.seg_end {
            s.lay(&mut x, i, 0.0, self.pace)?;
            *simulated += 1;
            let risky = self.judged[i].iter().any(|&k| {
                rev.judged().contains(&k)
                    && s.judge(&x.points()[k], x.support(k), s.dwell.margin_k)
                        .is_some()
            });
            if risky {
                break;
            }
        }
        let (risk, hottest) = check(s, &x, rev.judged(), s.dwell.margin_k);
        Ok((x, risk, hottest))
    }

    /// The smallest dwell before the revolution that keeps it safe: cooling of the excess above
    /// ambient is close to exponential, so two tries give its time constant and the dwell that
    /// reaches the target; then the bracket closes to 10 %.
    ///
    /// `unrested` is this segment's trial without a dwell from `start` (already made by the
    /// caller: the same laying would give the same run).
    fn smallest_dwell<R: HeatRun>(
        &self,
        start: &R,
        unrested: &Trial<R>,
        guess: f64,
        cache: &mut Vec<(f64, R)>,
        simulated: &mut usize,
    ) -> Result<Option<(f64, R)>, ThermalError> {
        let aim = self.s.aim_k(&unrested.0, self.rev.judged());
        // Each try cools on from the longest cooled state kept below its dwell ([`cooled`]):
        // the dwell's cooling is what the search costs on a large part, and the tries' dwells
        // overlap. Kept: the states a later try can start from, which lie between the longest
        // failing dwell and the shortest passing one ([`shortest_dwell`] tries only between);
        // the caller may cool on from them to the longest dwell when none passes.
        shortest_dwell(self.s, Guess::after(guess, 10.0), aim, |d| {
            let x = cooled(start, cache, d)?;
            let (x, risk, hot) = self.trial(x, simulated)?;
            let safe = risk.is_none();
            keep_between(cache, d, safe);
            Ok((x, safe, hot))
        })
    }
}

/// Where a dwell search starts: its first try, and whether that is a dwell found for the point
/// or revolution before (warm: the dwell wanted is likely near it) or a plain default.
#[derive(Debug, Clone, Copy)]
struct Guess {
    dwell_s: f64,
    warm: bool,
}

impl Guess {
    /// From the `last` dwell found (0 for none), else from `default`.
    fn after(last: f64, default: f64) -> Guess {
        match last > 0.0 {
            true => Guess {
                dwell_s: last,
                warm: true,
            },
            false => Guess {
                dwell_s: default,
                warm: false,
            },
        }
    }
}

/// How close the shortest safe dwell is found: the bracket (longest failing try, shortest
/// passing one) closes to 10 % of the passing dwell, or half a second.
fn tolerance(d: f64) -> f64 {
    (0.1 * d).max(0.5)
}

/// The shortest dwell that `attempt` (the run after a dwell, whether it is safe, its hottest
/// preheat) finds safe, from `guess` on: cooling of the excess above ambient is close to
/// exponential, so two tries give its time constant and the dwell that brings the preheat to
/// `target` (the preheat that cures the criterion broken, [`Search::aim_k`]); the bracket then
/// closes to [`tolerance`]. None shorter than `min_dwell_s` is tried (a dwell is an arc stop
/// and a restart: one that cools for a fraction of a second buys nothing). `None` if even the
/// longest dwell fails.
///
/// The preheat without a dwell is not fitted: a short dwell may raise it (the heat of metal just
/// laid soaks into the metal beneath the next points), so it lies off the decay. Each try cools
/// for its whole dwell, the cost of a search on a large part: a warm guess that fails is first
/// grown by a quarter, not doubled, and a pass with no fail below it is followed by the try
/// that closes the bracket if it fails.
fn shortest_dwell<R>(
    s: &Search,
    guess: Guess,
    target: f64,
    mut attempt: impl FnMut(f64) -> Result<(R, bool, f64), ThermalError>,
) -> Result<Option<(f64, R)>, ThermalError> {
    let mut tries = Vec::new();
    let mut d = guess.dwell_s;
    let (mut fail, mut best): (f64, Option<(f64, R)>) = (0.0, None);
    let shortest = s.dwell.min_dwell_s.min(s.dwell.max_dwell_s);
    for _ in 0..MAX_TRIES {
        d = d.clamp(shortest, s.dwell.max_dwell_s);
        let (x, safe, hot) = attempt(d)?;
        tries.push((d, hot));
        if safe {
            let close = d - fail <= tolerance(d) || d <= shortest;
            best = Some((d, x));
            if close {
                break;
            }
        } else {
            fail = fail.max(d);
            let closed = best.as_ref().is_some_and(|b| b.0 - fail <= tolerance(b.0));
            if closed || d >= s.dwell.max_dwell_s {
                break;
            }
        }
        let bracket = Bracket {
            fail,
            pass: best.as_ref().map(|b| b.0),
        };
        d = next_dwell(&tries, bracket, s.ambient_k, target, guess.warm);
    }
    Ok(best)
}

/// A dwell search's bracket: its longest failing try (0 before one fails) and its shortest
/// passing one.
#[derive(Debug, Clone, Copy)]
struct Bracket {
    fail: f64,
    pass: Option<f64>,
}

/// The next dwell to try, from the tries so far (dwell, hottest preheat): the exponential fit of
/// the last two (T − T_a ∝ e^{−d/τ}) kept inside the bracket, and no nearer its passing end than
/// the try that closes it; else the bracket halved, or, with nothing below the pass, the try that
/// closes it; else, with no pass yet, the longest failure grown (by a quarter after a `warm`
/// first guess, else doubled).
fn next_dwell(tries: &[(f64, f64)], b: Bracket, ambient: f64, target: f64, warm: bool) -> f64 {
    let n = tries.len();
    let fit = if n >= 2 {
        let ((d0, t0), (d1, t1)) = (tries[n - 2], tries[n - 1]);
        let (e0, e1, et) = (t0 - ambient, t1 - ambient, target - ambient);
        // τ > 0: the later of the two dwells left the metal cooler (in either order).
        let tau = (d1 - d0) / (e0 / e1).ln();
        (e0 > 0.0 && e1 > 0.0 && et > 0.0 && tau > 0.0 && tau.is_finite())
            .then(|| d1 + tau * (e1 / et).ln())
    } else {
        None
    };
    match (fit, b.pass) {
        (Some(g), Some(p)) if g > b.fail && g < p => g.min(p - 0.999 * tolerance(p)),
        (_, Some(p)) if b.fail > 0.0 => 0.5 * (b.fail + p),
        (_, Some(p)) => p - 0.999 * tolerance(p),
        // No pass yet: a revolution's trials stop at their first risky point, so the fit sees
        // only a little of the excess; grow at least geometrically.
        (Some(g), None) => (g * 1.05).max(1.5 * b.fail),
        (None, None) if warm && n == 1 => 1.25 * b.fail,
        (None, None) => (2.0 * b.fail).max(10.0),
    }
}

/// Simulate the first `upto` deposits of the build with `dwell_s` and return the first risky
/// point, if any; stops there. A point's preheat is read upstream of it, so once it is laid it
/// can be judged.
pub fn first_risk(
    s: &Search,
    model: &HeatModel,
    deps: &[Deposit],
    dwell_s: &[f64],
    upto: usize,
) -> Result<Option<(usize, Risk)>, ThermalError> {
    let mut run = model.start(deps)?;
    for (i, &dwell) in dwell_s.iter().enumerate().take(upto.min(deps.len())) {
        run.deposit(i, dwell)?;
        if let Some(r) = s.judge(&run.points()[i], run.support(i), 0.0) {
            return Ok(Some((i, r)));
        }
    }
    Ok(None)
}

/// Dwell positions of the revolution policy: the deposit before which each revolution's dwell goes.
pub fn dwell_points(pl: &Plan, deps: &[Deposit], lead: f64) -> Vec<usize> {
    revolutions(pl, deps, lead)
        .iter()
        .skip(1)
        .map(|r| r.dwell_at)
        .collect()
}

/// The uniform-dwell baseline: the same dwell before every revolution.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Uniform {
    /// The smallest dwell that keeps the points before `until` safe, s; `None` if not even the
    /// longest does.
    pub dwell_s: Option<f64>,
    /// The first deposit of the revolution where the longest dwell before each revolution no
    /// longer keeps the part safe: from there a revolution's own heat breaks a limit and only
    /// dwells inside revolutions help (the closing zone of a dome). The number of deposits when
    /// the policy works throughout.
    pub until: usize,
}

/// The smallest uniform dwell per revolution that keeps every point before the policy's limit
/// safe ([`Uniform::until`]), by bisection over builds stopped at their first risky point.
pub fn uniform_baseline(
    s: &Search,
    pl: &Plan,
    model: &HeatModel,
    deps: &[Deposit],
) -> Result<Uniform, ThermalError> {
    let at = dwell_points(pl, deps, model.lead());
    let with = |d: f64| {
        let mut v = vec![0.0; deps.len()];
        for &i in &at {
            v[i] = d;
        }
        v
    };
    let max = s.dwell.max_dwell_s;
    let until = match first_risk(s, model, deps, &with(max), deps.len())? {
        None => deps.len(),
        Some((i, _)) => {
            let layer = pl.points[i].layer;
            pl.points.iter().position(|q| q.layer == layer).unwrap_or(i)
        }
    };
    // The run above judged every point before `until` safe at the longest dwell.
    if until == 0 {
        return Ok(Uniform {
            dwell_s: None,
            until,
        });
    }
    let (mut lo, mut hi) = (0.0, max);
    while hi - lo > (0.02 * hi).max(0.5) {
        let mid = 0.5 * (lo + hi);
        if first_risk(s, model, deps, &with(mid), until)?.is_some() {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    Ok(Uniform {
        dwell_s: Some(hi),
        until,
    })
}

/// "Wait until the last layer is below the limit": before each revolution's dwell point, wait
/// until all the metal of the previous revolution is below the interpass limit (capped at the
/// longest dwell). Returns the dwells it waited.
pub fn wait_until_cool(
    s: &Search,
    pl: &Plan,
    model: &HeatModel,
    deps: &[Deposit],
) -> Result<Vec<f64>, ThermalError> {
    let revs = revolutions(pl, deps, model.lead());
    let mut run = model.start(deps)?;
    let mut dwell = vec![0.0; deps.len()];
    let mut cursor = 0;
    for (r, rev) in revs.iter().enumerate().skip(1) {
        for i in cursor..rev.dwell_at {
            run.deposit(i, 0.0)?;
        }
        cursor = rev.dwell_at;
        let prev = revs[r - 1];
        let hot = |run: &thermal::ModelRun| {
            (prev.first..prev.end.min(cursor))
                .map(|i| run.temperature_of(i))
                .fold(f64::NEG_INFINITY, f64::max)
        };
        let mut waited = 0.0;
        while hot(&run) > s.dwell.interpass_max_k && waited < s.dwell.max_dwell_s {
            run.cool(1.0)?;
            waited += 1.0;
        }
        dwell[rev.dwell_at] = waited;
        // The waiting is done: lay the rest of this stretch.
        let end = revs
            .get(r + 1)
            .map_or(deps.len(), |x| x.dwell_at)
            .max(cursor);
        for i in cursor..end {
            run.deposit(i, 0.0)?;
        }
        cursor = end;
    }
    Ok(dwell)
}

#[cfg(test)]
mod tests {
    use thermal::material::Material;
    use thermal::network::Surroundings;
    use thermal::wall::{WallModel, WallRun, WallSettings};
    use thermal::{HeatRun, Plate};

    /// Each point is judged by the one stretch its preheat is read in: the last point of a
    /// revolution read during the deposit that reads the next one's first (where the dwell
    /// before that deposit cools both) is judged with the next revolution, not with its own,
    /// whose stretch ends before it is read.
    #[test]
    fn a_point_is_judged_in_the_stretch_it_is_read_in() {
        let layers = [0, 0, 0, 0, 1, 1, 1, 2, 2];
        // Point 3 read with point 4, during deposit 3; points 6 and 7 each in their own.
        let read = [
            None,
            Some(0),
            Some(1),
            Some(3),
            Some(3),
            Some(4),
            Some(5),
            Some(6),
            Some(7),
        ];
        let revs = super::revolutions_read(&layers, &read);
        let judged: Vec<_> = revs.iter().map(|r| r.judged()).collect();
        assert_eq!(judged, [0..3, 3..7, 7..9]);
        assert_eq!(
            revs.iter().map(|r| r.dwell_at).collect::<Vec<_>>(),
            [0, 3, 6]
        );
        for (r, rev) in revs.iter().enumerate() {
            let end = revs.get(r + 1).map_or(usize::MAX, |n| n.dwell_at);
            for k in rev.judged() {
                let at = read[k].unwrap_or(0);
                assert!((rev.dwell_at..end).contains(&at), "point {k} read at {at}");
            }
        }
    }

    /// Trials of any order through the cache give the state one `cool(d)` gives, bit for bit.
    #[test]
    fn cooling_on_from_the_cache_equals_cooling_once() {
        let deps = thermal::schedule::helix(0.03, 40, 3, 2e-3, 5e-3, 10e-3, 1700.0);
        let settings = WallSettings {
            material: Material::g3si(),
            surroundings: Surroundings {
                ambient_k: 293.15,
                convection_w_m2k: 15.0,
                emissivity: 0.6,
                table_w_m2k: 100.0,
            },
            plate: Plate {
                size: [0.1, 0.1, 0.008],
                centre: [0.0, 0.0],
                cell: 5e-3,
                layers: 3,
                disc: false,
                material: None,
            },
            min_node: 3e-3,
            deposit_temperature: 1823.15,
            footprint: 5e-3,
            lead: 10e-3,
            hot_threshold: 873.15,
            max_step: 30.0,
            probes: vec![],
            probe_every: 0.0,
            snapshot_times: vec![],
            traces: vec![],
            watch_metal: false,
            local_steps: Some(thermal::rates::LocalSteps {
                near: 0.02,
                period: 1.0,
                levels: 5,
                age_share: 0.1,
                change: None,
            }),
            merge_plate: true,
        };
        let mut run = WallRun::new(
            WallModel::build(&deps, &settings).unwrap(),
            &deps,
            &settings,
        );
        for i in 0..60 {
            run.deposit(i, 0.0).unwrap();
        }
        let mut cache = Vec::new();
        for d in [5.0, 21.0, 15.0, 18.0, 70.0, 0.5, 33.3] {
            let mut once = run.clone();
            once.cool(d).unwrap();
            let on = super::cooled(&run, &mut cache, d).unwrap();
            assert_eq!(on.temperatures(), once.temperatures(), "dwell {d}");
            assert!((on.now() - once.now()).abs() < 1e-9);
        }
        assert!(cache.len() >= 4);
    }

    /// The cooled states a dwell search drops are none that a later try of it would start from:
    /// searches of cooling slow and fast, aims near and far, first guesses short and long.
    #[test]
    fn a_dwell_search_keeps_the_cooled_states_its_later_tries_start_from() {
        let b = crate::pipeline::test_parts::dome(30.0, "");
        let pacing = b.pacing();
        let s = b.search(&pacing);
        let steps = thermal::CoolingSteps::Doubling { max: 30.0 };
        let ambient = s.ambient_k;
        let (mut pruned_any, mut searches) = (false, 0);
        for tau in [20.0, 90.0, 400.0] {
            for aim_above_k in [5.0, 40.0, 150.0] {
                for (guess, warm) in [(10.0, false), (45.0, true), (300.0, false), (300.0, true)] {
                    let guess = super::Guess {
                        dwell_s: guess,
                        warm,
                    };
                    let hot = |d: f64| ambient + 400.0 * (-d / tau).exp();
                    let aim = ambient + aim_above_k;
                    // Every state a try cooled to, and those the search kept.
                    let (mut all, mut kept) = (Vec::<f64>::new(), Vec::<(f64, ())>::new());
                    let start = |keys: &mut dyn Iterator<Item = f64>, d: f64| {
                        let b = super::last_whole_step(steps, d);
                        keys.filter(|&k| k <= b).fold(0.0, f64::max)
                    };
                    let found = super::shortest_dwell(&s, guess, aim, |d| {
                        let from = start(&mut all.iter().copied(), d);
                        assert_eq!(
                            start(&mut kept.iter().map(|k| k.0), d),
                            from,
                            "tau {tau} s, aim {aim_above_k} K, {guess:?}: the try of {d} s"
                        );
                        let b = super::last_whole_step(steps, d);
                        if b > from {
                            all.push(b);
                            kept.push((b, ()));
                        }
                        let safe = hot(d) <= aim;
                        super::keep_between(&mut kept, d, safe);
                        Ok(((), safe, hot(d)))
                    })
                    .unwrap();
                    pruned_any |= kept.len() < all.len();
                    searches += usize::from(found.is_some());
                }
            }
        }
        assert!(
            pruned_any,
            "no search dropped a state: the test shows nothing"
        );
        assert!(searches > 10, "too few searches found a dwell ({searches})");
    }

    /// A search started from a dwell found nearby (a warm guess within 15 % of the answer)
    /// finds the shortest safe dwell to its tolerance in three tries, whether the guess is short
    /// or long, on exponential cooling whose first seconds heat the point instead (heat just
    /// laid soaking in: no fit may use them).
    #[test]
    fn a_warm_dwell_search_closes_in_three_tries() {
        let b = crate::pipeline::test_parts::dome(30.0, "");
        let pacing = b.pacing();
        let s = b.search(&pacing);
        let ambient = s.ambient_k;
        for tau in [20.0, 90.0, 400.0] {
            for aim_above_k in [40.0, 150.0] {
                let aim = ambient + aim_above_k;
                let hot = |d: f64| {
                    let soak = 80.0 * (d / 3.0) * (-d / 3.0).exp();
                    ambient + 400.0 * (-d / tau).exp() + soak
                };
                // The shortest safe dwell: the decay alone reaches the aim there.
                let answer = tau * (400.0 / aim_above_k).ln();
                if answer < s.dwell.min_dwell_s || answer > s.dwell.max_dwell_s / 1.2 {
                    continue;
                }
                for share in [0.85, 1.0, 1.15] {
                    let guess = super::Guess {
                        dwell_s: share * answer,
                        warm: true,
                    };
                    let mut tries = Vec::new();
                    let found = super::shortest_dwell(&s, guess, aim, |d| {
                        tries.push(d);
                        Ok(((), hot(d) <= aim + 1e-9, hot(d)))
                    })
                    .unwrap()
                    .map(|f| f.0);
                    let found = found.expect("a safe dwell");
                    let at = format!("tau {tau} s, aim {aim_above_k} K, guess {share}: {tries:?}");
                    assert!(hot(found) <= aim + 1e-9, "{at}");
                    assert!(found - answer <= super::tolerance(found) + 1e-9, "{at}");
                    assert!(tries.len() <= 3, "{at}");
                }
            }
        }
    }
}
