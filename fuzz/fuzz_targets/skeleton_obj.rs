//! An OBJ of polylines into a skeleton, then slice it a few drops: never a panic.
#![no_main]
use libfuzzer_sys::fuzz_target;
use planner::saam::graph::BranchSpec;
use planner::saam::{Priority, Skeleton, Slicer, SlicerSettings};

fuzz_target!(|data: &[u8]| {
    let Ok(p) = planner::io::read_obj_polylines(data) else {
        return;
    };
    // Bounded work: a skeleton of a few thousand vertices at most.
    if p.vertices.len() > 2000 || p.lines.len() > 200 {
        return;
    }
    let Ok(sk) = Skeleton::new(&p.vertices, &p.lines, |_| BranchSpec {
        radius_mm: 3.0,
        priority: Priority::None,
    }) else {
        return;
    };
    let extent = sk
        .branches
        .iter()
        .flat_map(|b| b.points.iter())
        .map(|q| q.coords.amax())
        .fold(0.0, f64::max);
    if extent > 1e4 {
        return;
    }
    let mut s = Slicer::new(&sk, SlicerSettings::default());
    for _ in 0..50 {
        if s.next_drop().is_none() {
            break;
        }
        s.built(None);
    }
});
