//! The CTPP planner over the part library (issue 4's acceptance cases). Each test prints the
//! numbers it checks.

use planner::mesh::{LowerLoop, Part, PartKind};
use planner::plan::{Plan, PlanParams, plan, range};
use planner::shapes::Shape;
use planner::spiral::SeamReason;

/// The documented planner defaults at `n_points` a generator.
pub fn params(n_points: usize) -> PlanParams {
    PlanParams {
        n_points,
        ..PlanParams::default()
    }
}

pub fn part(shape: Shape, edge: f64) -> Part {
    Part::from_mesh(shape.mesh(edge), LowerLoop::LowestZ).unwrap()
}

/// Eq.6 holds: every step along the generators and every projected deposit H = d·cos θ is inside
/// the window (up to the 0.01 mm tolerance), the seam included.
fn assert_feasible(pl: &Plan) {
    assert!(
        pl.points
            .iter()
            .all(|q| q.step_mm >= 1.8 - 1e-9 && q.step_mm <= 2.2 + 1e-9),
        "steps outside the window"
    );
    assert!(
        pl.feasible(),
        "Eq.6 violations: {:?}",
        &pl.violations[..pl.violations.len().min(5)]
    );
}

fn report(name: &str, pl: &Plan) {
    let (glo, ghi) = pl.generator_length_range();
    let (dlo, dhi) = pl.deposit_range();
    eprintln!(
        "{name}: {} generators ({} filled), lengths {glo:.2}..{ghi:.2} mm, start-up {} + Eq.5 {} = {} revolutions, deposits {dlo:.3}..{dhi:.3} mm, {} violations, deviation {:.3}..{:.3} mm (rms {:.4})",
        pl.generators.len(),
        pl.n_filled,
        pl.spiral.start_up.layers.len(),
        pl.spiral.n_layers,
        pl.spiral.n_revolutions(),
        pl.violations.len(),
        pl.deviation.min_mm,
        pl.deviation.max_mm,
        pl.deviation.rms_mm
    );
}

#[test]
fn open_cylinder() {
    let p = part(
        Shape::Cylinder {
            radius_mm: 80.0,
            height_mm: 160.0,
        },
        2.0,
    );
    let pl = plan(&p, &params(120)).unwrap();
    report("cylinder", &pl);
    let (glo, ghi) = pl.generator_length_range();
    assert!((glo - 160.0).abs() < 0.01 && (ghi - 160.0).abs() < 0.01);
    // Eq.5 on the remaining lengths after the start-up.
    let after_startup = pl
        .spiral
        .start_up
        .height((pl.generators.len() - 1) as f64 / pl.generators.len() as f64);
    assert_eq!(
        pl.spiral.n_layers,
        ((160.0 - after_startup) / 1.8).floor() as usize
    );
    assert_feasible(&pl);
    let last = pl.spiral.n_revolutions() - 1;
    for q in pl.points.iter().filter(|q| q.layer == last) {
        assert!(
            (q.position.z - 160.0).abs() < 0.05,
            "last layer on the rim: z = {}",
            q.position.z
        );
    }
}

#[test]
fn closed_hemisphere() {
    let r = 100.0;
    let p = part(Shape::Hemisphere { radius_mm: r }, 2.0);
    let pl = plan(&p, &params(120)).unwrap();
    report("hemisphere", &pl);
    let c = pl.closing_point.unwrap();
    eprintln!("hemisphere closing point {:.3} {:.3} {:.3}", c.x, c.y, c.z);
    assert!((c - planner::nalgebra::Point3::new(0.0, 0.0, r)).norm() < 0.5);
    let exact = std::f64::consts::FRAC_PI_2 * r;
    let (glo, ghi) = pl.generator_length_range();
    assert!(
        (glo - exact).abs() < 0.005 * exact && (ghi - exact).abs() < 0.005 * exact,
        "{glo} {ghi}"
    );
    assert_eq!(pl.kind, PartKind::Closed);
    let mut by_layer = std::collections::BTreeMap::new();
    for v in &pl.violations {
        *by_layer.entry(v.layer).or_insert(0) += 1;
    }
    eprintln!("hemisphere violations by layer: {by_layer:?}");
}

#[test]
fn multi_branch_surface_is_a_clear_error() {
    let p = Part::from_mesh(crate::two_humps(), LowerLoop::LowestZ).unwrap();
    let e = plan(&p, &params(60)).unwrap_err();
    let msg = e.to_string();
    eprintln!("two humps: {msg}");
    assert!(
        msg.contains("branches") && msg.contains("splits into"),
        "{msg}"
    );
}

/// The CTPP paper's open part, Table 2: generators 152 to 178 mm, 84 layers, deposits 1.8 to
/// 2.2 mm, feasible. Here a cylinder R = 80 cut by a tilted plane spans the same lengths.
#[test]
fn tilted_cylinder_against_table_2() {
    let p = part(
        Shape::Vase {
            radius_mm: 80.0,
            height_mm: 165.0,
            bulge_mm: 0.0,
            top_slope_mm: 13.0,
            top_wave_mm: 0.0,
            top_waves: 0,
        },
        2.0,
    );
    let pl = plan(&p, &params(120)).unwrap();
    report("tilted cylinder", &pl);
    let (glo, ghi) = pl.generator_length_range();
    assert!(
        (glo - 152.0).abs() < 0.2 && (ghi - 178.0).abs() < 0.2,
        "{glo} {ghi}"
    );
    // Start-up 5 revolutions + Eq.5 78 = 83 (the paper counts 84; see the issue note).
    assert_eq!(pl.spiral.start_up.layers.len() + pl.spiral.n_layers, 83);
    let (dlo, dhi) = (
        pl.points
            .iter()
            .map(|q| q.step_mm)
            .fold(f64::INFINITY, f64::min),
        pl.points.iter().map(|q| q.step_mm).fold(0.0, f64::max),
    );
    assert!(dlo >= 1.8 - 1e-9 && dhi <= 2.2 + 1e-9, "{dlo} {dhi}");
    assert_feasible(&pl);
}

/// Cylinders R 80 cut by a tilted plane with Table 2's generator ratio (178/152), 60 to 200 mm
/// tall: the seam and the count of revolutions keep every step along the generators in
/// [1.8, 2.2] mm at every height, and Eq.6 holds on the projected deposits. Where Eq.5 from
/// the lower loop's first generator would break the window the seam moves
/// (`SeamReason::Moved`), and the plan says where to: measured 2026-11-22, at 60 and 80 mm a
/// quarter turn from the longest generator, steps 1.800–2.197 mm; from 100 mm up Eq.5 holds.
#[test]
fn tilted_cylinders_of_every_height_are_feasible() {
    for height in [60.0, 80.0, 100.0, 120.0, 140.0, 160.0, 180.0, 200.0] {
        let p = part(
            Shape::Vase {
                radius_mm: 80.0,
                height_mm: height,
                bulge_mm: 0.0,
                top_slope_mm: height * 13.0 / 165.0,
                top_wave_mm: 0.0,
                top_waves: 0,
            },
            2.0,
        );
        let pl = plan(&p, &params(120)).unwrap();
        let (glo, ghi) = pl.generator_length_range();
        let (slo, shi) = range(pl.points.iter().map(|q| q.step_mm));
        let start = pl.generators[0].start();
        eprintln!(
            "tilted cylinder {height} mm: generators {glo:.1}..{ghi:.1} mm, seam at lower-loop generator {} ({:.1}, {:.1}) of length {:.1} mm, {:?}, {} + {} revolutions (Eq.5 {}), steps {slo:.3}..{shi:.3} mm, margin {:.3} mm",
            pl.seam.first,
            start.x,
            start.y,
            pl.generators[0].length(),
            pl.seam.reason,
            pl.spiral.start_up.layers.len(),
            pl.seam.n_layers,
            pl.seam.eq5_layers,
            pl.seam.margin_mm
        );
        assert!((ghi / glo - 178.0 / 152.0).abs() < 0.01, "{glo} {ghi}");
        assert_ne!(pl.seam.reason, SeamReason::NoChoiceHolds, "{height} mm");
        assert_feasible(&pl);
    }
}

/// Fig. 25: on a vase with a non-planar top CTPP stays in the window, planar 2.5D slicing does not.
#[test]
fn vase_ctpp_against_planar() {
    let p = part(
        Shape::Vase {
            radius_mm: 60.0,
            height_mm: 120.0,
            bulge_mm: 10.0,
            top_slope_mm: 6.0,
            top_wave_mm: 2.0,
            top_waves: 3,
        },
        2.0,
    );
    let pl = plan(&p, &params(120)).unwrap();
    report("vase", &pl);
    assert_feasible(&pl);
    let planar = planner::planar::slice(&p, 2.0);
    let all: Vec<f64> = planar.all_deposits().collect();
    let outside = all.iter().filter(|&&d| !(1.79..=2.21).contains(&d)).count();
    let (lo, hi) = all
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &d| (a.min(d), b.max(d)));
    eprintln!(
        "vase planar: {} layers, deposits {lo:.3}..{hi:.3} mm, {outside} of {} outside [1.8, 2.2]",
        planar.layers.len(),
        all.len()
    );
    assert!(
        outside > 0 && lo < 1.0,
        "planar slicing must leave the window at the non-planar top"
    );
    // Fig. 30: the swept surface stays within ±0.2 mm of the part.
    assert!(pl.deviation.min_mm >= -0.2 && pl.deviation.max_mm <= 0.2);
}

/// The closed part of the paper's kind: the closing point lies in the symmetry plane and leans
/// towards the side the dome leans to.
#[test]
fn asymmetric_dome_closing_point() {
    let p = part(
        Shape::AsymmetricDome {
            radius_mm: 80.0,
            radius_y_mm: 80.0,
            height_mm: 140.0,
            lean_mm: 30.0,
        },
        2.0,
    );
    let pl = plan(&p, &params(120)).unwrap();
    report("asymmetric dome", &pl);
    let c = pl.closing_point.unwrap();
    eprintln!(
        "asymmetric dome closing point {:.3} {:.3} {:.3}",
        c.x, c.y, c.z
    );
    assert!(c.y.abs() < 0.5, "off the symmetry plane: y = {}", c.y);
    assert!(c.x < -5.0, "should lean towards -x: x = {}", c.x);
}

/// Quarter torus R 100: Eq.1's generators cut from the outside of the bend to the inside (not the
/// iso-parametric lines), converge there, and leave the outside of the bend uncovered; the gap is
/// found and filled up to the outer meridian, on the surface. r = 8 fits ±10 % along its
/// generators, r = 20 does not (lengths 125.7..188.5 mm, ratio > 1.1/0.9), too long on the
/// outside; no seam helps it, and the one taken misses the window by the least.
#[test]
fn quarter_torus_generators_gaps_and_feasibility() {
    let bend = 100.0;
    for (r, edge, exact) in [(8.0, 1.0, (144.5, 153.2)), (20.0, 1.5, (125.7, 158.3))] {
        let pl = plan(
            &part(
                Shape::QuarterTorus {
                    bend_radius_mm: bend,
                    tube_radius_mm: r,
                },
                edge,
            ),
            &params(120),
        )
        .unwrap();
        report(&format!("quarter torus r = {r}"), &pl);
        let traced = pl.generators.iter().filter(|g| !g.filled);
        let (lo, hi) = planner::plan::range(traced.map(|g| g.length()));
        eprintln!("  traced generators {lo:.2}..{hi:.2} mm (exact {exact:?})");
        assert!(
            (lo - exact.0).abs() < 0.005 * exact.0,
            "{lo} vs {}",
            exact.0
        );
        assert!(
            (hi - exact.1).abs() < 0.005 * exact.1,
            "{hi} vs {}",
            exact.1
        );
        // Not the iso-lines: those run (R − r)·π/2 to (R + r)·π/2.
        let outer = (bend + r) * std::f64::consts::FRAC_PI_2;
        assert!(hi < outer - 10.0);
        // The outside of the bend is filled, up to its meridian.
        let longest = pl.generators.iter().map(|g| g.length()).fold(0.0, f64::max);
        assert!(
            pl.n_filled > 0 && (longest - outer).abs() < 0.01 * outer,
            "{longest} vs {outer}"
        );
        // On the surface (the analytic torus) and the swept layers on the part.
        let off = |p: &planner::plan::PathPoint| {
            let p = p.position;
            let rho = ((p.x + bend).powi(2) + p.z.powi(2)).sqrt() - bend;
            ((rho * rho + p.y * p.y).sqrt() - r).abs()
        };
        let worst = pl.points.iter().map(off).fold(0.0, f64::max);
        assert!(worst < 0.1, "a path point {worst} mm off the torus");
        assert!(pl.deviation.min_mm > -0.25 && pl.deviation.max_mm < 0.25);
        let long: Vec<_> = pl
            .points
            .iter()
            .filter(|q| q.step_mm > 2.2 + 1e-9)
            .collect();
        let short = pl.points.iter().filter(|q| q.step_mm < 1.8 - 1e-9).count();
        eprintln!(
            "  steps above h_max: {}, below h_min: {short}; seam {:?}",
            long.len(),
            pl.seam
        );
        if r == 8.0 {
            assert!(
                long.is_empty() && short == 0,
                "r = 8 fits [1.8, 2.2] along its generators"
            );
            assert_eq!(pl.seam.reason, SeamReason::Eq5Holds);
        } else {
            assert!(!long.is_empty(), "r = 20 cannot fit [1.8, 2.2]");
            // No seam and count hold the window; the one taken misses it by less than Eq.5
            // from the lower loop's first generator does (which steps only too long).
            assert_eq!(pl.seam.reason, SeamReason::NoChoiceHolds);
            let mut lengths: Vec<f64> = pl.generators.iter().map(|g| g.length()).collect();
            lengths.rotate_right(pl.seam.first);
            let eq5 = planner::spiral::spiral(&lengths, 2.0, 1.8, 2.2).unwrap();
            let miss = |step: f64| (step - 2.2).max(1.8 - step);
            let eq5_miss = eq5
                .points
                .iter()
                .map(|q| miss(q.step_mm))
                .fold(0.0, f64::max);
            eprintln!(
                "  miss {:.3} mm against Eq.5's {eq5_miss:.3} mm",
                -pl.seam.margin_mm
            );
            assert!(-pl.seam.margin_mm < eq5_miss, "{eq5_miss}");
            // Every generator too long starts on the outside of the bend (x > 0 at the bottom:
            // the bend's centre is at x = −R): the fills, and the traced ones that cut across.
            assert!(
                long.iter()
                    .all(|q| pl.generators[q.generator].start().x > 0.0),
                "a generator too long starts on the inside of the bend"
            );
        }
    }
}

/// A closed dome R 40 with the default nozzle (radius 10, 12 to 92 mm from the deposit): near
/// the top the build direction lies almost flat and the nozzle reaches across to the far side.
/// Turning the tool about the travel (at most 30°, 2°/mm) frees all but the closing point's last
/// revolution, where the path turns round a ring a few millimetres wide; what is left is located
/// in plan.json. With at most 5° most stay, and are reported.
#[test]
fn nozzle_collisions_on_a_dome_are_turned_away() {
    let scenario = |max: f64| {
        format!(
            "[part]\nshape = \"hemisphere\"\nradius_mm = 40.0\nedge_mm = 2.5\n[planner]\nn_points = 60\n\
             nozzle_max_rotation_deg = {max}\n"
        )
    };
    let out = crate::run_scenario("collisions_dome", "plan", &scenario(30.0));
    let plan: serde_json::Value =
        serde_json::from_slice(&std::fs::read(out.join("plan.json")).unwrap()).unwrap();
    let c = &plan["collisions"];
    eprintln!("collisions: {c}");
    let detected = c["detected"].as_u64().unwrap();
    let unresolved = c["unresolved"].as_u64().unwrap();
    assert!(detected > 100, "{c}");
    assert_eq!(c["resolved"].as_u64().unwrap() + unresolved, detected);
    assert!(unresolved <= 2, "{c}");
    // The last revolution before the closing point (itself a layer of one point).
    let (h, rows) = crate::read_csv(&out.join("path.csv"));
    let layer = h.iter().position(|x| x == "layer").unwrap();
    let last = rows
        .iter()
        .map(|r| r[layer].parse::<u64>().unwrap())
        .max()
        .unwrap();
    for p in c["unresolved_points"].as_array().unwrap() {
        assert!(p["layer"].as_u64().unwrap() >= last - 1, "{p}");
    }
    let turn = c["max_rotation_deg"].as_f64().unwrap();
    assert!(turn > 0.0 && turn <= 30.0);

    // A nozzle of 16 mm across (radius 8), the metal a tube of 2.5 mm (half a 5 mm bead) and
    // the torch body an arm of radius 40 from 92 mm up the axis: every collision resolved, the
    // last ones next to the closing point.
    let slim = crate::run_scenario(
        "collisions_dome_slim",
        "plan",
        &scenario(30.0).replace(
            "n_points = 60\n",
            "n_points = 60\nnozzle_radius_mm = 8.0\ndeposit_tube_radius_mm = 2.5\n\
             arm_radius_mm = 40.0\narm_from_mm = 92.0\n",
        ),
    );
    let plan: serde_json::Value =
        serde_json::from_slice(&std::fs::read(slim.join("plan.json")).unwrap()).unwrap();
    let s = &plan["collisions"];
    eprintln!("slim nozzle: {s}");
    assert!(s["detected"].as_u64().unwrap() > 100, "{s}");
    assert_eq!(s["unresolved"].as_u64().unwrap(), 0, "{s}");
    assert_eq!(s["resolved"], s["detected"]);
    let revolutions = plan["n_revolutions"].as_u64().unwrap();
    assert!(
        s["detected_layers"]["max"].as_f64().unwrap() >= (revolutions - 3) as f64,
        "{s}"
    );
    assert!(plan["tool"]["rate_found_max_deg_mm"].as_f64().unwrap() <= 30.0 + 1e-6);

    let tight = crate::run_scenario("collisions_dome_tight", "plan", &scenario(5.0));
    let plan: serde_json::Value =
        serde_json::from_slice(&std::fs::read(tight.join("plan.json")).unwrap()).unwrap();
    let t = &plan["collisions"];
    assert_eq!(t["detected"], detected);
    assert!(
        t["unresolved"].as_u64().unwrap() > 10 * unresolved.max(1),
        "{t}"
    );
    assert!(t["max_rotation_deg"].as_f64().unwrap() <= 5.0);
    let located = t["unresolved_points"].as_array().unwrap();
    assert!(!located.is_empty() && located[0]["position_mm"].as_array().unwrap().len() == 3);
}

/// Chalvin et al. 2019 on their quarter torus (R 60, r 20; Δ = the scenario's 2 mm): the local
/// inter-layer distance of the two tube strategies against the paper (§2.1 about ±30 %, §2.2 at
/// most −46 % and never above Δ), and CTPP's on the same tube, in one table (printed); the
/// numeric build direction within 0.25° of the analytic one on average; each map drawn.
#[test]
fn tube_strategies_against_chalvin() {
    let scenario = crate::root().join("scenarios/chalvin_torus.toml");
    let mut table = String::from("strategy | layers | min % | max % | mean mm | outside window\n");
    let mut spreads = Vec::new();
    for (name, strategy) in [
        ("perpendicular", "tube-perpendicular"),
        ("non-planar", "tube-non-planar"),
        ("ctpp", "ctpp"),
    ] {
        let out = crate::scratch(&format!("tube_{name}"));
        let o = crate::waamtwin(&[
            "plan",
            scenario.to_str().unwrap(),
            "-o",
            out.to_str().unwrap(),
            "--strategy",
            strategy,
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let plan: serde_json::Value =
            serde_json::from_slice(&std::fs::read(out.join("plan.json")).unwrap()).unwrap();
        let il = &plan["interlayer"];
        let (lo, hi) = (
            il["min_variation_pct"].as_f64().unwrap(),
            il["max_variation_pct"].as_f64().unwrap(),
        );
        let layers = plan["n_layers"].as_u64().unwrap();
        let outside = plan["window_violations_total"]
            .as_u64()
            .or(plan["bead"]["window_violations_total"].as_u64())
            .unwrap();
        table += &format!(
            "{name} | {layers} | {lo:+.1} | {hi:+.1} | {:.3} | {outside}\n",
            il["mean_mm"].as_f64().unwrap()
        );
        assert!(std::fs::metadata(out.join("interlayer.png")).unwrap().len() > 10_000);
        assert!(out.join("interlayer.csv").exists());
        if strategy != "ctpp" {
            let mean = plan["build_direction_numeric_vs_analytic_deg"]["mean"]
                .as_f64()
                .unwrap();
            assert!(mean < 0.25, "{name}: {mean}°");
        }
        spreads.push((lo, hi));
    }
    eprintln!("{table}");
    let [(p_lo, p_hi), (n_lo, n_hi), (c_lo, c_hi)] = spreads[..] else {
        unreachable!()
    };
    // §2.1: (R ± r)/R − 1 = ±33.3 %, the paper's "about ±30 %".
    assert!((p_lo + 33.3).abs() < 1.0 && (p_hi - 33.3).abs() < 1.0);
    // §2.2: never above Δ, down to −46 %.
    assert!(
        n_hi <= 0.01 && (-48.0..=-44.0).contains(&n_lo),
        "{n_lo} {n_hi}"
    );
    // CTPP keeps one count of revolutions on every generator: on this tube its spread is wider
    // than either.
    assert!(c_hi - c_lo > p_hi - p_lo, "{c_lo} {c_hi}");
}
