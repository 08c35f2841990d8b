//! # sim
//!
//! Runs the pipeline (plan → beads → heat → decisions) and writes its files; holds the
//! `waamtwin` command. Two layers: [`pipeline`], the engine, which does no IO and takes plain
//! parameter types; and the shell around it ([`scenario`] and [`part`] read the inputs,
//! [`commands`] call the engine, [`output`] and [`record`] write the files). This is the only
//! crate that touches files.

pub mod cli;
pub mod commands;
pub mod error;
pub mod measured;
pub mod output;
pub mod part;
pub mod pipeline;
pub mod progress;
pub mod record;
pub mod scenario;

use cli::Command;
pub use error::{Error, Result};

/// Run one command and print what it says; `main` only maps the result to an exit code.
pub fn run(cli: cli::Cli) -> Result<()> {
    println!("{}", execute(cli)?);
    Ok(())
}

/// Run one command and return what it says (the line `waamtwin` prints; `inspect`'s report):
/// the command line prints it, the Python package returns it.
pub fn execute(cli: cli::Cli) -> Result<String> {
    match cli.command {
        Command::Inspect { mesh, json } => {
            let r = commands::inspect::inspect(&mesh)?;
            Ok(match json {
                true => serde_json::to_string_pretty(&r).unwrap_or_default(),
                false => commands::inspect::format_report(&r).trim_end().to_string(),
            })
        }
        Command::Geodesic { mesh, from, out } => {
            let n = commands::geodesic::geodesic(&mesh, &from, &out)?;
            Ok(format!("{}: distance at {n} vertices", out.display()))
        }
        Command::Plan {
            scenario,
            out,
            strategy,
        } => commands::plan::run(&scenario, &out, strategy),
        Command::Simulate {
            scenario,
            out,
            checkpoints,
        } => commands::simulate::run(&scenario, &out, checkpoints),
        Command::Follow {
            scenario,
            out,
            until_idle_s,
            connect,
            checkpoints,
        } => commands::follow::run(
            &scenario,
            &out,
            until_idle_s,
            connect.as_deref(),
            checkpoints,
        ),
        Command::Calibrate {
            scenario,
            out,
            fit,
            holdout,
            checkpoints,
        } => {
            let window = |w: Option<String>, flag: &str| {
                w.map(|w| commands::calibrate::window(&w, flag)).transpose()
            };
            let (fit, holdout) = (window(fit, "--fit")?, window(holdout, "--holdout")?);
            commands::calibrate::run(&scenario, &out, fit, holdout, checkpoints)
        }
        Command::Replay {
            scenario,
            out,
            checkpoints,
        } => commands::replay::run(&scenario, &out, checkpoints),
        Command::Dwell {
            scenario,
            out,
            no_baselines,
            pareto,
            checkpoints,
        } => {
            let extras = commands::dwell::Extras {
                baselines: !no_baselines,
                pareto,
            };
            commands::dwell::run(&scenario, &out, extras, checkpoints)
        }
        Command::Study {
            study,
            out,
            shard,
            emit,
            jobs,
        } => {
            let shard = shard
                .as_deref()
                .map(commands::study::parse_shard)
                .transpose()?;
            commands::study::run(&study, &out, shard, emit.as_deref(), jobs)
        }
        Command::Mesh { scenario, out } => {
            let s = scenario::Scenario::load(&scenario)?;
            let p = part::load_part(&s.part)?;
            let name = out.display().to_string();
            let format = planner::io::MeshFormat::from_extension(&name).ok_or_else(|| {
                Error::input(format!(
                    "{name}: unknown mesh extension; expected .stl, .obj or .ply"
                ))
            })?;
            let bytes = planner::io::write_mesh(&p.mesh, format, planner::io::Encoding::Binary);
            output::write_atomic(&out, &bytes)?;
            Ok(format!(
                "{}: {} vertices, {} faces, {} part",
                name,
                p.mesh.n_vertices(),
                p.mesh.n_faces(),
                p.kind.as_str()
            ))
        }
        Command::Export {
            dir,
            format,
            pivot_mm,
            part_offset_mm,
            tilt_limits_deg,
        } => {
            let table = commands::export::table(&pivot_mm, &part_offset_mm, &tilt_limits_deg)?;
            commands::export::run(&dir, format, &table)
        }
        Command::Skeleton { scenario, out } => commands::skeleton::run(&scenario, &out),
        Command::Demo { out } => {
            commands::demo::demo(&out)?;
            Ok(format!("demo written to {}", out.display()))
        }
    }
}
