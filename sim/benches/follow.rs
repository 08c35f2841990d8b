//! The live twin's speed: `follow` on the two measured builds with their whole logs already
//! written (the twin never waits for data), 16 members as their scenarios set them. Prints the
//! build seconds followed per wall second spent computing (the real-time factor), which the
//! issue asks to be at least 10 on this 2-core machine. Skipped where
//! `../shared/validation-data` is absent.
//!
//! `cargo bench -p sim --bench follow` (the ORNL pad and the GAMMA wall; one of them:
//! `-- ornl` or `-- gamma`).

use std::path::Path;

fn main() {
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).parent().unwrap();
    if !root.join("../shared/validation-data").is_dir() {
        eprintln!("skipped: ../shared/validation-data is absent");
        return;
    }
    let only: Vec<String> = std::env::args()
        .skip(1)
        .filter(|a| !a.starts_with('-'))
        .collect();
    for (name, scenario) in [
        ("ornl", "scenarios/ornl_srp_pad.toml"),
        ("gamma", "scenarios/gamma_in718_wall.toml"),
    ] {
        if !only.is_empty() && !only.iter().any(|o| name.contains(o.as_str())) {
            continue;
        }
        let out = std::env::temp_dir().join(format!("waamtwin-bench-follow-{name}"));
        let _ = std::fs::remove_dir_all(&out);
        let line = sim::commands::follow::run(
            &root.join(scenario),
            &out,
            Some(1.0),
            None,
            sim::commands::checkpoint::Options::default(),
        )
        .unwrap_or_else(|e| panic!("{name}: {e}"));
        let v: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("follow.json")).unwrap()).unwrap();
        println!(
            "{name}: {:.0} s of build followed in {:.1} s of computing: {:.1}× real time, {} \
             threads\n  {line}",
            v["followed_build_s"].as_f64().unwrap_or(0.0),
            v["busy_wall_s"].as_f64().unwrap_or(0.0),
            v["real_time_factor"].as_f64().unwrap_or(0.0),
            rayon::current_num_threads(),
        );
    }
}
