//! The command's common machinery: help, the demo and its manifest, the mesh writer.

use crate::{root, scratch, waamtwin};

#[test]
fn every_subcommand_has_help() {
    for cmd in ["inspect", "geodesic", "mesh", "demo"] {
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

#[test]
fn geodesic_command_writes_distance_per_vertex() {
    let dir = scratch("geodesic_cmd");
    let stl = dir.join("cyl.stl");
    let scenario = root().join("scenarios/cylinder.toml");
    assert!(
        waamtwin(&[
            "mesh",
            scenario.to_str().unwrap(),
            "-o",
            stl.to_str().unwrap()
        ])
        .status
        .success()
    );
    let csv = dir.join("d.csv");
    let out = waamtwin(&[
        "geodesic",
        stl.to_str().unwrap(),
        "--from",
        "lower",
        "-o",
        csv.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = std::fs::read_to_string(&csv).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("x,y,z,distance_mm"));
    let mut n = 0;
    for l in lines {
        let v: Vec<f64> = l.split(',').map(|x| x.parse().unwrap()).collect();
        // Distance from the lower loop of a cylinder is the height (f32 STL coordinates).
        assert!((v[3] - v[2]).abs() < 0.05, "{l}");
        n += 1;
    }
    assert!(n > 20_000);
    crate::assert_input_error(
        &waamtwin(&[
            "geodesic",
            stl.to_str().unwrap(),
            "--from",
            "vertex:7,x",
            "-o",
            csv.to_str().unwrap(),
        ]),
        &["vertex:7,x", "'x' is not a vertex index"],
    );
}
