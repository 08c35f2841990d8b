//! The cost of a heat run shown before it starts, and a run that cannot fit in this machine's
//! available memory refused (exit 2) with the key to change and by how much (issue 19). The
//! arithmetic is the engine's (`pipeline::cost`); this shell reads what the machine has.

use crate::error::{Error, Result};
use crate::part::load_part;
use crate::pipeline::cost::{
    BASE_BYTES, Estimate, REPLAY_DEPOSIT_BYTES, RUN_DEPOSIT_BYTES, bytes, estimate, plan_bytes,
    plan_vertices_to_fit, voxel_to_fit,
};
use crate::pipeline::deposition::material;
use crate::pipeline::params::{Material, ThermalModel, ThermalSettings};
use crate::pipeline::replay::Replay;
use crate::scenario::{PartSource, PartSpec};
use planner::mesh::Part;
use thermal::schedule::Deposit;

/// Memory this machine can give a run now, bytes: Linux's MemAvailable (`/proc/meminfo`), or
/// the `WAAMTWIN_MEMORY_BYTES` override (tests; a machine shared with other jobs). None
/// elsewhere: the estimate is shown, nothing is refused. (The `sysinfo` crate would read it on
/// every platform; one line of /proc is not worth its dependency tree.)
pub fn available_memory() -> Option<f64> {
    if let Some(v) = std::env::var("WAAMTWIN_MEMORY_BYTES")
        .ok()
        .and_then(|v| v.parse::<f64>().ok())
    {
        return Some(v);
    }
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    text.lines()
        .find(|l| l.starts_with("MemAvailable:"))?
        .split_whitespace()
        .nth(1)?
        .parse::<f64>()
        .ok()
        .map(|kb| kb * 1024.0)
}

/// What a command keeps besides the run itself.
#[derive(Debug, Clone, Copy)]
pub struct Keeps {
    /// Copies of the model held at once (a dwell search keeps checkpoints to restart from).
    pub copies: f64,
    pub frames: usize,
    /// Heat runs the command makes, in build times (a dwell search: about two and a half,
    /// docs/PERFORMANCE.md, then the run with its dwells).
    pub runs: f64,
    /// The frames are recorded (run.rrd, run.mcap, fields.h5, the plots): each sink's scene
    /// holds them too ([`crate::pipeline::cost::recording_bytes`]).
    pub recorded: bool,
    /// The vertices of the part the command planned first (0: none counted): the plan's peak,
    /// shown beside the run's memory where it is the larger ([`plan_bytes`]).
    pub planned: usize,
    /// The measured readings the command holds, compares and records (a replay's probes,
    /// those `follow`'s file will have; 0: none, or not known before the run, as a file
    /// `follow` finds with fewer than two rows).
    pub readings: usize,
    /// The deposits of a logged path the command holds besides its model's cells
    /// ([`REPLAY_DEPOSIT_BYTES`] each, and [`RUN_DEPOSIT_BYTES`] in each further copy; set by
    /// [`check_replay`]; 0 for a planned part, whose points the fitted constants hold).
    pub deposits: usize,
}

impl Keeps {
    /// One run of one model, nothing recorded, planned or read: what each command changes
    /// from (`Keeps { copies: 2.0, ..Keeps::ONE_RUN }`).
    pub const ONE_RUN: Keeps = Keeps {
        copies: 1.0,
        frames: 0,
        runs: 1.0,
        recorded: false,
        planned: 0,
        readings: 0,
        deposits: 0,
    };
}

/// Estimate the run, print the estimate on stderr, and refuse it where it cannot fit.
pub fn check(
    file: &str,
    t: &ThermalSettings,
    m: &Material,
    deposits: &[Deposit],
    build_s: f64,
    keeps: Keeps,
) -> Result<Estimate> {
    held(
        file,
        (t, &material(m, t)),
        deposits,
        build_s,
        keeps,
        "thermal.voxel_mm",
    )
}

/// The same for the heat runs of a logged build (`replay`, `calibrate`, `follow`), on the model
/// its scenario sets up, until `end_s` (the last deposit or the last reading); `key` names the
/// voxel edge (`live.voxel_mm` where the twin has its own).
pub fn check_replay(
    file: &str,
    r: &Replay,
    end_s: f64,
    keeps: Keeps,
    key: &str,
) -> Result<Estimate> {
    // The step is the shorter of the deposit's and the plate's own material's (the cells of
    // edge dx under the metal: `thermal::voxel::VoxelModel::stable_step`).
    let t = &r.values.thermal;
    let step = |m| crate::pipeline::cost::stable_step(m, t.voxel_m);
    let m = match &r.plate_material {
        Some(p) if step(p) < step(&r.material) => p,
        _ => &r.material,
    };
    let deposits = Keeps {
        deposits: r.deps.len(),
        ..keeps
    };
    held(file, (t, m), &r.deps, end_s, deposits, key)
}

fn held(
    file: &str,
    (t, m): (&ThermalSettings, &thermal::material::Material),
    deposits: &[Deposit],
    build_s: f64,
    keeps: Keeps,
    key: &str,
) -> Result<Estimate> {
    let e = weigh((t, m), deposits, build_s, keeps);
    eprintln!("{}", e.line());
    for w in crate::pipeline::resolution::before_run(t, deposits, key) {
        eprintln!("{}", w.line);
    }
    fits(file, t, &e, key)?;
    Ok(e)
}

/// A study's case (the scenario `s` planned as `b`, keeping what its command keeps), refused
/// where it cannot fit in the memory available now, as its command alone would be; its estimate
/// is not shown (a study's cases would bury the terminal in them) and its warnings are
/// returned for the case to show and keep. `file` names the case.
pub fn check_case(
    file: &str,
    s: &crate::scenario::Scenario,
    b: &crate::pipeline::Build,
    keeps: Keeps,
) -> Result<Vec<crate::pipeline::resolution::Warning>> {
    let t = &b.params.thermal;
    let deposits = b.deposits();
    let end = deposits.last().map_or(0.0, |d| d.time);
    let e = weigh((t, &material(&s.material, t)), deposits, end, keeps);
    fits(file, t, &e, "thermal.voxel_mm")?;
    Ok(crate::pipeline::resolution::before_run(
        t,
        deposits,
        "thermal.voxel_mm",
    ))
}

/// The estimate of what a command keeps (`held`'s arithmetic, printed by none).
fn weigh(
    (t, m): (&ThermalSettings, &thermal::material::Material),
    deposits: &[Deposit],
    build_s: f64,
    keeps: Keeps,
) -> Estimate {
    let mut e = estimate(
        t,
        m,
        deposits,
        build_s,
        keeps.copies,
        keeps.frames,
        rayon::current_num_threads(),
    );
    e.seconds *= keeps.runs;
    if keeps.planned > 0 {
        e.plan_bytes = plan_bytes(keeps.planned);
    }
    if keeps.recorded {
        e.bytes += crate::pipeline::cost::recording_bytes(deposits.len(), keeps.frames);
    }
    // A logged path's deposits once, and their per-run share in every further copy.
    let further = (keeps.copies - 1.0).max(0.0);
    e.bytes += crate::pipeline::cost::READING_BYTES * keeps.readings as f64
        + (REPLAY_DEPOSIT_BYTES + RUN_DEPOSIT_BYTES * further) * keeps.deposits as f64;
    e
}

/// Refuse `e` where it cannot fit in the memory available now.
fn fits(file: &str, t: &ThermalSettings, e: &Estimate, key: &str) -> Result<()> {
    match available_memory() {
        Some(avail) if e.bytes > avail => Err(refusal(file, t, e, avail, key)),
        _ => Ok(()),
    }
}

/// A logged path's deposits, counted before they are made (`deposits` of them, the longest
/// deposited segment `longest`: its end's time and its length, mm), refused where they alone
/// cannot fit: a waypoint a kilometre off, or a `toolpath.deposit_mm` of a micrometre, would
/// otherwise make the schedule until the memory ran out. Silent where they fit: the run's
/// estimate follows once the schedule is made.
pub fn check_deposits(
    file: &str,
    deposits: f64,
    deposit_mm: f64,
    longest: (f64, f64),
) -> Result<()> {
    let need = deposits * REPLAY_DEPOSIT_BYTES;
    match available_memory() {
        Some(avail) if need > avail => Err(Error::input(format!(
            "{file}: the toolpath cut into deposits of at most toolpath.deposit_mm = {deposit_mm} makes {deposits:.3e} of them, about {}, and this machine has {} available (the longest deposited segment ends at t = {} s, {:.4e} mm long); expected a toolpath in mm whose deposited segments the machine ran, or a larger toolpath.deposit_mm",
            bytes(need),
            bytes(avail),
            longest.0,
            longest.1
        ))),
        _ => Ok(()),
    }
}

/// Refuse a run whose plate alone cannot fit, before any planning (silently where it fits:
/// the full estimate follows once the schedule is known).
pub fn check_plate(file: &str, t: &ThermalSettings, m: &Material, keeps: Keeps) -> Result<()> {
    let e = estimate(t, &material(m, t), &[], 0.0, keeps.copies, keeps.frames, 1);
    fits(file, t, &e, "thermal.voxel_mm")
}

/// The part a command plans, refused where planning it cannot fit in the available memory: a
/// library shape before it is meshed (its vertices counted), a mesh file once read (the file is
/// bounded). Silent where it fits: the heat run's estimate follows once the plan is made.
pub fn part_to_plan(file: &str, spec: &PartSpec) -> Result<Part> {
    if let PartSource::Shape { shape, edge_mm } = &spec.source {
        plan_fits(file, spec, shape.vertices(*edge_mm))?;
    }
    let part = load_part(spec)?;
    if let PartSource::Mesh(_) = &spec.source {
        plan_fits(file, spec, part.mesh.n_vertices())?;
    }
    Ok(part)
}

/// Refuse a plan of `vertices` vertices that cannot fit, naming the key to change and how far.
fn plan_fits(file: &str, spec: &PartSpec, vertices: usize) -> Result<()> {
    let Some(avail) = available_memory() else {
        return Ok(());
    };
    let need = plan_bytes(vertices);
    if need <= avail {
        return Ok(());
    }
    let fit = plan_vertices_to_fit(avail);
    let (part, coarser) = match &spec.source {
        // The vertices go as 1/edge²; 2 % over, as the rings round their counts.
        PartSource::Shape { edge_mm, .. } => (
            format!("part.edge_mm = {edge_mm} meshes the part with {vertices} vertices"),
            format!(
                "part.edge_mm = {:.2} or more (at most {fit} vertices)",
                (edge_mm * (1.02 * vertices as f64 / fit.max(1) as f64).sqrt() * 100.0).ceil()
                    / 100.0
            ),
        ),
        PartSource::Mesh(path) => (
            format!("part.mesh = {} has {vertices} vertices", path.display()),
            format!("a coarser mesh (at most {fit} vertices)"),
        ),
    };
    let expected = match fit {
        0 => format!(
            "more memory: the process alone takes about {}",
            bytes(BASE_BYTES)
        ),
        _ => coarser,
    };
    Err(Error::input(format!(
        "{file}: {part}; planning them takes about {} (the heat method's factors grow as V·log V), and this machine has {} available; expected {expected}",
        bytes(need),
        bytes(avail)
    )))
}

/// The refusal of a run that cannot fit; `key` names the voxel edge to change.
fn refusal(file: &str, t: &ThermalSettings, e: &Estimate, avail: f64, key: &str) -> Error {
    match t.model {
        ThermalModel::Voxel => {
            let dx = voxel_to_fit(t.voxel_m, e.bytes, avail) * 1e3;
            Error::input(format!(
                "{file}: {key} = {} asks for {:.3e} voxels ({:.3e} of them the plate), about {}, and this machine has {} available; expected a run that fits: {key} = {:.2} or more (memory goes as 1/voxel³), or a smaller thermal.plate_mm, or fewer output.frames",
                t.voxel_m * 1e3,
                e.cells,
                e.plate_cells,
                bytes(e.bytes),
                bytes(avail),
                (dx * 100.0).ceil() / 100.0
            ))
        }
        ThermalModel::ThinWall => Error::input(format!(
            "{file}: the thin-wall model asks for {:.3e} nodes, about {}, and this machine has {} available; expected a run that fits: a larger thermal.node_mm, or fewer output.frames",
            e.cells,
            bytes(e.bytes),
            bytes(avail)
        )),
    }
}
