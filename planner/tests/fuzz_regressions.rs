//! Every input a fuzzer crashed the planner's readers with (`fuzz/`, issue 19), kept under
//! `tests/fuzz/TARGET/` and run through what its target runs: each must now give a value or an
//! error, never a panic. The release build checks integer overflow in this crate
//! (Cargo.toml), so an overflow the fuzzer found fails here too.

use planner::io::{MeshFormat, read_mesh};
use planner::mesh::{LowerLoop, Part};
use std::path::Path;

fn inputs(target: &str) -> Vec<(String, Vec<u8>)> {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"))
        .join("tests/fuzz")
        .join(target);
    let mut v: Vec<_> = std::fs::read_dir(&dir)
        .map(|d| {
            d.filter_map(|e| e.ok())
                .map(|e| {
                    (
                        e.file_name().to_string_lossy().into_owned(),
                        std::fs::read(e.path()).unwrap(),
                    )
                })
                .collect()
        })
        .unwrap_or_default();
    v.sort();
    v
}

fn mesh(target: &str, format: MeshFormat) -> usize {
    let all = inputs(target);
    for (name, bytes) in &all {
        let r = std::panic::catch_unwind(|| {
            if let Ok(m) = read_mesh(bytes, format) {
                let _ = Part::from_mesh(m, LowerLoop::LowestZ);
            }
        });
        assert!(r.is_ok(), "{target}/{name} panics");
    }
    all.len()
}

#[test]
fn mesh_readers_survive_their_crashes() {
    let n = mesh("mesh_stl", MeshFormat::Stl)
        + mesh("mesh_obj", MeshFormat::Obj)
        + mesh("mesh_ply", MeshFormat::Ply);
    assert!(n >= 2, "the crash inputs are missing");
}

#[test]
fn skeleton_reader_survives_its_crashes() {
    use planner::saam::graph::BranchSpec;
    use planner::saam::{Priority, Skeleton, Slicer, SlicerSettings};
    for (name, bytes) in inputs("skeleton_obj") {
        let r = std::panic::catch_unwind(|| {
            let Ok(p) = planner::io::read_obj_polylines(&bytes) else {
                return;
            };
            let Ok(sk) = Skeleton::new(&p.vertices, &p.lines, |_| BranchSpec {
                radius_mm: 3.0,
                priority: Priority::None,
            }) else {
                return;
            };
            let mut s = Slicer::new(&sk, SlicerSettings::default());
            for _ in 0..50 {
                if s.next_drop().is_none() {
                    break;
                }
                s.built(None);
            }
        });
        assert!(r.is_ok(), "skeleton_obj/{name} panics");
    }
}
