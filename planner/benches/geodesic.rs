//! Geodesic benchmark (issue 3): the heat method on a ~100k-vertex tube (500 × 200 grid, radius
//! 80 mm, height 160 mm). Prints factorisation and per-solve times; when python3 with potpourri3d
//! is installed, times geometry-central's heat method on the same mesh in the same run.
//!
//! Run: `cargo bench -p planner --bench geodesic`

use planner::geodesic::{HeatOptions, HeatSolver};
use planner::io::write_obj;
use planner::mesh::{LowerLoop, Part};
use planner::shapes::tube_grid;
use std::time::Instant;

fn best_of<T>(n: usize, mut f: impl FnMut() -> T) -> (f64, T) {
    let mut best = f64::INFINITY;
    let mut out = None;
    for _ in 0..n {
        let t = Instant::now();
        let r = f();
        best = best.min(t.elapsed().as_secs_f64());
        out = Some(r);
    }
    (best, out.expect("n > 0"))
}

fn main() {
    let part =
        Part::from_mesh(tube_grid(80.0, 160.0, 500, 200), LowerLoop::LowestZ).expect("valid tube");
    let (mesh, topo) = (&part.mesh, &part.topology);
    println!(
        "mesh: {} vertices, {} faces",
        mesh.n_vertices(),
        mesh.n_faces()
    );
    let (t_setup, solver) = best_of(3, || {
        HeatSolver::new(mesh, &topo.is_boundary_vertex, HeatOptions::default()).expect("factor")
    });
    println!("setup (operators + symbolic + 3 numeric factorisations): {t_setup:.3} s");
    let reps = 20;
    let t = Instant::now();
    for k in 0..reps {
        std::hint::black_box(
            solver.distance_from_vertices(&[(12_345 + 997 * k) as u32 % mesh.n_vertices() as u32]),
        );
    }
    let t_single = t.elapsed().as_secs_f64() / reps as f64;
    println!("solve, one vertex source (mean of {reps}): {t_single:.4} s");
    let plain = HeatSolver::new(
        mesh,
        &topo.is_boundary_vertex,
        HeatOptions {
            exact_rings: 0,
            ..Default::default()
        },
    )
    .expect("factor");
    let t = Instant::now();
    for k in 0..reps {
        std::hint::black_box(
            plain.distance_from_vertices(&[(12_345 + 997 * k) as u32 % mesh.n_vertices() as u32]),
        );
    }
    println!(
        "solve, one vertex source, no exact rings (mean of {reps}): {:.4} s",
        t.elapsed().as_secs_f64() / reps as f64
    );
    let lower = &part.lower_loop().vertices;
    let t = Instant::now();
    std::hint::black_box(solver.distance_from_vertices(lower));
    let t_loop_first = t.elapsed().as_secs_f64();
    let (t_loop, _) = best_of(5, || solver.distance_from_vertices(lower));
    println!(
        "solve, lower loop ({} sources): first {t_loop_first:.4} s (numeric factorisation), then {t_loop:.4} s",
        lower.len()
    );

    let obj = std::path::Path::new(env!("CARGO_TARGET_TMPDIR")).join("waamtwin_bench_tube.obj");
    std::fs::write(&obj, write_obj(mesh)).expect("write temp mesh");
    let script = concat!(env!("CARGO_MANIFEST_DIR"), "/benches/peer_potpourri3d.py");
    match std::process::Command::new("python3")
        .args([script, obj.to_str().unwrap(), "12345", &reps.to_string()])
        .output()
    {
        Ok(out) if out.status.success() => {
            let line = String::from_utf8_lossy(&out.stdout).trim().to_string();
            println!("peer potpourri3d (geometry-central), same mesh: {line}");
            let field = |k: &str| {
                line.split_whitespace()
                    .find_map(|w| w.strip_prefix(k))
                    .and_then(|v| v.parse::<f64>().ok())
            };
            if let (Some(s), Some(q)) = (field("setup_s="), field("solve_s=")) {
                println!(
                    "ratio ours/peer: setup {:.2}, one-source solve {:.2}",
                    t_setup / s,
                    t_single / q
                );
            }
        }
        _ => println!("peer potpourri3d not available (pip install potpourri3d numpy)"),
    }
    let _ = std::fs::remove_file(obj);
}
