//! Skeleton arc AM run (Radel et al. 2019): the slicer ([`planner::saam`]) drives a virtual
//! cell drop by drop. Each drop grows its branch by the new metal it brings spread over the
//! branch's section (k_w·4/3·πR³ / πR²), scattered by the drop's own noise and now and then a bad
//! drop (a poor transfer); a virtual camera reads the top with its own error (§2.4). Closed loop,
//! the slicer propagates the next point from the top the camera read, so the contact tip stays
//! at its CTDWP; open loop, by the nominal increment δ, and the stand-off drifts with what the
//! drops really did. The same noise (drawn per drop number from the seed) serves both loops.
//! Then the heat, drop by drop on the voxel model: each drop struck where the branch stands,
//! the wait after it until its metal and the metal beneath it are solid (what the camera waits
//! for before it can read the top), the Bond number of the drop (Eq.1).
//!
//! No IO: the command writes the files.

use super::deposition::{heat_model, material};
use super::params::{Material, Process, ThermalModel, ThermalSettings};
use planner::saam::{Planned, Skeleton, Slicer};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use thermal::error::ThermalError;
use thermal::run::HeatRun;
use thermal::schedule::{Deposit, DropPart};

/// What skeleton arc AM needs beyond the part and the process (a scenario's `[skeleton]`,
/// checked, or a caller's own): radii in mm, wire feed in m/min, times in s.
#[derive(Debug, Clone, PartialEq)]
pub struct SkeletonSettings {
    pub radius_mm: f64,
    pub radii_mm: Vec<f64>,
    pub priorities: Vec<planner::saam::Priority>,
    pub slicer: planner::saam::SlicerSettings,
    pub wfs_m_min: f64,
    pub closed_loop: bool,
    pub camera_noise_mm: f64,
    pub drop_height_noise: f64,
    pub bad_drop_probability: f64,
    pub bad_drop_height: f64,
    pub seed: u64,
    pub min_wait_s: f64,
    pub max_wait_s: f64,
    pub heat: bool,
    pub max_drops: usize,
}

impl Default for SkeletonSettings {
    /// The documented defaults (scenarios/README.md `[skeleton]`): the paper's slicer (δ 1.3 mm
    /// for R_d 3 mm), 2 m/min, the virtual cell's closed loop on noisy drops (seed 1), waits of
    /// 1 to 120 s, the heat run on.
    fn default() -> Self {
        SkeletonSettings {
            radius_mm: 3.0,
            radii_mm: Vec::new(),
            priorities: Vec::new(),
            slicer: planner::saam::SlicerSettings::default(),
            wfs_m_min: 2.0,
            closed_loop: true,
            camera_noise_mm: 0.05,
            drop_height_noise: 0.1,
            bad_drop_probability: 0.02,
            bad_drop_height: 0.3,
            seed: 1,
            min_wait_s: 1.0,
            max_wait_s: 120.0,
            heat: true,
            max_drops: 20_000,
        }
    }
}

/// One drop as laid.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drop {
    pub planned: Planned,
    /// What the drop really added to its branch, mm.
    pub height_mm: f64,
    /// The branch's real top before and after it (abscissa), mm.
    pub top_before_mm: f64,
    pub top_mm: f64,
    /// The top the camera read, mm.
    pub top_read_mm: f64,
    /// The contact tip's real distance to the metal as the arc struck: the planned stand-off
    /// plus how far the point aimed at lay above the real top, mm.
    pub ctdwp_mm: f64,
    pub bad: bool,
    /// t_w = k_w × the time the wire feed takes to fill the whole sphere, s.
    pub weld_time_s: f64,
}

/// A loop's run: its drops, and what the slicer could not keep apart.
#[derive(Debug, Clone)]
pub struct LoopRun {
    pub closed: bool,
    pub drops: Vec<Drop>,
    /// Points let into a collision zone with nothing left to wait for.
    pub forced: usize,
    pub zones: usize,
    /// The branches as built (geometry, for the heat and the files).
    pub slicer: Slicer,
}

impl LoopRun {
    /// The contact tip's real distance over the drops: (min, max), mm.
    pub fn ctdwp_range(&self) -> (f64, f64) {
        planner::plan::range(self.drops.iter().map(|d| d.ctdwp_mm))
    }
}

/// One drop's noise: its height factor, whether it is bad, the camera's error.
#[derive(Debug, Clone, Copy)]
struct Noise {
    height: f64,
    bad: bool,
    camera_mm: f64,
}

/// The noise of drop k: a stream per drop number, so both loops see the same drops.
fn noise(set: &SkeletonSettings, k: usize) -> Noise {
    let mut rng =
        ChaCha8Rng::seed_from_u64(set.seed ^ (k as u64).wrapping_mul(0x9E37_79B9_7F4A_7C15));
    // Box–Muller: two normal deviates from two uniforms.
    let mut normal = || {
        let (u, v): (f64, f64) = (rng.random::<f64>().max(1e-300), rng.random::<f64>());
        (-2.0 * u.ln()).sqrt() * (std::f64::consts::TAU * v).cos()
    };
    let (h, c) = (normal(), normal());
    let bad = rng.random::<f64>() < set.bad_drop_probability;
    Noise {
        height: (1.0 + set.drop_height_noise * h).max(0.05),
        bad,
        camera_mm: set.camera_noise_mm * c,
    }
}

/// Run the slicer and the virtual cell, closed or open loop.
pub fn run_loop(sk: &Skeleton, set: &SkeletonSettings, p: &Process, closed: bool) -> LoopRun {
    let mut slicer = Slicer::new(sk, set.slicer);
    let mut tops: Vec<Option<f64>> = vec![None; sk.branches.len()];
    let mut drops = Vec::new();
    while drops.len() < set.max_drops {
        let Some(pl) = slicer.next_drop() else { break };
        let k = drops.len();
        let nz = noise(set, k);
        let r = pl.radius_mm;
        let sphere = 4.0 / 3.0 * std::f64::consts::PI * r.powi(3);
        let nominal = pl.weld_ratio * sphere / (std::f64::consts::PI * r * r);
        let height = nominal * nz.height * if nz.bad { set.bad_drop_height } else { 1.0 };
        // A branch's first drop lands where it is aimed (the plate, or a node's metal).
        let before = tops[pl.branch].unwrap_or(pl.s_mm);
        let top = before + height;
        let read = top + nz.camera_mm;
        tops[pl.branch] = Some(top);
        drops.push(Drop {
            planned: pl,
            height_mm: height,
            top_before_mm: before,
            top_mm: top,
            top_read_mm: read,
            ctdwp_mm: pl.standoff_mm + (pl.s_mm - before),
            bad: nz.bad,
            // The closing drops' welding time (one drop model): volume over the wire's feed.
            weld_time_s: bead_model::drop::welding_time(
                pl.weld_ratio * sphere * 1e-9,
                p.wire_diameter_m,
                set.wfs_m_min / 60.0,
            ),
        });
        slicer.built(closed.then_some(read));
    }
    LoopRun {
        closed,
        forced: slicer.forced,
        zones: slicer.zones().len(),
        drops,
        slicer,
    }
}

/// The heat of one drop: the wait before the next, and what it took to solidify.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DropHeat {
    /// From the arc's end until the drop and the metal beneath it are below the solidus, s
    /// (capped at the longest wait).
    pub solidification_s: f64,
    /// The wait after the drop before the next strikes, s.
    pub wait_s: f64,
    /// The drop's metal and the metal beneath it as the arc struck, K.
    pub preheat_k: f64,
    /// Eq.1: ρ g R² / σ.
    pub bond: f64,
}

/// The deposition schedule of a loop's drops, SI: each drop a short bead across its branch
/// (width 2R, as long as a disc of radius R is wide on average, πR/2, so that its section holds
/// the rod's), from the branch's top before it to its top after, laid on the drop beneath.
pub fn schedule(run: &LoopRun, set: &SkeletonSettings, p: &Process) -> Vec<Deposit> {
    let power = p.power.power(set.wfs_m_min / 60.0);
    let mut t = 0.0;
    run.drops
        .iter()
        .map(|d| {
            let b = run.slicer.branch(d.planned.branch);
            let (top, axis) = b.at(d.top_mm);
            let across = axis
                .cross(&planner::nalgebra::Vector3::x())
                .try_normalize(1e-6)
                .unwrap_or_else(|| axis.cross(&planner::nalgebra::Vector3::y()).normalize());
            let half = std::f64::consts::PI * d.planned.radius_mm / 4.0;
            let si = |q: planner::nalgebra::Point3<f64>| [q.x * 1e-3, q.y * 1e-3, q.z * 1e-3];
            t += d.weld_time_s;
            Deposit {
                position: si(top + across * half),
                start: Some(si(top - across * half)),
                time: t,
                arc_time: d.weld_time_s,
                heat: p.efficiency * power * d.weld_time_s,
                width: 2.0 * d.planned.radius_mm * 1e-3,
                height: d.height_mm.max(0.01) * 1e-3,
                axis: [axis.x, axis.y, axis.z],
                support: d.planned.support,
                drop: Some(DropPart::Strikes { deposits: 1 }),
            }
        })
        .collect()
}

/// What the skeleton command finds ([`skeleton`]): the loop the settings ask for, the other
/// on the same noisy drops, and the first's heat drop by drop where asked.
#[derive(Debug, Clone)]
pub struct Skeletoned {
    /// The loop `closed_loop` names, and the other.
    pub main: LoopRun,
    pub other: LoopRun,
    pub heats: Option<Vec<DropHeat>>,
}

/// The skeleton command's work: the slicer and the virtual cell closed loop and open loop on
/// `sk`'s drops, and (`set.heat`) the main loop's heat drop by drop.
pub fn skeleton(
    sk: &Skeleton,
    set: &SkeletonSettings,
    p: &Process,
    m: &Material,
    t: &ThermalSettings,
) -> Result<Skeletoned, ThermalError> {
    let main = run_loop(sk, set, p, set.closed_loop);
    let other = run_loop(sk, set, p, !set.closed_loop);
    let heats = match set.heat {
        true => Some(heat(&main, set, p, m, t)?),
        false => None,
    };
    Ok(Skeletoned { main, other, heats })
}

/// Run the heat drop by drop on the voxel model: after each drop, cool until its metal and
/// the metal beneath are below the solidus (0.1 s steps), wait at least `min_wait_s`.
pub fn heat(
    run: &LoopRun,
    set: &SkeletonSettings,
    p: &Process,
    m: &Material,
    t: &ThermalSettings,
) -> Result<Vec<DropHeat>, ThermalError> {
    let deps = schedule(run, set, p);
    let voxel = ThermalSettings {
        model: ThermalModel::Voxel,
        ..t.clone()
    };
    let solidus = material(m, &voxel).solidus;
    let mut model = heat_model(m, &voxel, &deps, Vec::new(), Vec::new()).start(&deps)?;
    let mut out = Vec::with_capacity(deps.len());
    let mut wait = 0.0;
    for (i, d) in run.drops.iter().enumerate() {
        let preheat = model.temperature_beneath(i);
        model.deposit(i, wait)?;
        let top = |r: &thermal::run::ModelRun| r.temperature_of(i).max(r.temperature_beneath(i));
        let mut elapsed = 0.0;
        while top(&model) >= solidus && elapsed < set.max_wait_s {
            model.cool(STEP_S)?;
            elapsed += STEP_S;
        }
        wait = (set.min_wait_s - elapsed).max(0.0);
        let r = d.planned.radius_mm * 1e-3;
        out.push(DropHeat {
            solidification_s: elapsed,
            wait_s: elapsed + wait,
            preheat_k: preheat,
            bond: bead_model::bond::bond_number(m.density_kg_m3, r, m.surface_tension_n_m),
        });
    }
    Ok(out)
}

/// The step of the solidification watch, s.
const STEP_S: f64 = 0.1;
