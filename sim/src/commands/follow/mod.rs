//! `waamtwin follow SCENARIO -o DIR [--until-idle-s S]`: the live twin on a build while it
//! runs. The replay scenario's toolpath is the program; its probe file is followed as the
//! logger writes it ([`tail`]), each row fed to the engine ([`crate::pipeline::twin::follow`])
//! in time order. forecasts.csv, assimilation.csv, alarms.csv and follow.json are rewritten as
//! the run goes (atomically) and at its end; the file contract is in `scenarios/README.md`.
//!
//! The run ends once the data reach the program's end plus the longest horizon (every
//! forecast can be held against a reading), after `--until-idle-s` seconds with nothing new,
//! or on Ctrl-C; a killed run goes on with `--resume` from its last checkpoint and writes
//! what an uninterrupted one does.

mod merge;
#[cfg(feature = "opcua")]
pub mod opcua;
pub mod tail;

use super::checkpoint;
use super::replay::{MOST_COOLING_S, names, one_clock_expected, set_up};
use crate::error::{Error, Result};
use crate::measured::probes::{self, Line};
use crate::output::RunDir;
use crate::pipeline::calibrate::Range;
use crate::pipeline::checkpoint::Checkpoints;
use crate::pipeline::replay::{BELOW_AMBIENT_K, Parameter, Replay, doubts};
use crate::pipeline::resolution::Warning;
use crate::pipeline::twin::asrun::MachineRow;
use crate::pipeline::twin::follow::{Alarm, Follower, Forecast, Horizon, KeptOwned, Unit};
use crate::pipeline::twin::{Twin, Uncertain};
use crate::scenario::replay::{Live, MachineLog, Probes, ReplayScenario, Signal};
use merge::{Merge, Next};
use serde::{Deserialize, Serialize};
use serde_json::json;
use std::fmt::Write;
use std::path::Path;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::{Duration, Instant};
use tail::{Mark, Tail};
use thermal::ZERO_CELSIUS_K as C;

/// How long the loop sleeps when a look found nothing new.
const POLL: Duration = Duration::from_millis(100);
/// How often the files are rewritten while the run goes, wall-clock.
const REWRITE: Duration = Duration::from_secs(10);
/// A reading fed this long (wall) after it was read counts as the twin falling behind.
const BEHIND_S: f64 = 5.0;

/// What the shell counts beside the engine: kept with its checkpoints.
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
struct Counters {
    malformed: usize,
    /// The first few malformed lines, named.
    malformed_lines: Vec<String>,
    below_ambient: usize,
    /// Rows read again after the file was replaced or cut, at or before the last fed.
    reread: usize,
    restarts: Vec<String>,
    /// (data time, wall seconds without a reading) of each stall.
    stalls: Vec<(f64, f64)>,
    /// Wall seconds spent feeding rows, and the build time they covered.
    busy_s: f64,
    first_data_s: Option<f64>,
    lag_max_s: f64,
    lag_sum_s: f64,
    lag_n: usize,
    /// Data times at which a reading was fed more than `BEHIND_S` after it was read.
    behind_at_s: Vec<f64>,
    /// What the OPC UA subscription met, where the readings come from one.
    #[serde(default)]
    opcua: Option<OpcuaCounts>,
    /// Where the machine log's own file is read to, what was fed of it.
    #[serde(default)]
    machine_mark: Mark,
    /// Rows of the machine log's own file that came after readings later than them were fed
    /// (it had stalled): dropped.
    #[serde(default)]
    machine_late: usize,
    /// Rows read from the probe file: until the first, a line whose time does not read is the
    /// logger's preamble, passed over as `replay` passes it.
    #[serde(default)]
    rows_read: usize,
    /// Readings met (before those below ambient were dropped), and what they gave reason to
    /// doubt, said once (`probe_unit`).
    #[serde(default)]
    readings_met: usize,
    #[serde(default)]
    warnings: Vec<(String, String)>,
    /// Per probe, the readings kept (not empty, not 0, not below ambient).
    #[serde(default)]
    kept_per_probe: Vec<usize>,
    /// Readings kept before the first arc (°C, at most `COLD_KEPT`), until the file's unit is
    /// judged on them (`doubts::lookalike`): at the first reading after the first arc, or at
    /// the run's end.
    #[serde(default)]
    cold: Vec<f64>,
    #[serde(default)]
    cold_judged: bool,
}

/// The most readings before the first arc kept to judge the file's unit by: their median is
/// what is judged, and a few thousand readings of a part standing at ambient tell it.
const COLD_KEPT: usize = 4096;

/// Readings met before `follow` judges the share of them below ambient: a logger's first
/// rows may all be a cold start's.
const READINGS_BEFORE_DOUBT: usize = 100;

/// What the OPC UA subscription met (`opcua::Subscription`), for follow.json. Typed plain data,
/// here rather than in the feature's module, so that `Counters` read back from a checkpoint in
/// any build: postcard reads no self-describing value (a `serde_json::Value` here made every
/// `follow` checkpoint unreadable, its resume a silent restart, until 2026-11-30).
#[derive(Debug, Clone, Default, Serialize, Deserialize)]
pub struct OpcuaCounts {
    /// Values that came again (at or before a row already handed on), not fed.
    pub repeated: usize,
    /// Rows handed on with a probe missing (its node sent nothing at that time).
    pub rows_incomplete: usize,
    pub lost: Vec<String>,
    pub reconnects: usize,
}

/// Where the readings come from: the probe file as the logger writes it, or the cell's OPC UA
/// server.
enum Source {
    File(Tail),
    #[cfg(feature = "opcua")]
    Opcua(opcua::Subscription),
}

/// What one look at the source brought: a file's lines, still to be read, or rows.
enum Brought {
    Lines(Vec<(Mark, String)>),
    #[cfg_attr(not(feature = "opcua"), allow(dead_code))]
    Rows(Vec<Row>),
}

impl Source {
    fn open(p: &Probes, live: &Live, mark: Mark, data_s: Option<f64>) -> Result<Source> {
        let Some(o) = &live.opcua else {
            return Ok(Source::File(Tail::new(&p.file, mark)));
        };
        #[cfg(feature = "opcua")]
        {
            let width = p.points.len() + Signal::ALL.len();
            let mut sub = opcua::Subscription::start(o, width).map_err(Error::input)?;
            sub.after(data_s);
            Ok(Source::Opcua(sub))
        }
        #[cfg(not(feature = "opcua"))]
        {
            let _ = (o, data_s);
            Err(Error::input(
                "[live.opcua]: this waamtwin was built without OPC UA (feature \"opcua\")",
            ))
        }
    }

    /// The file, or the endpoint, as messages name it.
    fn name(p: &Probes, live: &Live) -> String {
        live.opcua
            .as_ref()
            .map_or_else(|| p.file.display().to_string(), |o| o.endpoint.clone())
    }

    /// What is new, and lines that say what happened to the source.
    fn look(&mut self, name: &str, c: &mut Counters) -> Result<(Brought, Vec<String>)> {
        match self {
            Source::File(tail) => {
                let look = tail
                    .look()
                    .map_err(|e| Error::failure(format!("cannot read {name}: {e}")))?;
                let said: Vec<String> = look
                    .restarted
                    .map(|why| format!("{why}; read again from its start"))
                    .into_iter()
                    .collect();
                c.restarts
                    .extend(said.iter().map(|l| format!("{name}: {l}")));
                Ok((Brought::Lines(look.lines), said))
            }
            #[cfg(feature = "opcua")]
            Source::Opcua(sub) => {
                let (rows, said) = sub
                    .look()
                    .map_err(|e| Error::failure(format!("OPC UA {name}: {e}")))?;
                c.opcua = Some(sub.counts.clone());
                Ok((Brought::Rows(rows), said))
            }
        }
    }
}

/// The priors: `[live] prior`'s calibration.json where given, else `[calibrate]`'s ranges.
fn priors(s: &ReplayScenario, live: &Live, r: &Replay) -> Result<Vec<Uncertain>> {
    if let Some(file) = &live.prior {
        return prior_of_calibration(file);
    }
    let Some(cal) = &s.calibrate else {
        return Err(Error::input(
            "follow needs the uncertain parameters: a [calibrate] section with their ranges, \
             or [live] prior = a calibration.json",
        ));
    };
    Ok(cal
        .parameters
        .iter()
        .map(|f| Uncertain::from_range(f.parameter, f.range, f.parameter.of(&r.values)))
        .collect())
}

/// A calibration.json's fitted values as the prior: its values the means, their standard
/// deviations (the covariance's diagonal, else the 95 % interval's) the spreads, its search
/// ranges the bounds. A name this waamtwin does not know is an error here: a prior that
/// silently left out a parameter would be certain of it.
fn prior_of_calibration(file: &Path) -> Result<Vec<Uncertain>> {
    let f = crate::scenario::calibration::read(file)?;
    if let Some((name, _)) = f.unknown.first() {
        return Err(Error::input(format!(
            "{}: parameter {name} is not one the twin learns; expected {}",
            file.display(),
            Parameter::ALL.map(|p| p.key()).join(", ")
        )));
    }
    Ok(f.fitted
        .iter()
        .map(|p| Uncertain {
            parameter: p.parameter,
            range: Range {
                low: p.low,
                high: p.high,
            },
            mean: p.value,
            sd: p.sd.unwrap_or((p.high - p.low) / 4.0).max(1e-9),
        })
        .collect())
}

/// A row's readings in °C, those below ambient dropped (counted), as replay reads them.
/// Once [`READINGS_BEFORE_DOUBT`] readings have come, most of them below ambient doubt the
/// unit: said once, on stderr and in follow.json's `warnings`, as `replay` says it.
fn in_celsius(values: &mut [Option<f64>], kelvin: bool, ambient_k: f64, c: &mut Counters) {
    let floor_c = ambient_k - C - BELOW_AMBIENT_K;
    for v in values.iter_mut() {
        if let Some(x) = v {
            c.readings_met += 1;
            if kelvin {
                *x -= C;
            }
            if *x < floor_c {
                *v = None;
                c.below_ambient += 1;
            }
        }
    }
    if c.readings_met >= READINGS_BEFORE_DOUBT
        && let Some(w) = doubts::below_ambient(c.below_ambient, c.readings_met, kelvin, ambient_k)
    {
        say_once(c, w);
    }
}

/// A doubt said once: on stderr and in follow.json's `warnings`, unless one of its kind was.
fn say_once(c: &mut Counters, w: Warning) {
    if c.warnings.iter().all(|(kind, _)| kind != w.kind) {
        eprintln!("follow: {}", w.line);
        c.warnings.push((w.kind.to_string(), w.line));
    }
}

/// The first arc and the last deposit of the build, s.
fn build_span(deps: &[thermal::schedule::Deposit]) -> (f64, f64) {
    let first_arc_s = deps.first().map_or(0.0, |d| d.arc_start());
    (first_arc_s, deps.last().map_or(0.0, |d| d.time))
}

/// The readings' clock and the file's unit, doubted as `replay` doubts them and as soon as the
/// readings show it: a first reading (at `t`) after the last deposit (`probe_clock`: a logger
/// an hour ahead of the program); readings before the first arc at ambient's kelvin read as
/// °C (`probe_unit`), judged at the first reading after the arc. What shows only at the end
/// (all readings before the first arc) is said by `say_at_end`.
fn doubt_live(
    t: f64,
    values: &[Option<f64>],
    deps: &[thermal::schedule::Deposit],
    c: &mut Counters,
    (kelvin, ambient_k): (bool, f64),
) {
    let (first_arc_s, last_s) = build_span(deps);
    if c.first_data_s.is_none()
        && t > last_s
        && let Some(w) = doubts::clock(&[t], first_arc_s, last_s)
    {
        say_once(c, w);
    }
    if kelvin || c.cold_judged {
        return;
    }
    if t < first_arc_s {
        let room = COLD_KEPT.saturating_sub(c.cold.len());
        c.cold.extend(values.iter().flatten().take(room));
        return;
    }
    judge_cold(c, ambient_k, first_arc_s);
}

/// The file's unit judged on the readings kept before the first arc, once.
fn judge_cold(c: &mut Counters, ambient_k: f64, first_arc_s: f64) {
    c.cold_judged = true;
    if let Some(w) = doubts::lookalike(std::mem::take(&mut c.cold), ambient_k, first_arc_s) {
        say_once(c, w);
    }
}

/// At the run's end, what only the whole run shows: readings that all ended before the first
/// arc (`probe_clock`), and the unit judged on them where no reading came after it.
fn say_at_end(f: &Follower, c: &mut Counters, (kelvin, ambient_k): (bool, f64)) {
    let (first_arc_s, last_s) = build_span(f.twin.deps());
    if let (Some(first), Some(last)) = (c.first_data_s, f.data_s())
        && let Some(w) = doubts::clock(&[first, last], first_arc_s, last_s)
    {
        say_once(c, w);
    }
    if !kelvin && !c.cold_judged {
        judge_cold(c, ambient_k, first_arc_s);
    }
}

/// Count each probe's readings kept (not empty, not 0, not below ambient).
fn count_kept(values: &[Option<f64>], p: &Probes, c: &mut Counters) {
    c.kept_per_probe.resize(p.points.len(), 0);
    for (k, v) in values.iter().enumerate().take(p.points.len()) {
        c.kept_per_probe[k] += usize::from(v.is_some());
    }
}

/// At the run's end, the probes whose column held no reading in any row followed, named by
/// their columns (`probe_empty`, as `replay` names them): a column counted wrong leaves the
/// twin a probe that never spoke. Not asked sooner: a camera's pixel reads nothing until its
/// layer is laid (the GAMMA wall's first reading comes at 120 s).
fn say_empty(p: &Probes, c: &mut Counters) {
    c.kept_per_probe.resize(p.points.len(), 0);
    let met: Vec<doubts::Met<'_>> = p
        .points
        .iter()
        .zip(&c.kept_per_probe)
        .map(|(q, &kept)| doubts::Met {
            name: &q.name,
            position_mm: q.position_m.map(|x| x * 1e3),
            column: q.column,
            read: kept > 0,
            // Whether metal met it is the twin's to show, not said here.
            compared: true,
        })
        .collect();
    for w in doubts::probes(&met) {
        eprintln!("follow: {}", w.line);
        c.warnings.push((w.kind.to_string(), w.line));
    }
}

/// How much of the probe file [`readings_expected`] reads for its pace, bytes.
const PACE_HEAD_BYTES: u64 = 64 * 1024;

/// The readings the twin will hold by the build's end `end_s`, as the probe file's first rows
/// pace them: every probe at every row (an upper bound: a camera's pixels read nothing until
/// metal is there), the rows at the pace of the file's first 64 kB. None where the file is not
/// there yet or has fewer than two rows: a build not begun says nothing of its pace.
fn readings_expected(p: &Probes, end_s: f64) -> Option<usize> {
    use std::io::Read;
    let mut head = String::new();
    std::fs::File::open(&p.file)
        .ok()?
        .take(PACE_HEAD_BYTES)
        .read_to_string(&mut head)
        .ok()?;
    // The last line may be cut by the head's end, or still being written.
    let whole = &head[..head.rfind('\n')?];
    let times: Vec<f64> = whole
        .lines()
        .enumerate()
        .filter_map(
            |(k, text)| match probes::line(text, k + 1, p.time_column, &[]) {
                Ok(Line::Row(t, _)) => Some(t),
                _ => None,
            },
        )
        .collect();
    let (&first, &last) = (times.first()?, times.last()?);
    if times.len() < 2 || last <= first {
        return None;
    }
    let every_s = (last - first) / (times.len() - 1) as f64;
    let rows = ((end_s - first) / every_s).max(0.0) + 1.0;
    Some((rows.max(times.len() as f64) * p.points.len() as f64) as usize)
}

/// Set by Ctrl-C ([`catch_ctrl_c`]) or by [`interrupt`]: the run ends at its next look, as
/// it ends when the data stop, with every output written.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// End the run that follows now at its next look (the Python package's Ctrl-C). One that
/// comes while the run is still setting up (the twin's members started, the outputs opened)
/// ends it at its first look: the run never clears it, its caller does ([`clear_interrupt`]).
pub fn interrupt() {
    INTERRUPTED.store(true, Ordering::SeqCst);
}

/// Forget an [`interrupt`]: before a run in a process that may have interrupted one before.
/// The run itself does not, or a Ctrl-C during its setup would be lost and it would wait for
/// data for ever (the Python test's SIGINT at 8 s, on a loaded machine, once did).
pub fn clear_interrupt() {
    INTERRUPTED.store(false, Ordering::SeqCst);
}

/// Make Ctrl-C end `follow` gracefully. The command line calls it before `follow`; a library
/// caller does not, so that its own Ctrl-C handling (Python's) stays its own. One handler for
/// the process (a second would be refused); without it Ctrl-C ends the process at once.
pub fn catch_ctrl_c() {
    static HANDLER: std::sync::Once = std::sync::Once::new();
    HANDLER.call_once(|| {
        let _ = ctrlc::set_handler(interrupt);
    });
}

pub fn run(
    scenario: &Path,
    out: &Path,
    until_idle_s: Option<f64>,
    connect: Option<&str>,
    resume: checkpoint::Options,
) -> Result<String> {
    let s = ReplayScenario::load(scenario)?;
    let name = scenario.display().to_string();
    let Some(p) = s.probes.clone() else {
        return Err(Error::input(format!(
            "{name}: no [probes]; follow needs the sensors it follows"
        )));
    };
    if let Some(v) = until_idle_s
        && !(v.is_finite() && v > 0.0)
    {
        return Err(Error::input(format!(
            "--until-idle-s {v}; expected seconds, more than 0"
        )));
    }
    #[cfg(feature = "recording")]
    if let Some(url) = connect {
        crate::record::live::viewer(url)?;
    }
    let live = s.live.clone().unwrap_or_default();
    let mut twin_scenario = s.clone();
    if let Some(v) = live.voxel_m {
        twin_scenario.thermal.voxel_m = v;
    }
    // The GPU steps every plate cell (coarsening is a CPU economy it does not run).
    twin_scenario.thermal.coarse_plate =
        live.coarse_plate && twin_scenario.thermal.device == thermal::voxel::Device::Cpu;
    let r = set_up(&twin_scenario, 1.0)?;
    let priors = priors(&s, &live, &r)?;
    // The ensemble's members and the open loop, each a model over the whole build, and each
    // copied and run on to the longest horizon at every forecast (`Twin::forecast`).
    let (runs, t) = (live.twin.ensemble as f64 + 1.0, &live.twin);
    let ahead = t.horizons_s.iter().copied().fold(0.0, f64::max) / t.forecast_every_s;
    super::cost::check_replay(
        &name,
        &r,
        r.deps.last().map_or(0.0, |d| d.time),
        super::cost::Keeps {
            copies: 2.0 * runs,
            runs: runs * (1.0 + ahead),
            readings: readings_expected(&p, r.deps.last().map_or(0.0, |d| d.time)).unwrap_or(0),
            ..super::cost::Keeps::ONE_RUN
        },
        match live.voxel_m {
            Some(_) => "live.voxel_mm",
            None => "thermal.voxel_mm",
        },
    )?;
    let print = checkpoint::of_run("follow", &s.to_json(), &r.deps);
    let mut folder = checkpoint::Folder::open(out, "follow", print, resume)?;
    let mut ck = Checkpoints::to(&mut folder);
    let twin = Twin::new(&r, live.twin.clone(), priors.clone())
        .map_err(|e| Error::from(e).context(&name))?;
    // The machine's signals in the probe file's rows, or in a file of their own.
    let machine_file = live.machine_log.as_ref().and_then(|m| m.file.clone());
    let in_rows = live.machine_log.as_ref().filter(|m| m.file.is_none());
    let layout = Layout::of(&p, in_rows);
    let (mut follower, mut probe_mark, mut counters) =
        match ck.load::<(KeptOwned, Mark, Counters)>("follow") {
            Some((kept, mark, counters)) => (Follower::resume(twin, &r.deps, kept), mark, counters),
            None => (
                Follower::new(twin, &r.deps, p.points.len()),
                Mark::default(),
                Counters::default(),
            ),
        };
    if live.machine_log.is_some() {
        follower = follower.with_machine_log(s.laying.power_w);
    };
    let mut source = Source::open(&p, &live, probe_mark.clone(), follower.data_s())?;
    let mut machine = machine_file
        .as_ref()
        .map(|(file, _)| MachineFile::new(file, counters.machine_mark.clone()));
    let source_name = Source::name(&p, &live);
    let mut dir = RunDir::create(out)?;
    let names = names(&p);
    let interpass_c = live.twin.tightest_limit().map(|(_, k)| k - C);
    let mut rec = Recorder::open(
        &dir,
        scenario,
        (&r, &p, &priors),
        (&live.twin.horizons_s, interpass_c),
        connect,
    )?;
    let longest = live.twin.horizons_s.iter().copied().fold(0.0, f64::max);
    let clock = Instant::now();
    let (mut last_new, mut last_any, mut last_rewrite) =
        (Instant::now(), Instant::now(), Instant::now());
    let mut stalled = false;
    let mut merge = Merge::new();
    // The program's end as the machine log has moved it, where the build has one.
    let done = |f: &Follower| {
        let end = f.twin.deps().last().map_or(0.0, |d| d.time);
        f.data_s().is_some_and(|d| d >= end + longest)
    };
    let ending = loop {
        if INTERRUPTED.load(Ordering::SeqCst) {
            break "interrupted (Ctrl-C)";
        }
        let (brought, said) = source.look(&source_name, &mut counters)?;
        let read_at = Instant::now();
        for line in said {
            eprintln!("follow: {source_name}: {line}");
        }
        let fresh = match &brought {
            Brought::Lines(l) => !l.is_empty(),
            Brought::Rows(r) => !r.is_empty(),
        };
        if fresh {
            if stalled {
                eprintln!(
                    "follow: {source_name}: readings again after {:.0} s",
                    last_new.elapsed().as_secs_f64()
                );
                if let Some(s) = counters.stalls.last_mut() {
                    s.1 = last_new.elapsed().as_secs_f64();
                }
                stalled = false;
            }
            last_new = Instant::now();
        }
        match brought {
            Brought::Lines(lines) => {
                for (mark, text) in lines {
                    match parse(&mut counters, &p, &layout, (mark.lines, &text))? {
                        Some(row) => merge.probe(mark, row),
                        // A line that is no row is read for good once nothing before it
                        // waits (a resumed run does not count a malformed one twice).
                        None if merge.holds_no_probe_row() => probe_mark = mark,
                        None => {}
                    }
                }
            }
            Brought::Rows(rows) => rows
                .into_iter()
                .for_each(|r| merge.probe(Mark::default(), r)),
        }
        let mut machine_fresh = false;
        if let (Some(m), Some(log)) = (machine.as_mut(), live.machine_log.as_ref()) {
            machine_fresh = m.look(log, live.stall_s, &mut counters, &mut merge)?;
        }
        // The machine's rows wait for the readings even while the probe file stalls (the twin
        // moves on readings alone; a row fed early would reach back into forecasts made at
        // earlier moments); the readings wait for the machine's file unless it stalls.
        let machine_waits = machine.as_ref().is_some_and(|m| !m.stalled);
        while let Some(next) = merge.next(true, machine_waits) {
            // Rows past the end are left unread: where a run ends does not hang on how the
            // sources were cut into looks.
            if done(&follower) {
                break;
            }
            let at = (&mut probe_mark, read_at);
            take(
                &mut follower,
                &mut counters,
                next,
                at,
                (&s, &p, live.machine_log.as_ref()),
                &mut rec,
            )?;
            // Kept after a row, with where the files are read to after it: a resumed run
            // reads on from the next row whatever the looks were.
            ck.save_if_due("follow", || (follower.kept(), &probe_mark, &counters));
            if last_rewrite.elapsed() >= REWRITE {
                write(
                    &mut dir, &follower, &names, &priors, &counters, &clock, "running",
                )?;
                last_rewrite = Instant::now();
            }
        }
        if done(&follower) {
            break "the data reached the program's end and the longest horizon";
        }
        // Idle counts from the end of the work on what came, not from its reading: a twin that
        // fell behind must not take its own lag for a silent logger. The probe file stalls on
        // its own silence (a machine log still growing beside it does not hide that); the run
        // is idle when neither file grows.
        if fresh {
            last_new = Instant::now();
        }
        if fresh || machine_fresh {
            last_any = Instant::now();
        }
        let idle = last_new.elapsed().as_secs_f64();
        if until_idle_s.is_some_and(|u| last_any.elapsed().as_secs_f64() >= u) {
            break "nothing new for --until-idle-s";
        }
        if !stalled && idle >= live.stall_s {
            stalled = true;
            let at = follower.data_s().unwrap_or(f64::NAN);
            eprintln!(
                "follow: {source_name}: no new reading for {idle:.0} s (data at t = {at:.1} s); \
                 the twin keeps its state and waits"
            );
            counters.stalls.push((at, idle));
        }
        if stalled && let Some(s) = counters.stalls.last_mut() {
            s.1 = idle;
        }
        if !(fresh || machine_fresh) {
            std::thread::sleep(POLL);
        }
    };
    // What was read and held for the other file goes now, in time order.
    while let Some(next) = merge.next(false, false) {
        if done(&follower) {
            break;
        }
        let at = (&mut probe_mark, Instant::now());
        take(
            &mut follower,
            &mut counters,
            next,
            at,
            (&s, &p, live.machine_log.as_ref()),
            &mut rec,
        )?;
    }
    say_empty(&p, &mut counters);
    say_at_end(&follower, &mut counters, (p.kelvin, s.thermal.ambient_k));
    write(
        &mut dir, &follower, &names, &priors, &counters, &clock, ending,
    )?;
    rec.finish(&mut dir, &follower)?;
    #[cfg(feature = "recording")]
    record(&mut dir, scenario, &p, &follower)?;
    dir.finish("follow", s.to_json())?;
    folder.close()?;
    Ok(summary(&follower, &counters, ending))
}

/// A row: build time, s, and its values (None where it has none): a reading per probe (°C or
/// K as the file says), then the machine's signals ([`Signal`]).
type Row = (f64, Vec<Option<f64>>);

/// Where a probe file's columns go in a row.
struct Layout {
    probes: Vec<usize>,
    /// The machine log's columns, and each one's slot after the probes.
    signals: Vec<usize>,
    slots: Vec<usize>,
}

impl Layout {
    fn of(p: &Probes, machine: Option<&MachineLog>) -> Layout {
        let n = p.points.len();
        let (mut signals, mut slots) = (Vec::new(), Vec::new());
        for (k, c) in machine
            .map_or([None; 4], |m| m.columns)
            .into_iter()
            .enumerate()
        {
            if let Some(c) = c {
                signals.push(c);
                slots.push(n + k);
            }
        }
        Layout {
            probes: p.points.iter().map(|q| q.column).collect(),
            signals,
            slots,
        }
    }
}

/// Line `n` of the probe file as a row; a line that does not read is named, counted and
/// skipped (None).
fn parse(
    c: &mut Counters,
    p: &Probes,
    l: &Layout,
    (n, text): (usize, &str),
) -> Result<Option<Row>> {
    if c.rows_read == 0
        && n <= probes::MOST_PREAMBLE_LINES
        && !probes::time_reads(text, p.time_column)
    {
        return match probes::unit_in_line(text, &l.probes, p.kelvin) {
            Some((column, cell)) => Err(Error::input(format!(
                "{} line {n}: {}",
                p.file.display(),
                probes::unit_against(column, &cell, p.kelvin)
            ))),
            None => Ok(None),
        };
    }
    let read = probes::line(text, n, p.time_column, &l.probes).and_then(|row| {
        match (row, l.signals.is_empty()) {
            (Line::Row(t, mut values), false) => {
                let Line::Row(_, signals) = probes::signals(text, n, p.time_column, &l.signals)?
                else {
                    return Ok(Line::Nothing);
                };
                values.resize(p.points.len() + Signal::ALL.len(), None);
                for (&slot, v) in l.slots.iter().zip(signals) {
                    values[slot] = v;
                }
                Ok(Line::Row(t, values))
            }
            (row, _) => Ok(row),
        }
    });
    Ok(match read {
        Ok(Line::Nothing) => None,
        Ok(Line::Row(t, v)) => {
            c.rows_read += 1;
            Some((t, v))
        }
        Err(e) => {
            let line = format!("{} line {n}: {e}", p.file.display());
            eprintln!("follow: skipped {line}");
            c.malformed += 1;
            if c.malformed_lines.len() < 20 {
                c.malformed_lines.push(line);
            }
            None
        }
    })
}

/// Feed what the merge let go: a probe row to the engine ([`feed`]), or a row of the machine
/// log's own file (one earlier than the readings already fed came too late: counted and
/// dropped); `probe_mark` and the counters' `machine_mark` then say where its file is read to.
fn take(
    follower: &mut Follower,
    counters: &mut Counters,
    next: Next,
    (probe_mark, read_at): (&mut Mark, Instant),
    of: (&ReplayScenario, &Probes, Option<&MachineLog>),
    rec: &mut Recorder,
) -> Result<()> {
    match next {
        Next::Probe(mark, row) => {
            feed(follower, counters, row, of, read_at, rec)?;
            *probe_mark = mark;
        }
        Next::Machine(mark, row) => {
            match follower.data_s().is_some_and(|d| row.t_s < d) {
                true => counters.machine_late += 1,
                false => follower.machine(row),
            }
            counters.machine_mark = mark;
        }
    }
    Ok(())
}

/// The machine log's own file (`[live.machine_log] file`), followed as the probe file is.
struct MachineFile {
    tail: Tail,
    /// No new line for `[live] stall_s`: the readings no longer wait for it.
    stalled: bool,
    last_new: Instant,
}

impl MachineFile {
    fn new(path: &Path, mark: Mark) -> MachineFile {
        MachineFile {
            tail: Tail::new(path, mark),
            stalled: false,
            last_new: Instant::now(),
        }
    }

    /// Read what is new into `merge`; whether anything came. Says when the file was cut or
    /// replaced, when it stalls and when it comes back.
    fn look(
        &mut self,
        log: &MachineLog,
        stall_s: f64,
        c: &mut Counters,
        merge: &mut Merge,
    ) -> Result<bool> {
        let name = self.tail.path().display().to_string();
        let look = self
            .tail
            .look()
            .map_err(|e| Error::failure(format!("cannot read {name}: {e}")))?;
        if let Some(why) = look.restarted {
            let line = format!("{name}: {why}; read again from its start");
            eprintln!("follow: {line}");
            c.restarts.push(line);
        }
        let fresh = !look.lines.is_empty();
        for (mark, text) in look.lines {
            if let Some(row) = machine_line(c, log, &name, (mark.lines, &text)) {
                merge.machine(mark, row);
            }
        }
        let quiet = self.last_new.elapsed().as_secs_f64();
        if fresh {
            if self.stalled {
                eprintln!("follow: {name}: the machine log again after {quiet:.0} s");
            }
            (self.stalled, self.last_new) = (false, Instant::now());
        } else if !self.stalled && quiet >= stall_s {
            self.stalled = true;
            eprintln!(
                "follow: {name}: no new line for {quiet:.0} s; the readings go on without it \
                 (the program as programmed where the log has not reached)"
            );
        }
        Ok(fresh)
    }
}

/// Line `n` of the machine log's own file as a machine row; a line that does not read is
/// named, counted and skipped, one that does not say the arc's state is nothing.
fn machine_line(
    c: &mut Counters,
    log: &MachineLog,
    name: &str,
    (n, text): (usize, &str),
) -> Option<MachineRow> {
    let time_column = log.file.as_ref().map_or(0, |f| f.1);
    let (columns, slots): (Vec<usize>, Vec<usize>) = log
        .columns
        .iter()
        .enumerate()
        .filter_map(|(k, c)| c.map(|c| (c, k)))
        .unzip();
    match probes::signals(text, n, time_column, &columns) {
        Ok(Line::Row(t, values)) => {
            let mut signals = [None; Signal::ALL.len()];
            for (slot, v) in slots.into_iter().zip(values) {
                signals[slot] = v;
            }
            machine_row(t, &signals, log)
        }
        Ok(Line::Nothing) => None,
        Err(e) => {
            let line = format!("{name} line {n}: {e}");
            eprintln!("follow: skipped {line}");
            c.malformed += 1;
            if c.malformed_lines.len() < 20 {
                c.malformed_lines.push(line);
            }
            None
        }
    }
}

/// Feed a row to the engine (one read again after the source restarted is counted and
/// skipped).
fn feed(
    follower: &mut Follower,
    counters: &mut Counters,
    (t, mut values): Row,
    (s, p, machine): (&ReplayScenario, &Probes, Option<&MachineLog>),
    read_at: Instant,
    rec: &mut Recorder,
) -> Result<()> {
    if !counters.restarts.is_empty() && follower.data_s().is_some_and(|d| t <= d) {
        counters.reread += 1;
        return Ok(());
    }
    // A reading on another clock (a logger's Unix time) would have the twin cool the part
    // for years before it: refused before it is fed, as `replay` refuses the file.
    let end_s = follower.twin.deps().last().map_or(0.0, |d| d.time);
    if t - end_s > MOST_COOLING_S {
        return Err(Error::input(format!(
            "{}: a reading at {t} s, {:.3e} s after the program's last deposit at {end_s:.1} s; \
             {}",
            p.file.display(),
            t - end_s,
            one_clock_expected()
        )));
    }
    let signals = values.split_off(p.points.len().min(values.len()));
    in_celsius(&mut values, p.kelvin, s.thermal.ambient_k, counters);
    count_kept(&values, p, counters);
    let unit = (p.kelvin, s.thermal.ambient_k);
    doubt_live(t, &values, follower.twin.deps(), counters, unit);
    let before = Instant::now();
    if let Some(m) = machine
        && let Some(row) = machine_row(t, &signals, m)
    {
        follower.machine(row);
    }
    let alarms = follower
        .feed(t, &values)
        .map_err(|e| Error::from(e).context(format!("follow at t = {t} s")))?;
    for a in &alarms {
        eprintln!("follow: {}", a.line());
    }
    counters.busy_s += before.elapsed().as_secs_f64();
    rec.row(t, &values, follower)?;
    counters.first_data_s.get_or_insert(t);
    let lag = read_at.elapsed().as_secs_f64();
    counters.lag_max_s = counters.lag_max_s.max(lag);
    counters.lag_sum_s += lag;
    counters.lag_n += 1;
    if lag > BEHIND_S && counters.behind_at_s.len() < 1000 {
        counters.behind_at_s.push(t);
    }
    Ok(())
}

/// The machine's state in a row's signals: the arc (on above the threshold) and the power
/// (logged, or V·I); None where the row does not say the arc's state.
fn machine_row(t_s: f64, signals: &[Option<f64>], m: &MachineLog) -> Option<MachineRow> {
    let at = |s: Signal| signals.get(s as usize).copied().flatten();
    let arc = at(Signal::ArcOn)?;
    let power_w =
        at(Signal::PowerW).or_else(|| Some(at(Signal::VoltageV)? * at(Signal::CurrentA)?));
    Some(MachineRow {
        t_s,
        arc_on: arc > m.arc_on_above,
        power_w,
    })
}

/// probes.png and run.mcap: each probe as measured and as forecast one horizon (the shortest)
/// before, at the forecasts' targets.
#[cfg(feature = "recording")]
fn record(dir: &mut RunDir, scenario: &Path, p: &Probes, f: &Follower) -> Result<()> {
    let Some(&first) = f.twin.settings.horizons_s.first() else {
        return Ok(());
    };
    let samples: Vec<Vec<crate::pipeline::replay::Sample>> = (0..p.points.len())
        .map(|k| {
            let mut v: Vec<_> = f
                .progress
                .forecasts
                .iter()
                .filter(|x| x.probe == k && x.horizon == Horizon::After(first))
                .filter_map(|x| Some((x.target_t_s, x.measured_c?, x.predicted_c)))
                .collect();
            v.sort_by(|a, b| a.0.total_cmp(&b.0));
            v
        })
        .collect();
    if samples.iter().all(Vec::is_empty) {
        return Ok(());
    }
    let title = format!(
        "{}: forecast {first:.0} s before",
        scenario
            .file_stem()
            .map_or("follow".into(), |n| n.to_string_lossy())
    );
    let series: Vec<(&str, &[crate::pipeline::replay::Sample])> = p
        .points
        .iter()
        .zip(&samples)
        .map(|(q, s)| (q.name.as_str(), s.as_slice()))
        .collect();
    crate::record::probe_plot(dir, "probes.png", &title, &series, None)?;
    let recorded: Vec<crate::record::replay::ProbeSeries> = p
        .points
        .iter()
        .zip(&samples)
        .map(|(q, s)| crate::record::replay::ProbeSeries {
            name: &q.name,
            position_mm: q.position_m.map(|x| x * 1e3),
            samples: s,
        })
        .collect();
    crate::record::replay::mcap(dir, &title, &recorded)
}

/// The part's top surface (mm) at the members' mean temperature (°C); None on a model
/// without voxels.
#[cfg(feature = "recording")]
fn part(f: &Follower) -> Option<(Vec<[f64; 3]>, Vec<f64>)> {
    let members = f.twin.read_members(&|run| match run {
        thermal::ModelRun::Voxel(v) => {
            let m = v.model();
            m.top_surface()
                .into_iter()
                .map(|(k, c)| (c.map(|x| x * 1e3), m.temperature(k) - C))
                .collect()
        }
        _ => Vec::new(),
    });
    // Every member lays the same voxels (one schedule), in the same order.
    let first = members.first().filter(|m| !m.is_empty())?;
    let n = members.len() as f64;
    let temps = (0..first.len())
        .map(|i| members.iter().map(|m| m[i].1).sum::<f64>() / n)
        .collect();
    Some((first.iter().map(|p| p.0).collect(), temps))
}

/// run.rrd as the run goes ([`crate::record::live`]), where this build records.
struct Recorder(#[cfg(feature = "recording")] crate::record::live::LiveRecording);

impl Recorder {
    fn open(
        dir: &RunDir,
        scenario: &Path,
        (r, p, priors): (&Replay, &Probes, &[Uncertain]),
        (horizons_s, interpass_c): (&[f64], Option<f64>),
        connect: Option<&str>,
    ) -> Result<Recorder> {
        #[cfg(feature = "recording")]
        {
            let title = scenario
                .file_stem()
                .map_or("follow".into(), |n| n.to_string_lossy())
                .to_string();
            let probes: Vec<(String, [f64; 3])> = p
                .points
                .iter()
                .map(|q| (q.name.clone(), q.position_m.map(|x| x * 1e3)))
                .collect();
            let parameters: Vec<(&'static str, [f64; 2])> = priors
                .iter()
                .map(|u| (u.parameter.key(), [u.range.low, u.range.high]))
                .collect();
            let scene = crate::record::live::Scene {
                title: &format!("{title}: followed live"),
                tracks: &super::replay::tracks(&r.deps),
                probes: &probes,
                parameters: &parameters,
                horizons_s,
                ambient_c: r.values.thermal.ambient_k - C,
                interpass_c,
            };
            crate::record::live::LiveRecording::open(dir, &scene, connect).map(Recorder)
        }
        #[cfg(not(feature = "recording"))]
        {
            let _ = (dir, scenario, r, p, priors, horizons_s, interpass_c);
            match connect {
                Some(_) => Err(Error::input(
                    "--connect: this waamtwin was built without recordings (feature \"recording\")",
                )),
                None => Ok(Recorder()),
            }
        }
    }

    /// A row's readings (°C), and what the follower made of it.
    fn row(&mut self, t_s: f64, values_c: &[Option<f64>], f: &Follower) -> Result<()> {
        #[cfg(feature = "recording")]
        {
            self.0.readings(t_s, values_c)?;
            self.0.progress(&f.progress)?;
            let every = crate::record::live::FIELD_EVERY_S;
            if self.0.field_at_s.is_none_or(|at| t_s >= at + every)
                && let Some((points, temps)) = part(f)
            {
                self.0.field(t_s, &points, &temps)?;
            }
        }
        #[cfg(not(feature = "recording"))]
        let _ = (t_s, values_c, f);
        Ok(())
    }

    fn finish(self, dir: &mut RunDir, f: &Follower) -> Result<()> {
        #[cfg(feature = "recording")]
        {
            let mut live = self.0;
            live.progress(&f.progress)?;
            live.finish(dir)?;
        }
        #[cfg(not(feature = "recording"))]
        let _ = (self, dir, f);
        Ok(())
    }
}

/// Per horizon, over every probe: the forecasts' RMS against what was measured.
fn summary(f: &Follower, c: &Counters, ending: &str) -> String {
    let p = &f.progress;
    let mut line = format!(
        "{} rows, {} readings, {} forecasts, {} alarms; {ending}",
        p.rows,
        p.readings,
        p.forecasts.len(),
        p.alarms.len()
    );
    for h in horizons(&p.forecasts) {
        if let Some(s) = score(&p.forecasts, |x| x.horizon == h) {
            let _ = write!(
                line,
                "; {}: RMS {:.1} °C (open loop {:.1}, persistence {:.1})",
                h.label(),
                s.assimilated_rms_c,
                s.open_loop_rms_c,
                s.persistence_rms_c
            );
        }
    }
    if c.malformed + p.back_in_time > 0 {
        let _ = write!(
            line,
            "; refused {} malformed, {} back in time",
            c.malformed, p.back_in_time
        );
    }
    line
}

/// The horizons forecast, in order.
fn horizons(forecasts: &[Forecast]) -> Vec<Horizon> {
    let mut out: Vec<Horizon> = Vec::new();
    for f in forecasts {
        if !out.contains(&f.horizon) {
            out.push(f.horizon);
        }
    }
    out.sort_by(|a, b| match (a, b) {
        (Horizon::After(x), Horizon::After(y)) => x.total_cmp(y),
        (Horizon::After(_), Horizon::NextLayer) => std::cmp::Ordering::Less,
        (Horizon::NextLayer, Horizon::After(_)) => std::cmp::Ordering::Greater,
        _ => std::cmp::Ordering::Equal,
    });
    out
}

/// How well forecasts did against what was measured.
#[derive(Debug, Clone, Copy, PartialEq, Serialize)]
struct Score {
    forecasts: usize,
    assimilated_rms_c: f64,
    open_loop_rms_c: f64,
    persistence_rms_c: f64,
    /// The ensemble's own mean, before what the sensor taught.
    ensemble_rms_c: f64,
    /// Share of the readings inside the 5–95 % band.
    band_coverage: f64,
}

/// The score of the measured forecasts `keep` picks (those with a persistence too, so that
/// the three are judged on the same readings); None without one.
fn score(forecasts: &[Forecast], keep: impl Fn(&Forecast) -> bool) -> Option<Score> {
    let (mut n, mut a, mut o, mut p, mut e, mut inside) = (0usize, 0.0, 0.0, 0.0, 0.0, 0usize);
    for f in forecasts.iter().filter(|f| keep(f)) {
        let (Some(m), Some(pers)) = (f.measured_c, f.persistence_c) else {
            continue;
        };
        n += 1;
        a += (f.predicted_c - m).powi(2);
        o += (f.open_loop_c - m).powi(2);
        p += (pers - m).powi(2);
        e += (f.ensemble_c - m).powi(2);
        inside += usize::from(f.p05_c <= m && m <= f.p95_c);
    }
    let rms = |x: f64| (x / n as f64).sqrt();
    (n > 0).then(|| Score {
        forecasts: n,
        assimilated_rms_c: rms(a),
        open_loop_rms_c: rms(o),
        persistence_rms_c: rms(p),
        ensemble_rms_c: rms(e),
        band_coverage: inside as f64 / n as f64,
    })
}

/// forecasts.csv, assimilation.csv, alarms.csv and follow.json as they stand.
fn write(
    dir: &mut RunDir,
    f: &Follower,
    names: &[String],
    priors: &[Uncertain],
    c: &Counters,
    clock: &Instant,
    state: &str,
) -> Result<()> {
    let p = &f.progress;
    let cell = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.2}"));
    let mut csv = String::from(
        "made_at_s,target_t_s,probe,predicted_c,p05_c,p95_c,open_loop_c,measured_c,horizon,\
         persistence_c,ensemble_c\n",
    );
    for x in &p.forecasts {
        let _ = writeln!(
            csv,
            "{:.3},{:.3},{},{:.2},{:.2},{:.2},{:.2},{},{},{},{:.2}",
            x.made_at_s,
            x.target_t_s,
            names[x.probe],
            x.predicted_c,
            x.p05_c,
            x.p95_c,
            x.open_loop_c,
            cell(x.measured_c),
            x.horizon.label(),
            cell(x.persistence_c),
            x.ensemble_c,
        );
    }
    dir.write("forecasts.csv", csv.as_bytes())?;
    let mut csv = String::from("t_s,parameter,mean,sd\n");
    for &(t, k, mean, sd) in &p.settling {
        let _ = writeln!(
            csv,
            "{t:.3},{},{mean:.6},{sd:.6}",
            priors[k].parameter.key()
        );
    }
    dir.write("assimilation.csv", csv.as_bytes())?;
    let mut csv = String::from(
        "made_at_s,layer,criterion,predicted_p95_c,limit_c,programmed_dwell_s,advised_dwell_s,\
         extra_dwell_s,predicted_p95_mm,limit_mm\n",
    );
    for a in &p.alarms {
        // Each criterion's numbers in the columns of its unit, the others' left empty.
        let pair = format!("{:.2},{:.2}", a.predicted_p95, a.limit);
        let (celsius, mm) = match a.unit {
            Unit::Celsius => (pair, ",".to_string()),
            Unit::Millimetre => (",".to_string(), pair),
        };
        let _ = writeln!(
            csv,
            "{:.3},{},{},{celsius},{:.1},{},{},{mm}",
            a.made_at_s,
            a.layer,
            a.criterion,
            a.programmed_dwell_s,
            a.advised_dwell_s
                .map_or(String::new(), |v| format!("{v:.1}")),
            a.extra_s().map_or(String::new(), |v| format!("{v:.1}")),
        );
    }
    dir.write("alarms.csv", csv.as_bytes())?;
    dir.write_json("follow.json", &report(f, names, c, clock, state))?;
    Ok(())
}

fn report(
    f: &Follower,
    names: &[String],
    c: &Counters,
    clock: &Instant,
    state: &str,
) -> serde_json::Value {
    let p = &f.progress;
    let followed_s = match (c.first_data_s, f.data_s()) {
        (Some(a), Some(b)) => b - a,
        _ => 0.0,
    };
    let scores: Vec<serde_json::Value> = horizons(&p.forecasts)
        .into_iter()
        .map(|h| {
            let per_probe: serde_json::Map<String, serde_json::Value> = names
                .iter()
                .enumerate()
                .map(|(k, n)| {
                    let s = score(&p.forecasts, |x| x.horizon == h && x.probe == k);
                    (n.clone(), json!(s))
                })
                .collect();
            json!({
                "horizon": h.label(),
                "all": score(&p.forecasts, |x| x.horizon == h),
                "per_probe": per_probe,
            })
        })
        .collect();
    let twin = &f.twin;
    let parameters: Vec<serde_json::Value> = twin
        .parameters()
        .into_iter()
        .zip(&twin.priors)
        .map(|((q, mean, sd), u)| {
            json!({"name": q.key(), "mean": mean, "sd": sd, "prior_mean": u.mean,
                   "prior_sd": u.sd, "low": u.range.low, "high": u.range.high})
        })
        .collect();
    let st = &twin.state;
    json!({
        "state": state,
        "ensemble": twin.settings.ensemble,
        "rows": p.rows,
        "readings": p.readings,
        "analyses": st.analyses,
        "readings_assimilated": st.assimilated,
        "innovation_rms_c": (st.assimilated > 0)
            .then(|| (st.innovation_sq / st.assimilated as f64).sqrt()),
        "refused": {
            "malformed": c.malformed,
            "malformed_lines": c.malformed_lines,
            "back_in_time": p.back_in_time,
            "below_ambient": c.below_ambient,
            "read_again": c.reread,
            "machine_late": c.machine_late,
        },
        "warnings": c.warnings.iter().map(|w| json!({"kind": w.0, "message": w.1}))
            .collect::<Vec<_>>(),
        "restarts": c.restarts,
        "opcua": c.opcua,
        "machine_log": p.asrun.as_ref().map(|a| json!({
            "rows": a.rows,
            "deposits_laid": a.laid(),
            "arc_stops": a.stops,
            "stops_mid_pass": a.stops_mid_pass,
            "mean_power_w": a.mean_power_w(),
            "late_s": a.late_s(),
        })),
        "stalls": c.stalls.iter().map(|s| json!({"at_data_s": s.0, "wall_s": s.1}))
            .collect::<Vec<_>>(),
        "data_s": f.data_s(),
        "followed_build_s": followed_s,
        "busy_wall_s": c.busy_s,
        "wall_s": clock.elapsed().as_secs_f64(),
        // Build seconds followed per wall second spent computing: how much faster than the
        // cell the twin could go (the wall clock it waited for data left out).
        "real_time_factor": (c.busy_s > 0.0).then(|| followed_s / c.busy_s),
        "lag_s": {
            "max": c.lag_max_s,
            "mean": (c.lag_n > 0).then(|| c.lag_sum_s / c.lag_n as f64),
            "behind_threshold_s": BEHIND_S,
            "behind_at_data_s": c.behind_at_s,
        },
        "forecasts": p.forecasts.len(),
        "scores": scores,
        "parameters": parameters,
        "alarms": p.alarms.iter().map(alarm_json).collect::<Vec<_>>(),
        "layers_judged": p.judged.iter().map(|j| json!({"made_at_s": j.0, "layer": j.1,
            "predicted_p95_c": j.2})).collect::<Vec<_>>(),
    })
}

fn alarm_json(a: &Alarm) -> serde_json::Value {
    let (predicted, limit) = match a.unit {
        Unit::Celsius => ("predicted_p95_c", "limit_c"),
        Unit::Millimetre => ("predicted_p95_mm", "limit_mm"),
    };
    json!({
        "made_at_s": a.made_at_s,
        "layer": a.layer,
        "criterion": a.criterion,
        predicted: a.predicted_p95,
        limit: a.limit,
        "programmed_dwell_s": a.programmed_dwell_s,
        "advised_dwell_s": a.advised_dwell_s,
        "extra_dwell_s": a.extra_s(),
    })
}

#[cfg(test)]
mod tests {
    use super::readings_expected;
    use crate::scenario::replay::{Probe, Probes};

    /// Every probe at every row the file will have by the build's end, at the pace of its first
    /// rows (a header and a line still being written skipped); nothing from a file not there or
    /// of one row.
    #[test]
    fn the_readings_to_come_are_paced_by_the_files_first_rows() {
        let dir = std::env::temp_dir().join(format!("waamtwin_pace_{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let probe = |column| Probe {
            name: format!("tc{column}"),
            column,
            position_m: [0.0; 3],
        };
        let probes = Probes {
            file: dir.join("log.csv"),
            kelvin: false,
            time_column: 0,
            points: vec![probe(1), probe(2), probe(3)],
        };
        assert_eq!(readings_expected(&probes, 100.0), None, "no file yet");
        std::fs::write(&probes.file, "t_s,a,b,c\n10,20,20,20\n").unwrap();
        assert_eq!(readings_expected(&probes, 100.0), None, "one row");
        std::fs::write(
            &probes.file,
            "t_s,a,b,c\n10,20,20,20\n10.5,21,20,20\n11,22,2",
        )
        .unwrap();
        // Rows every 0.5 s from 10 s to 100 s: 181, three probes each.
        assert_eq!(readings_expected(&probes, 100.0), Some(543));
        // A file already longer than the build: its own rows.
        assert_eq!(readings_expected(&probes, 10.2), Some(6));
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
