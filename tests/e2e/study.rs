//! `waamtwin study`: a 12-case sweep on two threads, killed half-way and resumed, and split into
//! shards whose merged summary equals the local run's.

use crate::{root, scratch};
use std::process::{Command, Output};

fn write_study(dir: &std::path::Path) -> std::path::PathBuf {
    std::fs::write(
        dir.join("base.toml"),
        "[part]\nshape = \"cylinder\"\nradius_mm = 25.0\nheight_mm = 14.0\nedge_mm = 2.5\n[planner]\nn_points = 40\n[thermal]\nplate_mm = [100.0, 100.0, 8.0]\n",
    )
    .unwrap();
    let study = dir.join("study.toml");
    std::fs::write(
        &study,
        "base = \"base.toml\"\ncommand = \"dwell\"\n[sweep]\n\"process.travel_speed_mm_s\" = [8.0, 10.0, 12.0]\n\"dwell.interpass_max_c\" = [150.0, 200.0]\n\"thermal.convection_w_m2k\" = [10.0, 30.0]\n",
    )
    .unwrap();
    study
}

fn study_cmd(args: &[&str]) -> Command {
    let mut c = Command::new(env!("CARGO_BIN_EXE_waamtwin"));
    c.arg("study").args(args).current_dir(root());
    c
}

fn finished(out: &std::path::Path) -> usize {
    std::fs::read_dir(out.join("cases")).map_or(0, |d| {
        d.filter_map(|e| e.ok())
            .filter(|e| e.path().join("manifest.json").is_file())
            .count()
    })
}

#[test]
fn a_killed_study_resumes_and_shards_merge_into_the_same_summary() {
    let dir = scratch("study");
    let study = write_study(&dir);
    let (s, out) = (study.to_str().unwrap(), dir.join("local"));
    // Start, kill once a few cases are done, resume.
    let mut child = study_cmd(&[s, "-o", out.to_str().unwrap()])
        .spawn()
        .unwrap();
    let start = std::time::Instant::now();
    while finished(&out) < 3 && start.elapsed().as_secs() < 120 {
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    child.kill().unwrap();
    child.wait().unwrap();
    let before = finished(&out);
    assert!((3..12).contains(&before), "killed after {before} cases");
    let resumed = study_cmd(&[s, "-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&resumed.stdout);
    assert!(
        resumed.status.success(),
        "{}",
        String::from_utf8_lossy(&resumed.stderr)
    );
    assert!(
        text.contains(&format!("{} already done", before)) || text.contains("already done"),
        "{text}"
    );
    assert_eq!(finished(&out), 12);
    let local = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    assert_eq!(local.lines().count(), 13, "{local}");
    let header: Vec<&str> = local.lines().next().unwrap().split(',').collect();
    assert_eq!(
        header[header.len() - 3..],
        ["first_risk", "first_risk_reason", "warnings"]
    );
    // Each row names what its first point at risk breaks, where it has one; the thin wall's
    // cases here earn no grid warning, and their plan (one plan: the sweep moves none of its
    // keys), not feasible away from any closing zone (a 14 mm cylinder's last two revolutions,
    // 1.52–2.50 mm where the spiral meets its top), earns `plan_infeasible` in each.
    let feasible = header.iter().position(|h| *h == "feasible").unwrap();
    for row in local.lines().skip(1) {
        let f: Vec<&str> = row.split(',').collect();
        assert_eq!(f.len(), header.len(), "{row}");
        let (point, reason) = (f[f.len() - 3], f[f.len() - 2]);
        assert_eq!(f[feasible], "false", "{row}");
        assert_eq!(f[f.len() - 1], "plan_infeasible", "{row}");
        assert_eq!(point.is_empty(), reason.is_empty(), "{row}");
        assert!(
            ["", "interpass", "strength", "humping", "bond"].contains(&reason),
            "{row}"
        );
    }
    // The trade-off: at each travel speed and convection, a higher interpass limit needs less dwell.
    let rows: Vec<Vec<String>> = local
        .lines()
        .skip(1)
        .map(|l| l.split(',').map(String::from).collect())
        .collect();
    for r in rows.iter().filter(|r| r[1] == "150.0") {
        let other = rows
            .iter()
            .find(|o| o[1] == "200.0" && o[2] == r[2] && o[3] == r[3])
            .unwrap();
        assert!(
            other[6].parse::<f64>().unwrap() < r[6].parse::<f64>().unwrap(),
            "{r:?} vs {other:?}"
        );
    }
    // Two shards into one folder: the same summary.
    let sharded = dir.join("sharded");
    for shard in ["0/2", "1/2"] {
        assert!(
            study_cmd(&[s, "-o", sharded.to_str().unwrap(), "--shard", shard])
                .status()
                .unwrap()
                .success()
        );
    }
    assert_eq!(
        std::fs::read_to_string(sharded.join("summary.csv")).unwrap(),
        local
    );
    // The job-array script for Slurm.
    assert!(
        study_cmd(&[s, "-o", sharded.to_str().unwrap(), "--emit", "slurm"])
            .status()
            .unwrap()
            .success()
    );
    let script = std::fs::read_to_string(sharded.join("study.slurm")).unwrap();
    assert!(
        script.contains("#SBATCH --array=0-11")
            && script.contains("--shard ${SLURM_ARRAY_TASK_ID}/12")
    );
}

/// Stops the single-node Slurm when dropped.
struct Stop;

impl Drop for Stop {
    fn drop(&mut self) {
        let _ = Command::new("bash")
            .arg(root().join("tests/slurm/stop.sh"))
            .status();
    }
}

/// A real single-node Slurm (tests/slurm/start.sh installs and starts the distribution's
/// slurm-wlm on loopback, as root) runs a small study as a job array; the merge job's summary
/// equals a local run's. Opt-in (`crate::SYSTEM_TESTS`): it changes the system.
#[test]
#[cfg_attr(
    not(system_tests),
    ignore = "opt-in, WAAMTWIN_SYSTEM_TESTS=1: installs and starts Slurm as root"
)]
fn slurm_runs_a_study_as_a_job_array() {
    let dir = scratch("study_slurm");
    std::fs::write(
        dir.join("base.toml"),
        "[part]\nshape = \"cylinder\"\nradius_mm = 25.0\nheight_mm = 14.0\nedge_mm = 2.5\n[planner]\nn_points = 40\n[thermal]\nplate_mm = [100.0, 100.0, 8.0]\n[output]\nrerun = false\nmcap = false\nhdf5 = false\nplots = false\n",
    )
    .unwrap();
    let study = dir.join("study.toml");
    std::fs::write(
        &study,
        "base = \"base.toml\"\ncommand = \"simulate\"\n[sweep]\n\"process.travel_speed_mm_s\" = [8.0, 12.0]\n\"thermal.convection_w_m2k\" = [10.0, 30.0]\n",
    )
    .unwrap();
    let s = study.to_str().unwrap();
    let local = dir.join("local");
    assert!(
        study_cmd(&[s, "-o", local.to_str().unwrap()])
            .status()
            .unwrap()
            .success()
    );

    // Slurm's daemons end with the test, passed or not (tests/slurm/stop.sh).
    let _slurm = Stop;
    let start = Command::new("bash")
        .arg(root().join("tests/slurm/start.sh"))
        .output()
        .unwrap();
    assert!(
        start.status.success(),
        "Slurm did not start: {}",
        String::from_utf8_lossy(&start.stderr)
    );
    let conf = String::from_utf8_lossy(&start.stdout).trim().to_string();
    let cluster = dir.join("cluster");
    assert!(
        study_cmd(&[s, "-o", cluster.to_str().unwrap(), "--emit", "slurm"])
            .status()
            .unwrap()
            .success()
    );
    // The array runs `waamtwin` from PATH, as on a cluster where it is installed.
    let bin = std::path::Path::new(env!("CARGO_BIN_EXE_waamtwin"))
        .parent()
        .unwrap();
    let path = format!(
        "{}:{}",
        bin.display(),
        std::env::var("PATH").unwrap_or_default()
    );
    let sbatch = |args: &[&str]| {
        let o = Command::new("sbatch")
            .args(args)
            .env("SLURM_CONF", &conf)
            .env("PATH", &path)
            .current_dir(root())
            .output()
            .unwrap();
        assert!(
            o.status.success(),
            "sbatch {args:?}: {}",
            String::from_utf8_lossy(&o.stderr)
        );
        String::from_utf8_lossy(&o.stdout).trim().to_string()
    };
    let array = cluster.join("study.slurm");
    let jid = sbatch(&["--parsable", array.to_str().unwrap()]);
    let merge = cluster.join("study-merge.slurm");
    sbatch(&[
        "--wait",
        &format!("--dependency=afterok:{jid}"),
        merge.to_str().unwrap(),
    ]);
    let logs: Vec<_> = std::fs::read_dir(&cluster)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().starts_with("slurm-"))
        .collect();
    assert_eq!(
        logs.len(),
        5,
        "4 array tasks and the merge job leave their logs"
    );
    assert_eq!(
        std::fs::read_to_string(cluster.join("summary.csv")).unwrap(),
        std::fs::read_to_string(local.join("summary.csv")).unwrap()
    );
}

/// `study NAME -o out` in a fresh folder `scratch`, beside a small cylinder as `base.toml`.
fn run_study_file(scratch_name: &str, name: &str, text: &str) -> (std::path::PathBuf, Output) {
    let dir = scratch(scratch_name);
    std::fs::write(
        dir.join("base.toml"),
        "[part]\nshape = \"cylinder\"\nradius_mm = 25.0\nheight_mm = 14.0\n",
    )
    .unwrap();
    std::fs::write(dir.join(name), text).unwrap();
    let out = study_cmd(&[
        dir.join(name).to_str().unwrap(),
        "-o",
        dir.join("out").to_str().unwrap(),
    ])
    .output()
    .unwrap();
    (dir, out)
}

/// A case whose overrides make a bad scenario is refused before anything runs, in one line that
/// names the study file, the case, its overrides and the key with its value, and no line number
/// of text the user never wrote.
#[test]
fn a_bad_case_names_the_study_file_and_the_case() {
    let (dir, out) = run_study_file(
        "study_bad_case",
        "bad_study.toml",
        "base = \"base.toml\"\n[[case]]\n\"thermal.voxel_mm\" = 1.0\n[[case]]\n\"thermal.voxel_mm\" = 0.01\n",
    );
    crate::assert_input_error(
        &out,
        &[
            "bad_study.toml case 001",
            "thermal.voxel_mm = 0.01",
            "expected between 0.25 and 20",
        ],
    );
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(!err.contains(" line "), "{err}");
    assert!(
        !dir.join("out")
            .join("cases")
            .join("000")
            .join("manifest.json")
            .exists()
    );
}

/// A few short lists in `[sweep]` multiply to any number of cases: past 10 000 the study is
/// refused at once, naming the lists, before any case is built (twenty lists of ten would be
/// 10^20 cases).
#[test]
fn a_sweep_of_too_many_cases_is_refused_at_once() {
    let mut text = String::from("base = \"base.toml\"\n[sweep]\n");
    for key in ["process.travel_speed_mm_s", "thermal.convection_w_m2k"] {
        let values: Vec<String> = (0..101).map(|k| format!("{}.0", 5 + k)).collect();
        text += &format!("\"{key}\" = [{}]\n", values.join(", "));
    }
    let clock = std::time::Instant::now();
    let (_, out) = run_study_file("study_too_many", "huge.toml", &text);
    crate::assert_input_error(
        &out,
        &[
            "huge.toml",
            "10201 cases",
            "process.travel_speed_mm_s: 101 × thermal.convection_w_m2k: 101",
            "at most 10000",
        ],
    );
    assert!(clock.elapsed().as_secs_f64() < 5.0);
}

/// A study's cases carry the warnings their commands would show: of two voxel cases on an R 20
/// dome's 1.96 mm beads, the 4 mm grid is named `coarse_voxels` in summary.csv, in its
/// thermal.json and on stderr with its case's number, the 2 mm grid is not. A case whose plate
/// cannot fit is refused before any case runs, naming the study file, the case and the key;
/// the cases run at once are as many as the largest case leaves room for.
#[test]
fn a_studys_cases_carry_their_warnings_and_one_too_big_is_refused() {
    let dir = scratch("study_warnings");
    std::fs::write(
        dir.join("base.toml"),
        "[part]\nshape = \"hemisphere\"\nradius_mm = 20.0\nedge_mm = 2.5\n[planner]\n\
         n_points = 40\n[thermal]\nmodel = \"voxel\"\nplate_mm = [60.0, 60.0, 6.0]\n\
         [output]\nrerun = false\nmcap = false\nhdf5 = false\nplots = false\n",
    )
    .unwrap();
    let study = dir.join("grid.toml");
    std::fs::write(
        &study,
        "base = \"base.toml\"\n[sweep]\n\"thermal.voxel_mm\" = [2.0, 4.0]\n",
    )
    .unwrap();
    let out = dir.join("out");
    let o = study_cmd(&[study.to_str().unwrap(), "-o", out.to_str().unwrap()])
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{err}");
    assert!(
        err.contains("case 001: warning: voxel model: thermal.voxel_mm = 4 is 2.05 times"),
        "{err}"
    );
    assert!(!err.contains("case 000:"), "{err}");
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    let last: Vec<&str> = summary
        .lines()
        .map(|l| l.rsplit(',').next().unwrap())
        .collect();
    assert_eq!(last, ["warnings", "", "coarse_voxels"], "{summary}");
    let thermal: serde_json::Value = serde_json::from_slice(
        &std::fs::read(out.join("cases").join("001").join("thermal.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(thermal["warnings"][0]["kind"], "coarse_voxels", "{thermal}");

    // 0.3 mm voxels through a 300 mm plate: 3.3e7 of them, some 4.6 GB, in 200 MB.
    let big = dir.join("big.toml");
    std::fs::write(
        &big,
        "base = \"base.toml\"\n[[case]]\n\"thermal.voxel_mm\" = 2.0\n[[case]]\n\
         \"thermal.voxel_mm\" = 0.3\n\"thermal.plate_mm\" = [300.0, 300.0, 10.0]\n",
    )
    .unwrap();
    let refused = dir.join("refused");
    let o = study_cmd(&[big.to_str().unwrap(), "-o", refused.to_str().unwrap()])
        .env("WAAMTWIN_MEMORY_BYTES", "2e8")
        .output()
        .unwrap();
    crate::assert_input_error(
        &o,
        &["big.toml case 001", "thermal.voxel_mm = 0.3", "voxels"],
    );
    assert!(!refused.join("cases").join("000").exists());

    // Cases at once are held to the memory, each by its own estimate: in 100 MB two of the
    // base's fit (25 MB each; 52 MB measured for the process), one with a 400 mm plate (91 MB)
    // runs alone, and while it waits a small case after it runs beside the small one before.
    let two_cores = std::thread::available_parallelism().is_ok_and(|n| n.get() >= 2);
    for (name, plates, jobs) in [
        (
            "same",
            "[[60.0, 60.0, 6.0], [60.0, 60.0, 6.0]]",
            "up to 2 at a time",
        ),
        (
            "mixed",
            "[[60.0, 60.0, 6.0], [400.0, 400.0, 12.0]]",
            "up to 1 at a time",
        ),
        (
            "waits",
            "[[60.0, 60.0, 6.0], [400.0, 400.0, 12.0], [60.0, 60.0, 6.0]]",
            "up to 2 at a time",
        ),
    ] {
        let file = dir.join(format!("{name}.toml"));
        std::fs::write(
            &file,
            format!("base = \"base.toml\"\n[sweep]\n\"thermal.plate_mm\" = {plates}\n"),
        )
        .unwrap();
        let o = study_cmd(&[
            file.to_str().unwrap(),
            "-o",
            dir.join(name).to_str().unwrap(),
        ])
        .env("WAAMTWIN_MEMORY_BYTES", "1e8")
        .output()
        .unwrap();
        let text = String::from_utf8_lossy(&o.stdout);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        match two_cores {
            true => assert!(text.contains(jobs), "{name}: {text}"),
            false => eprintln!("skipped: one core, every study runs one case at a time"),
        }
    }
}

/// A case that fails does not cost the others theirs: of an R 15 and an R 60 dome on one 80 mm
/// plate, the R 60 one outgrows the plate (found once it is planned), its folder keeps the
/// message in failed.json and failed.csv names it, the R 15 dome's row is in summary.csv, and
/// the study exits 2 naming the case and the key. Given a plate that holds it, the study runs
/// that case alone and failed.csv is gone.
#[test]
fn a_failed_case_is_named_and_the_others_finish() {
    let dir = scratch("study_failed_case");
    let base = |plate: f64| {
        format!(
            "[part]\nshape = \"hemisphere\"\nradius_mm = 15.0\nedge_mm = 2.5\n[planner]\n\
             n_points = 40\n[thermal]\nplate_mm = [{plate}, {plate}, 6.0]\n\
             [output]\nrerun = false\nmcap = false\nhdf5 = false\nplots = false\n"
        )
    };
    std::fs::write(dir.join("base.toml"), base(80.0)).unwrap();
    let study = dir.join("sizes.toml");
    std::fs::write(
        &study,
        "base = \"base.toml\"\n[sweep]\n\"part.radius_mm\" = [15.0, 60.0]\n",
    )
    .unwrap();
    let out = dir.join("out");
    let run = || {
        study_cmd(&[study.to_str().unwrap(), "-o", out.to_str().unwrap()])
            .output()
            .unwrap()
    };
    let o = run();
    crate::assert_input_error(
        &o,
        &[
            "1 of 2 cases failed",
            "failed.csv",
            "sizes.toml case 001 (part.radius_mm = 60.0)",
            "plate_mm",
            "summary.csv has 1 of 2 cases",
        ],
    );
    let (header, rows) = crate::read_csv(&out.join("summary.csv"));
    assert_eq!(header[..2], ["case", "part.radius_mm"]);
    assert_eq!(
        rows.iter().map(|r| r[0].as_str()).collect::<Vec<_>>(),
        ["000"]
    );
    let failed = std::fs::read_to_string(out.join("failed.csv")).unwrap();
    let lines: Vec<&str> = failed.lines().collect();
    assert_eq!(lines[0], "case,part.radius_mm,exit_code,message");
    assert!(
        lines.len() == 2
            && lines[1].starts_with("001,60.0,2,\"")
            && lines[1].contains("sizes.toml case 001 (part.radius_mm = 60.0): thermal:"),
        "{failed}"
    );
    let kept: serde_json::Value = serde_json::from_slice(
        &std::fs::read(out.join("cases").join("001").join("failed.json")).unwrap(),
    )
    .unwrap();
    assert_eq!(kept["exit_code"], 2);
    assert!(
        kept["message"]
            .as_str()
            .unwrap()
            .contains("outside the plate")
    );

    std::fs::write(dir.join("base.toml"), base(200.0)).unwrap();
    let o = run();
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    assert!(
        text.contains("1 cases run") && text.contains("1 already done"),
        "{text}"
    );
    assert!(!out.join("failed.csv").exists());
    assert!(!out.join("cases").join("001").join("failed.json").exists());
    assert_eq!(crate::read_csv(&out.join("summary.csv")).1.len(), 2);
}
