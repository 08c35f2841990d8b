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
        Command::Mesh { scenario, out } => commands::mesh::run(&scenario, &out),
        Command::Export {
            dir,
            format,
            pivot_mm,
            part_offset_mm,
            tilt_limits_deg,
            min_move_mm,
            rotary_rpm_max,
            tilt_rpm_max,
        } => {
            let table = commands::export::table(&pivot_mm, &part_offset_mm, &tilt_limits_deg)?;
            let speed = commands::export::table_speed(rotary_rpm_max, tilt_rpm_max, format)?;
            commands::export::run(&dir, format, &table, speed, min_move_mm)
        }
        Command::Skeleton { scenario, out } => commands::skeleton::run(&scenario, &out),
        Command::Demo { out } => {
            commands::demo::demo(&out)?;
            Ok(format!("demo written to {}", out.display()))
        }
    }
}

#[cfg(test)]
mod tests {
    use std::path::{Path, PathBuf};

    fn sources(dir: &Path, out: &mut Vec<PathBuf>) {
        for e in std::fs::read_dir(dir).unwrap().flatten() {
            let p = e.path();
            match p.is_dir() {
                true => sources(&p, out),
                false if p.extension().is_some_and(|x| x == "rs") => out.push(p),
                false => {}
            }
        }
    }

    /// docs/ARCHITECTURE.md: the commands are the shell. The engine, the readers and the sinks
    /// never name them; only `commands/`, `cli.rs` and `lib.rs` do.
    #[test]
    fn the_engine_does_not_reach_into_the_commands() {
        let src = Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        let mut files = Vec::new();
        sources(&src, &mut files);
        let names = |p: &Path| {
            let text = std::fs::read_to_string(p).unwrap();
            text.contains("crate::commands") || text.contains("super::commands")
        };
        let shell = |rel: &Path| {
            rel.starts_with("commands") || rel == Path::new("cli.rs") || rel == Path::new("lib.rs")
        };
        let offenders: Vec<_> = files
            .iter()
            .filter(|p| !shell(p.strip_prefix(&src).unwrap()) && names(p))
            .collect();
        assert!(offenders.is_empty(), "outside the shell: {offenders:?}");
        // The look finds what it looks for: cli.rs names the commands' options.
        assert!(names(&src.join("cli.rs")) && files.len() > 50);
    }
}
