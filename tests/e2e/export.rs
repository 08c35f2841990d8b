//! `waamtwin export`: the machine programs of a dwelled dome, parsed back: one move per path
//! point (`--min-move-mm 0`; by default the moves under 0.1 mm merged) at its position
//! (1e-6 mm) and tool frame (1e-6 rad), the arc struck once at the start and once after each
//! arc stop the plan made; the G-code's axes through the table's kinematics; a layered tube
//! path struck once per bead.

use crate::{read_csv, waamtwin};
use planner::frame::{Frame, frames};
use planner::nalgebra::{Point3, Quaternion, Rotation3, UnitQuaternion, Vector3};

/// The frames path.csv gives, and the plan's arc stops.
fn planned(out: &std::path::Path) -> (Vec<Frame>, usize) {
    let (h, rows) = read_csv(&out.join("path.csv"));
    let col = |n: &str| h.iter().position(|x| x == n).unwrap();
    let v = |r: &Vec<String>, n: &str| r[col(n)].parse::<f64>().unwrap();
    let points: Vec<Point3<f64>> = rows
        .iter()
        .map(|r| Point3::new(v(r, "x"), v(r, "y"), v(r, "z")))
        .collect();
    let tools: Vec<Vector3<f64>> = rows
        .iter()
        .map(|r| Vector3::new(v(r, "tool_x"), v(r, "tool_y"), v(r, "tool_z")))
        .collect();
    let d: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("dwell.json")).unwrap()).unwrap();
    (
        frames(&points, &tools),
        d["arc_stops"].as_u64().unwrap() as usize,
    )
}

/// A JSON array of numbers.
fn floats(v: &serde_json::Value) -> Vec<f64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_f64().unwrap())
        .collect()
}

/// The numbers between the first `open` after `key` and its `close`.
fn numbers(line: &str, key: &str) -> Vec<f64> {
    let rest = &line[line.find(key).unwrap() + key.len()..];
    rest.split(|c: char| !(c.is_ascii_digit() || c == '.' || c == '-' || c == 'E'))
        .filter(|t| !t.is_empty() && *t != "E")
        .map(|t| t.parse().unwrap())
        .collect()
}

fn close(f: &Frame, position: [f64; 3], rotation: &Rotation3<f64>, what: &str) {
    let p = f.position;
    let d = (Vector3::new(position[0], position[1], position[2]) - p.coords).norm();
    assert!(d < 1e-6, "{what}: {d} mm off");
    let angle = (rotation.matrix() - f.rotation.matrix()).norm();
    assert!(angle < 1e-6, "{what}: {angle} rad off");
}

#[test]
fn programs_parse_back_to_the_path() {
    let out = crate::run_scenario(
        "export_dome",
        "dwell",
        "[part]\nshape = \"hemisphere\"\nradius_mm = 20.0\nedge_mm = 2.5\n[planner]\nn_points = 40\n\
         [thermal]\nplate_mm = [80.0, 80.0, 8.0]\n[dwell]\ninterpass_max_c = 250.0\n\
         [output]\nrerun = false\nmcap = false\nhdf5 = false\nplots = false\n",
    );
    let (expected, stops) = planned(&out);
    assert!(stops > 1);
    short_moves_merge(&out, &expected, 1 + stops);
    // Every point a move from here on.
    for format in ["json", "rapid", "krl"] {
        let o = waamtwin(&[
            "export",
            out.to_str().unwrap(),
            "--format",
            format,
            "--min-move-mm",
            "0",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    gcode_parses_back(&out, &expected, 1 + stops);

    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("program.json")).unwrap()).unwrap();
    let moves = j["moves"].as_array().unwrap();
    assert_eq!(moves.len(), expected.len());
    assert_eq!(j["arc_strikes"].as_u64().unwrap() as usize, 1 + stops);
    for (m, f) in moves.iter().zip(&expected) {
        let p = floats(&m["position_mm"]);
        let q = floats(&m["quaternion_wxyz"]);
        let r = UnitQuaternion::from_quaternion(Quaternion::new(q[0], q[1], q[2], q[3]));
        close(f, [p[0], p[1], p[2]], &r.to_rotation_matrix(), "json");
    }

    let rapid = std::fs::read_to_string(out.join("program.mod")).unwrap();
    let moves: Vec<&str> = rapid
        .lines()
        .filter(|l| l.trim_start().starts_with("MoveL"))
        .collect();
    assert_eq!(moves.len(), expected.len());
    for (l, f) in moves.iter().zip(&expected) {
        let v = numbers(l, "MoveL");
        let r = UnitQuaternion::from_quaternion(Quaternion::new(v[3], v[4], v[5], v[6]));
        close(f, [v[0], v[1], v[2]], &r.to_rotation_matrix(), "rapid");
    }
    let on = rapid.matches("SetDO doArc, 1;").count();
    let off = rapid.matches("SetDO doArc, 0;").count();
    assert_eq!(
        (on, off),
        (1 + stops, 1 + stops),
        "one strike and one end per arc"
    );
    assert!(rapid.matches("WaitTime").count() <= stops);

    let krl = std::fs::read_to_string(out.join("program.src")).unwrap();
    let moves: Vec<&str> = krl.lines().filter(|l| l.starts_with("LIN")).collect();
    assert_eq!(moves.len(), expected.len());
    for (l, f) in moves.iter().zip(&expected) {
        let v = numbers(l, "LIN");
        let [a, b, c] = [v[3], v[4], v[5]].map(f64::to_radians);
        let r = Rotation3::from_euler_angles(c, b, a);
        close(f, [v[0], v[1], v[2]], &r, "krl");
    }
    assert_eq!(krl.matches("$OUT[1] = TRUE").count(), 1 + stops);
    assert_eq!(krl.matches("$OUT[1] = FALSE").count(), 1 + stops);
}

/// By default a move under 0.1 mm from the move kept before it is merged into the next: the
/// program's moves are path points (`i`) at their planned frames, every move but the last at
/// least 0.1 mm, every point dropped within 0.1 mm of the one kept before it, and the arc still
/// struck once per bead (a point where it is struck is never dropped).
fn short_moves_merge(out: &std::path::Path, expected: &[Frame], beads: usize) {
    let o = waamtwin(&["export", out.to_str().unwrap(), "--format", "json"]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("program.json")).unwrap()).unwrap();
    let moves = j["moves"].as_array().unwrap();
    let kept: Vec<usize> = moves
        .iter()
        .map(|m| m["i"].as_u64().unwrap() as usize)
        .collect();
    let merged = expected.len() - kept.len();
    assert!(merged > 0, "the dome's closing point bunches its points");
    let line = String::from_utf8_lossy(&o.stdout);
    assert!(
        line.contains(&format!("({merged} path points under 0.1 mm")),
        "{line}"
    );
    assert_eq!(j["arc_strikes"].as_u64().unwrap() as usize, beads);
    assert_eq!((kept[0], *kept.last().unwrap()), (0, expected.len() - 1));
    for (w, pair) in kept.windows(2).enumerate() {
        let (a, b) = (expected[pair[0]].position, expected[pair[1]].position);
        if pair[1] + 1 < expected.len() {
            assert!(
                (b - a).norm() >= 0.1,
                "move {} is {} mm",
                w + 1,
                (b - a).norm()
            );
        }
        for dropped in &expected[pair[0] + 1..pair[1]] {
            assert!((dropped.position - a).norm() < 0.1);
        }
    }
    for (m, &i) in moves.iter().zip(&kept) {
        let p = floats(&m["position_mm"]);
        assert!((Vector3::new(p[0], p[1], p[2]) - expected[i].position.coords).norm() < 1e-6);
    }
}

/// The G-code of a tilt-rotary table with its pivot off the origin and the part raised on the
/// table: every G0/G1's axes taken back through the table's kinematics, written here apart from
/// the exporter's (m = P + Rx(A)·Rz(C)·(p + o), the torch along the machine's +Z), give the
/// path point within 1e-6 mm and its tool axis within 1e-6 rad; C never turns back a half turn
/// between moves; one M3 and one M5 per bead.
fn gcode_parses_back(out: &std::path::Path, expected: &[Frame], beads: usize) {
    let o = waamtwin(&[
        "export",
        out.to_str().unwrap(),
        "--format",
        "gcode",
        "--pivot-mm",
        "250,-40,-300",
        "--part-offset-mm",
        "0,0,45",
        "--min-move-mm",
        "0",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let g = std::fs::read_to_string(out.join("program.nc")).unwrap();
    let moves: Vec<&str> = g
        .lines()
        .filter(|l| l.contains("G1 X") || l.contains("G0 X"))
        .collect();
    assert_eq!(moves.len(), expected.len());
    let (pivot, offset) = (
        Vector3::new(250.0, -40.0, -300.0),
        Vector3::new(0.0, 0.0, 45.0),
    );
    let mut last_c: Option<f64> = None;
    for (k, (l, f)) in moves.iter().zip(expected).enumerate() {
        let word = |w: char| -> f64 {
            let at = l.find(&format!(" {w}")).unwrap() + 2;
            l[at..].split(' ').next().unwrap().parse().unwrap()
        };
        let (a, c) = (word('A').to_radians(), word('C').to_radians());
        let back = Rotation3::from_axis_angle(&Vector3::z_axis(), -c)
            * Rotation3::from_axis_angle(&Vector3::x_axis(), -a);
        let m = Vector3::new(word('X'), word('Y'), word('Z'));
        let p = back * (m - pivot) - offset;
        let d = (p - f.position.coords).norm();
        assert!(d < 1e-6, "gcode move {k}: {d} mm off");
        let angle = (back * Vector3::z()).angle(&f.tool());
        assert!(angle < 1e-6, "gcode move {k}: tool {angle} rad off");
        if let Some(prev) = last_c {
            assert!((c.to_degrees() - prev).abs() < 180.0, "C jumps at move {k}");
        }
        last_c = Some(c.to_degrees());
        if k > 0 {
            assert!(l.contains(" F"), "{l}");
        }
    }
    assert!(g.contains("G93"), "inverse-time feed");
    assert_eq!(g.lines().filter(|l| *l == "M3").count(), beads);
    assert_eq!(g.lines().filter(|l| *l == "M5").count(), beads);
    // The table's fastest turn on C, as the command says it, is the program's own: ΔC × F
    // (inverse time, 1/min) over the moves, in rpm.
    let word = |l: &str, w: char| -> f64 {
        let at = l.find(&format!(" {w}")).unwrap() + 2;
        l[at..].split(' ').next().unwrap().parse().unwrap()
    };
    // (A move that goes nowhere has F at its 1e9 floor and no pace of its own.)
    let fastest_c = moves
        .windows(2)
        .filter(|p| word(p[1], 'F') < 1e8)
        .map(|p| (word(p[1], 'C') - word(p[0], 'C')).abs() * word(p[1], 'F') / 360.0)
        .fold(0.0, f64::max);
    let line = String::from_utf8_lossy(&o.stdout);
    let said: f64 = line
        .split("the table turning up to ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .and_then(|r| r.parse().ok())
        .unwrap_or_else(|| panic!("{line}"));
    assert!(
        (said - fastest_c).abs() <= 0.05 + 1e-3 * fastest_c,
        "{said} against {fastest_c}"
    );
    // Held to a tenth of it, the moves over are said, with the torch's pace there.
    assert!(fastest_c > 0.0, "the table turns");
    let limit = format!("{}", fastest_c / 10.0);
    let o = waamtwin(&[
        "export",
        out.to_str().unwrap(),
        "--format",
        "gcode",
        "--min-move-mm",
        "0",
        "--rotary-rpm-max",
        &limit,
    ]);
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{e}");
    assert!(
        e.contains("warning: table_speed: ") && e.contains("mm/s (planned"),
        "{e}"
    );
    // A robot has no table.
    let o = waamtwin(&[
        "export",
        out.to_str().unwrap(),
        "--format",
        "krl",
        "--rotary-rpm-max",
        "10",
    ]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--rotary-rpm-max 10"));
}

/// A path.csv that is not one: exit 2 naming the file and line, and no program written.
#[test]
fn a_broken_path_is_refused() {
    let dir = crate::scratch("export_broken");
    std::fs::write(
        dir.join("path.csv"),
        "i,x,y,z,tool_x,tool_y,tool_z,layer,generator,deposit_mm,wfs_m_min,travel_mm_s,t_s,dwell_s\n\
         0,1,2,3,0,0,1,0,0,2,6,10,0.5,0\n1,1,2,x,0,0,1,0,0,2,6,10,1.0,0\n",
    )
    .unwrap();
    let o = waamtwin(&["export", dir.to_str().unwrap(), "--format", "rapid"]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(e.contains("path.csv line 3") && e.contains("\"x\""), "{e}");
    assert!(!dir.join("program.mod").exists());
}

/// The tube strategies' layered path (each layer its own bead, path.csv's `strike`): one strike
/// and one end per layer, each bead's first move reached with the arc off; a tilt the table
/// cannot reach is refused with exit 2, naming the point.
#[test]
fn a_layered_tube_is_struck_once_per_layer() {
    let out = crate::scratch("export_tube");
    let o = waamtwin(&[
        "plan",
        crate::root()
            .join("scenarios/chalvin_torus.toml")
            .to_str()
            .unwrap(),
        "-o",
        out.to_str().unwrap(),
        "--strategy",
        "tube-non-planar",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let plan: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("plan.json")).unwrap()).unwrap();
    let layers = plan["n_layers"].as_u64().unwrap() as usize;
    let (h, rows) = read_csv(&out.join("path.csv"));
    let strike = h.iter().position(|x| x == "strike").unwrap();
    let beads = rows.iter().filter(|r| r[strike] == "1").count();
    assert!(beads >= layers, "{beads} beads, {layers} layers");
    for format in ["json", "krl"] {
        let o = waamtwin(&["export", out.to_str().unwrap(), "--format", format]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    }
    let j: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("program.json")).unwrap()).unwrap();
    assert_eq!(j["arc_strikes"].as_u64().unwrap() as usize, beads);
    let moves = j["moves"].as_array().unwrap();
    assert_eq!(moves[0]["arc"], "struck_here");
    // KRL: the arc goes off before the move to a new bead and on after it.
    let krl = std::fs::read_to_string(out.join("program.src")).unwrap();
    let lines: Vec<&str> = krl.lines().collect();
    let on: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i] == "$OUT[1] = TRUE")
        .collect();
    assert_eq!(on.len(), beads);
    assert!(on.iter().all(|&i| lines[i - 1].starts_with("LIN")));
    let (h, rows) = read_csv(&out.join("path.csv"));
    let col = |n: &str| h.iter().position(|x| x == n).unwrap();
    let points: Vec<Point3<f64>> = rows
        .iter()
        .map(|r| {
            Point3::new(
                r[col("x")].parse().unwrap(),
                r[col("y")].parse().unwrap(),
                r[col("z")].parse().unwrap(),
            )
        })
        .collect();
    let tools: Vec<Vector3<f64>> = rows
        .iter()
        .map(|r| {
            Vector3::new(
                r[col("tool_x")].parse().unwrap(),
                r[col("tool_y")].parse().unwrap(),
                r[col("tool_z")].parse().unwrap(),
            )
        })
        .collect();
    gcode_parses_back(&out, &frames(&points, &tools), beads);
    let o = waamtwin(&[
        "export",
        out.to_str().unwrap(),
        "--format",
        "gcode",
        "--tilt-limits-deg",
        "-20,20",
    ]);
    assert_eq!(o.status.code(), Some(2));
    let e = String::from_utf8_lossy(&o.stderr);
    assert!(
        e.contains("path point") && e.contains("--tilt-limits-deg -20,20"),
        "{e}"
    );
}
