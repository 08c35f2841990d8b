//! The two thermal models on the same schedule: a 10-revolution cylinder.

use thermal::material::Material;
use thermal::network::Surroundings;
use thermal::schedule::{Deposit, helix};
use thermal::voxel::{VoxelModel, VoxelSettings};
use thermal::wall::{WallModel, WallSettings};
use thermal::{Cells, HeatModel, HeatRun, ModelRun, Plate, PointResult};

fn surroundings() -> Surroundings {
    Surroundings {
        ambient_k: 293.15,
        convection_w_m2k: 15.0,
        emissivity: 0.6,
        table_w_m2k: 100.0,
    }
}

fn plate() -> Plate {
    Plate {
        size: [0.2, 0.2, 0.01],
        centre: [0.0, 0.0],
        cell: 5e-3,
        layers: 3,
        disc: false,
        material: None,
    }
}

/// The thin wall on G3Si with nodes at least `min_node` long, m, every node at every step.
fn wall_settings(min_node: f64, watch_metal: bool) -> WallSettings {
    WallSettings {
        material: Material::g3si(),
        surroundings: surroundings(),
        plate: plate(),
        min_node,
        deposit_temperature: 1823.15,
        footprint: 6e-3,
        lead: 10e-3,
        hot_threshold: 873.15,
        max_step: 30.0,
        probes: vec![],
        probe_every: 0.0,
        snapshot_times: vec![],
        traces: vec![],
        watch_metal,
        local_steps: None,
        merge_plate: true,
    }
}

/// The voxel model on G3Si, 2 mm cells, the plate uncut.
fn voxel_settings(watch_metal: bool) -> VoxelSettings {
    VoxelSettings {
        material: Material::g3si(),
        surroundings: surroundings(),
        plate: plate(),
        size: 2e-3,
        deposit_temperature: 1823.15,
        lead: 10e-3,
        hot_threshold: 873.15,
        snapshot_times: vec![],
        traces: vec![],
        watch_metal,
        courant: 0.9,
        probes: vec![],
        probe_every: 0.0,
        source: thermal::voxel::HeatSource::DoubleEllipsoid,
        coarse_plate: false,
        device: Default::default(),
    }
}

/// Mean preheat per revolution.
fn per_revolution(pre: &[f64], n: usize) -> Vec<f64> {
    pre.chunks(n)
        .map(|c| c.iter().sum::<f64>() / c.len() as f64)
        .collect()
}

#[test]
fn voxel_and_thin_wall_agree_on_a_ten_layer_cylinder() {
    let (n, layers) = (120, 10);
    // 6 mm bead: three 2 mm voxels, so both models lay the same metal.
    let deps = helix(0.06, n, layers, 2e-3, 6e-3, 10e-3, 0.85 * 2000.0);
    let ws = wall_settings(3e-3, true);
    let wall = WallModel::build(&deps, &ws)
        .unwrap()
        .run(&deps, &ws, 0.0)
        .unwrap();
    let vs = voxel_settings(true);
    let t = std::time::Instant::now();
    let vox = VoxelModel::new(&deps, &vs).unwrap().run(&deps).unwrap();
    let Cells::Voxel {
        voxels, updates, ..
    } = vox.cells
    else {
        panic!("a voxel run reports voxels")
    };
    let secs = t.elapsed().as_secs_f64();
    let fe: Vec<f64> = per_revolution(
        &wall.points.iter().map(|p| p.preheat).collect::<Vec<_>>(),
        n,
    );
    let vx = per_revolution(&vox.points.iter().map(|p| p.preheat).collect::<Vec<_>>(), n);
    eprintln!(
        "voxel: {} voxels, {} steps, {:.2e} updates/s, balance {:.2e}; thin wall balance {:.2e}",
        voxels,
        vox.steps,
        updates as f64 / secs,
        vox.balance_error,
        wall.balance_error
    );
    // Compare the rise above ambient: that is what the models compute. Every revolution within
    // 5 % of the rise, or 2 K where the rise is a few kelvin (5 K on revolution 0, which reads
    // the plate ahead of the arc, below). The first two within 10 %: revolution 1
    // lies on revolution 0, which lies on the plate, whose cells the models cut differently
    // (the thin wall's merged 5 mm cells, 2 mm voxels). Measured 5.1 % there (2026-12-02, a
    // thin-wall node at its stretch's middle; 2.6 % on revolution 2, 1.6 % on 3), 7.4 % before
    // (2026-11-29; the thin wall 4.2 K warmer, 3.9 % on revolution 2, 2.5 % on 3, since a
    // voxel run takes in no more heat than its arcs: 4.1 K, 3.8 and 2.4 % before); 4.9 %
    // before, while the voxel model's first deposit laid a slab of 20 cells (2 now; the next
    // deposits 5–6) that warmed the start of revolution 1 (its first point read 104 °C between
    // neighbours at 49–58 °C).
    let mut worst = 0.0f64;
    for k in 0..layers {
        let rel = (fe[k] - vx[k]) / (vx[k] - 293.15);
        eprintln!(
            "revolution {k}: preheat thin wall {:.1} °C, voxel {:.1} °C ({:+.1}% of the rise)",
            fe[k] - 273.15,
            vx[k] - 273.15,
            100.0 * rel
        );
        let share = if k < 2 { 0.10 } else { 0.05 };
        // Revolution 0 reads the plate ahead of the arc, each model at its own resolution:
        // the voxel model the 2 mm columns at the point (22.5 °C), the thin wall its 5 mm
        // plate cell there, which holds the heat of the deposit 3.1 mm behind (26.8 °C).
        // Rosenthal's moving point source puts the plate 10 mm ahead of a 10 mm/s arc at most
        // some 2 K over what the plate has gathered, and the thin wall's mean falls 27.0 → 24.5
        // °C as its plate cells go from 5 to 1 mm (docs/PHYSICS.md "The metal at the support's
        // point"): within 5 K there.
        let floor = if k == 0 { 5.0 } else { 2.0 };
        let tolerance = (share * (vx[k] - 293.15)).max(floor);
        worst = worst.max((fe[k] - vx[k]).abs() / tolerance);
    }
    assert!(
        vox.balance_error.abs() < 0.01,
        "voxel energy balance {}",
        vox.balance_error
    );
    assert!(worst < 1.0, "models differ by {worst} times the tolerance");
    // Per point the rest of what the thin wall gives: time above 600 °C per revolution within
    // 20 % (+1 s), the pool within 2.4 mm (three quarters of a 3.1 mm thin-wall node: its tail
    // interpolated between samples, `thermal::pool`; counted in whole samples, the two differed
    // by 3.0 mm here), peaks above the solidus.
    let mean = |v: &[PointResult], k: usize, f: fn(&PointResult) -> f64| {
        v[k * n..(k + 1) * n].iter().map(f).sum::<f64>() / n as f64
    };
    for k in 0..layers {
        let (a, b) = (wall.points.as_slice(), vox.points.as_slice());
        let above = (mean(a, k, |p| p.time_above), mean(b, k, |p| p.time_above));
        let pool = (mean(a, k, |p| p.pool_length), mean(b, k, |p| p.pool_length));
        let peak = (mean(a, k, |p| p.peak), mean(b, k, |p| p.peak));
        eprintln!(
            "revolution {k}: time above 600 °C {:.1} / {:.1} s, pool {:.1} / {:.1} mm, peak {:.0} / {:.0} °C (thin wall / voxel)",
            above.0,
            above.1,
            pool.0 * 1e3,
            pool.1 * 1e3,
            peak.0 - 273.15,
            peak.1 - 273.15
        );
        assert!(
            (above.0 - above.1).abs() <= 0.2 * above.1 + 1.0,
            "{above:?}"
        );
        assert!((pool.0 - pool.1).abs() <= 2.4e-3, "{pool:?}");
        assert!(peak.0 > 1740.0 && peak.1 > 1740.0, "{peak:?}");
    }
}

/// The points of the thin wall's run of `deps` with nodes at least `min_node` long, m.
fn wall_points(deps: &[Deposit], min_node: f64) -> Vec<PointResult> {
    let ws = wall_settings(min_node, false);
    WallModel::build(deps, &ws)
        .unwrap()
        .run(deps, &ws, 0.0)
        .unwrap()
        .points
}

/// The largest departure of a point's value `v` from its neighbours' mean, over `p` less its
/// ends.
fn jitter(v: &dyn Fn(&PointResult) -> f64, p: &[PointResult]) -> f64 {
    (1..p.len() - 1)
        .map(|i| (v(&p[i]) - 0.5 * (v(&p[i - 1]) + v(&p[i + 1]))).abs())
        .fold(0.0, f64::max)
}

/// The thin wall on a ring whose deposits are a little under `min_node` (2.8 mm on 3 mm, as a
/// canister 100 × 80 mm cut by 106 generators): its nodes were grown to at least `min_node`,
/// two deposits each, one temperature laid whole at the first; neighbouring points' preheats
/// alternated by 15 K and the pool by 6 mm, and a false humping risk was read on the third
/// revolution. Against the same ring with a node per deposit (`min_node` 1 mm).
#[test]
fn deposits_a_little_under_a_node_read_as_with_a_node_each() {
    // R 60 mm, 135 deposits a revolution: 2.79 mm chords.
    let deps = helix(0.06, 135, 6, 2e-3, 5e-3, 10e-3, 0.85 * 2000.0);
    let run = |min_node: f64| wall_points(&deps, min_node);
    let (fine, default) = (run(1e-3), run(3e-3));
    // Revolutions 2-5.
    let (fine, default) = (&fine[269..], &default[269..]);
    let pre = |p: &PointResult| p.preheat;
    let pool = |p: &PointResult| p.pool_length * 1e3;
    let longest = |p: &[PointResult]| p[1..].iter().map(pool).fold(0.0, f64::max);
    let (jp, jl) = (jitter(&pre, default), jitter(&pool, default));
    let (lf, ld) = (longest(fine), longest(default));
    eprintln!(
        "3 mm nodes: preheat jitter {jp:.2} K, pool jitter {jl:.2} mm, longest pool {ld:.2} mm; \
         a node a deposit: {:.2} K, {:.2} mm, {lf:.2} mm",
        jitter(&pre, fine),
        jitter(&pool, fine)
    );
    // Nodes of two (before 2026-12-02): 21.4 K, 4.9 mm, 20.0 mm against 12.7 mm.
    assert!(jp < 2.0, "preheat jitter {jp} K");
    // The pool's own jitter on this ring, a node a deposit: 2.1 mm (4.9 mm with nodes of two).
    let jf = jitter(&pool, fine);
    assert!(jl < jf + 0.5, "pool jitter {jl} mm against {jf} mm");
    assert!(
        (ld - lf).abs() < 1.0,
        "longest pool {ld} mm against {lf} mm"
    );
}

/// A ring whose deposits are far finer than `min_node` (0.70 mm on 3 mm: nodes of five).
fn fine_ring() -> Vec<Deposit> {
    // R 60 mm, 540 deposits a revolution.
    helix(0.06, 540, 6, 2e-3, 5e-3, 10e-3, 0.85 * 2000.0)
}

/// The heat the deposition puts in enters as the schedule lays it: after every deposit, what
/// the sources and the metal laid have brought is the heat of the deposits laid so far. A node
/// of several deposits was switched on whole at its first, bringing the enthalpy of metal not
/// yet laid a node's length early (its later deposits' arcs then brought that much less),
/// and holding the first deposit's heat in five deposits' mass (docs/PHYSICS.md "Nodes of
/// several deposits").
#[test]
fn a_node_of_several_deposits_takes_its_metal_as_laid() {
    let deps = fine_ring();
    let deps = &deps[..1080];
    let ws = wall_settings(3e-3, false);
    let mut run = HeatModel::ThinWall(ws).start(deps).unwrap();
    // The first deposit stands for a bead's width (5 mm) and brings more enthalpy than its arc's
    // heat (the arc books none): counted from after it.
    run.deposit(0, 0.0).unwrap();
    let energy_in = |run: &ModelRun| run.clone().finish().ledger.energy_in();
    let first = energy_in(&run);
    let (mut given, mut worst) = (0.0, 0.0f64);
    for (i, d) in deps.iter().enumerate().skip(1) {
        run.deposit(i, 0.0).unwrap();
        given += d.heat;
        worst = worst.max((energy_in(&run) - first - given).abs() / d.heat);
    }
    // Laid whole at a node's first deposit: four deposits' metal early, 2.43 deposits' heat
    // (checked, 2026-12-02).
    assert!(worst < 1e-9, "{worst} deposits' heat off the schedule");
}

/// Nodes of five deposits read as smoothly as a node a deposit: the pool behind the torch
/// counts the torch's own node as far as laid (counted whole, it jumped by the node's unlaid
/// length at each node's first deposit), and a point's preheat is read linear between the
/// centres of the node under it and that node's neighbour (read from the node alone, the points
/// of one node read one temperature and the next node's another, a staircase along the
/// revolution; docs/PHYSICS.md "Nodes of several deposits").
#[test]
fn nodes_of_five_deposits_read_as_smoothly_as_a_node_a_deposit() {
    let deps = fine_ring();
    let run = |min_node: f64| wall_points(&deps, min_node);
    let (fine, default) = (run(0.5e-3), run(3e-3));
    // Revolutions 3-6.
    let (fine, default) = (&fine[1079..], &default[1079..]);
    let pool = |p: &PointResult| p.pool_length * 1e3;
    let pre = |p: &PointResult| p.preheat;
    let mean = |p: &[PointResult]| p[1..].iter().map(pool).sum::<f64>() / (p.len() - 1) as f64;
    let (jf, jd) = (jitter(&pool, fine), jitter(&pool, default));
    let (mf, md) = (mean(fine), mean(default));
    let (pf, pd) = (jitter(&pre, fine), jitter(&pre, default));
    eprintln!(
        "pool jitter {jd:.2} mm, mean {md:.2} mm, preheat jitter {pd:.2} K; a node a deposit: \
         {jf:.2} mm, {mf:.2} mm, {pf:.2} K"
    );
    // Read from the node under it alone (before 2026-12-02): 1.69 K. A node a deposit: 0.02 K.
    assert!(pd < 1.0, "preheat jitter {pd} K");
    // Counted whole (before 2026-12-02): 2.61 mm. A node a deposit: 0.27 mm.
    assert!(jd < 1.5, "pool jitter {jd} mm");
    // The nodes' own resolution: 3 mm nodes read the pool 1.8 mm short of a node a deposit
    // on this ring (0.4 mm counted whole, which over-counted the unlaid metal), inside the
    // thin wall's 2.4 mm against the voxel model (above).
    assert!((md - mf).abs() < 2.4, "pool {md} mm against {mf} mm");
}

/// An upright wall (a pressure-vessel head's flange: R 80, 5 mm beads 1.87 mm high, 1 700 W at
/// 10 mm/s), eight revolutions of `a_revolution` deposits each.
fn flange(a_revolution: usize) -> Vec<Deposit> {
    helix(0.08, a_revolution, 8, 1.87e-3, 5e-3, 10e-3, 1700.0)
}

/// The thin wall's mean preheat per revolution on `flange(a_revolution)`, nodes at least
/// `min_node` long.
fn flange_on_the_thin_wall(a_revolution: usize, min_node: f64) -> Vec<f64> {
    let (deps, ws) = (flange(a_revolution), wall_settings(min_node, false));
    let wall = WallModel::build(&deps, &ws)
        .unwrap()
        .run(&deps, &ws, 0.0)
        .unwrap();
    let preheats: Vec<f64> = wall.points.iter().map(|p| p.preheat).collect();
    per_revolution(&preheats, a_revolution)
}

/// The voxel model's mean preheat per revolution on `flange(120)`, 2 mm cells.
fn flange_on_voxels() -> Vec<f64> {
    let deps = flange(120);
    let vs = voxel_settings(false);
    let vox = VoxelModel::new(&deps, &vs).unwrap().run(&deps).unwrap();
    let preheats: Vec<f64> = vox.points.iter().map(|p| p.preheat).collect();
    per_revolution(&preheats, 120)
}

/// The torispherical head's upright flange read 7 % of the rise colder on the voxel model than
/// on the thin wall (docs/PHYSICS.md "A torispherical head"). Traced on a plain upright wall:
/// it is the thin wall's node length. With the head's 120 points a revolution its nodes are
/// one 4.2 mm deposit each, and it read 10.5 K over the voxel model on revolution 1 (6.5 K
/// since a node stands at its stretch's middle); with 1.05 mm nodes its preheats meet the
/// voxel model's, which moves less than 0.5 K from 120 to 960 deposits a revolution
/// (docs/PHYSICS.md "A node at its stretch's middle"). The thin wall less the voxel model over
/// the voxel model's rise, revolutions 1-7.
#[test]
fn the_thin_wall_meets_the_voxel_model_on_an_upright_wall_as_its_nodes_shorten() {
    let vox = flange_on_voxels();
    let rise = |wall: Vec<f64>| -> Vec<f64> {
        (1..8)
            .map(|k| (wall[k] - vox[k]) / (vox[k] - 293.15))
            .collect()
    };
    let long = rise(flange_on_the_thin_wall(120, 3e-3));
    let short = rise(flange_on_the_thin_wall(480, 1e-3));
    eprintln!("4.2 mm nodes, share of the rise: {long:.3?}\n1.05 mm nodes: {short:.3?}");
    let worst = |v: &[f64]| v.iter().fold(0.0f64, |m, x| m.max(x.abs()));
    // Measured 2026-12-02: 1.05 mm nodes within 0.8 % of the rise; 4.2 mm nodes at most
    // 11.9 % over (revolution 1), 18.6 % with a node at its deposits' points. The rest is
    // the long node's error, not mended: more points a revolution refine it.
    assert!(worst(&short) < 0.03, "1.05 mm nodes: {short:?}");
    assert!(worst(&long) < 0.15, "4.2 mm nodes: {long:?}");
}
