//! A dwell plan searched on the thin wall with its cost cut (local steps, the plate merged away
//! from the part) against the same plan heated by the reference, the thin wall stepping every
//! node of the uniform plate every step: the accuracy bound for a plan at full scale
//! (docs/PERFORMANCE.md "Parts at full scale": preheats within 2 % of the rise of a run that
//! does not cut the cost). Plans once (the cut model), then heats the plan on both models and
//! prints, over the points whose reference preheat rises more than 10 K, the largest and the
//! median |cut − reference| as a share of the reference's rise, and the points each run leaves
//! at risk.
//!
//! `cargo run --release -p sim --example plan_reference -- SCENARIO`

use sim::pipeline::{Build, Simulation};
use sim::scenario::Scenario;
use std::process::ExitCode;
use std::time::Instant;

fn main() -> ExitCode {
    let Some(path) = std::env::args().nth(1) else {
        eprintln!("usage: plan_reference SCENARIO (a thin-wall scenario with local_steps = true)");
        return ExitCode::from(2);
    };
    match run(&path) {
        Ok(()) => ExitCode::SUCCESS,
        Err(Failure::Input(e)) => {
            eprintln!("{path}: {e}");
            ExitCode::from(2)
        }
        Err(Failure::Numerical(e)) => {
            eprintln!("{path}: {e}");
            ExitCode::from(1)
        }
    }
}

/// Bad input (exit 2), or a heat run that failed on good input (exit 1).
enum Failure {
    Input(String),
    Numerical(String),
}

fn run(path: &str) -> Result<(), Failure> {
    let input = |e: &dyn std::fmt::Display| Failure::Input(e.to_string());
    let s = Scenario::load(path.as_ref()).map_err(|e| input(&e))?;
    let part = sim::part::load_part(&s.part).map_err(|e| input(&e))?;
    let cut = sim::commands::plan::build(&s, &part).map_err(|e| input(&e))?;
    if !cut.params.thermal.local_steps {
        let why = "[thermal] local_steps = false: the plan must be searched with the cost cut";
        return Err(Failure::Input(why.into()));
    }
    let mut reference = cut.clone();
    reference.params.thermal.local_steps = false;
    reference.params.thermal.merge_plate = false;

    let t = Instant::now();
    let plan = cut
        .plan_dwells()
        .map_err(|e| Failure::Numerical(format!("the search: {e}")))?;
    println!(
        "plan: {} dwells, {:.0} s in all, searched in {:.1} s",
        plan.cooling.dwell_s.iter().filter(|&&d| d > 0.0).count(),
        plan.cooling.dwell_s.iter().sum::<f64>(),
        t.elapsed().as_secs_f64()
    );
    let heat = |b: &Build, name: &str| {
        let t = Instant::now();
        let sim = b.simulate_cooled(&plan.cooling, 0, Vec::new());
        let sim = sim.map_err(|e| Failure::Numerical(format!("{name}: {e}")))?;
        println!("{name}: heated in {:.1} s", t.elapsed().as_secs_f64());
        Ok::<Simulation, Failure>(sim)
    };
    let on_cut = heat(&cut, "cut (local steps)")?;
    let on_reference = heat(
        &reference,
        "reference (every node every step, the uniform plate)",
    )?;

    let ambient = cut.params.thermal.ambient_k;
    let mut shares: Vec<f64> = on_reference
        .result
        .points
        .iter()
        .zip(&on_cut.result.points)
        .filter(|(r, _)| r.preheat - ambient > 10.0)
        .map(|(r, c)| (c.preheat - r.preheat).abs() / (r.preheat - ambient))
        .collect();
    shares.sort_by(f64::total_cmp);
    let Some(&worst) = shares.last() else {
        let why = "no point's preheat rises 10 K: nothing to compare";
        return Err(Failure::Input(why.into()));
    };
    println!(
        "preheats: within {:.2} % of the rise (median {:.3} %, {} points compared)",
        100.0 * worst,
        100.0 * shares[shares.len() / 2],
        shares.len()
    );
    let at_risk = |sim: &Simulation| sim.risks(&cut.criteria).iter().flatten().count();
    println!(
        "points at risk with the plan: {} on the cut model, {} on the reference",
        at_risk(&on_cut),
        at_risk(&on_reference)
    );
    // Where the two judge a point differently: what each read there.
    let (rc, rr) = (
        on_cut.risks(&cut.criteria),
        on_reference.risks(&cut.criteria),
    );
    for i in (0..rc.len()).filter(|&i| rc[i] != rr[i]).take(10) {
        let (c, r) = (&on_cut.result.points[i], &on_reference.result.points[i]);
        println!(
            "  point {i}: cut {:?}, reference {:?}; preheat {:.1} / {:.1} °C, pool {:.2} / {:.2} mm",
            rc[i],
            rr[i],
            c.preheat - 273.15,
            r.preheat - 273.15,
            1e3 * c.pool_length,
            1e3 * r.pool_length
        );
    }
    Ok(())
}
