use super::lay::{column_growth, settle};
use super::metal::path_lengths;
use super::source::{Goldak, arc_frame};
use super::vec3::{cross, dot, norm, normalize, scale, sub};
use super::*;
use crate::network::Surroundings;
use crate::run::{Burn, Cells};
use crate::schedule::{helix, segment_start};
use rustc_hash::FxHashSet as HashSet;

/// A 3-revolution helix R 30 mm on a `plate_mm` square plate, 2 mm voxels.
fn three_revolutions(plate_mm: f64) -> (Vec<Deposit>, VoxelSettings) {
    let deps = helix(0.03, 60, 3, 2e-3, 6e-3, 10e-3, 1700.0);
    let settings = VoxelSettings {
        material: Material::g3si(),
        surroundings: Surroundings {
            ambient_k: 293.15,
            convection_w_m2k: 15.0,
            emissivity: 0.6,
            table_w_m2k: 100.0,
        },
        plate: Plate::square_mm(plate_mm),
        size: 2e-3,
        deposit_temperature: 1823.15,
        lead: 10e-3,
        hot_threshold: 873.15,
        snapshot_times: vec![],
        traces: vec![],
        watch_metal: true,
        courant: 0.9,
        probes: vec![],
        probe_every: 0.0,
        source: HeatSource::DoubleEllipsoid,
        coarse_plate: false,
        device: Default::default(),
    };
    (deps, settings)
}

/// Over the points `range` of a run on `deps`: the largest departure of a point's preheat from
/// the mean of its two neighbours, and the largest rise over ambient, K.
fn preheat_jitter(
    deps: &[Deposit],
    settings: &VoxelSettings,
    range: std::ops::Range<usize>,
) -> (f64, f64) {
    let r = VoxelModel::new(deps, settings).unwrap().run(deps).unwrap();
    let p: Vec<f64> = r.points.iter().map(|q| q.preheat).collect();
    let jitter = range
        .clone()
        .map(|i| (p[i] - 0.5 * (p[i - 1] + p[i + 1])).abs())
        .fold(0.0, f64::max);
    let rise = p[range].iter().fold(0.0f64, |a, &b| a.max(b)) - 293.15;
    (jitter, rise)
}

/// The preheat of a point is the metal at its support's point, not along the support's whole
/// segment: on a ring of R 100 in 120 chords (5.2 mm, half the 10 mm lead) each support's
/// segment reached back to within some 5 mm of the arc, and the points' preheats alternated
/// as their segments took one voxel column more or less. Measured on the third revolution,
/// the largest departure of a point from the mean of its two neighbours: 101.9 K reading
/// the segment's mean, 2.6 K now (the rise some 140 K).
#[test]
fn a_preheat_is_read_at_the_supports_point() {
    let (_, mut settings) = three_revolutions(240.0);
    settings.watch_metal = false;
    let deps = helix(0.1, 120, 3, 1.8e-3, 5e-3, 10e-3, 2500.0);
    let (jitter, rise) = preheat_jitter(&deps, &settings, 241..359);
    eprintln!("third revolution: jitter {jitter:.2} K, rise {rise:.1} K");
    assert!(rise > 50.0, "the metal beneath is warm: {rise} K");
    assert!(jitter < 5.0, "{jitter} K between neighbours");
}

/// A point on the plate reads the plate's top at the point, the four columns round it
/// interpolated, not every cell under the bead's width alike: the square of 5 × 5 columns
/// shifted by a column as the points went round, and their preheats alternated (a library
/// hemisphere's first layer 26 K from its neighbours' mean at 25–60 °C; docs/PHYSICS.md "The
/// metal at the support's point"). A ring of R 100 in 120 chords on a 240 mm plate, its first
/// revolution: the largest departure of a point from the mean of its two neighbours.
#[test]
fn a_point_on_the_plate_reads_the_plate_at_the_point() {
    let (_, mut settings) = three_revolutions(240.0);
    settings.watch_metal = false;
    let deps = helix(0.1, 120, 2, 1.8e-3, 5e-3, 10e-3, 2500.0);
    let (jitter, rise) = preheat_jitter(&deps, &settings, 1..119);
    eprintln!("first revolution: jitter {jitter:.2} K, rise {rise:.1} K");
    assert!(
        rise > 5.0,
        "the plate warms as the arc comes round: {rise} K"
    );
    assert!(jitter < 3.0, "{jitter} K between neighbours");
}

/// A support's cells are read at the bead's core, not at its edges: on a wall leaning in (a
/// pressure-vessel head's knuckle) a tilted bead's outer cells stand a layer up, beside the
/// bead being laid, and read its heat: single points of a head's knuckle 20-27 K over their
/// neighbours (docs/PHYSICS.md "The metal at the support's point"). A knuckle of radius 20 mm
/// turning in from R 100 mm, 1.8 mm layers along it, 120 chords a revolution, the torch along
/// the wall: the largest departure of a point of its last four revolutions (leaning 21-40°)
/// from the mean of its two neighbours, 33.9 K reading every cell along the path, 3.2 K now
/// (the rise some 215 K).
#[test]
fn a_leaning_walls_support_is_read_at_its_beads_core() {
    let (_, mut settings) = three_revolutions(240.0);
    settings.watch_metal = false;
    let (n, revs, h, knuckle) = (120, 8, 1.8e-3, 0.02);
    let mut deps = helix(0.1, n, revs, h, 5e-3, 10e-3, 2500.0);
    for (i, d) in deps.iter_mut().enumerate() {
        let th = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
        let phi = h * i as f64 / n as f64 / knuckle;
        let r = 0.1 - knuckle * (1.0 - phi.cos());
        d.position = [r * th.cos(), r * th.sin(), h + knuckle * phi.sin()];
        d.axis = [-phi.sin() * th.cos(), -phi.sin() * th.sin(), phi.cos()];
    }
    let last = (revs / 2) * n + 1..revs * n - 1;
    let (jitter, rise) = preheat_jitter(&deps, &settings, last);
    eprintln!("the knuckle's last four revolutions: jitter {jitter:.2} K, rise {rise:.1} K");
    assert!(rise > 50.0, "the metal beneath is warm: {rise} K");
    assert!(jitter < 5.0, "{jitter} K between neighbours");
}

/// Where none of a support's cells lies within a cell of its point along the path (the
/// cells there laid before it, the next deposit's further on), its metal is read at the cell
/// at its bead's middle there, not at its own cells back towards the torch, which read the
/// arc's front: single points of a head's flange 26-30 K over their neighbours
/// (docs/PHYSICS.md "The metal at the support's point"). A second track over a first, a
/// tack laid before it from 5.5 to 10 mm: the support ending at 6 mm was read at its own
/// cells 3 mm and more back, now within a cell of its point.
#[test]
fn a_support_whose_cells_lie_back_is_read_at_its_point() {
    let (_, mut settings) = three_revolutions(100.0);
    settings.watch_metal = false;
    let bead = |x: f64, top: f64, start: Option<f64>| Deposit {
        position: [x, 0.0, top],
        time: 0.0,
        arc_time: 0.5,
        heat: 500.0,
        width: 4e-3,
        height: 1.8e-3,
        axis: [0.0, 0.0, 1.0],
        support: None,
        start: start.map(|s| [s, 0.0, top]),
        drop: None,
    };
    let x = |k: usize| -24e-3 + 6e-3 * k as f64;
    let mut deps: Vec<Deposit> = (0..9).map(|k| bead(x(k), 2e-3, None)).collect();
    let mut tack = bead(10e-3, 3.2e-3, Some(5.5e-3));
    tack.support = Some(5);
    deps.push(tack);
    for k in 0..9 {
        let mut d = bead(x(k), 3.2e-3, (k == 0).then(|| x(0)));
        d.support = Some(k);
        deps.push(d);
    }
    for (k, d) in deps.iter_mut().enumerate() {
        d.time = 0.5 * (k + 1) as f64;
    }
    let s = 10 + 5; // the second track's segment from x = 0 to 6 mm
    let mut run = VoxelRun::new(VoxelModel::new(&deps, &settings).unwrap(), &deps).unwrap();
    for i in 0..=s + 1 {
        run.deposit(i, 0.0).unwrap();
    }
    let m = run.model();
    let dx = settings.size;
    let back = |v: u32| deps[s].position[0] - m.centre_of(v)[0];
    assert!(!m.laid[s].is_empty() && m.laid[s].iter().all(|&v| back(v) > dx));
    assert!(m.laid[s + 1].iter().all(|&v| back(v) < -dx));
    let read = m.under_point(&deps, s);
    assert!(!read.is_empty());
    for (v, _) in read {
        assert!(back(v).abs() <= dx, "a cell {:.1} mm back", back(v) * 1e3);
    }
}

/// A support that switched on no cell of its own is read at the bead's cells either side of
/// its point, as a support with cells is. It was read at its own support, and so on down:
/// on a pressure-vessel head's flat crown the deposit after each revolution's seam lays no
/// cell, and the point over it was read at the metal many revolutions down, up to 100 K
/// under its neighbours (docs/PHYSICS.md "The metal at the support's point"). Here a ring
/// of R 100 in 120 chords, a deposit of no length and a fifth of a millimetre after the
/// same point of each of its first nine revolutions, each on the one before (the first on
/// the plate): the tenth revolution's point over them against its neighbours' mean, −26.2
/// K before (the plate's top read, 20 mm down), +2.2 K now (rise 266 K).
#[test]
fn a_support_with_no_cell_of_its_own_is_read_at_the_bead_beside_it() {
    let (_, mut settings) = three_revolutions(240.0);
    settings.watch_metal = false;
    const REVS: usize = 10;
    let n = 120;
    let ring = helix(0.1, n, REVS, 2e-3, 5e-3, 10e-3, 2500.0);
    // Each ring deposit's index in `deps` (a tiny one pushed after some), and the tiny ones'.
    let (mut deps, mut index, mut seams) = (Vec::new(), Vec::new(), Vec::<usize>::new());
    let mut late = 0.0;
    for (j, d) in ring.iter().enumerate() {
        index.push(deps.len());
        let mut d = *d;
        d.time += late;
        d.support = d.support.map(|s| index[s]);
        deps.push(d);
        if j % n == n / 2 && j < (REVS - 1) * n {
            let mut tiny = d;
            (tiny.arc_time, tiny.heat) = (1e-3, 2500.0 * 1e-3);
            (tiny.width, tiny.height) = (0.2e-3, 0.2e-3);
            late += tiny.arc_time;
            tiny.time += tiny.arc_time;
            tiny.support = seams.last().copied();
            seams.push(deps.len());
            deps.push(tiny);
        }
    }
    let k = index[(REVS - 1) * n + n / 2];
    deps[k].support = seams.last().copied();
    let mut run = VoxelRun::new(VoxelModel::new(&deps, &settings).unwrap(), &deps).unwrap();
    for i in 0..deps.len() {
        run.deposit(i, 0.0).unwrap();
    }
    assert!(seams.iter().all(|&s| run.model().laid[s].is_empty()));
    let p: Vec<f64> = run.points().iter().map(|q| q.preheat).collect();
    let off = p[k] - 0.5 * (p[k - 1] + p[k + 1]);
    let rise = p[k - 1] - 293.15;
    eprintln!(
        "the point on the empty supports: {off:+.1} K from its neighbours (rise {rise:.1} K)"
    );
    assert!(rise > 50.0, "the metal beneath is warm: {rise} K");
    assert!(off.abs() < 5.0, "{off} K");
}

/// A ring of beads 1.8 mm high climbing 1.93 mm a revolution on 2 mm cells (R 100 in 120
/// chords of 5.2 mm: the library cylinder's) lays no cell for a stretch of deposits now and
/// then (here its whole fifth revolution), their beads in the cells of the revolution
/// beneath. The pool behind the arc reads those cells, as it reads the cells of deposits
/// that laid some; read as a gap between the samples around it, such a run made the pool
/// 88 mm long on the cylinder. Measured over eight revolutions: the longest pool 637 mm
/// before (the whole empty revolution), 18.4 mm now (the first deposit after it, whose
/// cells take the revolution's metal at once); the median 7.7 and 7.9 mm.
#[test]
fn a_pool_reads_the_cells_under_deposits_that_laid_none() {
    let (_, mut settings) = three_revolutions(240.0);
    settings.coarse_plate = true;
    // The beads 1.8 mm high (Eq.7's), the layers 1.93 mm apart (the plan's deposit).
    let mut deps = helix(0.1, 120, 8, 1.93e-3, 5e-3, 10e-3, 1700.0);
    deps.iter_mut().for_each(|d| d.height = 1.8e-3);
    let mut run = VoxelRun::new(VoxelModel::new(&deps, &settings).unwrap(), &deps).unwrap();
    for i in 0..deps.len() {
        run.deposit(i, 0.0).unwrap();
    }
    let empty = run.model().laid.iter().filter(|l| l.is_empty()).count();
    let pools: Vec<f64> = run.points().iter().map(|p| p.pool_length).collect();
    let longest = pools.iter().fold(0.0f64, |a, &b| a.max(b));
    let mut sorted = pools.clone();
    sorted.sort_by(f64::total_cmp);
    let median = sorted[sorted.len() / 2];
    eprintln!(
        "{empty} deposits laid no cell; pool median {:.1} mm, longest {:.1} mm",
        median * 1e3,
        longest * 1e3
    );
    assert!(empty > 10, "{empty}");
    assert!(median > 4e-3, "the arc makes a pool: {median}");
    assert!(longest < 25e-3, "{longest}");
}

/// A strut of `width`: a torch climbing along its own vertical axis from 4 mm over the
/// plate's centre to 24 mm, 4 mm a deposit and each 4 mm high (the first at its foot, with
/// no segment of its own).
fn strut(width: f64) -> Vec<Deposit> {
    (0..6usize)
        .map(|k| Deposit {
            position: [0.0, 0.0, 4e-3 * (k + 1) as f64],
            time: (k + 1) as f64,
            arc_time: 1.0,
            heat: 500.0,
            width,
            height: 4e-3,
            axis: [0.0, 0.0, 1.0],
            support: k.checked_sub(1),
            start: None,
            drop: None,
        })
        .collect()
}

/// A deposit whose new cells take more heat than its arc gives takes the rest from the
/// arcs after it: the run takes in its arcs' heat and what is still owed at its end, no
/// more (before, each such deposit's excess was added to the heat in).
#[test]
fn the_metal_takes_no_more_heat_than_the_arcs_give() {
    // Its 6 mm beads on 2 mm voxels: 14 of its 180 deposits lay more cells than their
    // arcs can heat.
    let (deps, settings) = three_revolutions(60.0);
    let mut run = VoxelRun::new(VoxelModel::new(&deps, &settings).unwrap(), &deps).unwrap();
    crate::run::replay(&mut run, &deps).unwrap();
    let (arcs, deficit) = (deps.iter().map(|d| d.heat).sum::<f64>(), run.deficit);
    let r = run.finish();
    let taken = r.ledger.source + r.ledger.deposited;
    assert!(
        r.underpowered > 10 && deficit < 0.01 * arcs,
        "{} {deficit}",
        r.underpowered
    );
    assert!(
        (taken - arcs - deficit).abs() < 1e-5 * arcs,
        "{taken} J for {arcs} J"
    );
    assert!(r.balance_error.abs() < 1e-5, "{}", r.balance_error);
}

/// A straight track along x over the plate's centre, its deposits `spacing(k)` apart.
fn track(n: usize, spacing: impl Fn(usize) -> f64) -> Vec<Deposit> {
    let mut x = -20e-3;
    (0..n)
        .map(|k| {
            x += if k > 0 { spacing(k) } else { 0.0 };
            Deposit {
                position: [x, 0.0, 1.5e-3],
                time: k as f64 * 0.01,
                arc_time: 0.01,
                heat: 100.0,
                width: 4e-3,
                height: 1.5e-3,
                axis: [0.0, 0.0, 1.0],
                support: None,
                start: None,
                drop: None,
            }
        })
        .collect()
}

/// The melt pool's walk back over a path cut finer than its voxels, runs of deposits that
/// laid no metal of their own read a cell's length at a time, gives the pool the walk a
/// deposit at a time gives (each empty one reading the cell at its bead) within a cell: 1
/// mm deposits on 2 mm voxels, 0.05 mm (forty to a voxel), and a stretch of each.
#[test]
fn the_pools_walk_reads_what_laid_no_metal_a_cell_at_a_time() {
    let (_, settings) = three_revolutions(60.0);
    // The walk a deposit at a time.
    let every = |m: &VoxelModel, deps: &[Deposit], i: usize| {
        let samples = (0..=i).rev().map(|j| {
            let d = &deps[j];
            let (a, b) = (segment_start(deps, j), d.position);
            let middle: [f64; 3] = std::array::from_fn(|c| 0.5 * (a[c] + b[c]));
            let bead = sub(middle, scale(d.axis, m.sink[j] + 0.5 * d.height));
            crate::pool::Sample {
                t: match m.laid[j].is_empty() {
                    true => m.voxel_near(bead).map(|v| m.temperature(v)),
                    false => Some(m.mean_t(&m.laid[j])),
                },
                length: if j == 0 {
                    0.0
                } else {
                    norm(sub(deps[j].position, deps[j - 1].position))
                },
                volume: m.laid[j].len() as f64 * m.settings.size.powi(3),
            }
        });
        let (length, volume) = crate::pool::behind(samples, m.settings.material.solidus);
        (length, (3.0 * volume / (2.0 * std::f64::consts::PI)).cbrt())
    };
    let fine = |k: usize| {
        if (300..700).contains(&k) {
            1e-3
        } else {
            0.05e-3
        }
    };
    for deps in [
        track(40, |_| 1e-3),
        track(800, |_| 0.05e-3),
        track(1000, fine),
    ] {
        let mut m = VoxelModel::new(&deps, &settings).unwrap();
        m.lay_all(&deps);
        let along = path_lengths(&deps);
        let end = along[deps.len() - 1];
        // Hot at the track's end, the solidus crossed 12 mm back along it.
        for (d, laid) in deps.iter().zip(&m.laid) {
            let back = end - (d.position[0] + 20e-3);
            for &v in laid {
                m.t[v as usize] = (1740.0 + 60_000.0 * (12e-3 - back)) as f32;
            }
        }
        let skipped = m.laid.iter().filter(|l| l.is_empty()).count();
        assert!(skipped > deps.len() / 3, "{skipped} of {}", deps.len());
        for i in 0..deps.len() {
            let (a, b) = (m.pool(&deps, &along, i), every(&m, &deps, i));
            assert!((a.0 - b.0).abs() <= 2e-3, "{i}: {a:?} {b:?}");
        }
        let (length, _) = m.pool(&deps, &along, deps.len() - 1);
        assert!((length - 12e-3).abs() < 2e-3, "{length}");
        // The metal's temperature read back to the last deposit that laid some.
        let last = deps.len() - 1;
        let j = (0..=last).rev().find(|&j| !m.laid[j].is_empty()).unwrap();
        assert_eq!(m.metal_t(last), m.mean_t(&m.laid[j]));
    }
}

/// A torch climbing along its own axis lays a column as wide as its bead every way, from
/// its foot (a spot) up, with no cell missing, and its arc heats round that axis. Before, a
/// bead with no direction across it took a slab as wide as the cube it looked through (a
/// logged strut 30 mm up, 4 mm wide, in 1 mm deposits on 2 mm voxels: 270 cells where the
/// wire's metal fills 22.5) and its arc spread the heat along the slab.
#[test]
fn a_torch_climbing_along_its_axis_lays_a_column() {
    let (_, settings) = three_revolutions(40.0);
    let deps = strut(4e-3);
    let mut m = VoxelModel::new(&deps, &settings).unwrap();
    m.lay_all(&deps);
    let metal: Vec<u32> = m.laid.iter().flatten().copied().collect();
    for &v in &metal {
        let c = m.centre_of(v);
        assert!(c[0].abs() <= 2e-3 && c[1].abs() <= 2e-3, "a cell at {c:?}");
    }
    // Cells of 2 mm centred at ±1 mm: 2 × 2 in each of the 12 cells up to 24 mm.
    assert_eq!(metal.len(), 48);
    // Its foot fills down to the plate: 2 × 2 cells at 1 and 3 mm.
    assert_eq!(m.laid[0].len(), 8, "the strut's foot");
    for i in [0, 5] {
        let mut w = Vec::new();
        let burn = Burn {
            heat: 500.0,
            arc_time: 1.0,
            drop: None,
        };
        m.source(&deps, i, burn, &mut w);
        let total: f64 = w.iter().map(|x| x.1 as f64).sum();
        let spread = w
            .iter()
            .map(|&(v, q)| {
                let c = m.centre_of(v);
                q as f64 * (c[0] * c[0] + c[1] * c[1])
            })
            .sum::<f64>()
            / total;
        // Goldak's a = W/2 and c_r = W: an RMS reach of about 2 mm here.
        assert!(
            spread.sqrt() < 3e-3,
            "deposit {i}: RMS {} mm",
            spread.sqrt() * 1e3
        );
    }
}

/// Ten revolutions of three points, each laid on its own generator's point a revolution
/// down (a plan's support): out 50 mm and back to 0.03 mm from where the revolution began,
/// the step to the next one along the torch's axis. Every bead lies on the one beneath,
/// its metal settled at its path point (sink 0). Taken as a torch climbing, each
/// revolution's metal settled 1.2 mm further back (12 mm by the tenth): the path from the
/// support goes out and back, no straight climb.
#[test]
fn a_plans_revolution_stepping_along_its_axis_is_no_column() {
    let deps: Vec<Deposit> = (0..30usize)
        .map(|k| Deposit {
            position: [[0.0, 5e-2, 3e-5][k % 3], 0.0, 2e-3 * (k / 3 + 1) as f64],
            time: (k + 1) as f64,
            arc_time: 1.0,
            heat: 500.0,
            width: 5e-3,
            height: 2e-3,
            axis: [0.0, 0.0, 1.0],
            support: k.checked_sub(3),
            start: None,
            drop: None,
        })
        .collect();
    let (below, sink) = settle(&deps);
    assert!(sink.iter().all(|&s| s < 1e-12), "{sink:?}");
    assert!(below.iter().all(|&b| (b - 2e-3).abs() < 1e-9), "{below:?}");
    assert!(column_growth(&deps, 3).is_none());
    // A strut logged in steps under a layer lies on a deposit a few back, straight below:
    // a climb.
    let strut: Vec<Deposit> = (0..20usize)
        .map(|k| Deposit {
            position: [0.0, 0.0, 0.5e-3 * (k + 1) as f64],
            support: k.checked_sub(3),
            ..deps[0]
        })
        .collect();
    assert!((3..20).all(|k| column_growth(&strut, k).is_some()));
}

/// A strut whose torch climbs faster than its wire feeds it (beads 4 mm wide and 2 mm high,
/// 4 mm a deposit) grows by the wire's metal, W·H·L a deposit (H·L/W = 2 mm up), not by
/// the torch's climb: its column holds the wire's volume to the cell and lies under the
/// path points, its top falling behind them. Before, a deposit longer than H laid a
/// window H high at the segment's bottom end and the next one's segment no longer reached
/// it: on a logged strut climbing 2 m in 100 mm deposits, 62 cells of 2 mm voxels (a slab
/// at its foot) where the wire's metal fills 1 500.
///
/// The same where no support is known (a logged path's are looked for within a layer of
/// the path point, and the column lags further): each grows on the one before.
#[test]
fn a_strut_grows_by_the_wires_metal() {
    for logged in [false, true] {
        strut_of_the_wires_metal(logged);
    }
}

fn strut_of_the_wires_metal(logged: bool) {
    let (_, settings) = three_revolutions(40.0);
    let deps: Vec<Deposit> = strut(4e-3)
        .into_iter()
        .map(|d| Deposit {
            height: 2e-3,
            support: d.support.filter(|_| !logged),
            ..d
        })
        .collect();
    let mut m = VoxelModel::new(&deps, &settings).unwrap();
    m.lay_all(&deps);
    let metal: Vec<u32> = m.laid.iter().flatten().copied().collect();
    // The foot (a spot W × W × H) and five columns of W·H·L: 32 + 5 × 32 mm³.
    let wire = 4e-3 * 2e-3 * (4e-3 + 5.0 * 4e-3);
    assert_eq!(metal.len() as f64, (wire / 8e-9_f64).round());
    for (i, laid) in m.laid.iter().enumerate() {
        assert_eq!(laid.len(), 4, "deposit {i}");
    }
    let top = metal.iter().map(|&v| m.centre_of(v)[2]).fold(0.0, f64::max);
    assert!(
        (top - 11e-3).abs() < 1e-9,
        "the column's top cell at {top} m"
    );
    for &v in &metal {
        let c = m.centre_of(v);
        assert!(c[0].abs() <= 2e-3 && c[1].abs() <= 2e-3, "a cell at {c:?}");
    }
}

/// A path's first deposit (no segment of its own) lays the start of the bead the path goes
/// on with: W wide across the way it runs, half a voxel along it. Before, it took a frame
/// from the tool axis crossed with the vertical (none for a vertical torch, a tenth of a
/// unit for a dome's slightly tilted one) and laid a slab across the path some 7 mm either
/// side, and spread its arc along it.
#[test]
fn a_path_starts_its_bead_no_wider_than_the_bead() {
    let (_, settings) = three_revolutions(60.0);
    for axis in [[0.0, 0.0, 1.0], normalize([-0.036, -0.002, 1.0])] {
        let deps: Vec<Deposit> = (0..6)
            .map(|k| Deposit {
                position: [3e-3 * k as f64, 0.0, 1.5e-3],
                time: (k + 1) as f64,
                height: 1.5e-3,
                axis,
                support: None,
                ..strut(5e-3)[0]
            })
            .collect();
        let mut m = VoxelModel::new(&deps, &settings).unwrap();
        m.lay(&deps, 0);
        assert!(!m.laid[0].is_empty());
        for &v in &m.laid[0] {
            let c = m.centre_of(v);
            assert!(
                c[1].abs() <= 2.5e-3 && c[0].abs() <= 1.001e-3,
                "a cell at {c:?}"
            );
        }
        let (travel, across) = arc_frame(&deps, 0);
        assert!(dot(travel, [1.0, 0.0, 0.0]) > 0.999 && dot(across, [0.0, 1.0, 0.0]) > 0.999);
    }
}

/// Goldak's frame is square to the torch (its travel across the axis, as the double
/// ellipsoid lies on the work), not sheared along a climb: on a climbing helix, its torch
/// upright and tilted 17°, and on a climb of 60°: the travel the bead's direction less its
/// part along the axis.
#[test]
fn the_arcs_frame_is_square_to_the_torch() {
    let (helix_deps, _) = three_revolutions(100.0);
    let steep: Vec<Deposit> = (0..4usize)
        .map(|k| Deposit {
            position: [2e-3 * k as f64, 0.0, 2e-3 + 3.46e-3 * k as f64],
            time: (k + 1) as f64,
            support: k.checked_sub(1),
            ..strut(5e-3)[0]
        })
        .collect();
    for tilt in [0.0, 0.3] {
        for (deps, i) in [(&helix_deps, 70), (&helix_deps, 150), (&steep, 2)] {
            let mut deps = deps.clone();
            deps[i].axis = normalize([tilt, 0.0, 1.0]);
            let (travel, across) = arc_frame(&deps, i);
            let run = normalize(sub(deps[i].position, segment_start(&deps, i)));
            assert!(dot(travel, deps[i].axis).abs() < 1e-12, "{i}: {travel:?}");
            assert!(dot(across, travel).abs() < 1e-12 && dot(across, run).abs() < 1e-12);
            assert!((norm(travel) - 1.0).abs() < 1e-12 && (norm(across) - 1.0).abs() < 1e-12);
            let along = dot(run, deps[i].axis);
            let way = (1.0 - along * along).sqrt();
            assert!(
                (dot(travel, run) - way).abs() < 1e-12,
                "{i}: the travel's way"
            );
        }
    }
}

/// `lay` looks only at the cells its scan range holds, and lays what a scan of the whole
/// cube round each deposit lays, cell for cell and in the same order: on the helix
/// (deposits of 3 mm, 2 mm voxels), on a wall of long deposits (40 mm each, some with the
/// tool tilted 27°, one climbing 4 mm, beads 12 mm wide and 1 mm, narrower than a voxel),
/// on a wall whose tool axis lies nearly along the travel, and on a strut and a climb of
/// 80° (the bead's thickness bounding the range across the travel).
#[test]
fn the_scan_range_holds_every_cell_a_deposit_takes() {
    let (helix_deps, settings) = three_revolutions(100.0);
    let tilt = normalize([0.0, 0.5, 1.0]);
    let mut wall = Vec::new();
    for layer in 0..4 {
        let z = 1.5e-3 * (layer + 1) as f64;
        let corners = [[-0.02, -0.02], [0.02, -0.02], [0.02, 0.02], [-0.02, 0.02]];
        for (k, c) in corners.iter().enumerate() {
            let n = wall.len();
            wall.push(Deposit {
                position: [c[0], c[1], z + if k == 1 { 4e-3 } else { 0.0 }],
                time: (n + 1) as f64,
                arc_time: 1.0,
                heat: 100.0,
                width: [5e-3, 5e-3, 12e-3, 1e-3][k],
                height: 1.5e-3,
                axis: if layer % 2 == 1 {
                    tilt
                } else {
                    [0.0, 0.0, 1.0]
                },
                support: (n >= 4).then(|| n - 4),
                start: None,
                drop: None,
            });
        }
    }
    let leaning: Vec<Deposit> = wall
        .iter()
        .map(|d| Deposit {
            axis: normalize([1.0, 0.05, 0.02]),
            ..*d
        })
        .collect();
    let climb: Vec<Deposit> = (0..8usize)
        .map(|k| Deposit {
            // 80° up from the plate, 4 mm a deposit.
            position: [-0.01 + 7e-4 * k as f64, 0.0, 2e-3 + 3.9e-3 * k as f64],
            time: (k + 1) as f64,
            support: k.checked_sub(1),
            ..strut(5e-3)[0]
        })
        .collect();
    for deps in [&helix_deps, &wall, &leaning, &strut(4e-3), &climb] {
        let laid = |cut: bool| {
            let mut m = VoxelModel::new(deps, &settings).unwrap();
            for i in 0..deps.len() {
                m.lay_scanning(deps, i, cut);
            }
            (m.laid, m.cell)
        };
        let (scanned, whole) = (laid(true), laid(false));
        if let Some(i) = (0..deps.len()).find(|&i| scanned.0[i] != whole.0[i]) {
            panic!(
                "deposit {i} of {}: {} cells laid, {} in the whole cube",
                deps.len(),
                scanned.0[i].len(),
                whole.0[i].len()
            );
        }
        assert!(scanned.1 == whole.1, "the cells' order");
    }
    // The range is tighter than the cube on a long deposit.
    let m = VoxelModel::new(&wall, &settings).unwrap();
    let prev = segment_start(&wall, 5);
    let seg = sub(wall[5].position, prev);
    let len = norm(seg);
    let tangent = scale(seg, 1.0 / len);
    let across = normalize(cross(wall[5].axis, tangent));
    let (lo, hi) = m.scan_range(&wall[5], (prev, len), (tangent, across), (3e-3, 0.0), true);
    let cells: usize = (0..3).map(|k| hi[k] + 1 - lo[k]).product();
    assert!(cells < 4000, "{cells} cells scanned for a 40 mm deposit");
}

/// The stable step is the stencil's own limit, dx²/(6·α_max) with α_max the largest
/// k/(ρ·dh/dT) at one temperature, not k_max/(ρ·c_min): a 16³ block of IN718 at 1 443 K
/// (where its k/c peaks), losses off, a checkerboard of ±0.5 K on it (the stencil's fastest
/// mode, eigenvalue 12·α/dx² less the block's edges, 11.88) dies away at 0.98 of the step
/// and grows at 1.05 of it. IN718's k rises with T as its c does, so the old bound was 1.5
/// times shorter than the stencil needs.
#[test]
fn the_stable_step_is_the_stencils_limit() {
    let m = Material::in718();
    let old = {
        let (mut cmin, mut kmax) = (f64::INFINITY, 0.0f64);
        for t in (250..3500).step_by(10) {
            cmin = cmin.min(m.apparent_heat(t as f64));
            kmax = kmax.max(m.conductivity(t as f64));
        }
        m.density * cmin / (6.0 * kmax)
    };
    let new = stable_step(&m, 1.0, 1.0);
    assert!((1.45..1.55).contains(&(new / old)), "{new} against {old}");
    let swing = |courant: f64| {
        let (deps, mut settings) = three_revolutions(32.0);
        settings.material = m.clone();
        settings.plate.size = [0.032, 0.032, 0.032];
        let mut v = VoxelModel::new(&deps, &settings).unwrap();
        v.set_losses(0.0, 0.0, 0.0);
        let n = v.active() as u32;
        assert_eq!(n, 16 * 16 * 16);
        for i in 0..n {
            let [x, y, z] = v.cell_of(i);
            v.set_temperature(i, 1443.0 + if (x + y + z) % 2 == 0 { 0.5 } else { -0.5 });
        }
        let dt = courant * v.stable_step() / settings.courant;
        for _ in 0..200 {
            v.step(dt, &[]);
        }
        let t: Vec<f64> = (0..n).map(|i| v.temperature(i)).collect();
        let mean = t.iter().sum::<f64>() / t.len() as f64;
        t.iter().map(|t| (t - mean).abs()).fold(0.0, f64::max)
    };
    let (below, above) = (swing(0.98), swing(1.05));
    assert!(
        below < 0.01,
        "at 0.98 of the step the checkerboard is {below} K"
    );
    assert!(
        above > 10.0,
        "at 1.05 of the step the checkerboard is {above} K"
    );
}

/// The vector kernel is the plain one eight at a time: on a 3-revolution build (hot metal
/// laid, groups regular in the plate and irregular in the wall, the tail) the preheats agree
/// to f32 rounding (6e-5 K measured), the peaks too, and the losses to 1e-6; on a plate of
/// its own material too, whose voxels end inside a group of eight (the spans either side of
/// that end), and with the plate coarsened (a third region, also ending inside a group).
#[test]
fn vector_and_plain_kernels_agree() {
    if !kernel::simd_available() {
        eprintln!("no AVX2 and FMA here: one kernel only");
        return;
    }
    let cases = [
        (100.0, None, false),
        (102.0, Some(Material::in718()), false),
        (101.0, Some(Material::in718()), true),
    ];
    for (mm, plate, coarse_plate) in cases {
        let (deps, mut settings) = three_revolutions(mm);
        settings.plate.material = plate;
        settings.coarse_plate = coarse_plate;
        if settings.plate.material.is_some() {
            let m = VoxelModel::new(&deps, &settings).unwrap();
            assert!(!m.plate_voxels.is_multiple_of(8), "{}", m.plate_voxels);
            assert!(!coarse_plate || !m.coarse.is_multiple_of(8), "{}", m.coarse);
        }
        kernels_agree(&deps, &settings);
    }
}

/// The top surface is exactly the active voxels with no active voxel above them, on the
/// bare plate (one per column) and after the wall is laid on it.
/// On a coarsened plate too (12 mm: its top is coarse away from the helix), where a coarse
/// cell's top is a cell edge above its centre.
#[test]
fn the_top_surface_is_what_has_nothing_above() {
    for coarse_plate in [false, true] {
        let (deps, mut settings) = three_revolutions(100.0);
        settings.plate.size[2] = 0.012;
        settings.coarse_plate = coarse_plate;
        let mut m = VoxelModel::new(&deps, &settings).unwrap();
        let check = |m: &VoxelModel| {
            let surface: Vec<u32> = m.top_surface().into_iter().map(|s| s.0).collect();
            for v in 0..m.cell.len() as u32 {
                let c = m.centre_of(v);
                assert_eq!(m.voxel_at(c), Some(v));
                let half = match (v as usize) < m.coarse {
                    true => m.settings.size,
                    false => m.settings.size / 2.0,
                };
                let above = m.voxel_at([c[0], c[1], c[2] + half + m.settings.size / 2.0]);
                assert_eq!(surface.contains(&v), above.is_none(), "voxel {v} at {c:?}");
            }
            surface.len()
        };
        let columns = check(&m);
        match coarse_plate {
            false => assert!(columns >= 2500, "a 50 × 50 plate"),
            true => assert!(m.coarse > 0 && columns < 2500, "{columns}"),
        }
        m.lay_all(&deps);
        assert!(m.active() > m.plate_voxels);
        check(&m);
    }
}

/// The plain and the vector kernel over a whole run of `deps`.
fn kernels_agree(deps: &[Deposit], settings: &VoxelSettings) {
    let run = |simd| {
        let mut m = VoxelModel::new(deps, settings).unwrap();
        m.simd = simd;
        m.run(deps).unwrap()
    };
    let (plain, vector) = (run(false), run(true));
    let worst = |f: fn(&PointResult) -> f64| {
        plain
            .points
            .iter()
            .zip(&vector.points)
            .map(|(a, b)| (f(a) - f(b)).abs())
            .fold(0.0, f64::max)
    };
    let (preheat, peak) = (worst(|p| p.preheat), worst(|p| p.peak));
    let lost = (plain.ledger.lost() - vector.ledger.lost()).abs() / plain.ledger.lost();
    eprintln!(
        "kernels: preheat within {preheat:.2e} K, peak within {peak:.2e} K, losses within {lost:.2e}"
    );
    assert!(preheat < 1e-3 && peak < 1e-3, "{preheat} {peak}");
    assert!(lost < 1e-6, "{lost}");
    assert!(plain.points.iter().any(|p| p.preheat > 400.0));
}

/// One thread or two, the same numbers to the bit: chunks are fixed and their partial sums
/// added in order. The 200 mm plate makes 13 chunks, so two threads do share the work; on
/// a plate of its own material too (chunks cut where the plate ends, the interface fixed
/// in order).
#[test]
fn one_thread_or_two_give_the_same_bits() {
    let cases = [
        (200.0, None, false),
        (202.0, Some(Material::in718()), false),
        (301.0, Some(Material::in718()), true),
    ];
    for (mm, plate, coarse_plate) in cases {
        let (deps, mut settings) = three_revolutions(mm);
        settings.plate.material = plate;
        settings.coarse_plate = coarse_plate;
        if settings.plate.material.is_some() {
            // The plate ends inside a group of eight: every kind of span is taken.
            let m = VoxelModel::new(&deps, &settings).unwrap();
            assert!(!m.plate_voxels.is_multiple_of(8) && !m.plate_voxels.is_multiple_of(CHUNK));
        }
        same_bits_on_one_thread_or_two(&deps, &settings);
    }
}

/// Goldak's ellipsoid cut at three semi-axes keeps every voxel the whole active set weighs
/// above 2e-12 of the peak, and its total to 1e-10: deposits of a climbing helix (a tangent
/// not square to the axis) and the same with the axis tilted 17°.
#[test]
fn the_ellipsoid_cut_keeps_the_source() {
    let (deps, settings) = three_revolutions(100.0);
    let mut m = VoxelModel::new(&deps, &settings).unwrap();
    m.lay_all(&deps);
    for i in [5, 70, 150] {
        for tilt in [0.0, 0.3] {
            let mut d = deps[i];
            d.axis = normalize([tilt, 0.0, 1.0]);
            let tangent = normalize(sub(d.position, segment_start(&deps, i)));
            let across = normalize(cross(d.axis, tangent));
            let pool = sub(d.position, scale(d.axis, m.sink[i]));
            let cut = m.ellipsoid(&d, pool, tangent, across);
            let g = Goldak {
                a: d.width / 2.0,
                b: d.height.max(m.settings.size),
                cf: d.width / 2.0,
                cr: Goldak::rear(d.width),
            };
            let all: Vec<(u32, f64)> = (0..m.h.len() as u32)
                .map(|v| {
                    let r = sub(m.centre_of(v), pool);
                    let depth = dot(r, d.axis).min(0.0);
                    (v, g.weight(dot(r, tangent), dot(r, across), depth))
                })
                .filter(|&(_, w)| w > 0.0)
                .collect();
            let peak = all.iter().map(|x| x.1).fold(0.0, f64::max);
            let kept: HashSet<u32> = cut.iter().map(|x| x.0).collect();
            assert!(cut.len() > 10 && kept.len() == cut.len());
            for &(v, w) in &all {
                assert!(
                    kept.contains(&v) || w < 2e-12 * peak,
                    "voxel {v}: {w} of {peak}"
                );
            }
            let total = |w: &[(u32, f64)]| w.iter().map(|x| x.1).sum::<f64>();
            let (a, b) = (total(&cut), total(&all));
            assert!((a - b).abs() < 1e-10 * b, "{i} {tilt}: {a} against {b}");
            assert!(cut.len() < all.len(), "the cut drops the far voxels");
        }
    }
}

/// A step that reads the laid metal in the chunks' tasks (`step_watched`) gives the peaks,
/// times above and hottest of a step then `observe`, to the bit: on a finished part cooling
/// from its deposit temperature, every deposit laid and half of them, deposits inside one
/// chunk and across two; where a deposit's voxels are not one run, and on a plate of
/// another material (both read apart).
#[test]
fn a_watched_step_reads_the_metal_as_observe_does() {
    // A plate whose voxels end short of a chunk's end, so that the wall's cross it.
    let finished = |mm: f64, plate: Option<Material>| {
        let (deps, mut settings) = three_revolutions(mm);
        settings.plate.material = plate;
        let mut m = VoxelModel::new(&deps, &settings).unwrap();
        m.lay_all(&deps);
        let chunks = m.h.len().div_ceil(CHUNK);
        let across = m
            .runs
            .clone()
            .cut(&m.laid, deps.len(), chunks)
            .unwrap()
            .across()
            .count();
        (across > 0).then_some((deps, m))
    };
    let (deps, base) = (190..=210)
        .step_by(2)
        .find_map(|mm| finished(mm as f64, None))
        .unwrap();
    let (_, in718) = (190..=210)
        .step_by(2)
        .find_map(|mm| finished(mm as f64, Some(Material::in718())))
        .unwrap();
    let dt = base.stable_step();
    let ambient = PointResult {
        peak: 293.15,
        ..PointResult::default()
    };
    let mut scrambled = base.clone();
    let k = scrambled.laid.iter().position(|v| v.len() > 2).unwrap();
    scrambled.laid[k].reverse();
    let cases = [
        (&base, deps.len()),
        (&base, deps.len() / 2),
        (&scrambled, 40),
        (&in718, deps.len()),
    ];
    for (model, laid) in cases {
        let (mut a, mut b) = (model.clone(), model.clone());
        let (mut pa, mut pb) = (vec![ambient; deps.len()], vec![ambient; deps.len()]);
        for _ in 0..30 {
            a.step(dt, &[]);
            let ha = a.observe(laid, dt, &mut pa);
            let points = &mut pb;
            let hb = b.step_watched(dt, &[], Some(Watch { laid, points }));
            assert_eq!(ha.to_bits(), hb.to_bits());
        }
        assert_eq!(pa, pb);
        assert!(pa[..laid].iter().any(|p| p.time_above > 0.0));
        assert!(pa[laid..].iter().all(|p| *p == ambient));
        assert_eq!(a.h, b.h);
    }
    // Both kinds of deposit were read: inside a chunk, and across two.
    let chunks = base.h.len().div_ceil(CHUNK);
    let cut = base
        .runs
        .clone()
        .cut(&base.laid, deps.len(), chunks)
        .unwrap();
    assert!(cut.across().count() > 0);
    assert!(cut.bounds.iter().filter(|(a, b)| b > a).count() > 1);
    assert!(
        scrambled
            .runs
            .clone()
            .cut(&scrambled.laid, 40, chunks)
            .is_none()
    );
}

/// One thread, or a set of fewer than 2·`CHUNKS_PER_TASK` chunks, is one task; two threads
/// take the chunks one at a time.
#[test]
fn a_step_is_cut_into_tasks_by_threads_and_size() {
    assert_eq!(chunks_per_task(100, 1), 100);
    assert_eq!(chunks_per_task(0, 2), 1);
    assert_eq!(chunks_per_task(7, 2), 7);
    assert_eq!(chunks_per_task(8, 2), 1);
    assert_eq!(chunks_per_task(167, 2), 1);
}

fn same_bits_on_one_thread_or_two(deps: &[Deposit], settings: &VoxelSettings) {
    let run = |threads| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| VoxelModel::new(deps, settings).unwrap().run(deps).unwrap())
    };
    let (one, two) = (run(1), run(2));
    let Cells::Voxel { voxels, .. } = one.cells else {
        unreachable!("a voxel run")
    };
    assert!(voxels > 2 * CHUNKS_PER_TASK * CHUNK);
    assert_eq!(one.points, two.points);
    assert_eq!(one.ledger, two.ledger);
    assert_eq!(one.stored.to_bits(), two.stored.to_bits());
    assert!(one.balance_error.abs() < 1e-3, "{}", one.balance_error);
}

/// A laser's Gaussian falls on the exposed tops within 2R of the pool and a layer of it:
/// its shares add up to the power, the nearest top gets the most, and a run with it keeps
/// its energy balance.
#[test]
fn a_gaussian_source_heats_the_exposed_top() {
    let (deps, mut settings) = three_revolutions(100.0);
    let radius = 3e-3;
    settings.source = HeatSource::Gaussian { radius };
    let mut m = VoxelModel::new(&deps, &settings).unwrap();
    for i in 0..=100 {
        m.lay(&deps, i);
    }
    let mut out = Vec::new();
    let (d, heat) = (&deps[100], 500.0);
    let burn = Burn {
        heat,
        ..Burn::of(d)
    };
    m.source(&deps, 100, burn, &mut out);
    assert!(out.len() > 3, "{} voxels", out.len());
    let total: f64 = out.iter().map(|x| x.1 as f64).sum();
    assert!((total - heat / d.arc_time).abs() < 1e-3 * total, "{total}");
    let pool = sub(d.position, scale(d.axis, m.sink[100]));
    for &(v, _) in &out {
        assert_eq!(
            m.neighbours[5][v as usize], v,
            "a voxel under another heated"
        );
        let r = sub(m.centre_of(v), pool);
        let off = norm(sub(r, scale(d.axis, dot(r, d.axis))));
        assert!(off <= 2.0 * radius + 1e-12);
    }
    let nearest = out
        .iter()
        .min_by(|a, b| {
            let da = norm(sub(m.centre_of(a.0), pool));
            let db = norm(sub(m.centre_of(b.0), pool));
            da.total_cmp(&db)
        })
        .unwrap();
    assert!(out.iter().all(|x| x.1 <= nearest.1 * (1.0 + 1e-6)));
    let r = VoxelModel::new(&deps, &settings)
        .unwrap()
        .run(&deps)
        .unwrap();
    assert!(r.balance_error.abs() < 1e-3, "{}", r.balance_error);
}

/// The 3-revolution helix on a 100 mm plate `thickness` m thick, a disc or a box, of
/// `material` (None: the deposit's).
fn helix_on_plate(
    thickness: f64,
    disc: bool,
    material: Option<Material>,
) -> (Vec<Deposit>, VoxelSettings) {
    let (deps, mut settings) = three_revolutions(100.0);
    settings.plate.size[2] = thickness;
    settings.plate.disc = disc;
    settings.plate.material = material;
    (deps, settings)
}

/// A coarsened box plate is the uncut plate's cells, merged: eight for each coarse cell and
/// one for each left at edge dx, the same count on boxes of an even and an odd number of
/// cells across. (A block taken where its centre alone lay inside made a box of an odd
/// number of cells a cell wider on one side: the ORNL pad's thermocouples by that edge
/// read 3.6–4.0 % of their rise off.) A disc's rim is a staircase of blocks: its count
/// within 2 % of the uncut plate's.
#[test]
fn the_coarse_plate_is_the_plates_own_cells() {
    for (mm, disc) in [
        (100.0, false),
        (102.0, false),
        (103.0, false),
        (102.0, true),
    ] {
        let (deps, mut settings) = helix_on_plate(0.010, disc, None);
        settings.plate.size[0] = mm * 1e-3;
        settings.plate.size[1] = mm * 1e-3;
        let uncut = VoxelModel::new(&deps, &settings).unwrap().plate_voxels;
        settings.coarse_plate = true;
        let m = VoxelModel::new(&deps, &settings).unwrap();
        assert!(m.coarse > 0);
        let cells = 8 * m.coarse + (m.plate_voxels - m.coarse);
        eprintln!("{mm} mm, disc {disc}: {cells} cells, uncut {uncut}");
        match disc {
            false => assert_eq!(cells, uncut, "{mm} mm: {} coarse", m.coarse),
            true => assert!(
                cells.abs_diff(uncut) * 50 <= uncut,
                "{cells} against {uncut}"
            ),
        }
    }
}

/// The largest difference of `f` between run b's points and reference a's, as a share of
/// a's largest rise of it above `ambient`.
fn worst_of_rise(a: &RunResult, b: &RunResult, ambient: f64, f: fn(&PointResult) -> f64) -> f64 {
    let rise = a.points.iter().map(f).fold(0.0, f64::max) - ambient;
    let worst = a.points.iter().zip(&b.points);
    worst.map(|(x, y)| (f(x) - f(y)).abs()).fold(0.0, f64::max) / rise
}

/// The plate coarsened away from the metal laid on it (`coarse_plate`) against every cell
/// of edge dx, on the 3-revolution helix: plates of an odd and an even number of cells, a
/// box and a disc, of the deposit's material and of its own. Measured: preheats within
/// 0.1–0.5 % of the rise, peaks within 0.1 % of theirs, the energy balance to 2e-7, the
/// plate's cells halved (an odd plate keeps its top layer of edge dx) to 0.29 of them.
#[test]
fn a_coarsened_plate_keeps_the_preheats() {
    let cases = [
        (0.010, false, None),
        (0.012, false, None),
        (0.012, true, Some(Material::in718())),
        (0.010, false, Some(Material::in718())),
    ];
    for (thickness, disc, material) in cases {
        let (deps, settings) = helix_on_plate(thickness, disc, material);
        let fine = VoxelModel::new(&deps, &settings).unwrap();
        let cut = VoxelModel::new(
            &deps,
            &VoxelSettings {
                coarse_plate: true,
                ..settings.clone()
            },
        )
        .unwrap();
        let (before, after) = (fine.plate_voxels, cut.plate_voxels);
        let (a, b) = (fine.run(&deps).unwrap(), cut.run(&deps).unwrap());
        let ambient = settings.surroundings.ambient_k;
        let preheat = worst_of_rise(&a, &b, ambient, |p| p.preheat);
        let peak = worst_of_rise(&a, &b, ambient, |p| p.peak);
        eprintln!(
            "plate {thickness} m, disc {disc}: plate cells {before} -> {after}; preheats \
             within {:.2} % of the rise, peaks {:.2} %; balance {:.1e}",
            100.0 * preheat,
            100.0 * peak,
            b.balance_error
        );
        assert!(preheat < 0.01 && peak < 0.01, "{preheat} {peak}");
        assert!(b.balance_error.abs() < 1e-5, "{}", b.balance_error);
        assert!((after as f64) < 0.6 * before as f64, "{before} -> {after}");
    }
}

/// The coarse cells at their own rate (`coarse_due`) against the same coarse plate stepped
/// at every step, on the 3-revolution helix: a plate of the deposit's material and one of
/// its own (IN718 under G3Si1, whose stable step binds), a box and a disc. The preheats
/// within 0.2 % of the rise, the peaks within 0.1 % of theirs, the energy balance to 1e-5,
/// the coarse cells' period at least 3 steps (3.8 on the deposit's material, 10.7 on IN718,
/// whose diffusivity is a third of the deposit's) and their updates cut by 60 % or more.
/// Measured: preheats within 0.03–0.06 % of the rise, updates 70–91 % fewer. The same
/// bits on one thread or two: `one_thread_or_two_give_the_same_bits`, whose coarse plate
/// steps at its own rate.
#[test]
fn coarse_cells_at_their_own_rate_keep_the_preheats() {
    let cases = [
        (0.012, false, None),
        (0.012, true, Some(Material::in718())),
        (0.010, false, Some(Material::in718())),
    ];
    for (thickness, disc, material) in cases {
        let (deps, mut settings) = helix_on_plate(thickness, disc, material);
        settings.coarse_plate = true;
        let own = VoxelModel::new(&deps, &settings).unwrap();
        let mut every = own.clone();
        every.coarse_own_rate = false;
        let period = own.coarse_period() / own.stable_step();
        let coarse = own.coarse;
        let (a, b) = (every.run(&deps).unwrap(), own.clone().run(&deps).unwrap());
        let ambient = settings.surroundings.ambient_k;
        let preheat = worst_of_rise(&a, &b, ambient, |p| p.preheat);
        let peak = worst_of_rise(&a, &b, ambient, |p| p.peak);
        let updates = |r: &RunResult| match r.cells {
            Cells::Voxel { updates, .. } => updates as f64,
            _ => unreachable!("a voxel run"),
        };
        let saved = (updates(&a) - updates(&b)) / (coarse as f64 * a.steps as f64);
        eprintln!(
            "plate {thickness} m, disc {disc}: coarse period {period:.2} steps, their \
             updates {:.0} % fewer; preheats within {:.3} % of the rise, peaks {:.3} %; \
             balance {:.1e}",
            100.0 * saved,
            100.0 * preheat,
            100.0 * peak,
            b.balance_error
        );
        assert!(period >= 3.0, "{period}");
        assert!(saved > 0.6, "{saved}");
        assert!(preheat < 0.002 && peak < 0.001, "{preheat} {peak}");
        assert!(b.balance_error.abs() < 1e-5, "{}", b.balance_error);
    }
}

/// Metal laid straight on coarse cells of a plate of its own material (the seams in
/// series, which the fine columns keep from happening on a plate planned for its part):
/// the model is set up for the helix 50 mm away and runs the helix itself, half of whose
/// first revolution then lies on 4 mm cells. The energy balance holds to 1e-5 (measured
/// 2.6e-6) and the preheats stay within 5 % of the rise of the plate of cells of edge dx
/// (measured 3.8 % with the coarse cells stepped at every step, 4.0 % at their own rate:
/// the coarse cells' mean is what the first revolution reads).
#[test]
fn metal_laid_on_coarse_cells_conducts_through_the_seams() {
    let (deps, mut settings) = three_revolutions(200.0);
    settings.plate.material = Some(Material::in718());
    // Six cells thick: the plate's top is coarse away from the columns kept fine.
    settings.plate.size[2] = 0.012;
    let fine = VoxelModel::new(&deps, &settings).unwrap();
    settings.coarse_plate = true;
    let mut away = deps.clone();
    for d in &mut away {
        d.position[0] += 0.05;
    }
    let mut cut = VoxelModel::new(&away, &settings).unwrap();
    assert_eq!((cut.dims, cut.origin), (fine.dims, fine.origin));
    assert!(cut.below == fine.below && cut.sink == fine.sink);
    for i in 0..deps.len() {
        cut.lay(&deps, i);
    }
    assert!(!cut.mixed_seams.is_empty());
    let cut = VoxelModel::new(&away, &settings).unwrap();
    let (a, b) = (fine.run(&deps).unwrap(), cut.run(&deps).unwrap());
    let ambient = settings.surroundings.ambient_k;
    let rise = a.points.iter().map(|p| p.preheat).fold(0.0, f64::max) - ambient;
    let worst = a.points.iter().zip(&b.points);
    let worst = worst
        .map(|(x, y)| (x.preheat - y.preheat).abs())
        .fold(0.0, f64::max);
    eprintln!(
        "on coarse cells: preheats within {:.2} % of the rise; balance {:.1e}",
        100.0 * worst / rise,
        b.balance_error
    );
    assert!(worst < 0.05 * rise, "{worst} of {rise}");
    assert!(b.balance_error.abs() < 1e-5, "{}", b.balance_error);
}

/// A straight wall leaning `lean_deg` from upright, 20° round from the grid's x, 60 mm long and
/// 14 layers of 2 mm along its tilted axis, 5 mm beads in 2 mm deposits, each layer a track of
/// its own from the same end.
fn leaning_wall(lean_deg: f64) -> Vec<Deposit> {
    let (az, lean) = (20f64.to_radians(), lean_deg.to_radians());
    let t = [az.cos(), az.sin(), 0.0];
    let axis = [lean.sin() * az.sin(), -lean.sin() * az.cos(), lean.cos()];
    let (per_layer, layers, h) = (31, 14, 2e-3);
    let mut deps = Vec::new();
    for k in 0..layers {
        for j in 0..per_layer {
            let (s, up) = (-30e-3 + 2e-3 * j as f64, h * (k + 1) as f64);
            let position: [f64; 3] = std::array::from_fn(|c| s * t[c] + up * axis[c]);
            let i = deps.len();
            deps.push(Deposit {
                position,
                time: (i + 1) as f64 * 0.2,
                arc_time: 0.2,
                heat: 300.0,
                width: 5e-3,
                height: h,
                axis,
                support: (k > 0).then(|| i - per_layer),
                start: (j == 0).then_some(position),
                drop: None,
            });
        }
    }
    deps
}

/// The faces a leaning wall's cells expose on its two sides add up to the sides' own area: a
/// face whose neighbour lies off the bead's side counts the side's normal projected on it
/// (`lay::surface_weights`). Measured over the wall's middle (a third of its length, 18 mm of
/// its height), against 2 × 20 mm × 18 mm: 0.98, 1.02, 1.00 and 0.97 upright and at 26°, 45°
/// and 64°; with the weights before (each face |e·across| + |e·axis|) 0.98 upright and 1.44 at
/// 26°.
#[test]
fn a_leaning_walls_sides_expose_their_own_area() {
    for lean in [0.0, 26.0, 45.0, 64.0] {
        let deps = leaning_wall(lean);
        let (_, mut settings) = three_revolutions(140.0);
        settings.coarse_plate = true;
        let mut m = VoxelModel::new(&deps, &settings).unwrap();
        m.lay_all(&deps);
        let (az, l) = (20f64.to_radians(), lean.to_radians());
        let t = [az.cos(), az.sin(), 0.0];
        let axis = [l.sin() * az.sin(), -l.sin() * az.cos(), l.cos()];
        let exposed: f64 = (m.plate_voxels as u32..m.cell.len() as u32)
            .filter(|&v| {
                let c = m.centre_of(v);
                dot(c, t).abs() < 10e-3 && (6e-3..24e-3).contains(&dot(c, axis))
            })
            .map(|v| m.exposed[v as usize] as f64)
            .sum();
        let ratio = exposed / (2.0 * 20e-3 * 18e-3);
        eprintln!("lean {lean}°: the sides' faces {ratio:.3} of their area");
        assert!((ratio - 1.0).abs() < 0.06, "lean {lean}°: {ratio}");
    }
}
