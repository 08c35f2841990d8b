//! Runs that resume: `simulate` and `dwell` killed part-way (aborted right after the n-th
//! checkpoint, as a kill would leave them) and run again with `--resume` write the files an
//! uninterrupted run writes, wall-clock fields aside; a checkpoint that is not the run's own
//! (another scenario, another version, damaged) is refused with exit 2 and never used.

use crate::determinism::DOME;
use crate::{assert_input_error, assert_same_outputs, scratch};
use std::path::{Path, PathBuf};
use std::process::Output;

const ABORT: &str = "WAAMTWIN_ABORT_AFTER_CHECKPOINTS";

fn waamtwin(args: &[&str], out: &Path, abort: Option<&str>) -> Output {
    let mut c = std::process::Command::new(env!("CARGO_BIN_EXE_waamtwin"));
    c.args(args).arg("-o").arg(out);
    if let Some(a) = abort {
        c.env(ABORT, a).args(["--checkpoint-every-s", "0"]);
    }
    c.output().unwrap()
}

/// `args` run once, then killed after the checkpoint `abort` names and resumed: the two
/// directories.
fn once_and_resumed(dir: &Path, args: &[&str], abort: &str) -> (PathBuf, PathBuf) {
    let (once, resumed) = (dir.join("once"), dir.join("resumed"));
    let o = waamtwin(args, &once, None);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let killed = waamtwin(args, &resumed, Some(abort));
    assert!(!killed.status.success(), "not killed at {abort}");
    assert!(resumed.join("checkpoint").is_dir());
    assert!(
        !resumed.join("manifest.json").exists(),
        "finished before the kill"
    );
    let mut again: Vec<&str> = args.to_vec();
    again.push("--resume");
    let o = waamtwin(&again, &resumed, None);
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    // Resumed, not started again: a state that no longer reads restarts its stage to the
    // same files, and only this line tells.
    assert!(err.contains("resuming"), "{err}");
    assert!(!err.contains("did not read"), "{err}");
    assert!(
        !resumed.join("checkpoint").exists(),
        "checkpoints left after the run"
    );
    (once, resumed)
}

#[test]
fn a_killed_simulate_resumes_to_the_same_files() {
    let dir = scratch("resume-simulate");
    let s = dir.join("s.toml");
    std::fs::write(&s, DOME).unwrap();
    // Voxels: the larger state, the plate and every field frame kept part-way.
    let args = ["simulate", s.to_str().unwrap()];
    let (once, resumed) = once_and_resumed(&dir, &args, "heat.run:200");
    let names = assert_same_outputs(&once, &resumed, "after a kill and --resume");
    assert!(names.iter().any(|n| n == "fields.h5"), "{names:?}");
}

#[test]
fn a_killed_dwell_resumes_to_the_same_files() {
    let dir = scratch("resume-dwell");
    let s = dir.join("s.toml");
    std::fs::write(&s, DOME.replace("\"voxel\"", "\"thin-wall\"")).unwrap();
    let args = ["dwell", s.to_str().unwrap()];
    // Killed inside the dwell search (kept between revolutions), and inside the baselines
    // (each kept as it finishes): both stages after one done and kept.
    for abort in ["search.run:3", "wait_until_cool:1"] {
        let d = dir.join(abort.replace(':', "-"));
        std::fs::create_dir_all(&d).unwrap();
        let (once, resumed) = once_and_resumed(&d, &args, abort);
        let names = assert_same_outputs(&once, &resumed, &format!("after a kill at {abort}"));
        assert!(names.iter().any(|n| n == "dwells.csv"), "{names:?}");
    }
}

#[test]
fn a_checkpoint_not_the_runs_own_is_refused() {
    let dir = scratch("resume-refused");
    let s = dir.join("s.toml");
    let fe = DOME.replace("\"voxel\"", "\"thin-wall\"");
    std::fs::write(&s, &fe).unwrap();
    let out = dir.join("out");
    let args = ["simulate", s.to_str().unwrap(), "--resume"];
    let killed = waamtwin(&args[..2], &out, Some("heat.run:5"));
    assert!(!killed.status.success());
    let file = out.join("checkpoint").join("heat.run.ckpt");
    let kept = std::fs::read(&file).unwrap();
    // Another scenario: a plate 2 mm thicker.
    std::fs::write(&s, fe.replace("8.0]", "10.0]")).unwrap();
    let o = waamtwin(&args, &out, None);
    assert_input_error(&o, &["heat.run.ckpt", "another scenario", "--resume"]);
    std::fs::write(&s, &fe).unwrap();
    // Another command on the same scenario.
    let o = waamtwin(&["dwell", s.to_str().unwrap(), "--resume"], &out, None);
    assert_input_error(&o, &["heat.run.ckpt", "waamtwin simulate"]);
    // Another version.
    let text = String::from_utf8_lossy(&kept).into_owned();
    let older = text.replacen(
        &format!("\"version\":\"{}\"", env!("CARGO_PKG_VERSION")),
        "\"version\":\"0.0.1\"",
        1,
    );
    assert_ne!(older, text);
    let header_end = kept.iter().position(|&b| b == b'\n').unwrap();
    let mut bytes = older.as_bytes()[..older.find('\n').unwrap()].to_vec();
    bytes.extend_from_slice(&kept[header_end..]);
    std::fs::write(&file, &bytes).unwrap();
    let o = waamtwin(&args, &out, None);
    assert_input_error(&o, &["heat.run.ckpt", "waamtwin 0.0.1"]);
    // Damaged: a byte of the state changed.
    let mut damaged = kept.clone();
    let last = damaged.len() - 1;
    damaged[last] ^= 0x55;
    std::fs::write(&file, &damaged).unwrap();
    let o = waamtwin(&args, &out, None);
    assert_input_error(&o, &["heat.run.ckpt", "damaged"]);
    // Nothing was used or written: the damaged file is still there, no outputs.
    assert_eq!(std::fs::read(&file).unwrap(), damaged);
    assert!(!out.join("thermal.json").exists());
    // Its own checkpoint, whole, resumes.
    std::fs::write(&file, &kept).unwrap();
    let o = waamtwin(&args, &out, None);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(out.join("thermal.json").is_file());
}
