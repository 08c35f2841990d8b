//! CTPP planning benchmark (issue 4): ~100k-vertex parts planned end to end (heat-method setup,
//! single-branch check, generators, closing point, gap filling, spiral, orientation,
//! feasibility, deviation, collisions).
//!
//! Run: `cargo bench -p planner --bench plan`

use planner::mesh::{LowerLoop, Part};
use planner::plan::{PlanParams, plan};
use planner::shapes::Shape;
use std::time::Instant;

fn main() {
    // The documented defaults.
    let params = PlanParams::default();
    let cases = [
        (
            "tilted cylinder R80 (open)",
            Shape::Vase {
                radius_mm: 80.0,
                height_mm: 165.0,
                bulge_mm: 0.0,
                top_slope_mm: 13.0,
                top_wave_mm: 0.0,
                top_waves: 0,
            },
            0.98,
        ),
        (
            "hemisphere R100 (closed)",
            Shape::Hemisphere { radius_mm: 100.0 },
            0.85,
        ),
    ];
    for (name, shape, edge) in cases {
        let part = Part::from_mesh(shape.mesh(edge), LowerLoop::LowestZ).expect("valid part");
        let mut best = f64::INFINITY;
        let mut points = 0;
        for _ in 0..3 {
            let t = Instant::now();
            let pl = plan(&part, &params).expect("plan");
            best = best.min(t.elapsed().as_secs_f64());
            points = pl.points.len();
        }
        println!(
            "{name}: {} vertices, {points} path points, plan {best:.2} s (best of 3)",
            part.mesh.n_vertices()
        );
    }
}
