//! Updates per second of the voxel model's step, on the CPU or a GPU: a plate of about
//! `VOXELS` cells of 1 mm, a hot block in its middle, cooled for `STEPS` explicit steps, timed
//! twice after 10 steps that make the device's copy (STEPS/2, then STEPS) so that the fixed
//! cost of a call (the field read back at its end) falls out of the difference.
//!
//! `cargo run --release -p thermal --features gpu --example voxel_rate -- VOXELS STEPS gpu|cpu`

use std::time::Instant;
use thermal::HeatRun;
use thermal::Plate;
use thermal::material::Material;
use thermal::network::Surroundings;
use thermal::voxel::{Device, HeatSource, VoxelModel, VoxelRun, VoxelSettings};

fn main() {
    let args: Vec<String> = std::env::args().collect();
    let voxels: f64 = args.get(1).map_or(4.8e5, |a| a.parse().expect("VOXELS"));
    let steps: usize = args.get(2).map_or(1000, |a| a.parse().expect("STEPS"));
    let device = match args.get(3).map(String::as_str) {
        Some("cpu") => Device::Cpu,
        _ => Device::Gpu,
    };
    // A square plate 12 mm thick (64 M: 100 mm), 1 mm cells.
    let dx = 1e-3;
    let thick = if voxels > 1e7 { 0.1 } else { 0.012 };
    let side = (voxels / (thick / dx)).sqrt() * dx;
    let settings = VoxelSettings {
        material: Material::g3si(),
        surroundings: Surroundings {
            ambient_k: 293.15,
            convection_w_m2k: 15.0,
            emissivity: 0.6,
            table_w_m2k: 100.0,
        },
        plate: Plate {
            size: [side, side, thick],
            centre: [0.0, 0.0],
            cell: 5e-3,
            layers: 3,
            disc: false,
            material: None,
        },
        size: dx,
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
        device,
    };
    let t0 = Instant::now();
    let model = VoxelModel::new(&[], &settings).unwrap_or_else(|e| {
        eprintln!("voxel_rate: {e}");
        std::process::exit(2)
    });
    let mut run = VoxelRun::new(model, &[]).expect("a stable step");
    let n = run.voxels();
    // A hot block at the centre: the arithmetic of a field that moves, not of one at rest.
    let hot = run.model().voxels_within([0.0, 0.0, -thick / 2.0], 0.02);
    for &(v, _) in &hot {
        run.model_mut().set_temperature(v, 1500.0);
    }
    let built = t0.elapsed().as_secs_f64();
    let dt = run.model().stable_step();
    let mut timed = |k: usize| {
        let t = Instant::now();
        run.cool(k as f64 * dt).expect("a stable run");
        t.elapsed().as_secs_f64()
    };
    // The device's copy made and its shader warm before the clock starts.
    let warm = timed(10);
    let first = timed(steps / 2);
    let second = timed(steps);
    let rate = (steps - steps / 2) as f64 * n as f64 / (second - first);
    let name = run.model().gpu_name().unwrap_or_else(|| "CPU".into());
    let regular = run.model().gpu_regular().unwrap_or(0);
    println!(
        "{name}: {n} voxels ({regular} regular, {} hot), built in {built:.1} s, first 10 steps \
         {warm:.3} s; {} steps {first:.3} s, {steps} steps {second:.3} s; {rate:.3e} updates/s \
         (difference), {:.3e} (whole)",
        hot.len(),
        steps / 2,
        steps as f64 * n as f64 / second
    );
}
