//! The same inputs give the same outputs on one thread or two: every file of a voxel dwell run
//! (the voxel kernel is the parallel part) compared byte for byte, wall-clock fields aside.

use crate::{assert_same_outputs, scratch};

pub const DOME: &str = "[part]\nshape = \"hemisphere\"\nradius_mm = 25.0\nedge_mm = 2.5\n[planner]\nn_points = 48\n[thermal]\nmodel = \"voxel\"\nplate_mm = [90.0, 90.0, 8.0]\n[output]\nframes = 20\n";

#[test]
fn one_thread_or_two_write_the_same_files() {
    let dir = scratch("determinism");
    std::fs::write(dir.join("s.toml"), DOME).unwrap();
    let run = |threads: &str| {
        let out = dir.join(format!("threads-{threads}"));
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_waamtwin"))
            .args(["dwell", dir.join("s.toml").to_str().unwrap(), "-o"])
            .arg(&out)
            .arg("--no-baselines")
            .env("RAYON_NUM_THREADS", threads)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        out
    };
    let (one, two) = (run("1"), run("2"));
    let names = assert_same_outputs(&one, &two, "between one thread and two");
    assert!(names.len() >= 14, "{names:?}");
}
