//! The same inputs give the same outputs on one thread or two: every file of a voxel dwell run
//! (the voxel kernel is the parallel part) compared byte for byte, wall-clock fields aside.

use crate::scratch;
use std::path::Path;

const DOME: &str = "[part]\nshape = \"hemisphere\"\nradius_mm = 25.0\nedge_mm = 2.5\n[planner]\nn_points = 48\n[thermal]\nmodel = \"voxel\"\nplate_mm = [90.0, 90.0, 8.0]\n[output]\nframes = 20\n";

/// JSON with the wall-clock fields taken out: keys naming `wall_s`, and the search cost, a
/// ratio of two wall-clock times.
fn without_clock(v: &mut serde_json::Value) {
    if let Some(m) = v.as_object_mut() {
        m.retain(|k, _| !k.contains("wall_s") && k != "search_cost_in_builds");
        m.values_mut().for_each(without_clock);
    }
}

/// run.mcap's messages in order (topic, log time, payload): its summary section lists schemas
/// and channels in the writer's hash order, which changes from process to process.
fn mcap_messages(path: &Path) -> Vec<(String, u64, Vec<u8>)> {
    let bytes = std::fs::read(path).unwrap();
    mcap::MessageStream::new(&bytes)
        .unwrap()
        .map(|m| {
            let m = m.unwrap();
            (m.channel.topic.clone(), m.log_time, m.data.into_owned())
        })
        .collect()
}

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
    let mut names: Vec<String> = std::fs::read_dir(&one)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    names.sort();
    assert!(names.len() >= 14, "{names:?}");
    for name in &names {
        let (a, b) = (one.join(name), two.join(name));
        match name.as_str() {
            // The manifest is a record of the run itself: its id, start and duration.
            "manifest.json" => {}
            // A rerun recording carries a random recording id and wall-clock times.
            "run.rrd" => assert!(b.is_file()),
            "run.mcap" => assert_eq!(mcap_messages(&a), mcap_messages(&b), "{name}"),
            n if n.ends_with(".json") => {
                let read = |p: &Path| {
                    let mut v: serde_json::Value =
                        serde_json::from_slice(&std::fs::read(p).unwrap()).unwrap();
                    without_clock(&mut v);
                    v
                };
                assert_eq!(read(&a), read(&b), "{name}");
            }
            _ => assert!(
                std::fs::read(&a).unwrap() == std::fs::read(&b).unwrap(),
                "{name} differs between one thread and two"
            ),
        }
    }
}
