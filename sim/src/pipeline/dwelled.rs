//! The dwell command's work as one engine call ([`dwell`]): at a confidence the plan at the
//! calibration's mean and its design point first (the build then stands at θ*,
//! [`super::confidence`]); the build heated without dwells; the dwell search (within an
//! arc-stop budget where there is one) against its yardstick, one dwell before each
//! revolution ([`super::arc_stops::never_worse`]); the fewest arc stops any plan can make; the
//! build heated with the plan's cooling; and what was asked beside: both plans under fresh
//! parameter draws, the arc-stop front, the baselines. No files: the command writes them.

use super::arc_stops::{self, Budgeted, Kept, Tried};
use super::bound::StopsBound;
use super::checkpoint::Checkpoints;
use super::confidence::{self, Check, DesignPoint, Uncertainty};
use super::deposition::Cooling;
use super::dwell::wait_until_cool;
use super::dwell::{DwellPlan, Uniform, dwell_points, first_risk, uniform_baseline};
use super::risk::Risk;
use super::{Build, Error, Report, Simulation};
use std::sync::atomic::{AtomicBool, Ordering};
use thermal::ThermalError;

/// What a dwell run does beyond the plan.
#[derive(Debug, Clone, Default)]
pub struct Options {
    /// Plan at this quantile of a calibration's uncertainty (`[dwell] confidence`).
    pub confidence: Option<confidence::Settings>,
    /// The uniform dwell and wait-until-cool baselines.
    pub baselines: bool,
    /// A plan per weight of an arc stop (the arc-stop front).
    pub pareto: bool,
    /// Field frames kept of the run with the dwells (0: none).
    pub frames: usize,
    /// Points whose temperature the run with the dwells keeps at every step.
    pub traces: Vec<usize>,
}

/// A dwell search's plan and what it was weighed against.
#[derive(Debug, Clone)]
pub struct Searched {
    /// The plan kept: the search's, or the yardstick's where that is better.
    pub plan: DwellPlan,
    /// The arc-stop budget and what the search made of it, where there is one.
    pub budget: Option<(usize, Budgeted)>,
    /// Wall-clock seconds of the search.
    pub search_s: f64,
    /// The yardstick: one dwell before each revolution.
    pub revolution: DwellPlan,
    /// The search's own plan's arc stops and build time, s.
    pub searched: usize,
    pub searched_build_s: f64,
    pub kept: Kept,
}

/// The plan at the calibration's mean and the design point of its cooling.
#[derive(Debug, Clone)]
pub struct AtMean {
    pub build: Build,
    pub plan: DwellPlan,
    pub design: DesignPoint,
    pub uncertainty: Uncertainty,
}

/// How sure a plan made at a confidence is: the plan at the mean, and both plans under the
/// same fresh draws.
#[derive(Debug, Clone)]
pub struct Sure {
    pub at_mean: AtMean,
    /// The plan at θ* under the draws.
    pub check: Check,
    /// The plan at the mean under the same draws.
    pub check_at_mean: Check,
}

/// The uniform dwell and wait-until-cool baselines.
#[derive(Debug, Clone)]
pub struct Baselines {
    pub uniform: Uniform,
    /// Dwell slots before `uniform.until`, and the plan's dwell there, s.
    pub slots: usize,
    pub planned_there_s: f64,
    /// Wait-until-cool's dwell per point, s; its first risk, and every point's risk in a
    /// fresh run with its waits.
    pub waits: Vec<f64>,
    pub wait_risk: Option<(usize, Risk)>,
    pub wait_risks: Vec<Option<Risk>>,
    /// Wall time this command spent on them, s (none for the stages a `--resume` took from
    /// its checkpoints).
    pub wall_s: f64,
}

/// Everything a dwell run found.
#[derive(Debug, Clone)]
pub struct Dwelled {
    /// The build planned and judged (at θ* where planned at a confidence).
    pub build: Build,
    pub before: Simulation,
    pub searched: Searched,
    pub bound: StopsBound,
    pub after: Simulation,
    pub sure: Option<Sure>,
    pub front: Option<Vec<Tried>>,
    pub baselines: Option<Baselines>,
}

/// Plan the dwells of `b` as `o` asks. With checkpoints on, each stage is kept (the heat runs,
/// the search between revolutions; the front and the baselines as each finishes) and taken
/// from there when the run resumes.
pub fn dwell(
    b: Build,
    o: &Options,
    ck: &mut Checkpoints<'_>,
    report: &mut dyn Report,
) -> Result<Dwelled, Error> {
    let at_mean = match &o.confidence {
        Some(c) => Some(plan_at_mean(&b, c, report)?),
        None => None,
    };
    let b = match &at_mean {
        Some(m) => confidence::build_at(&b, &m.uncertainty, &m.design.x),
        None => b,
    };
    let ((before, bound), searched) =
        with_yardstick(&b, ck, |ck| beside_the_yardstick(&b, ck, report))?;
    report.stage("heating the build");
    let after = b.simulate_kept(
        &searched.plan.cooling,
        o.frames,
        o.traces.clone(),
        ck,
        "after",
        &mut |k, n| report.laid(k, n),
    )?;
    let sure = match (at_mean, &o.confidence) {
        (Some(m), Some(c)) => {
            report.stage("the plans under fresh parameter draws");
            let safe: Vec<bool> = after
                .risks(&b.criteria)
                .iter()
                .map(|r| r.is_none())
                .collect();
            Some(check_both(&b, m, c, &searched.plan.cooling, &safe)?)
        }
        _ => None,
    };
    let front = match o.pareto {
        true => {
            report.stage("the arc-stop front: a dwell plan per weight of an arc stop");
            let known = searched
                .budget
                .as_ref()
                .map_or(&[][..], |(_, r)| r.tried.as_slice());
            Some(ck.stage("front", |_, _| arc_stops::front(&b, known))?.0)
        }
        false => None,
    };
    let baselines = match o.baselines {
        true => {
            report.stage("baselines: uniform dwell, wait until cool");
            Some(baselines(&b, &searched.plan, ck)?)
        }
        false => None,
    };
    Ok(Dwelled {
        build: b,
        before,
        searched,
        bound,
        after,
        sure,
        front,
        baselines,
    })
}

/// `work` (which makes the dwell search's plan, and what else `T` holds) with the
/// revolution-dwell yardstick beside it; the search's plan is weighed against the yardstick's
/// and the better kept ([`arc_stops::never_worse`]).
///
/// The yardstick is a rayon task: it starts from the build and shares nothing with the work,
/// so a second worker takes the shorter of the two off the wall time (the thin wall steps on
/// one thread), and the results are those made one after the other. The scope is in place (the
/// command already runs on a worker, `main.rs`): on one thread its worker makes the yardstick
/// itself after the work, where a blocking join would wait on the worker it holds. Where the
/// work fails, the yardstick is told to stop at its next revolution, so that the error is not
/// held back by a plan no one will read.
fn with_yardstick<T>(
    b: &Build,
    ck: &mut Checkpoints<'_>,
    work: impl FnOnce(&mut Checkpoints<'_>) -> Result<(T, SearchedPlan), Error>,
) -> Result<(T, Searched), Error> {
    let kept = ck.done::<DwellPlan>(YARDSTICK);
    let stop = AtomicBool::new(false);
    let mut made = None;
    let done = rayon::in_place_scope(|scope| {
        if kept.is_none() {
            scope.spawn(|_| {
                let t = std::time::Instant::now();
                made = Some(
                    b.revolution_dwells_unless(&stop)
                        .map(|p| (p, t.elapsed().as_secs_f64())),
                );
            });
        }
        let done = work(ck);
        if done.is_err() {
            stop.store(true, Ordering::Relaxed);
        }
        done
    });
    let (other, (plan, budget, search_s)) = done?;
    let revolution = match (kept, made) {
        (Some((plan, _)), _) => plan,
        (None, Some(made)) => {
            let (plan, spent_s) = made?;
            ck.keep_done(YARDSTICK, &plan, spent_s);
            plan
        }
        (None, None) => unreachable!("the yardstick is kept or made"),
    };
    let searched = arc_stops::arc_stops(&plan);
    let searched_build_s = arc_stops::build_time_s(b, &plan);
    let (plan, kept) = arc_stops::never_worse(b, plan, &revolution);
    let searched = Searched {
        plan,
        budget,
        search_s,
        revolution,
        searched,
        searched_build_s,
        kept,
    };
    Ok((other, searched))
}

/// What the dwell command makes beside the yardstick, one after another: the build heated
/// without dwells, the search, and the fewest arc stops any plan can make (the budget's bound
/// where the search had one).
fn beside_the_yardstick(
    b: &Build,
    ck: &mut Checkpoints<'_>,
    report: &mut dyn Report,
) -> Result<((Simulation, StopsBound), SearchedPlan), Error> {
    report.stage("heating the build");
    let before = b.simulate_kept(
        &Cooling::default(),
        0,
        Vec::new(),
        ck,
        "before",
        &mut |k, n| report.laid(k, n),
    )?;
    report.stage("planning the dwells");
    let searched = searched_plan(b, ck)?;
    let bound = match &searched.1 {
        Some((_, r)) => r.bound.clone(),
        None => {
            report.stage("the fewest arc stops any plan can make");
            ck.stage("bound", |_, _| b.arc_stops_lower_bound())?.0
        }
    };
    Ok(((before, bound), searched))
}

/// The checkpoint stage of the revolution-dwell yardstick.
const YARDSTICK: &str = "revolution_dwell";

/// The search's plan, the budget's result where there is one, and the seconds it took.
type SearchedPlan = (DwellPlan, Option<(usize, Budgeted)>, f64);

/// The dwell search, within the arc-stop budget where there is one.
fn searched_plan(b: &Build, ck: &mut Checkpoints<'_>) -> Result<SearchedPlan, Error> {
    Ok(match b.params.dwell.max_arc_stops {
        Some(max) => {
            let (r, wall_s) = ck.stage("search", |_, _| arc_stops::within_budget(b, max))?;
            (r.plan.clone(), Some((max, r)), wall_s)
        }
        None => {
            let weight = b.params.dwell.count_weight_s;
            let (plan, wall_s) = ck.stage("search", |ck, progress| {
                b.plan_dwells_kept(weight, ck, progress)
            })?;
            (plan, None, wall_s)
        }
    })
}

fn plan_at_mean(
    b: &Build,
    c: &confidence::Settings,
    report: &mut dyn Report,
) -> Result<AtMean, Error> {
    report.stage("the plan at the calibration's mean");
    let work = |ck: &mut Checkpoints<'_>| Ok(((), searched_plan(b, ck)?));
    let plan = with_yardstick(b, &mut Checkpoints::off(), work)?.1.plan;
    report.stage("the design point: a run a standard deviation off per parameter");
    let design = confidence::design_point(b, &c.uncertainty, c.confidence, &plan.cooling)?;
    Ok(AtMean {
        build: b.clone(),
        plan,
        design,
        uncertainty: c.uncertainty.clone(),
    })
}

/// The plan at θ* and the plan at the mean, each under the same fresh draws.
fn check_both(
    b: &Build,
    m: AtMean,
    c: &confidence::Settings,
    cooling: &Cooling,
    safe: &[bool],
) -> Result<Sure, Error> {
    let x = confidence::draws(&m.uncertainty, c.check_draws, c.seed);
    let q = c.confidence;
    let check = confidence::check(b, &m.uncertainty, cooling, safe, &x, q)?;
    let own = m.build.simulate_cooled(&m.plan.cooling, 0, Vec::new())?;
    let safe_mean: Vec<bool> = own
        .risks(&m.build.criteria)
        .iter()
        .map(|r| r.is_none())
        .collect();
    let check_at_mean =
        confidence::check(&m.build, &m.uncertainty, &m.plan.cooling, &safe_mean, &x, q)?;
    Ok(Sure {
        at_mean: m,
        check,
        check_at_mean,
    })
}

/// The uniform dwell and wait-until-cool baselines of `b` against `plan`. The two share
/// nothing, so wait-until-cool's runs are a rayon task beside the uniform dwell's search (as the
/// yardstick is beside the search, [`with_yardstick`]): on the thin wall, which steps on one
/// thread, a second worker takes the shorter of the two off the wall time; the results are those
/// made one after the other.
fn baselines(b: &Build, plan: &DwellPlan, ck: &mut Checkpoints<'_>) -> Result<Baselines, Error> {
    let clock = std::time::Instant::now();
    let deps = b.deposits();
    let pl = &b.plan;
    let model = b.heat_model(deps, Vec::new());
    let pacing = b.pacing();
    let search = b.search(&pacing);
    let kept = KeptWaits {
        waits: ck.done(WAIT).map(|d| d.0),
        risk: ck.done(WAIT_RISK).map(|d| d.0),
        risks: ck.done(WAIT_RUN).map(|d| d.0),
    };
    let mut made = None;
    let uniform = rayon::in_place_scope(|scope| {
        scope.spawn(|_| made = Some(wait_until_cool_runs(b, &search, kept)));
        ck.stage("uniform", |_, _| {
            uniform_baseline(&search, pl, &model, deps)
        })
    });
    let (waited, [spent_waits, spent_risk, spent_run]) = made.expect("the scope ran the task")?;
    let uniform = uniform?.0;
    let Waited {
        waits,
        risk: wait_risk,
        risks: wait_risks,
    } = waited;
    // Each stage the task made kept as `ck.stage` would have kept it, once both are done (the
    // task holds no `Checkpoints`: a kill before then makes its stages again).
    if let Some(s) = spent_waits {
        ck.keep_done(WAIT, &waits, s);
    }
    if let Some(s) = spent_risk {
        ck.keep_done(WAIT_RISK, &wait_risk, s);
    }
    if let Some(s) = spent_run {
        ck.keep_done(WAIT_RUN, &wait_risks, s);
    }
    // Where the uniform policy stops working (a dome's closing zone), both are compared on the
    // points before.
    let until = uniform.until;
    let slots = dwell_points(pl, deps, model.lead())
        .into_iter()
        .filter(|&i| i < until)
        .count();
    let planned_there_s: f64 = plan.dwell_s()[..until].iter().sum();
    Ok(Baselines {
        uniform,
        slots,
        planned_there_s,
        waits,
        wait_risk,
        wait_risks,
        wall_s: clock.elapsed().as_secs_f64(),
    })
}

/// The checkpoint stages of the wait-until-cool baseline: its waits, their first risk, every
/// point's risk in a fresh run with them.
const WAIT: &str = "wait_until_cool";
const WAIT_RISK: &str = "wait_until_cool_risk";
const WAIT_RUN: &str = "wait_until_cool_run";

/// The wait-until-cool baseline: its waits, their first risk, and every point's risk in a
/// fresh run with them.
struct Waited {
    waits: Vec<f64>,
    risk: Option<(usize, Risk)>,
    risks: Vec<Option<Risk>>,
}

/// The stages of [`Waited`] an earlier run kept.
struct KeptWaits {
    waits: Option<Vec<f64>>,
    risk: Option<Option<(usize, Risk)>>,
    risks: Option<Vec<Option<Risk>>>,
}

/// The stages of the wait-until-cool baseline, each taken from `kept` or made, with the
/// wall-clock seconds each one made took.
fn wait_until_cool_runs(
    b: &Build,
    search: &super::dwell::Search,
    kept: KeptWaits,
) -> Result<(Waited, [Option<f64>; 3]), Error> {
    let deps = b.deposits();
    let model = b.heat_model(deps, Vec::new());
    let mut spent = [None; 3];
    let waits = kept_or_made(kept.waits, &mut spent[0], || {
        wait_until_cool(search, &b.plan, &model, deps)
    })?;
    let risk = kept_or_made(kept.risk, &mut spent[1], || {
        first_risk(search, &model, deps, &waits, deps.len())
    })?;
    // Where it fails, all of it: a fresh run with its waits, every point judged.
    let risks = kept_or_made(kept.risks, &mut spent[2], || {
        Ok::<_, ThermalError>(b.simulate(&waits, 0)?.risks(&b.criteria))
    })?;
    Ok((Waited { waits, risk, risks }, spent))
}

/// `kept`, or `make`'s result and the seconds it took in `spent`.
fn kept_or_made<T>(
    kept: Option<T>,
    spent: &mut Option<f64>,
    make: impl FnOnce() -> Result<T, ThermalError>,
) -> Result<T, ThermalError> {
    match kept {
        Some(t) => Ok(t),
        None => {
            let clock = std::time::Instant::now();
            let t = make()?;
            *spent = Some(clock.elapsed().as_secs_f64());
            Ok(t)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed dome R 20 mm on the thin wall.
    fn dome() -> Build {
        super::super::test_parts::dome(20.0, "")
    }

    /// Told to stop, the yardstick ends before its first revolution with `Stopped`, where left
    /// alone it makes a plan.
    #[test]
    fn a_yardstick_told_to_stop_ends_without_a_plan() {
        let b = dome();
        assert!(b.revolution_dwells_unless(&AtomicBool::new(false)).is_ok());
        let stopped = b.revolution_dwells_unless(&AtomicBool::new(true));
        assert!(
            matches!(stopped, Err(ThermalError::Stopped { .. })),
            "{stopped:?}"
        );
    }

    /// The work beside the yardstick failing is what comes back (the yardstick stopped by it
    /// is not reported in its place).
    #[test]
    fn a_failure_beside_the_yardstick_is_what_comes_back() {
        let b = dome();
        let failed = with_yardstick(&b, &mut Checkpoints::off(), |_| {
            Err::<((), SearchedPlan), _>(Error::Measured("the work beside".into()))
        });
        match failed {
            Err(Error::Measured(m)) => assert_eq!(m, "the work beside"),
            other => panic!("{:?}", other.map(|_| ())),
        }
    }

    /// Beside the yardstick, the search's plan is the one made alone, and the yardstick's the
    /// one `revolution_dwells` makes.
    #[test]
    fn beside_the_yardstick_the_plans_are_those_made_alone() {
        let b = dome();
        let work = |ck: &mut Checkpoints<'_>| Ok(((), searched_plan(&b, ck)?));
        let (_, s) = with_yardstick(&b, &mut Checkpoints::off(), work).unwrap();
        let json = |p: &DwellPlan| serde_json::to_string(p).unwrap();
        assert_eq!(json(&s.revolution), json(&b.revolution_dwells().unwrap()));
        let alone = b.plan_dwells().unwrap();
        assert_eq!(s.searched, arc_stops::arc_stops(&alone));
        assert_eq!(s.searched_build_s, arc_stops::build_time_s(&b, &alone));
    }
}
