//! The cooling-dwell planner: where to pause the arc and for how long so that no risk criterion
//! is broken, with as little dwell as possible, and the baselines it is judged against.
//!
//! The search walks the build once, revolution by revolution, from checkpoints of the thermal run
//! (a clone of its state). A revolution is simulated without a dwell; if it breaks a criterion,
//! two remedies are sized and the cheaper kept (dwell plus `count_weight_s` per arc stop):
//!
//! - one dwell before the revolution's first preheat reading (the deposit during whose arc the
//!   torch is `lead_mm` upstream of its first point), so that the whole revolution is laid on
//!   metal that has cooled: the smallest such dwell, from a few simulations of that revolution;
//! - dwells inside the revolution, each just before the deposit whose arc would break a
//!   criterion, as short as keeps it safe. Near a closing point a revolution lasts seconds and
//!   heats its own substrate as it goes: no dwell before it can keep it under the limit, and
//!   only these can.

use super::params::DwellSettings;
use super::risk::{Criteria, Risk, judge_for_dwell};
use planner::plan::Plan;
use thermal::schedule::Deposit;
use thermal::schedule::read_points;
use thermal::{CoolingSteps, HeatModel, HeatRun, Support, ThermalError};

/// What a dwell search judges by and aims for.
#[derive(Debug, Clone, Copy)]
pub struct Search<'a> {
    pub criteria: &'a Criteria,
    pub dwell: &'a DwellSettings,
    /// The cooling of the excess above it is close to exponential, K.
    pub ambient_k: f64,
}

impl Search<'_> {
    fn judge(&self, p: &thermal::PointResult, support: Support, margin_k: f64) -> Option<Risk> {
        judge_for_dwell(self.criteria, p, support, margin_k)
    }

    /// The temperature the search aims below, K.
    fn target_k(&self) -> f64 {
        self.dwell.interpass_max_k - self.dwell.margin_k
    }
}

/// Tries of one revolution's dwell search before it gives up at the longest dwell.
const MAX_TRIES: usize = 8;

/// The point search copies its run every this many deposits.
const CHECKPOINT_EVERY: usize = 16;

/// A deposit whose judged points lie on metal this far below the limit is laid without a copy
/// (the arc warms the metal ahead of it by less than this over one deposit).
const PREDICT_MARGIN_K: f64 = 50.0;

/// A revolution and where its dwell goes.
#[derive(Debug, Clone, Copy)]
struct Revolution {
    /// Its points.
    first: usize,
    end: usize,
    /// Its dwell goes before this deposit; it is simulated from here to the next one's.
    dwell_at: usize,
}

fn revolutions(pl: &Plan, deps: &[Deposit], lead: f64) -> Vec<Revolution> {
    let read = read_points(deps, lead);
    let mut revs: Vec<Revolution> = Vec::new();
    for (i, q) in pl.points.iter().enumerate() {
        if i == 0 || q.layer != pl.points[i - 1].layer {
            revs.push(Revolution {
                first: i,
                end: i + 1,
                dwell_at: read[i].unwrap_or(0),
            });
        } else {
            revs.last_mut().expect("revolution").end = i + 1;
        }
    }
    revs
}

#[derive(Debug, Clone)]
pub struct DwellPlan {
    /// Per deposit: dwell before it, s, and why.
    pub dwell_s: Vec<f64>,
    pub reason: Vec<Option<Risk>>,
    /// Points still at risk at the longest dwell.
    pub unresolved: Vec<usize>,
    /// Deposits simulated by the search, in whole builds.
    pub cost_builds: f64,
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

/// Lay deposits `from..to`, the first after `dwell` seconds.
fn advance(run: &mut impl HeatRun, from: usize, to: usize, dwell: f64) -> Result<(), ThermalError> {
    for i in from..to {
        run.deposit(i, if i == from { dwell } else { 0.0 })?;
    }
    Ok(())
}

/// `base` cooled for `d` seconds with the steps one `cool(d)` takes (1, 2, 4 … s up to the
/// longest step, then what is left; or equal steps), carried on from the longest state in
/// `cache` on that sequence: a search trying longer and longer dwells cools on instead of
/// starting over, and the dwell it settles on gives the state a fresh run with that dwell gives
/// (the same bits on the thin wall; the voxel model's last partial step may round differently).
fn cooled<R: HeatRun>(base: &R, cache: &mut Vec<(f64, R)>, d: f64) -> Result<R, ThermalError> {
    let boundary = match base.cooling_steps() {
        CoolingSteps::Doubling { max } => {
            let (mut boundary, mut dt) = (0.0, 1.0f64);
            while boundary + dt <= d + 1e-9 {
                boundary += dt;
                dt = (dt * 2.0).min(max);
            }
            boundary
        }
        CoolingSteps::Fixed { step } => ((d + 1e-9) / step).floor() * step,
    };
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

/// Per deposit, the points whose preheat is read during its arc, and itself (its pool).
fn judged_at(deps: &[Deposit], lead: f64) -> Vec<Vec<usize>> {
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

/// Point dwells over the deposits of `range` from `start`: each deposit is tried without a dwell, and
/// given the shortest one that keeps the points judged at it safe when it is not.
fn point_dwells<R: HeatRun>(
    s: &Search,
    judged: &[Vec<usize>],
    start: &R,
    range: std::ops::Range<usize>,
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
            y.deposit(j, d)?;
        }
        Ok::<R, ThermalError>(y)
    };
    for i in range {
        if i - cp_at >= CHECKPOINT_EVERY {
            cp = x.clone();
            cp_at = i;
        }
        let cool = judged[i].iter().all(|&k| {
            x.support(k) != Support::Deposit || x.temperature_beneath(k) < target - PREDICT_MARGIN_K
        });
        if cool {
            x.deposit(i, 0.0)?;
            *simulated += 1.0;
            if risk_at(&x, i).0.is_none() {
                continue;
            }
            x = replay(&cp, cp_at, i, &dwells)?;
            *simulated += (i - cp_at) as f64;
        }
        let mut trial = x.clone();
        trial.deposit(i, 0.0)?;
        *simulated += 1.0;
        let (risk, hot0) = risk_at(&trial, i);
        let Some(why) = risk else {
            x = trial;
            continue;
        };
        let mut cache = Vec::new();
        let pass = shortest_dwell(s, 5.0, hot0, |d| {
            let mut t = cooled(&x, &mut cache, d)?;
            t.deposit(i, 0.0)?;
            *simulated += 1.0;
            let (r, hot) = risk_at(&t, i);
            Ok((t, r.is_none(), hot))
        })?;
        match pass {
            Some((d, t)) => {
                dwells.push((i, d, why));
                x = t;
            }
            None => {
                let mut t = x.clone();
                t.deposit(i, s.dwell.max_dwell_s)?;
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

/// Plan the dwells of the build `deps` (its schedule without dwells) on `run`, a fresh run of
/// any heat model on it; `lead` is where the model reads preheat.
pub fn plan_dwells<R: HeatRun>(
    s: &Search,
    pl: &Plan,
    deps: &[Deposit],
    lead: f64,
    mut run: R,
) -> Result<DwellPlan, ThermalError> {
    let n = deps.len();
    let revs = revolutions(pl, deps, lead);
    let judged = judged_at(deps, lead);
    let mut plan = DwellPlan {
        dwell_s: vec![0.0; n],
        reason: vec![None; n],
        unresolved: vec![],
        cost_builds: 0.0,
    };
    let mut simulated = 0usize;
    let w = s.dwell.count_weight_s;
    let mut last_dwell = 0.0f64;
    let mut cursor = 0;
    for (r, rev) in revs.iter().enumerate() {
        let seg_end = revs.get(r + 1).map_or(n, |x| x.dwell_at).max(rev.dwell_at);
        if cursor < rev.dwell_at {
            advance(&mut run, cursor, rev.dwell_at, 0.0)?;
            simulated += rev.dwell_at - cursor;
        }
        let segment = Segment {
            s,
            judged: &judged,
            rev: *rev,
            seg_end,
        };
        let (x0, risk0, _) = segment.try_dwell(&run, 0.0, &mut simulated)?;
        let Some((_, why)) = risk0 else {
            run = x0;
            cursor = seg_end;
            continue;
        };
        // Dwells inside the revolution, just where they are needed: the least dwell time.
        let mut point_sim = 0.0;
        let (xp, point, point_unresolved) =
            point_dwells(s, &judged, &run, rev.dwell_at..seg_end, &mut point_sim)?;
        simulated += point_sim as usize;
        let point_cost = point.iter().map(|p| p.1).sum::<f64>() + w * point.len() as f64;
        // One dwell before the revolution: one arc stop. Sized only when stops carry a weight or
        // the point dwells cannot make the revolution safe.
        let whole = if w > 0.0 || !point_unresolved.is_empty() {
            segment.smallest_dwell(&run, last_dwell, &mut simulated)?
        } else {
            None
        };
        match whole {
            Some((d, x)) if d + w < point_cost || !point_unresolved.is_empty() => {
                plan.dwell_s[rev.dwell_at] = d;
                plan.reason[rev.dwell_at] = Some(why);
                last_dwell = d;
                run = x;
            }
            _ => {
                for &(i, d, why) in &point {
                    plan.dwell_s[i] = d;
                    plan.reason[i] = Some(why);
                }
                plan.unresolved.extend(point_unresolved);
                run = xp;
            }
        }
        // A trial that stopped at its first risky point leaves the segment unfinished.
        if run.laid() < seg_end {
            let from = run.laid();
            advance(&mut run, from, seg_end, 0.0)?;
            simulated += seg_end - from;
        }
        cursor = seg_end;
    }
    plan.cost_builds = simulated as f64 / n.max(1) as f64;
    Ok(plan)
}

/// One revolution's stretch of deposits, from its dwell point to the next one's.
struct Segment<'a> {
    s: &'a Search<'a>,
    judged: &'a [Vec<usize>],
    rev: Revolution,
    seg_end: usize,
}

impl Segment<'_> {
    /// Lay the stretch after a dwell of `d` from `start`, stopping at the first risky point of the
    /// revolution: failing trials are cheap.
    fn try_dwell<R: HeatRun>(
        &self,
        start: &R,
        d: f64,
        simulated: &mut usize,
    ) -> Result<Trial<R>, ThermalError> {
        let (s, rev) = (self.s, self.rev);
        let mut x = start.clone();
        for i in rev.dwell_at..self.seg_end {
            x.deposit(i, if i == rev.dwell_at { d } else { 0.0 })?;
            *simulated += 1;
            let risky = self.judged[i].iter().any(|&k| {
                k >= rev.first
                    && k < rev.end
                    && s.judge(&x.points()[k], x.support(k), s.dwell.margin_k)
                        .is_some()
            });
            if risky {
                break;
            }
        }
        let (risk, hottest) = check(s, &x, rev.first..rev.end, s.dwell.margin_k);
        Ok((x, risk, hottest))
    }

    /// The smallest dwell before the revolution that keeps it safe: cooling of the excess above
    /// ambient is close to exponential, so two tries give its time constant and the dwell that
    /// reaches the target; then the bracket closes to 10 %.
    fn smallest_dwell<R: HeatRun>(
        &self,
        start: &R,
        guess: f64,
        simulated: &mut usize,
    ) -> Result<Option<(f64, R)>, ThermalError> {
        let (_, _, hot0) = self.try_dwell(start, 0.0, simulated)?;
        shortest_dwell(self.s, if guess > 0.0 { guess } else { 10.0 }, hot0, |d| {
            let (x, risk, hot) = self.try_dwell(start, d, simulated)?;
            Ok((x, risk.is_none(), hot))
        })
    }
}

/// The shortest dwell that `attempt` (the run after a dwell, whether it is safe, its hottest
/// preheat) finds safe, starting from `guess`: cooling of the excess above ambient is close to
/// exponential, so two tries give its time constant and the dwell that reaches the target; then
/// the bracket closes to 10 %. None shorter than `min_dwell_s` is tried (a dwell is an arc stop
/// and a restart: one that cools for a fraction of a second buys nothing). `None` if even the
/// longest dwell fails.
fn shortest_dwell<R>(
    s: &Search,
    guess: f64,
    hot0: f64,
    mut attempt: impl FnMut(f64) -> Result<(R, bool, f64), ThermalError>,
) -> Result<Option<(f64, R)>, ThermalError> {
    let (ambient, target) = (s.ambient_k, s.target_k());
    let mut tries = vec![(0.0, hot0)];
    let mut d = guess;
    let (mut fail, mut best): (f64, Option<(f64, R)>) = (0.0, None);
    let shortest = s.dwell.min_dwell_s.min(s.dwell.max_dwell_s);
    for _ in 0..MAX_TRIES {
        d = d.clamp(shortest, s.dwell.max_dwell_s);
        let (x, safe, hot) = attempt(d)?;
        tries.push((d, hot));
        if safe {
            // Within 10 % of the bracket, or at the shortest dwell allowed.
            let close = d - fail <= (0.1 * d).max(0.5) || d <= shortest;
            best = Some((d, x));
            if close {
                break;
            }
        } else {
            fail = fail.max(d);
            if d >= s.dwell.max_dwell_s {
                break;
            }
        }
        d = next_dwell(&tries, fail, best.as_ref().map(|b| b.0), ambient, target);
    }
    Ok(best)
}

/// The next dwell to try: from the exponential fit of the last two tries (T − T_a ∝ e^{−d/τ}),
/// kept inside the bracket (largest failing, smallest passing); bisection when the fit fails.
fn next_dwell(
    tries: &[(f64, f64)],
    fail: f64,
    pass: Option<f64>,
    ambient: f64,
    target: f64,
) -> f64 {
    let n = tries.len();
    let guess = if n >= 2 {
        let ((d0, t0), (d1, t1)) = (tries[n - 2], tries[n - 1]);
        let (e0, e1, et) = (t0 - ambient, t1 - ambient, target - ambient);
        if e0 > 0.0 && e1 > 0.0 && et > 0.0 && e1 < e0 && d1 != d0 {
            let tau = (d1 - d0) / (e0 / e1).ln();
            Some(d1 + tau * (e1 / et).ln())
        } else {
            None
        }
    } else {
        None
    };
    match (guess, pass) {
        (Some(g), Some(p)) if g > fail && g < p => g,
        // No pass yet: trials stop at their first risky point, so the fit sees only a little of
        // the excess; grow at least geometrically.
        (Some(g), None) => (g * 1.05).max(1.5 * fail),
        (_, Some(p)) => 0.5 * (fail + p),
        _ => (2.0 * fail).max(10.0),
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
#[derive(Debug, Clone, PartialEq)]
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
        advance(&mut run, cursor, rev.dwell_at, 0.0)?;
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
        if end > cursor {
            run.deposit(cursor, 0.0)?;
            advance(&mut run, cursor + 1, end, 0.0)?;
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
            trace_hottest: false,
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
}
