//! `waamtwin study STUDY.toml -o DIR [--shard I/N] [--emit slurm]`: what-if sweeps over a base
//! scenario. A study file names its base scenario and the overrides, as a sweep (every
//! combination) and/or a list of cases:
//!
//! ```toml
//! base = "hemisphere.toml"       # relative to the study file
//! command = "simulate"           # or "dwell" (without its baselines)
//! [sweep]
//! "process.travel_speed_mm_s" = [8.0, 10.0, 12.0]
//! "dwell.interpass_max_c" = [150.0, 200.0]
//! [[case]]
//! "thermal.convection_w_m2k" = 30.0
//! ```
//!
//! Each case runs in `DIR/cases/NNN` and is done once its manifest.json exists (written last,
//! atomically), so a killed study resumes where it stopped and shards of a cluster's job array
//! can share DIR. `summary.csv` is rebuilt from every finished case after each run, and
//! `failed.csv` from every failed one (a failed case keeps `failed.json`; the others go on).

use crate::error::{Error, ErrorKind, Result};
use crate::output::{RunDir, write_atomic};
use crate::scenario::Scenario;
use serde_json::Value;
use std::fmt::Write;
use std::path::{Path, PathBuf};

pub struct Case {
    pub id: String,
    pub overrides: Vec<(String, toml::Value)>,
}

pub struct Study {
    /// The study file, as messages name it.
    pub file: String,
    pub base_text: String,
    pub base_dir: PathBuf,
    pub command: String,
    pub cases: Vec<Case>,
}

/// Most cases a study may have: a few short lists in `[sweep]` multiply to any number, and each
/// case is checked (a scenario built) before anything runs.
pub const MAX_CASES: usize = 10_000;

pub fn load(path: &Path) -> Result<Study> {
    let file = path.display().to_string();
    let text = std::fs::read_to_string(path).map_err(|e| Error::input(format!("{file}: {e}")))?;
    let dir = path.parent().unwrap_or(Path::new("."));
    parse(&text, &file, dir)
}

/// A study from its text; `file` names it in errors, its base scenario is read from `dir`.
pub fn parse(text: &str, file: &str, dir: &Path) -> Result<Study> {
    let file = file.to_string();
    let table: toml::Table =
        toml::from_str(text).map_err(|e| Error::input(format!("{file}: {}", e.message())))?;
    let dir = dir.to_path_buf();
    let base = table
        .get("base")
        .and_then(|v| v.as_str())
        .ok_or_else(|| Error::input(format!("{file}: base = \"scenario.toml\" is missing")))?;
    let base_path = dir.join(base);
    let base_text = std::fs::read_to_string(&base_path)
        .map_err(|e| Error::input(format!("{file}: base = \"{base}\": {e}")))?;
    // The base first, on its own: its errors name its own file and lines.
    Scenario::parse(&base_text, &base_path.display().to_string(), &dir)?;
    let command = table
        .get("command")
        .and_then(|v| v.as_str())
        .unwrap_or("simulate")
        .to_string();
    if command != "simulate" && command != "dwell" {
        return Err(Error::input(format!(
            "{file}: command = \"{command}\"; expected \"simulate\" or \"dwell\""
        )));
    }
    for key in table.keys() {
        if !["base", "command", "sweep", "case"].contains(&key.as_str()) {
            return Err(Error::input(format!(
                "{file}: unknown key {key}; expected base, command, sweep, case"
            )));
        }
    }
    let mut combos: Vec<Vec<(String, toml::Value)>> = vec![vec![]];
    if let Some(sweep) = table.get("sweep").and_then(|v| v.as_table()) {
        let mut count = 1usize;
        for (key, values) in sweep {
            let values = values.as_array().ok_or_else(|| {
                Error::input(format!("{file}: sweep.\"{key}\" must be a list of values"))
            })?;
            count = count.saturating_mul(values.len());
        }
        let listed = table
            .get("case")
            .and_then(|v| v.as_array())
            .map_or(0, |l| l.len());
        if count.saturating_add(listed) > MAX_CASES {
            return Err(Error::input(format!(
                "{file}: [sweep] makes {} cases ({}){}; expected at most {MAX_CASES}",
                if count == usize::MAX {
                    "more than 10^19".to_string()
                } else {
                    count.to_string()
                },
                sweep
                    .iter()
                    .map(|(k, v)| format!("{k}: {}", v.as_array().map_or(0, |a| a.len())))
                    .collect::<Vec<_>>()
                    .join(" × "),
                if listed > 0 {
                    format!(" and [[case]] {listed} more")
                } else {
                    String::new()
                }
            )));
        }
        for (key, values) in sweep {
            let values = values.as_array().ok_or_else(|| {
                Error::input(format!("{file}: sweep.\"{key}\" must be a list of values"))
            })?;
            combos = combos
                .iter()
                .flat_map(|c| {
                    values
                        .iter()
                        .map(move |v| [c.clone(), vec![(key.clone(), v.clone())]].concat())
                })
                .collect();
        }
    }
    if table.get("sweep").is_none() {
        combos.clear();
    }
    if let Some(list) = table.get("case").and_then(|v| v.as_array()) {
        for c in list {
            let t = c.as_table().ok_or_else(|| {
                Error::input(format!("{file}: [[case]] must be tables of overrides"))
            })?;
            combos.push(t.iter().map(|(k, v)| (k.clone(), v.clone())).collect());
        }
    }
    if combos.is_empty() {
        return Err(Error::input(format!(
            "{file}: no cases; expected a [sweep] or [[case]] entries"
        )));
    }
    if combos.len() > MAX_CASES {
        return Err(Error::input(format!(
            "{file}: {} cases; expected at most {MAX_CASES}",
            combos.len()
        )));
    }
    let cases = combos
        .into_iter()
        .enumerate()
        .map(|(i, overrides)| Case {
            id: format!("{i:03}"),
            overrides,
        })
        .collect();
    let study = Study {
        file: file.clone(),
        base_text,
        base_dir: dir,
        command,
        cases,
    };
    // Every case must be a valid scenario before anything runs.
    for c in &study.cases {
        study.scenario(c)?;
    }
    Ok(study)
}

impl Study {
    /// A case as messages name it: the study file and the case's number.
    fn case_name(&self, c: &Case) -> String {
        format!("{} case {}", self.file, c.id)
    }

    /// A case as an error names it: the study file, the case's number and its overrides.
    fn case_label(&self, c: &Case) -> String {
        format!(
            "{} ({})",
            self.case_name(c),
            c.overrides
                .iter()
                .map(|(k, v)| format!("{k} = {v}"))
                .collect::<Vec<_>>()
                .join(", ")
        )
    }

    /// The base scenario with a case's overrides ("section.key" = value). Errors name the
    /// study file, the case and its overrides.
    pub fn scenario(&self, c: &Case) -> Result<Scenario> {
        let what = self.case_label(c);
        let fail = |m: String| Error::input(format!("{what}: {m}"));
        let mut t: toml::Table =
            toml::from_str(&self.base_text).map_err(|e| fail(e.message().into()))?;
        for (key, value) in &c.overrides {
            let (section, name) = key
                .split_once('.')
                .ok_or_else(|| fail(format!("override \"{key}\"; expected \"section.key\"")))?;
            let entry = t
                .entry(section.to_string())
                .or_insert_with(|| toml::Value::Table(toml::Table::new()));
            let table = entry
                .as_table_mut()
                .ok_or_else(|| fail(format!("override \"{key}\": {section} is not a section")))?;
            table.insert(name.to_string(), value.clone());
        }
        let text = toml::to_string(&t).map_err(|e| Error::failure(e.to_string()))?;
        let kept: Vec<String> = c.overrides.iter().map(|o| o.0.clone()).collect();
        Scenario::parse_generated(&text, &what, &self.base_dir, &kept)
    }
}

/// What a case keeps: `simulate`'s one run, or a dwell case's search and dwelled run.
fn case_keeps(command: &str, s: &Scenario) -> super::cost::Keeps {
    match command {
        "dwell" => super::dwell::search_keeps(s),
        // A case records nothing (`run_case`): one run of the model.
        _ => super::cost::Keeps::ONE_RUN,
    }
}

/// Parse `I/N`.
pub fn parse_shard(s: &str) -> Result<(usize, usize)> {
    let bad = || Error::input(format!("--shard {s}; expected I/N with 0 ≤ I < N"));
    let (i, n) = s.split_once('/').ok_or_else(bad)?;
    let (i, n): (usize, usize) = (i.parse().map_err(|_| bad())?, n.parse().map_err(|_| bad())?);
    if n == 0 || i >= n {
        return Err(bad());
    }
    Ok((i, n))
}

pub fn run(
    path: &Path,
    out: &Path,
    shard: Option<(usize, usize)>,
    emit: Option<&str>,
    jobs: Option<usize>,
) -> Result<String> {
    let study = load(path)?;
    if jobs == Some(0) {
        return Err(Error::input("--jobs 0; expected at least 1"));
    }
    std::fs::create_dir_all(out.join("cases"))
        .map_err(|e| Error::input(format!("{}: {e}", out.display())))?;
    if let Some(kind) = emit {
        if kind != "slurm" {
            return Err(Error::input(format!("--emit {kind}; expected slurm")));
        }
        return emit_slurm(path, out, study.cases.len());
    }
    let (i, n) = shard.unwrap_or((0, 1));
    let mine: Vec<&Case> = study
        .cases
        .iter()
        .enumerate()
        .filter(|(k, _)| k % n == i)
        .map(|(_, c)| c)
        .collect();
    let done = |c: &Case| {
        out.join("cases")
            .join(&c.id)
            .join("manifest.json")
            .is_file()
    };
    let pending: Vec<&&Case> = mine.iter().filter(|c| !done(c)).collect();
    let skipped = mine.len() - pending.len();
    // A case whose plate alone cannot fit is refused before any case runs; the rest of each
    // case's estimate needs its plan, and is checked as the case starts (`run_case`).
    for c in &pending {
        let s = study.scenario(c)?;
        super::cost::check_plate(
            &study.case_name(c),
            &s.thermal,
            &s.material,
            case_keeps(&study.command, &s),
        )?;
    }
    let needs = case_memory(&study, &pending)?;
    let cores = std::thread::available_parallelism().map_or(1, |n| n.get());
    let workers = jobs.unwrap_or(cores).min(pending.len()).max(1);
    let budget = super::cost::available_memory().unwrap_or(f64::INFINITY);
    let admission = Admission::new(&needs, budget, workers, cores);
    let finished = std::sync::Mutex::new(Vec::with_capacity(pending.len()));
    std::thread::scope(|scope| {
        for _ in 0..workers {
            scope.spawn(|| {
                while let Some(taken) = admission.take() {
                    let (k, threads) = (taken.case, taken.threads);
                    // Its memory and cores go back however the case ends, a panic included (the
                    // other workers would otherwise wait for them for ever).
                    let _running = Running {
                        admission: &admission,
                        taken,
                    };
                    let c = pending[k];
                    let dir = out.join("cases").join(&c.id);
                    // The case's own threads: its heat model's steps and its side-by-side runs
                    // share them, not the cores the other cases hold.
                    let r = rayon::ThreadPoolBuilder::new()
                        .num_threads(threads)
                        .build()
                        .map_err(|e| Error::failure(e.to_string()))
                        .and_then(|pool| pool.install(|| run_case(&study, c, &dir)));
                    if r.as_ref().is_err_and(|e| e.kind == ErrorKind::Stopped) {
                        admission.stop();
                    }
                    lock(&finished).push((k, r));
                }
            });
        }
    });
    let mut results = finished.into_inner().unwrap_or_else(|p| p.into_inner());
    results.sort_by_key(|r| r.0);
    let (ran, jobs) = (results.len(), admission.most());
    // A case that fails is kept with its message and the others go on: one case of a night's
    // sweep that outgrows its plate or its memory must not cost the rest their summary. A stop
    // asked for (Ctrl-C from Python) stops the study, and is no case's failure.
    let mut stopped = None;
    let mut failed = Vec::new();
    for (k, r) in results {
        let c = pending[k];
        match r {
            Ok(()) => {}
            Err(e) if e.kind == ErrorKind::Stopped => stopped = Some(e),
            Err(e) => {
                record_failure(c, &out.join("cases").join(&c.id), &e)?;
                failed.push(e);
            }
        }
    }
    let rows = write_summary(&study, out)?;
    if let Some(e) = stopped {
        return Err(e);
    }
    let line = format!(
        "{} cases run, up to {jobs} at a time, {skipped} already done; summary.csv has {rows} of {} cases",
        ran - failed.len(),
        study.cases.len()
    );
    match failed.first() {
        None => Ok(line),
        Some(first) => Err(Error {
            // Bad input where every failure was the input's, ours where any was ours.
            kind: if failed.iter().all(|e| e.kind == ErrorKind::Input) {
                ErrorKind::Input
            } else {
                ErrorKind::Failure
            },
            message: format!(
                "{} of {} cases failed, each named in {} with its message; \
                 the first: {}; {line}",
                failed.len(),
                ran,
                out.join("failed.csv").display(),
                first.message
            ),
        }),
    }
}

/// A failed case's folder keeps what its command would have said, in failed.json (`id`,
/// `overrides`, `exit_code`, `message`), until it runs again; failed.csv is made from these.
fn record_failure(c: &Case, dir: &Path, e: &Error) -> Result<()> {
    std::fs::create_dir_all(dir)
        .map_err(|io| Error::failure(format!("{}: {io}", dir.display())))?;
    let failure = serde_json::json!({
        "id": c.id,
        "overrides": overrides_json(c),
        "exit_code": e.exit_code(),
        "message": e.message,
    });
    let text = serde_json::to_string_pretty(&failure).map_err(|j| Error::failure(j.to_string()))?;
    write_atomic(&dir.join(FAILED), text.as_bytes())
}

/// The file a failed case leaves in its folder.
const FAILED: &str = "failed.json";

fn overrides_json(c: &Case) -> serde_json::Map<String, Value> {
    c.overrides
        .iter()
        .map(|(k, v)| (k.clone(), serde_json::to_value(v).unwrap_or(Value::Null)))
        .collect()
}

/// Each pending case's memory, as the cases at once are held to it: its plate-only estimate,
/// with the copies its command keeps, ×2 for the part's metal and the process; or its plan's
/// peak, where larger. A sweep over `thermal.voxel_mm` or the part's size holds cases of very
/// different sizes, so no one case's need (the base's, or the largest's) sizes them all.
fn case_memory(study: &Study, pending: &[&&Case]) -> Result<Vec<f64>> {
    let mut needs = Vec::with_capacity(pending.len());
    // A mesh file's vertices once per file: the overrides seldom change it.
    let mut meshes: Vec<(std::path::PathBuf, usize)> = Vec::new();
    for c in pending {
        let s = study.scenario(c)?;
        let m = crate::pipeline::deposition::material(&s.material, &s.thermal);
        let copies = case_keeps(&study.command, &s).copies;
        let heat =
            2.0 * crate::pipeline::cost::estimate(&s.thermal, &m, &[], 0.0, copies, 0, 1).bytes;
        let vertices = match &s.part.source {
            crate::scenario::PartSource::Shape { shape, edge_mm } => shape.vertices(*edge_mm),
            crate::scenario::PartSource::Mesh(path) => {
                match meshes.iter().find(|(p, _)| p == path) {
                    Some(&(_, v)) => v,
                    None => {
                        let v = crate::part::load_part(&s.part)?.mesh.n_vertices();
                        meshes.push((path.clone(), v));
                        v
                    }
                }
            }
        };
        needs.push(heat.max(crate::pipeline::cost::plan_bytes(vertices)));
    }
    Ok(needs)
}

/// The cases handed to the workers as the memory and the cores allow. A worker takes the first
/// waiting case whose need fits what the running cases leave of the memory, or any where none
/// runs (a case too large alone is refused by its own checks); where a large case must wait,
/// smaller ones after it run beside what is running. A case gets the free cores shared with
/// the cases that could start beside it now: two side by side a core each on two cores, one
/// that runs alone (none fits beside it, or none is left) all of them. Measured on two cores:
/// two voxel cases side by side on two threads each ran slower than one after the other
/// (docs/PERFORMANCE.md "Studies"). Each case's files are its own, whatever the order.
struct Admission<'a> {
    needs: &'a [f64],
    workers: usize,
    state: std::sync::Mutex<Queue>,
    freed: std::sync::Condvar,
}

struct Queue {
    /// Indices of the pending cases not yet taken, in order.
    waiting: Vec<usize>,
    /// The budget less the running cases' needs, bytes.
    free: f64,
    /// The cores the running cases do not hold.
    cores: usize,
    running: usize,
    /// The most cases that ran at once.
    most: usize,
}

/// A case handed to a worker, with the threads it runs on.
struct Taken {
    case: usize,
    threads: usize,
    /// Of them, the cores it holds from the others.
    held: usize,
}

/// A case running: dropped, it hands its memory and cores back.
struct Running<'s, 'a> {
    admission: &'s Admission<'a>,
    taken: Taken,
}

impl Drop for Running<'_, '_> {
    fn drop(&mut self) {
        self.admission.done(&self.taken);
    }
}

fn lock<T>(m: &std::sync::Mutex<T>) -> std::sync::MutexGuard<'_, T> {
    // A case that panicked poisons nothing the others read: its result is never pushed.
    m.lock().unwrap_or_else(|p| p.into_inner())
}

impl<'a> Admission<'a> {
    fn new(needs: &'a [f64], budget: f64, workers: usize, cores: usize) -> Self {
        Self {
            needs,
            workers,
            state: std::sync::Mutex::new(Queue {
                waiting: (0..needs.len()).collect(),
                free: budget,
                cores,
                running: 0,
                most: 0,
            }),
            freed: std::sync::Condvar::new(),
        }
    }

    /// The next case this worker runs, waiting while none fits; `None` once none is left.
    fn take(&self) -> Option<Taken> {
        let needs = self.needs;
        let mut q = lock(&self.state);
        loop {
            if q.waiting.is_empty() {
                return None;
            }
            let fits = q
                .waiting
                .iter()
                .position(|&k| q.running == 0 || needs[k] <= q.free);
            if let Some(at) = fits {
                let k = q.waiting.remove(at);
                q.free -= needs[k];
                q.running += 1;
                q.most = q.most.max(q.running);
                // The cases that could start beside this one now, in order, as workers allow.
                let mut free = q.free;
                let beside = q
                    .waiting
                    .iter()
                    .filter(|&&j| {
                        let fits = needs[j] <= free;
                        if fits {
                            free -= needs[j];
                        }
                        fits
                    })
                    .count()
                    .min(self.workers - q.running);
                let threads = (q.cores / (1 + beside)).max(1);
                // More workers than cores (`--jobs`): a case beyond them holds none.
                let held = threads.min(q.cores);
                q.cores -= held;
                return Some(Taken {
                    case: k,
                    threads,
                    held,
                });
            }
            q = self.freed.wait(q).unwrap_or_else(|p| p.into_inner());
        }
    }

    fn done(&self, taken: &Taken) {
        let mut q = lock(&self.state);
        q.free += self.needs[taken.case];
        q.cores += taken.held;
        q.running -= 1;
        self.freed.notify_all();
    }

    /// A stop was asked for: no further case starts.
    fn stop(&self) {
        lock(&self.state).waiting.clear();
        self.freed.notify_all();
    }

    fn most(&self) -> usize {
        lock(&self.state).most
    }
}

/// Run one case into `dir`; its error, if any, names the study file, the case and its
/// overrides, however deep it arose (a plate the case's part outgrows, a numerical failure).
fn run_case(study: &Study, c: &Case, dir: &Path) -> Result<()> {
    // What an earlier attempt left: this one's outcome replaces it.
    let _ = std::fs::remove_file(dir.join(FAILED));
    run_case_files(study, c, dir).map_err(|e| {
        let label = study.case_label(c);
        if e.message.starts_with(&study.case_name(c)) {
            e
        } else {
            e.context(label)
        }
    })
}

fn run_case_files(study: &Study, c: &Case, dir: &Path) -> Result<()> {
    let s = study.scenario(c)?;
    // Messages name the case: its warnings on a terminal that many cases share, its refusal.
    let name = study.case_name(c);
    let part = super::cost::part_to_plan(&name, &s.part)?;
    let mut d = RunDir::create(dir)?;
    let b = super::plan::build(&s, &part)?;
    let keeps = super::cost::Keeps {
        planned: part.mesh.n_vertices(),
        ..case_keeps(&study.command, &s)
    };
    let warned = super::cost::check_case(&name, &s, &b, keeps)?;
    super::plan::write_plan(&mut d, &s, &b)?;
    let (cooling, sim) = b.case(study.command == "dwell")?;
    let dwell = &cooling.dwell_s;
    let after = super::simulate::write_thermal(&mut d, &b, &sim)?;
    for w in warned.iter().chain(&after) {
        eprintln!("case {}: {}", c.id, w.line);
    }
    d.write_json("case.json", &serde_json::json!({"id": c.id, "overrides": overrides_json(c), "total_dwell_s": dwell.iter().sum::<f64>(), "dwell_count": dwell.iter().filter(|&&x| x > 0.0).count(), "arc_stops": cooling.arc_stops()}))?;
    d.finish("study case", s.to_json())?;
    Ok(())
}

/// summary.csv from every finished case, one row each; failed.csv from every failed one (its
/// overrides, exit code and message), removed where none failed. Returns summary.csv's rows.
fn write_summary(study: &Study, out: &Path) -> Result<usize> {
    let keys: Vec<String> = {
        let mut k: Vec<String> = study
            .cases
            .iter()
            .flat_map(|c| c.overrides.iter().map(|o| o.0.clone()))
            .collect();
        k.sort();
        k.dedup();
        k
    };
    let mut csv = format!(
        "case,{},feasible,max_preheat_c,total_dwell_s,dwell_count,build_time_s,first_risk,\
         first_risk_reason,warnings\n",
        keys.join(",")
    );
    let read =
        |p: PathBuf| -> Option<Value> { serde_json::from_slice(&std::fs::read(p).ok()?).ok() };
    let mut rows = 0;
    let mut failed = format!("case,{},exit_code,message\n", keys.join(","));
    let mut failed_rows = 0;
    #[cfg(feature = "recording")]
    let mut tradeoff = Vec::new();
    for c in &study.cases {
        let dir = out.join("cases").join(&c.id);
        let values: Vec<String> = keys
            .iter()
            .map(|k| {
                c.overrides
                    .iter()
                    .find(|o| &o.0 == k)
                    .map_or(String::new(), |o| o.1.to_string())
            })
            .collect();
        if !dir.join("manifest.json").is_file() {
            if let Some(f) = read(dir.join(FAILED)) {
                let _ = writeln!(
                    failed,
                    "{},{},{},{}",
                    c.id,
                    values.join(","),
                    f["exit_code"],
                    csv_field(f["message"].as_str().unwrap_or(""))
                );
                failed_rows += 1;
            }
            continue;
        }
        let (plan, thermal, case) = (
            read(dir.join("plan.json")),
            read(dir.join("thermal.json")),
            read(dir.join("case.json")),
        );
        let (Some(plan), Some(thermal), Some(case)) = (plan, thermal, case) else {
            continue;
        };
        let _ = writeln!(
            csv,
            "{},{},{},{:.2},{:.2},{},{:.2},{},{},{}",
            c.id,
            values.join(","),
            plan["feasible"],
            thermal["max_preheat_c"].as_f64().unwrap_or(f64::NAN),
            case["total_dwell_s"].as_f64().unwrap_or(0.0),
            case["dwell_count"],
            thermal["build_time_s"].as_f64().unwrap_or(f64::NAN),
            thermal["first_overheat"]
                .as_u64()
                .map_or(String::new(), |v| v.to_string()),
            thermal["first_overheat_reason"].as_str().unwrap_or(""),
            warning_kinds(&thermal)
        );
        rows += 1;
        #[cfg(feature = "recording")]
        tradeoff.push(crate::record::Case {
            label: c.id.clone(),
            total_dwell_s: case["total_dwell_s"].as_f64().unwrap_or(0.0),
            max_preheat_c: thermal["max_preheat_c"].as_f64().unwrap_or(f64::NAN),
            interpass_max_c: thermal["interpass_max_c"].as_f64().unwrap_or(f64::NAN),
        });
    }
    write_atomic(&out.join("summary.csv"), csv.as_bytes())?;
    let failed_csv = out.join("failed.csv");
    if failed_rows > 0 {
        write_atomic(&failed_csv, failed.as_bytes())?;
    } else if failed_csv.is_file() {
        std::fs::remove_file(&failed_csv)
            .map_err(|e| Error::failure(format!("cannot remove {}: {e}", failed_csv.display())))?;
    }
    #[cfg(feature = "recording")]
    if !tradeoff.is_empty() {
        crate::record::study_plots(&mut RunDir::create(out)?, &tradeoff)?;
    }
    Ok(rows)
}

/// A CSV field: quoted, its quotes doubled, where it holds a comma, a quote or a line break
/// (RFC 4180); a message names values such as `[100.0, 100.0, 10.0]`.
fn csv_field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// thermal.json's warnings as summary.csv holds them: their kinds, `;` between (empty where
/// there are none).
fn warning_kinds(thermal: &Value) -> String {
    thermal["warnings"].as_array().map_or(String::new(), |w| {
        w.iter()
            .filter_map(|w| w["kind"].as_str())
            .collect::<Vec<_>>()
            .join(";")
    })
}

/// Slurm scripts: a job array with one task per case shard, and a merge job that rebuilds
/// summary.csv from every finished case once the array is done (array tasks that finish
/// together may each write a summary that misses the other).
fn emit_slurm(study: &Path, out: &Path, cases: usize) -> Result<String> {
    let (out_s, study_s) = (out.display(), study.display());
    let array = format!(
        "#!/bin/bash\n# waamtwin study as a Slurm job array; submit with the merge job after it:\n#   jid=$(sbatch --parsable {out_s}/study.slurm)\n#   sbatch --dependency=afterok:$jid {out_s}/study-merge.slurm\n#SBATCH --job-name=waamtwin-study\n#SBATCH --array=0-{last}\n#SBATCH --cpus-per-task=2\n#SBATCH --output={out_s}/slurm-%A_%a.out\nset -euo pipefail\nwaamtwin study {study_s} -o {out_s} --shard ${{SLURM_ARRAY_TASK_ID}}/{n}\n",
        last = cases.saturating_sub(1),
        n = cases.max(1)
    );
    let merge = format!(
        "#!/bin/bash\n# Rebuilds {out_s}/summary.csv once every array task of study.slurm is done: every case\n# is skipped as finished, and the summary and plots are written from all of them.\n#SBATCH --job-name=waamtwin-study-merge\n#SBATCH --output={out_s}/slurm-merge-%j.out\nset -euo pipefail\nwaamtwin study {study_s} -o {out_s}\n"
    );
    write_atomic(&out.join("study.slurm"), array.as_bytes())?;
    write_atomic(&out.join("study-merge.slurm"), merge.as_bytes())?;
    Ok(format!(
        "{}: {cases} array tasks, one case shard each; then study-merge.slurm rebuilds summary.csv \
         (jid=$(sbatch --parsable {out_s}/study.slurm); sbatch --dependency=afterok:$jid {out_s}/study-merge.slurm)",
        out.join("study.slurm").display()
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn taken(a: &Admission) -> (usize, usize) {
        let t = a.take().expect("a case fits");
        (t.case, t.threads)
    }

    /// In 100 MB on two cores: a 90 MB case waits while a 50 MB one runs, the 50 MB case after
    /// it runs beside, each of the two on one core; the large one then runs alone on both.
    #[test]
    fn a_large_case_waits_and_the_small_ones_after_it_run_beside() {
        let needs = [50e6, 90e6, 50e6];
        let a = Admission::new(&needs, 100e6, 2, 2);
        let first = a.take().unwrap();
        assert_eq!((first.case, first.threads), (0, 1));
        let second = a.take().unwrap();
        assert_eq!((second.case, second.threads), (2, 1));
        a.done(&first);
        a.done(&second);
        assert_eq!(taken(&a), (1, 2));
        assert!(a.take().is_none());
        assert_eq!(a.most(), 2);
    }

    /// Where nothing fits beside it a case gets every core; where a case cannot fit alone it
    /// still runs once nothing else does (its own checks refuse it); more workers than cores
    /// give the extra cases a thread each.
    #[test]
    fn cores_go_to_the_cases_that_can_run() {
        let needs = [80e6, 80e6];
        let a = Admission::new(&needs, 100e6, 2, 2);
        let first = a.take().unwrap();
        assert_eq!((first.case, first.threads), (0, 2));
        a.done(&first);
        assert_eq!(taken(&a), (1, 2));

        let needs = [500e6];
        let a = Admission::new(&needs, 100e6, 2, 2);
        assert_eq!(taken(&a), (0, 2));

        let needs = [1e6; 4];
        let a = Admission::new(&needs, 100e6, 4, 2);
        let held: Vec<usize> = (0..4).map(|_| a.take().unwrap().held).collect();
        assert_eq!(held, [1, 1, 0, 0]);
    }
}
