//! Thermal benchmarks (issue 6).
//!
//! 1. The voxel kernel: explicit 7-point enthalpy updates over the active set of a finished
//!    10-revolution cylinder (R 60 mm, 2 mm voxels, with its 200 × 200 × 10 mm plate), and over
//!    the plate alone, on one thread and on two; updates per second.
//! 2. The thin-wall model on a whole build: the 80-revolution cylinder R 80 × 160 mm.
//!
//! Run: `cargo bench -p thermal --bench thermal` (add `-- voxel` for the kernel alone,
//! `VOXEL_MM=1` for 1 mm voxels)

use std::time::Instant;
use thermal::Plate;
use thermal::material::Material;
use thermal::network::Surroundings;
use thermal::schedule::helix;
use thermal::voxel::{VoxelModel, VoxelSettings};
use thermal::wall::{WallModel, WallSettings};

fn cylinder(r: f64, n: usize, layers: usize) -> Vec<thermal::schedule::Deposit> {
    helix(r, n, layers, 2e-3, 6e-3, 10e-3, 0.85 * 2000.0)
}

fn surroundings() -> Surroundings {
    Surroundings {
        ambient_k: 293.15,
        convection_w_m2k: 15.0,
        emissivity: 0.6,
        table_w_m2k: 100.0,
    }
}

fn main() {
    let deps = cylinder(0.06, 120, 10);
    // `VOXEL_MM=1` times the kernel on 1 mm voxels (445 682, the state spilling each core's L2).
    let voxel_mm: f64 =
        std::env::var("VOXEL_MM").map_or(2.0, |v| v.parse().expect("VOXEL_MM: a number of mm"));
    let vs = VoxelSettings {
        material: Material::g3si(),
        surroundings: surroundings(),
        plate: Plate {
            size: [0.2, 0.2, 0.01],
            centre: [0.0, 0.0],
            cell: 5e-3,
            layers: 3,
            disc: false,
            material: None,
        },
        size: voxel_mm * 1e-3,
        deposit_temperature: 1823.15,
        lead: 10e-3,
        hot_threshold: 873.15,
        snapshot_times: vec![],
        traces: vec![],
        watch_metal: true,
        courant: 0.9,
        probes: vec![],
        probe_every: 0.0,
        source: thermal::voxel::HeatSource::DoubleEllipsoid,
        coarse_plate: false,
        device: Default::default(),
    };
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            // The plate alone, then the finished part: what a deposit voxel costs beside a
            // plate voxel (its neighbours irregular, the plate's in regular groups).
            for part in ["the plate alone", "the finished part"] {
                let mut m = VoxelModel::new(&deps, &vs).unwrap();
                if part == "the finished part" {
                    m.lay_all(&deps);
                }
                let dt = m.stable_step();
                let steps = 4000 * 55_599 / m.active().max(1);
                m.step(dt, &[]);
                let t = Instant::now();
                for _ in 0..steps {
                    m.step(dt, &[]);
                }
                let secs = t.elapsed().as_secs_f64();
                println!(
                    "voxel kernel, {threads} thread(s), {part}: {} active voxels, {:.3e} updates/s ({:.2} ns/update)",
                    m.active(),
                    (m.active() * steps) as f64 / secs,
                    secs * 1e9 / (m.active() * steps) as f64
                );
            }
        });
    }
    // `cargo bench -p thermal --bench thermal -- voxel` times the kernel alone.
    if std::env::args().any(|a| a == "voxel") {
        return;
    }
    let deps = cylinder(0.08, 126, 80);
    let ws = WallSettings {
        material: Material::g3si(),
        surroundings: surroundings(),
        plate: Plate {
            size: [0.25, 0.25, 0.01],
            centre: [0.0, 0.0],
            cell: 5e-3,
            layers: 3,
            disc: false,
            material: None,
        },
        min_node: 3e-3,
        deposit_temperature: 1823.15,
        footprint: 6e-3,
        lead: 10e-3,
        hot_threshold: 873.15,
        max_step: 30.0,
        probes: vec![],
        probe_every: 0.0,
        snapshot_times: vec![],
        traces: vec![],
        watch_metal: true,
        local_steps: None,
        merge_plate: true,
    };
    let t = Instant::now();
    let r = WallModel::build(&deps, &ws)
        .unwrap()
        .run(&deps, &ws, 0.0)
        .unwrap();
    let thermal::Cells::ThinWall { cg_iterations, .. } = r.cells else {
        unreachable!("a thin-wall run")
    };
    println!(
        "thin wall, cylinder R80 × 160 mm (80 revolutions, {:.0} s of arc): {:.1} s wall, {} steps, {:.1} CG iterations a step",
        deps.last().unwrap().time,
        t.elapsed().as_secs_f64(),
        r.steps,
        cg_iterations as f64 / r.steps as f64
    );
}
