//! `waamtwin skeleton SCENARIO -o DIR`: skeleton arc AM (Radel et al. 2019) of the scenario's
//! OBJ skeleton: the slicer and the virtual cell closed loop and open loop on the same noisy
//! drops, the heat drop by drop (`sim::pipeline::skeleton`); drops.csv, loops.csv, path.csv
//! (one drop a row, for `waamtwin export`), skeleton.json, solidification.png, standoff.png.

use crate::commands::plan::PATH_COLUMNS;
use crate::error::Result;
use crate::output::RunDir;
use crate::part::load_skeleton;
use crate::pipeline::skeleton::{DropHeat, LoopRun, Skeletoned, run_loop, skeleton};
use crate::scenario::Scenario;
use planner::saam::slicer::Intersection;
use serde_json::{Value, json};
use std::fmt::Write;
use std::path::Path;

pub fn run(scenario: &Path, out: &Path) -> Result<String> {
    let s = Scenario::load(scenario)?;
    let set = &s.skeleton;
    let sk = load_skeleton(&s.part, set)?;
    let mut dir = RunDir::create(out)?;
    // The voxel run's estimate is checked before any of it runs.
    if set.heat {
        cost(
            scenario,
            &s,
            &run_loop(&sk, set, &s.process, set.closed_loop),
        )?;
    }
    let Skeletoned { main, other, heats } = {
        let _stage = crate::progress::Stage::start(match set.heat {
            true => "slicing the skeleton, heating drop by drop (voxels)",
            false => "slicing the skeleton",
        });
        skeleton(&sk, set, &s.process, &s.material, &s.thermal)?
    };
    dir.write("drops.csv", drops_csv(&main, heats.as_deref()).as_bytes())?;
    dir.write("loops.csv", loops_csv(&main, &other).as_bytes())?;
    dir.write("path.csv", path_csv(&main, heats.as_deref(), &s).as_bytes())?;
    let json = summary(&s, &sk, &main, &other, heats.as_deref());
    dir.write_json("skeleton.json", &json)?;
    #[cfg(feature = "recording")]
    {
        let (closed, open) = if main.closed {
            (&main, &other)
        } else {
            (&other, &main)
        };
        crate::record::standoff_plot(
            &mut dir,
            &s.title(),
            &closed.drops.iter().map(|d| d.ctdwp_mm).collect::<Vec<_>>(),
            &open.drops.iter().map(|d| d.ctdwp_mm).collect::<Vec<_>>(),
            set.slicer.standoff_mm,
        )?;
        if s.output.rerun || s.output.mcap {
            recordings(&mut dir, &s, &main, heats.as_deref())?;
        }
        if let Some(h) = &heats {
            crate::record::solidification_plot(
                &mut dir,
                &s.title(),
                &h.iter().map(|x| x.solidification_s).collect::<Vec<_>>(),
            )?;
        }
    }
    dir.finish("skeleton", s.to_json())?;
    Ok(line(&main, &other, heats.as_deref()))
}

/// The voxel run's estimate shown and checked (`commands::cost`): the drops' schedule, each
/// drop's wait taken as the rod's plateau of docs/PHYSICS.md (15 s) up to the longest wait.
fn cost(file: &Path, s: &Scenario, run: &LoopRun) -> Result<()> {
    let deps = crate::pipeline::skeleton::schedule(run, &s.skeleton, &s.process);
    let wait = s.skeleton.max_wait_s.min(15.0).max(s.skeleton.min_wait_s);
    let build_s = deps.last().map_or(0.0, |d| d.time) + wait * deps.len() as f64;
    let voxel = crate::pipeline::params::ThermalSettings {
        model: crate::pipeline::params::ThermalModel::Voxel,
        ..s.thermal.clone()
    };
    let keeps = super::cost::Keeps::ONE_RUN;
    super::cost::check(
        &file.display().to_string(),
        &voxel,
        &s.material,
        &deps,
        build_s,
        keeps,
    )
    .map(|_| ())
}

/// run.rrd and run.mcap: the drops as the run laid them, each at its strike time.
#[cfg(feature = "recording")]
fn recordings(
    dir: &mut RunDir,
    s: &Scenario,
    run: &LoopRun,
    heats: Option<&[DropHeat]>,
) -> Result<()> {
    let n = run
        .drops
        .iter()
        .map(|d| d.planned.branch)
        .max()
        .map_or(0, |b| b + 1);
    let polylines: Vec<Vec<[f64; 3]>> = (0..n)
        .map(|b| {
            run.slicer
                .branch(b)
                .points
                .iter()
                .map(|p| [p.x, p.y, p.z])
                .collect()
        })
        .collect();
    let mut t = 0.0;
    let views: Vec<crate::record::DropView> = run
        .drops
        .iter()
        .enumerate()
        .map(|(i, d)| {
            if i > 0 {
                t += run.drops[i - 1].weld_time_s + heats.map_or(0.0, |h| h[i - 1].wait_s);
            }
            let p = &d.planned;
            crate::record::DropView {
                position_mm: [p.position.x, p.position.y, p.position.z],
                radius_mm: p.radius_mm,
                tool: [p.tool.x, p.tool.y, p.tool.z],
                t_s: t,
                branch: p.branch,
                ctdwp_mm: d.ctdwp_mm,
                weld_time_s: d.weld_time_s,
                solidification_s: heats.map(|h| h[i].solidification_s),
            }
        })
        .collect();
    crate::record::skeleton_recordings(
        dir,
        &s.title(),
        &polylines,
        &views,
        (s.output.rerun, s.output.mcap),
    )
}

fn line(main: &LoopRun, other: &LoopRun, heats: Option<&[DropHeat]>) -> String {
    let (lo, hi) = main.ctdwp_range();
    let (olo, ohi) = other.ctdwp_range();
    let mut l = format!(
        "{} drops on {} branches; stand-off {lo:.2}..{hi:.2} mm {} loop, {olo:.2}..{ohi:.2} mm {} loop",
        main.drops.len(),
        main.drops
            .iter()
            .map(|d| d.planned.branch)
            .max()
            .map_or(0, |b| b + 1),
        if main.closed { "closed" } else { "open" },
        if other.closed { "closed" } else { "open" },
    );
    if let Some(h) = heats {
        let total: f64 = main.drops.iter().map(|d| d.weld_time_s).sum::<f64>()
            + h.iter().map(|x| x.wait_s).sum::<f64>();
        let _ = write!(
            l,
            "; solidification {:.1} s (first) to {:.1} s (last), build {:.0} s",
            h.first().map_or(0.0, |x| x.solidification_s),
            h.last().map_or(0.0, |x| x.solidification_s),
            total
        );
    }
    l
}

fn intersection(i: Option<Intersection>) -> &'static str {
    match i {
        None => "",
        Some(Intersection::Divergent) => "divergent",
        Some(Intersection::Convergent) => "convergent",
    }
}

fn drops_csv(run: &LoopRun, heats: Option<&[DropHeat]>) -> String {
    let mut csv = String::from(
        "i,branch,polyline,s_mm,x_mm,y_mm,z_mm,tool_x,tool_y,tool_z,radius_mm,weld_ratio,weld_time_s,standoff_planned_mm,ctdwp_mm,height_mm,top_mm,top_read_mm,bad,intersection,waited_for,support,solidification_s,wait_s,preheat_c,bond\n",
    );
    for (i, d) in run.drops.iter().enumerate() {
        let p = &d.planned;
        let b = run.slicer.branch(p.branch);
        let opt = |v: Option<usize>| v.map_or(String::new(), |x| x.to_string());
        let _ = write!(
            csv,
            "{i},{},{},{:.4},{:.4},{:.4},{:.4},{:.6},{:.6},{:.6},{},{:.5},{:.4},{:.3},{:.4},{:.4},{:.4},{:.4},{},{},{},{},",
            p.branch,
            b.source + 1,
            p.s_mm,
            p.position.x,
            p.position.y,
            p.position.z,
            p.tool.x,
            p.tool.y,
            p.tool.z,
            p.radius_mm,
            p.weld_ratio,
            d.weld_time_s,
            p.standoff_mm,
            d.ctdwp_mm,
            d.height_mm,
            d.top_mm,
            d.top_read_mm,
            u8::from(d.bad),
            intersection(p.intersection),
            opt(p.waited_for),
            opt(p.support),
        );
        match heats.and_then(|h| h.get(i)) {
            Some(h) => {
                let _ = writeln!(
                    csv,
                    "{:.2},{:.2},{:.1},{:.4}",
                    h.solidification_s,
                    h.wait_s,
                    h.preheat_k - 273.15,
                    h.bond
                );
            }
            None => csv.push_str(",,,\n"),
        }
    }
    csv
}

fn loops_csv(main: &LoopRun, other: &LoopRun) -> String {
    let (closed, open) = if main.closed {
        (main, other)
    } else {
        (other, main)
    };
    let mut csv = String::from("drop,ctdwp_closed_mm,ctdwp_open_mm\n");
    for k in 0..closed.drops.len().max(open.drops.len()) {
        let v = |r: &LoopRun| {
            r.drops
                .get(k)
                .map_or(String::new(), |d| format!("{:.4}", d.ctdwp_mm))
        };
        let _ = writeln!(csv, "{k},{},{}", v(closed), v(open));
    }
    csv
}

/// One row a drop, as the robot runs it: the TCP (a CTDWP from the contact tip) at the drop's
/// point, moved back along the tool by δ_coll where a collision zone asks; reached with the arc
/// off after the wait, struck for its welding time (`arc_s`) standing there (`strike` 1).
fn path_csv(run: &LoopRun, heats: Option<&[DropHeat]>, s: &Scenario) -> String {
    let mut csv = format!("{PATH_COLUMNS},strike,arc_s\n");
    let mut t = 0.0;
    let travel = s.process.travel_speed_m_s * 1e3;
    for (i, d) in run.drops.iter().enumerate() {
        let p = &d.planned;
        let dwell = match (i, heats) {
            (0, _) | (_, None) => 0.0,
            (_, Some(h)) => h[i - 1].wait_s,
        };
        t += dwell;
        let tcp = p.position + p.tool * (p.standoff_mm - s.skeleton.slicer.standoff_mm);
        let _ = writeln!(
            csv,
            "{i},{:.4},{:.4},{:.4},{:.6},{:.6},{:.6},{},{},{},{},{},{:.3},{:.3},1,{:.4}",
            tcp.x,
            tcp.y,
            tcp.z,
            p.tool.x,
            p.tool.y,
            p.tool.z,
            p.branch,
            run.slicer.branch(p.branch).source,
            d.height_mm,
            s.skeleton.wfs_m_min,
            travel,
            t,
            dwell,
            d.weld_time_s
        );
        t += d.weld_time_s;
    }
    csv
}

fn summary(
    s: &Scenario,
    sk: &planner::saam::Skeleton,
    main: &LoopRun,
    other: &LoopRun,
    heats: Option<&[DropHeat]>,
) -> Value {
    let loop_json = |r: &LoopRun| {
        let (lo, hi) = r.ctdwp_range();
        let n = r.drops.len().max(1) as f64;
        let mean = r.drops.iter().map(|d| d.ctdwp_mm).sum::<f64>() / n;
        json!({"closed": r.closed, "drops": r.drops.len(), "ctdwp_mm": {"min": lo, "max": hi, "mean": mean,
            "last": r.drops.last().map(|d| d.ctdwp_mm)},
            "bad_drops": r.drops.iter().filter(|d| d.bad).count()})
    };
    let d = &main.drops;
    let count =
        |f: &dyn Fn(&crate::pipeline::skeleton::Drop) -> bool| d.iter().filter(|x| f(x)).count();
    let mut j = json!({
        "source": "Radel, Diourté, Soulié, Company, Bordreuil 2019 (skeleton arc AM)",
        "branches": sk.branches.len(),
        "nodes": sk.nodes.len(),
        "intersections": sk.nodes.iter().filter(|n| n.branches.len() > 2).count(),
        "drops": d.len(),
        "divergent_drops": count(&|x| x.planned.intersection == Some(Intersection::Divergent)),
        "convergent_drops": count(&|x| x.planned.intersection == Some(Intersection::Convergent)),
        "collision_zones": main.zones,
        "collision_waits": count(&|x| x.planned.waited_for.is_some()),
        "collision_standoff_drops": count(&|x| x.planned.standoff_mm > s.skeleton.slicer.standoff_mm),
        "collision_standoff_max_mm": d.iter().map(|x| x.planned.standoff_mm - s.skeleton.slicer.standoff_mm).fold(0.0, f64::max),
        "forced_into_zones": main.forced,
        "weld_time_s": {"min": d.iter().map(|x| x.weld_time_s).fold(f64::INFINITY, f64::min),
            "max": d.iter().map(|x| x.weld_time_s).fold(0.0, f64::max)},
        "loop": loop_json(main),
        "other_loop": loop_json(other),
        "heat_model": if heats.is_some() { Value::from("voxel") } else { Value::Null },
    });
    if let Some(h) = heats {
        let at = |k: usize| h.get(k).map(|x| x.solidification_s);
        j["solidification_s"] = json!({"first": at(0), "drop_10": at(9), "drop_50": at(49),
            "last": h.last().map(|x| x.solidification_s),
            "max": h.iter().map(|x| x.solidification_s).fold(0.0, f64::max),
            "capped": h.iter().filter(|x| x.solidification_s >= s.skeleton.max_wait_s).count()});
        j["bond"] = json!({"max": h.iter().map(|x| x.bond).fold(0.0, f64::max), "bond_max": s.bead.bond_max,
            "over": h.iter().filter(|x| x.bond > s.bead.bond_max).count()});
        j["build_s"] = json!(
            d.iter().map(|x| x.weld_time_s).sum::<f64>() + h.iter().map(|x| x.wait_s).sum::<f64>()
        );
    }
    j
}
