//! Local time stepping ([`thermal::rates`]) against the reference that steps every node at every
//! step, on schedules it was not tuned on (the defaults were chosen on the closed domes R 100
//! and R 200 in `sim`, docs/PHYSICS.md "Local time stepping"): a tall cylinder laid without a
//! pause, and a straight wall of separate tracks with a travel and a dwell before each.

use thermal::material::Material;
use thermal::network::Surroundings;
use thermal::rates::LocalSteps;
use thermal::schedule::{Deposit, helix};
use thermal::wall::{WallModel, WallRun, WallSettings};
use thermal::{HeatRun, Plate, RunResult};

/// The engine's defaults (`sim`'s documented LOCAL_* constants).
const LOCAL: LocalSteps = LocalSteps {
    near: 0.05,
    period: 1.0,
    levels: 12,
    age_share: 0.025,
    change: Some(1.0),
};

fn settings(local_steps: Option<LocalSteps>) -> WallSettings {
    WallSettings {
        material: Material::g3si(),
        surroundings: Surroundings {
            ambient_k: 293.15,
            convection_w_m2k: 15.0,
            emissivity: 0.6,
            table_w_m2k: 100.0,
        },
        plate: Plate {
            size: [0.2, 0.2, 0.01],
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
        watch_metal: true,
        local_steps,
        merge_plate: true,
    }
}

/// The run, with a dwell before each deposit `dwell(i)`, and its node steps.
fn run(
    deps: &[Deposit],
    local: Option<LocalSteps>,
    dwell: impl Fn(usize) -> f64,
) -> (RunResult, u64) {
    let s = settings(local);
    let mut run = WallRun::new(WallModel::build(deps, &s).unwrap(), deps, &s);
    for i in 0..deps.len() {
        run.deposit(i, dwell(i)).unwrap();
    }
    run.cool(60.0).unwrap();
    let work = run.node_steps();
    (run.finish(), work)
}

/// The largest and the median |preheat − reference| over the reference's rise above ambient,
/// over the points that rise more than 10 K.
fn errors(a: &RunResult, reference: &RunResult) -> (f64, f64) {
    let mut e: Vec<f64> = a
        .points
        .iter()
        .zip(&reference.points)
        .filter(|(_, r)| r.preheat - 293.15 > 10.0)
        .map(|(p, r)| (p.preheat - r.preheat).abs() / (r.preheat - 293.15))
        .collect();
    e.sort_by(f64::total_cmp);
    (e[e.len() - 1], e[e.len() / 2])
}

fn compare(deps: &[Deposit], dwell: impl Fn(usize) -> f64 + Copy, name: &str) -> (f64, f64, f64) {
    let (reference, all) = run(deps, None, dwell);
    let (local, some) = run(deps, Some(LOCAL), dwell);
    let (worst, median) = errors(&local, &reference);
    eprintln!(
        "{name}: preheats within {:.2} % of the rise (median {:.3} %), {} of {} node steps \
         ({:.2}), balance {:.1e}",
        100.0 * worst,
        100.0 * median,
        some,
        all,
        some as f64 / all as f64,
        local.balance_error
    );
    assert!(
        local.balance_error.abs() < 1e-9,
        "{name}: {}",
        local.balance_error
    );
    assert_eq!(local.points.len(), reference.points.len());
    (worst, median, some as f64 / all as f64)
}

/// 25 revolutions of R 60 mm at 10 mm/s, 1.7 kW, no pause: the part heats up revolution after
/// revolution, the far side of each stepped at its own rate.
#[test]
fn a_tall_cylinder_keeps_its_preheats_and_steps_far_fewer_nodes() {
    let deps = helix(0.06, 120, 25, 2e-3, 5e-3, 10e-3, 1700.0);
    // Measured: within 0.05 % (median 0.02 %), 76 % of the node steps; the bound is the issue's
    // (2 % of the rise). So small a part lies mostly within the near zone (50 mm); the share of
    // the work falls as the part grows (docs/PERFORMANCE.md: the dome R 200 in 40 % of the
    // reference's time).
    let (worst, median, work) = compare(&deps, |_| 0.0, "cylinder");
    assert!(worst < 0.02 && median < 0.005, "{worst} {median}");
    assert!(work < 0.85, "{work} of the reference's node steps");
}

/// 20 tracks of 100 mm, each from the same end after a travel and a 20 s dwell: every travel
/// is stepped whole and sorts every node again, every dwell brings every level to one time.
#[test]
fn a_wall_of_separate_tracks_with_dwells_keeps_its_preheats() {
    let (per, layers, seg, speed) = (40, 20, 2.5e-3, 8e-3);
    let dt = seg / speed;
    let mut deps = Vec::new();
    for l in 0..layers {
        for k in 0..per {
            let i = l * per + k;
            let x = -0.05 + (k as f64 + 1.0) * seg;
            let z = 2e-3 * (l as f64 + 1.0);
            deps.push(Deposit {
                position: [x, 0.0, z],
                time: 0.0,
                arc_time: dt,
                heat: 1500.0 * dt,
                width: 5e-3,
                height: 2e-3,
                axis: [0.0, 0.0, 1.0],
                support: (l > 0).then(|| i - per),
                start: (k == 0).then_some([-0.05, 0.0, z]),
                drop: None,
            });
        }
    }
    let dwell = |i: usize| {
        if i.is_multiple_of(per) && i > 0 {
            20.0
        } else {
            0.0
        }
    };
    let mut t = 0.0;
    for (i, d) in deps.iter_mut().enumerate() {
        t += dwell(i) + d.arc_time;
        d.time = t;
    }
    // Measured: within 0.05 % (median 0.01 %), 58 % of the node steps. With a near zone of
    // 25 mm: 0.21 %, and 1.3 % with the dwells stepping every node at once, 3.4 % with each
    // level solved apart through the dwells' long steps (the levels in step with level 0 are
    // now solved with it).
    let (worst, median, _) = compare(&deps, dwell, "straight wall");
    assert!(worst < 0.02 && median < 0.005, "{worst} {median}");
}
