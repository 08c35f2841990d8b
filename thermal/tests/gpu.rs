//! The voxel model on a GPU (`device = Gpu`, the `gpu` feature) against the same model on the
//! CPU: the tolerances, preheats within 1 % of the rise and the energy balance closed to
//! 1e-5, on a build that uses every part of the device's step (a plate of its own material, so
//! the interface's correction; a dwell; probes, snapshots and the hottest metal read back
//! mid-call; the deposits' peaks and times above kept on the device). The contract's tests run
//! on it too (`contract.rs`, with the `gpu` feature and `WAAMTWIN_SYSTEM_TESTS=1`). CI runs both
//! on Mesa's software Vulkan (lavapipe, `mesa-vulkan-drivers`).

use thermal::material::Material;
use thermal::network::Surroundings;
use thermal::schedule::{Deposit, helix};
use thermal::voxel::{Device, VoxelSettings};
use thermal::{HeatModel, HeatRun, Plate, RunResult, ThermalError};

/// Three revolutions of 48 deposits, R 24 mm, 2 mm voxels, on an 80 mm plate of IN718 under a
/// G3Si1 wall.
fn build(device: Device) -> (Vec<Deposit>, VoxelSettings) {
    let deps = helix(0.024, 48, 3, 2e-3, 6e-3, 10e-3, 1700.0);
    let settings = VoxelSettings {
        material: Material::g3si(),
        surroundings: Surroundings {
            ambient_k: 293.15,
            convection_w_m2k: 15.0,
            emissivity: 0.6,
            table_w_m2k: 100.0,
        },
        plate: Plate {
            size: [0.08, 0.08, 0.01],
            centre: [0.0, 0.0],
            cell: 5e-3,
            layers: 3,
            disc: false,
            material: Some(Material::in718()),
        },
        size: 2e-3,
        deposit_temperature: 1823.15,
        lead: 10e-3,
        hot_threshold: 873.15,
        snapshot_times: vec![10.0, 40.0],
        // No trace: a trace has the host observe the metal every step; without, the device does.
        traces: vec![],
        watch_metal: true,
        courant: 0.9,
        probes: vec![[0.024, 0.0, -1e-3], [0.0, 0.024, 5e-3]],
        probe_every: 0.5,
        source: thermal::voxel::HeatSource::DoubleEllipsoid,
        coarse_plate: false,
        device,
    };
    (deps, settings)
}

/// Every deposit in order, a 20 s dwell before the second revolution, 30 s of cooling at the end.
fn run(device: Device) -> Result<RunResult, ThermalError> {
    let (deps, settings) = build(device);
    let mut run = HeatModel::Voxel(settings).start(&deps)?;
    for i in 0..deps.len() {
        let dwell = if i == 48 { 20.0 } else { 0.0 };
        run.deposit(i, dwell)?;
    }
    run.cool(30.0)?;
    Ok(run.finish())
}

#[test]
#[cfg_attr(
    not(system_tests),
    ignore = "opt-in, WAAMTWIN_SYSTEM_TESTS=1: a GPU adapter (CI: Mesa's lavapipe)"
)]
fn the_gpu_steps_as_the_cpu_does() {
    let cpu = run(Device::Cpu).unwrap();
    let gpu = run(Device::Gpu).expect("a GPU adapter (in CI: apt-get install mesa-vulkan-drivers)");
    let rise = 1823.15 - 293.15;
    let worst = |f: &dyn Fn(&RunResult) -> Vec<f64>| {
        f(&cpu)
            .iter()
            .zip(f(&gpu))
            .map(|(a, b)| (a - b).abs() / rise)
            .fold(0.0, f64::max)
    };
    let preheat = worst(&|r| r.points.iter().map(|p| p.preheat).collect());
    let peak = worst(&|r| r.points.iter().map(|p| p.peak).collect());
    let probes = worst(&|r| {
        r.probes
            .iter()
            .flat_map(|p| p.temperature.iter().copied().filter(|t| t.is_finite()))
            .collect()
    });
    let snapshots = worst(&|r| {
        r.snapshots
            .iter()
            .flat_map(|s| s.temperature.iter().copied())
            .collect()
    });
    let above = cpu
        .points
        .iter()
        .zip(&gpu.points)
        .map(|(a, b)| (a.time_above - b.time_above).abs())
        .fold(0.0, f64::max);
    let lost = |r: &RunResult| r.ledger.lost();
    let e = cpu.ledger.energy_in();
    eprintln!(
        "GPU against CPU, worst share of the rise: preheats {preheat:.2e}, peaks {peak:.2e}, \
         probes {probes:.2e}, snapshots {snapshots:.2e}; time above {above:.3} s; balance \
         {:.1e} (CPU {:.1e}); losses {:.2e} of the energy in",
        gpu.balance_error,
        cpu.balance_error,
        (lost(&cpu) - lost(&gpu)).abs() / e
    );
    // The issue asks 1 % of the rise; the device does the CPU's arithmetic in the same f32, so
    // the two differ by rounding alone (2e-7 measured on lavapipe): 1e-5 would catch a term
    // dropped or a neighbour misread, which the 1 % would let through.
    for (what, x) in [
        ("preheats", preheat),
        ("peaks", peak),
        ("probes", probes),
        ("snapshots", snapshots),
    ] {
        assert!(x < 1e-5, "{what}: {x} of the rise");
    }
    assert!(gpu.balance_error.abs() < 1e-5, "{}", gpu.balance_error);
    assert!((lost(&cpu) - lost(&gpu)).abs() / e < 1e-5);
    // The same records, read at the same times.
    assert_eq!(cpu.probes[0].time, gpu.probes[0].time);
    assert_eq!(cpu.hottest.time, gpu.hottest.time);
    assert_eq!(cpu.steps, gpu.steps);
    assert!(above < 0.1, "time above {above} s");
}

/// A plate alone with a hot block in it: most of its voxels step on the shader's fast path
/// (six neighbours at fixed strides, nothing exposed), the rest on the neighbour table; every
/// voxel's temperature after 60 steps agrees with the CPU's to f32 rounding.
#[test]
#[cfg_attr(
    not(system_tests),
    ignore = "opt-in, WAAMTWIN_SYSTEM_TESTS=1: a GPU adapter (CI: Mesa's lavapipe)"
)]
fn a_plate_steps_on_the_fast_path_as_on_the_cpu() {
    use thermal::voxel::{VoxelModel, VoxelRun};
    let field = |device: Device| {
        let (_, mut s) = build(device);
        s.plate.material = None;
        s.plate.size = [0.04, 0.03, 0.012];
        s.size = 1e-3;
        let mut run = VoxelRun::new(VoxelModel::new(&[], &s).unwrap(), &[]).unwrap();
        for (v, _) in run.model().voxels_within([0.0, 0.0, -0.006], 0.008) {
            run.model_mut().set_temperature(v, 1500.0);
        }
        run.cool(60.0 * run.model().stable_step()).unwrap();
        let regular = run.model().gpu_regular();
        let n = run.voxels() as u32;
        let t: Vec<f64> = (0..n).map(|v| run.model().temperature(v)).collect();
        (t, regular)
    };
    let (cpu, _) = field(Device::Cpu);
    let (gpu, regular) = field(Device::Gpu);
    let regular = regular.expect("a device");
    assert!(
        regular > gpu.len() / 2,
        "{regular} of {} regular",
        gpu.len()
    );
    let worst = cpu
        .iter()
        .zip(&gpu)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    eprintln!(
        "{regular} of {} voxels regular; worst {worst:.2e} K",
        gpu.len()
    );
    assert!(worst < 1e-3, "{worst} K");
}

/// Member k of a small ensemble: its arc's heat times `scale`, its losses (convection W/m²K,
/// emissivity, table W/m²K); at deposit 72 it takes the next member's losses, and member 1 has
/// a temperature put on its plate (what a data assimilation does between calls).
const MEMBERS: [(f64, [f64; 3]); 3] = [
    (1.0, [15.0, 0.6, 100.0]),
    (0.8, [40.0, 0.3, 300.0]),
    (1.15, [5.0, 0.9, 0.0]),
];

fn member(k: usize) -> (Vec<Deposit>, thermal::voxel::VoxelRun) {
    let (deps, mut s) = build(Device::Gpu);
    let [c, e, t] = MEMBERS[k].1;
    s.surroundings.convection_w_m2k = c;
    s.surroundings.emissivity = e;
    s.surroundings.table_w_m2k = t;
    let model = thermal::voxel::VoxelModel::new(&deps, &s).unwrap();
    (
        deps.clone(),
        thermal::voxel::VoxelRun::new(model, &deps).unwrap(),
    )
}

/// Member k's program through deposit `last` (exclusive), then 30 s of cooling.
fn program(
    k: usize,
    deps: &[Deposit],
    run: &mut thermal::voxel::VoxelRun,
    last: usize,
) -> Result<(), ThermalError> {
    for (i, d) in deps.iter().enumerate().take(last) {
        if i == 72 {
            let [c, e, t] = MEMBERS[(k + 1) % 3].1;
            run.set_losses(c, e, t);
            if k == 1 {
                run.model_mut().set_temperature(3, 900.0);
            }
        }
        let dwell = if i == 48 { 20.0 } else { 0.0 };
        let burn = thermal::run::Burn {
            heat: d.heat * MEMBERS[k].0,
            ..thermal::run::Burn::of(d)
        };
        run.deposit_burning(i, dwell, Some(burn))?;
    }
    run.cool(30.0)
}

/// The members run as one batch, each on a thread of its own; per member its run's result.
fn batched(lasts: [usize; 3]) -> Vec<Result<RunResult, ThermalError>> {
    let mut runs: Vec<(Vec<Deposit>, thermal::voxel::VoxelRun)> = (0..3).map(member).collect();
    let mut models: Vec<&mut thermal::voxel::VoxelModel> =
        runs.iter_mut().map(|(_, r)| r.model_mut()).collect();
    let seats = thermal::voxel::share_device(&mut models).expect("a batch on the device");
    std::thread::scope(|s| {
        let handles: Vec<_> = runs
            .into_iter()
            .zip(seats)
            .enumerate()
            .map(|(k, ((deps, mut run), seat))| {
                s.spawn(move || {
                    let _seat = seat;
                    program(k, &deps, &mut run, lasts[k]).map(|()| run.finish())
                })
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    })
}

/// Three members stepped as one batch on the device (one dispatch for all, their losses and
/// their arc's heat apart, the losses changed and a temperature put midway) give what each
/// gives run alone on it, to the bit: a member's state, heat, losses, peaks or sums read at
/// another's place would not.
#[test]
#[cfg_attr(
    not(system_tests),
    ignore = "opt-in, WAAMTWIN_SYSTEM_TESTS=1: a GPU adapter (CI: Mesa's lavapipe)"
)]
fn an_ensemble_steps_as_one_batch_as_each_member_alone() {
    // Two revolutions: the dwell at 48 and the losses changed at 72 both inside.
    let all = 96;
    let alone: Vec<RunResult> = (0..3)
        .map(|k| {
            let (deps, mut run) = member(k);
            program(k, &deps, &mut run, all).unwrap();
            run.finish()
        })
        .collect();
    let together = batched([all; 3]);
    for (k, (a, b)) in alone.iter().zip(together).enumerate() {
        let b = b.unwrap();
        let bits = |r: &RunResult| -> Vec<u64> {
            r.points
                .iter()
                .flat_map(|p| [p.preheat, p.peak, p.time_above])
                .chain([r.ledger.lost(), r.stored])
                .chain(r.hottest.temperature.iter().copied())
                .map(f64::to_bits)
                .collect()
        };
        assert_eq!(bits(a), bits(&b), "member {k}");
        assert_eq!(a.steps, b.steps);
    }
    // The members differ: a batch that stepped one member's field for all would pass the
    // comparison above only if they did not.
    assert!((alone[0].stored - alone[1].stored).abs() > 1e-3 * alone[0].stored);
}

/// A member whose program stops early leaves the others' next read failing with a message that
/// names the batch, not waiting for ever.
#[test]
#[cfg_attr(
    not(system_tests),
    ignore = "opt-in, WAAMTWIN_SYSTEM_TESTS=1: a GPU adapter (CI: Mesa's lavapipe)"
)]
fn a_member_out_of_step_fails_the_batch_rather_than_hangs_it() {
    let results = batched([96, 96, 30]);
    for r in &results[..2] {
        match r {
            Err(ThermalError::DeviceLost { reason, .. }) => {
                assert!(reason.contains("batch"), "{reason}")
            }
            Err(e) => panic!("{e}"),
            Ok(_) => panic!("a member ran on alone"),
        }
    }
}
