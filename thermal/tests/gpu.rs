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
        trace_hottest: true,
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
