//! The command's common machinery: help, the demo and its manifest, the mesh writer.

use crate::{root, scratch, waamtwin};

#[test]
fn every_subcommand_has_help() {
    for cmd in ["inspect", "mesh", "demo"] {
        let out = waamtwin(&[cmd, "--help"]);
        assert!(out.status.success(), "{cmd} --help");
        assert!(
            String::from_utf8_lossy(&out.stdout).contains("Usage"),
            "{cmd}"
        );
    }
}

#[test]
fn demo_writes_a_manifest_listing_its_files() {
    let dir = scratch("demo");
    let out = waamtwin(&["demo", "-o", dir.to_str().unwrap()]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let m: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("manifest.json")).unwrap()).unwrap();
    for key in [
        "run_id",
        "version",
        "command",
        "scenario",
        "started_utc",
        "wall_s",
        "files",
    ] {
        assert!(!m[key].is_null(), "manifest lacks {key}");
    }
    assert_eq!(m["scenario"]["part"]["shape"], "hemisphere");
    for f in m["files"].as_array().unwrap() {
        assert!(
            dir.join(f.as_str().unwrap()).is_file(),
            "{f} listed but missing"
        );
    }
    let leftovers: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().contains(".tmp-"))
        .collect();
    assert!(leftovers.is_empty(), "temporary files left behind");
}

#[test]
fn mesh_command_writes_a_part_that_inspects_the_same() {
    let dir = scratch("mesh_cmd");
    let out_path = dir.join("torus.ply");
    let scenario = root().join("scenarios/quarter_torus.toml");
    let out = waamtwin(&[
        "mesh",
        scenario.to_str().unwrap(),
        "-o",
        out_path.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let r = waamtwin(&["inspect", out_path.to_str().unwrap(), "--json"]);
    let r: serde_json::Value = serde_json::from_slice(&r.stdout).unwrap();
    assert_eq!(r["part_kind"], "open");
    assert_eq!(r["boundary_loops"], 2);
}
