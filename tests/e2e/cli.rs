//! The command's common machinery: help, the demo and its manifest, the mesh writer.

use crate::{read_csv, root, scratch, waamtwin};

#[test]
fn every_subcommand_has_help() {
    for cmd in [
        "inspect",
        "geodesic",
        "plan",
        "simulate",
        "dwell",
        "mesh",
        "demo",
        "replay",
        "calibrate",
    ] {
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
    // What a person opens shows physical temperatures (fields.h5, run.mcap; run.rrd through
    // the reference readers).
    crate::outputs::assert_physical(&dir);
    #[cfg(system_tests)]
    crate::outputs::open_in_readers(&dir);
    for f in [
        "plan.json",
        "path.csv",
        "generators.csv",
        "thermal.json",
        "layers.csv",
    ] {
        assert!(dir.join(f).is_file(), "demo lacks {f}");
    }
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

#[test]
fn plan_writes_the_contract_files() {
    let dir = scratch("plan_cmd");
    let scenario = root().join("scenarios/tilted_cylinder.toml");
    let out = waamtwin(&[
        "plan",
        scenario.to_str().unwrap(),
        "-o",
        dir.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let plan: serde_json::Value =
        serde_json::from_slice(&std::fs::read(dir.join("plan.json")).unwrap()).unwrap();
    for key in [
        "part_kind",
        "n_generators",
        "n_filled",
        "n_step_layers",
        "n_layers",
        "generator_length_mm",
        "deposit_mm",
        "closing_point_mm",
        "feasible",
        "violations",
        "deviation_mm",
        "collisions",
    ] {
        assert!(plan.get(key).is_some(), "plan.json lacks {key}");
    }
    assert_eq!(plan["part_kind"], "open");
    assert_eq!(plan["n_step_layers"], 6);
    // Table 2's part: Eq.5 from the lower loop's first generator holds the window.
    let seam = &plan["seam"];
    assert_eq!(seam["reason"], "eq5_holds", "{seam}");
    assert_eq!(seam["n_layers"], plan["n_layers"]);
    assert!(seam["step_margin_mm"].as_f64().unwrap() >= 0.0 && seam["miss_mm"].is_null());
    assert_eq!(seam["position_mm"].as_array().unwrap().len(), 3);
    let (header, rows) = read_csv(&dir.join("path.csv"));
    assert_eq!(
        header.join(","),
        "i,x,y,z,tool_x,tool_y,tool_z,layer,generator,deposit_mm,wfs_m_min,travel_mm_s,t_s,dwell_s"
    );
    assert_eq!(rows.len() as u64, plan["n_points"].as_u64().unwrap());
    // Eq.7 per point at constant travel speed: WFS = 4·W·TS·LH / (π d²), to 1e-9 relative.
    let col = |name: &str| header.iter().position(|h| h == name).unwrap();
    let mut t_prev = -1.0;
    for r in &rows {
        let lh: f64 = r[col("deposit_mm")].parse().unwrap();
        let wfs: f64 = r[col("wfs_m_min")].parse().unwrap();
        let ts: f64 = r[col("travel_mm_s")].parse().unwrap();
        let expected = 4.0 * 5.0 * ts * lh / std::f64::consts::PI * 60.0 / 1000.0;
        assert!(
            (wfs - expected).abs() <= 1e-9 * expected,
            "{wfs} vs {expected}"
        );
        let t: f64 = r[col("t_s")].parse().unwrap();
        assert!(t >= t_prev, "time runs forward");
        t_prev = t;
        let tool: Vec<f64> = ["tool_x", "tool_y", "tool_z"]
            .iter()
            .map(|c| r[col(c)].parse::<f64>().unwrap())
            .collect();
        assert!((tool.iter().map(|x| x * x).sum::<f64>().sqrt() - 1.0).abs() < 1e-5);
    }
    let (gh, grows) = read_csv(&dir.join("generators.csv"));
    assert_eq!(gh.join(","), "id,filled,length_mm,x0,y0,z0,x1,y1,z1");
    assert_eq!(grows.len() as u64, plan["n_generators"].as_u64().unwrap());

    let planar = scratch("plan_planar");
    let vase = root().join("scenarios/vase.toml");
    let out = waamtwin(&[
        "plan",
        vase.to_str().unwrap(),
        "-o",
        planar.to_str().unwrap(),
        "--strategy",
        "planar",
    ]);
    assert!(out.status.success());
    let p: serde_json::Value =
        serde_json::from_slice(&std::fs::read(planar.join("plan.json")).unwrap()).unwrap();
    assert_eq!(p["strategy"], "planar");
    assert_eq!(p["feasible"], false);
}

#[test]
fn plan_of_a_branching_part_is_an_input_error() {
    let dir = scratch("plan_branch");
    let m = crate::two_humps();
    std::fs::write(
        dir.join("humps.stl"),
        planner::io::write_stl(&m, planner::io::Encoding::Binary),
    )
    .unwrap();
    std::fs::write(dir.join("s.toml"), "[part]\nmesh = \"humps.stl\"\n").unwrap();
    let out = waamtwin(&[
        "plan",
        dir.join("s.toml").to_str().unwrap(),
        "-o",
        dir.join("out").to_str().unwrap(),
    ]);
    crate::assert_input_error(&out, &["plan:", "branches", "z ≈"]);
    assert!(!dir.join("out/plan.json").exists());
}

/// A mesh as CAD exports it: drawn 250 mm up, in metres, or on its side. Each is refused with
/// what to change (before, the raised and the lying ones planned and were heated as if they
/// stood on the plate, the voxel model laying two thirds of the raised one's metal);
/// `offset_mm` and `mesh_unit` stand them on the plate, where they plan as the mesh drawn in mm
/// on z = 0 does.
#[test]
fn a_mesh_off_the_plate_is_named_and_moved_onto_it() {
    let dir = scratch("plan_seat");
    let drawn = |name: &str, f: &dyn Fn(nalgebra::Point3<f64>) -> nalgebra::Point3<f64>| {
        let mut m = planner::shapes::Shape::Hemisphere { radius_mm: 20.0 }.mesh(2.0);
        m.map_positions(f);
        let bytes = planner::io::write_stl(&m, planner::io::Encoding::Binary);
        std::fs::write(dir.join(name), bytes).unwrap();
    };
    drawn("dome.stl", &|p| p);
    drawn("raised.stl", &|p| {
        p + nalgebra::Vector3::new(0.0, 0.0, 250.0)
    });
    drawn("metres.stl", &|p| p * 1e-3);
    drawn("lying.stl", &|p| nalgebra::Point3::new(p.z, p.y, -p.x));
    let plan = |toml: &str, out: &str| {
        let file = dir.join(format!("{out}.toml"));
        std::fs::write(&file, toml).unwrap();
        let o = waamtwin(&[
            "plan",
            file.to_str().unwrap(),
            "-o",
            dir.join(out).to_str().unwrap(),
        ]);
        (o, dir.join(out).join("path.csv"))
    };
    let (o, _) = plan("[part]\nmesh = \"raised.stl\"\n", "raised");
    crate::assert_input_error(
        &o,
        &["lies at z = 250.00 mm", "offset_mm = [0, 0, -250.00]"],
    );
    let (o, _) = plan("[part]\nmesh = \"metres.stl\"\n", "metres");
    crate::assert_input_error(&o, &["0.020 mm tall", "mesh_unit = \"m\""]);
    let (o, _) = plan("[part]\nmesh = \"lying.stl\"\n", "lying");
    crate::assert_input_error(&o, &["not level", "from -20.00 to 19.9"]);
    let (o, _) = plan(
        "[part]\nshape = \"hemisphere\"\nradius_mm = 20.0\nmesh_unit = \"m\"\n",
        "shape_unit",
    );
    crate::assert_input_error(&o, &["part.mesh_unit", "library shape"]);

    let (o, reference) = plan("[part]\nmesh = \"dome.stl\"\n", "dome");
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let (_, rows) = crate::read_csv(&reference);
    for (toml, out) in [
        (
            "[part]\nmesh = \"raised.stl\"\noffset_mm = [0.0, 0.0, -250.0]\n",
            "moved",
        ),
        (
            "[part]\nmesh = \"metres.stl\"\nmesh_unit = \"m\"\n",
            "scaled",
        ),
    ] {
        let (o, path) = plan(toml, out);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let (_, got) = crate::read_csv(&path);
        assert_eq!(got.len(), rows.len(), "{out}");
        for (a, b) in got.iter().zip(&rows) {
            for k in 1..4 {
                let (x, y): (f64, f64) = (a[k].parse().unwrap(), b[k].parse().unwrap());
                // The STL's f32 rounds metres and millimetres differently (some 1e-6 mm), and
                // a generator leaving the loop at one of its vertices takes one face's gradient
                // or the other's: measured up to 0.084 mm, 0.008 the median. A unit or an offset
                // applied wrong moves every point by millimetres.
                assert!(
                    (x - y).abs() < 0.1,
                    "{out}: point {} axis {k}: {x} {y}",
                    a[0]
                );
            }
        }
    }
}

/// Issue 19: a voxel run that cannot fit in the machine's memory (the plate, 1000 ×
/// 1000 × 50 mm at 0.25 mm: 3.2e9 voxels) is refused at once, before any planning, naming
/// `thermal.voxel_mm` and the size that would fit; a run that fits shows its estimate first.
#[test]
fn a_run_too_big_for_the_machine_is_refused_at_once() {
    let dir = crate::scratch("too_big");
    std::fs::write(
        dir.join("s.toml"),
        "[part]\nshape = \"hemisphere\"\nradius_mm = 100.0\n[thermal]\nmodel = \"voxel\"\n\
         voxel_mm = 0.25\nplate_mm = [1000.0, 1000.0, 50.0]\n",
    )
    .unwrap();
    let clock = std::time::Instant::now();
    let o = crate::waamtwin(&[
        "simulate",
        dir.join("s.toml").to_str().unwrap(),
        "-o",
        dir.join("out").to_str().unwrap(),
    ]);
    let took = clock.elapsed().as_secs_f64();
    crate::assert_input_error(
        &o,
        &[
            "s.toml",
            "thermal.voxel_mm = 0.25",
            "3.200e9 voxels",
            "or more",
        ],
    );
    assert!(took < 1.0, "{took} s");
    assert!(!dir.join("out").join("manifest.json").exists());
    // A small plate at 2 mm fits, and says what it will cost before it runs.
    let dir = crate::scratch("fits_estimate");
    let o = simulate_small_voxel_dome(&dir, 2.0);
    assert!(o.status.success());
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(
        err.contains("estimate: ") && err.contains("voxels") && err.contains("steps"),
        "{err}"
    );
    assert!(!err.contains("beads' height"), "{err}");
    // With less memory than that run asks, the same scenario is refused before it starts.
    let o = std::process::Command::new(env!("CARGO_BIN_EXE_waamtwin"))
        .args(["simulate", dir.join("s.toml").to_str().unwrap(), "-o"])
        .arg(dir.join("out2"))
        .env("WAAMTWIN_MEMORY_BYTES", "100000")
        .output()
        .unwrap();
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("thermal.voxel_mm"));
}

/// A voxel edge twice the beads' height (4 mm on 1.96 mm beads) is named before the run, with
/// its key and the edge that refines it, and the run goes on (docs/PHYSICS.md "The voxel grid
/// against the layer"); the 2 mm edge above is not.
#[test]
fn a_voxel_edge_much_taller_than_the_beads_is_named() {
    let dir = crate::scratch("coarse_voxels");
    let o = simulate_small_voxel_dome(&dir, 4.0);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains(
            "warning: voxel model: thermal.voxel_mm = 4 is 2.05 times the beads' height (1.96 mm"
        ),
        "{err}"
    );
    assert!(err.contains("An edge of 1.96 mm or less"), "{err}");
    assert!(dir.join("out/thermal.json").exists());
}

/// `simulate` of an R 20 dome on `voxel_mm` voxels and a 60 mm plate, outputs off, written as
/// `dir`/s.toml, into `dir`/out.
fn simulate_small_voxel_dome(dir: &std::path::Path, voxel_mm: f64) -> std::process::Output {
    std::fs::write(
        dir.join("s.toml"),
        format!(
            "[part]\nshape = \"hemisphere\"\nradius_mm = 20.0\nedge_mm = 2.5\n[planner]\n\
             n_points = 40\n[thermal]\nmodel = \"voxel\"\nvoxel_mm = {voxel_mm}\n\
             plate_mm = [60.0, 60.0, 6.0]\n[output]\nrerun = false\nmcap = false\nhdf5 = false\n\
             plots = false\n"
        ),
    )
    .unwrap();
    crate::waamtwin(&[
        "simulate",
        dir.join("s.toml").to_str().unwrap(),
        "-o",
        dir.join("out").to_str().unwrap(),
    ])
}

/// A part too fine for the planner to hold is refused before it is meshed: the R 400 dome at
/// 0.4 mm edges (7.3e6 vertices, about 50 GB to plan; meshing it alone, `waamtwin mesh`, took
/// 2.06 GB and 47 s) within 2 GB, by `plan` and by `simulate`, naming `part.edge_mm` and the
/// edge that fits. That edge, asked of a smaller dome within 40 MB, plans within the same
/// memory; a mesh file too large is named with its vertices.
#[test]
fn a_part_too_fine_to_plan_is_refused_before_it_is_meshed() {
    let dir = crate::scratch("too_fine");
    let run = |command: &str, toml: &str, memory: &str| {
        std::fs::write(dir.join("s.toml"), toml).unwrap();
        let clock = std::time::Instant::now();
        let o = std::process::Command::new(env!("CARGO_BIN_EXE_waamtwin"))
            .args([command, dir.join("s.toml").to_str().unwrap(), "-o"])
            .arg(dir.join("out"))
            .env("WAAMTWIN_MEMORY_BYTES", memory)
            .output()
            .unwrap();
        (o, clock.elapsed().as_secs_f64())
    };
    let huge = "[part]\nshape = \"hemisphere\"\nradius_mm = 400.0\nedge_mm = 0.4\n";
    for command in ["plan", "simulate"] {
        let (o, took) = run(command, huge, "2e9");
        crate::assert_input_error(
            &o,
            &[
                "s.toml",
                "part.edge_mm = 0.4",
                "7259085 vertices",
                "or more",
            ],
        );
        assert!(took < 2.0, "{command}: refused after {took} s");
        assert!(!dir.join("out").join("plan.json").exists());
    }
    let dome = |edge: &str| {
        format!("[part]\nshape = \"hemisphere\"\nradius_mm = 100.0\nedge_mm = {edge}\n")
    };
    let (o, _) = run("plan", &dome("2.0"), "40e6");
    crate::assert_input_error(&o, &["part.edge_mm = 2 ", "18354 vertices", "or more"]);
    let err = String::from_utf8_lossy(&o.stderr);
    let fits = err
        .split("expected part.edge_mm = ")
        .nth(1)
        .and_then(|t| t.split(' ').next())
        .unwrap_or_else(|| panic!("no edge that fits in: {err}"));
    let (o, _) = run("plan", &dome(fits), "40e6");
    assert!(
        o.status.success(),
        "edge_mm = {fits}: {}",
        String::from_utf8_lossy(&o.stderr)
    );
    let cone = format!(
        "[part]\nmesh = \"{}\"\n",
        crate::root().join("scenarios/parts/cone.stl").display()
    );
    let (o, _) = run("plan", &cone, "13e6");
    crate::assert_input_error(&o, &["cone.stl has 1429 vertices", "a coarser mesh"]);
}
