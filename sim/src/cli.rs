//! The `waamtwin` command line (see `../shared/interface.md`).

use clap::{Parser, Subcommand};
use std::path::PathBuf;

#[derive(Debug, Parser)]
#[command(
    name = "waamtwin",
    version,
    about = "Plan and simulate wire-arc additive manufacturing of thin parts"
)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Debug, Subcommand)]
pub enum Command {
    /// Mesh report: vertices, faces, boundary loops, open/closed, problems.
    Inspect {
        /// An STL, OBJ or PLY file.
        mesh: PathBuf,
        /// Print the report as JSON.
        #[arg(long)]
        json: bool,
    },
    /// Geodesic distance from a boundary loop or from vertices, one row per welded vertex.
    Geodesic {
        mesh: PathBuf,
        /// `lower`, `upper`, or `vertex:I[,J..]` (indices of the welded mesh, as `inspect` counts).
        #[arg(long)]
        from: String,
        #[arg(short = 'o', long = "out")]
        out: PathBuf,
    },
    /// Plan the continuous path: plan.json, generators.csv, path.csv.
    Plan {
        scenario: PathBuf,
        #[arg(short = 'o', long = "out")]
        out: PathBuf,
        #[arg(long, value_enum, default_value_t = Strategy::Ctpp)]
        strategy: Strategy,
    },
    /// Plan, beads and the heat of the build without dwells: thermal.json, layers.csv.
    Simulate {
        scenario: PathBuf,
        #[arg(short = 'o', long = "out")]
        out: PathBuf,
        #[command(flatten)]
        checkpoints: crate::commands::checkpoint::Options,
    },
    /// Replay a toolpath the machine ran on the voxel model and compare with its probes:
    /// probes.csv, replay.json, probes.png.
    Replay {
        scenario: PathBuf,
        #[arg(short = 'o', long = "out")]
        out: PathBuf,
        #[command(flatten)]
        checkpoints: crate::commands::checkpoint::Options,
    },
    /// Follow a build while it runs: the replay scenario's toolpath is the program, its probe
    /// file is read as the logger writes it; an ensemble learns from every reading and
    /// forecasts the probes and the next layer: forecasts.csv, assimilation.csv, alarms.csv,
    /// follow.json.
    Follow {
        scenario: PathBuf,
        #[arg(short = 'o', long = "out")]
        out: PathBuf,
        /// End after this many seconds with nothing new in the followed files (default: wait
        /// until the data reach the program's end, or Ctrl-C).
        #[arg(long)]
        until_idle_s: Option<f64>,
        /// Stream the recording to a running rerun viewer as it is written (its gRPC URL;
        /// default rerun+http://127.0.0.1:9876/proxy, the viewer's own).
        #[arg(long, value_name = "URL", num_args = 0..=1,
              default_missing_value = "rerun+http://127.0.0.1:9876/proxy")]
        connect: Option<String>,
        #[command(flatten)]
        checkpoints: crate::commands::checkpoint::Options,
    },
    /// Fit up to three of a replay's parameters to its probes over a fit window and judge the
    /// fit on a held-out one: calibration.json, probes.csv, probes.png.
    Calibrate {
        scenario: PathBuf,
        #[arg(short = 'o', long = "out")]
        out: PathBuf,
        /// The fit window, T0:T1 in seconds of build time (default: the first half).
        #[arg(long)]
        fit: Option<String>,
        /// The held-out window, T0:T1 (default: the second half).
        #[arg(long)]
        holdout: Option<String>,
        #[command(flatten)]
        checkpoints: crate::commands::checkpoint::Options,
    },
    /// Plan, simulate and plan the cooling dwells: dwells.csv, dwell.json, and the dwelled run.
    Dwell {
        scenario: PathBuf,
        #[arg(short = 'o', long = "out")]
        out: PathBuf,
        /// Skip the baselines (uniform dwell, wait until cool), which take several builds.
        #[arg(long)]
        no_baselines: bool,
        /// Plan at six weights of an arc stop and write the front of arc stops against build
        /// time (pareto.csv, pareto.png): six dwell searches.
        #[arg(long)]
        pareto: bool,
        #[command(flatten)]
        checkpoints: crate::commands::checkpoint::Options,
    },
    /// What-if study: overrides of a base scenario, run `--jobs` at a time, resumable;
    /// summary.csv.
    Study {
        study: PathBuf,
        #[arg(short = 'o', long = "out")]
        out: PathBuf,
        /// Run only every N-th case from I (a cluster job array's task): `I/N`.
        #[arg(long)]
        shard: Option<String>,
        /// Write a job-array script for a scheduler instead of running (`slurm`).
        #[arg(long)]
        emit: Option<String>,
        /// The most cases run at once (default: this machine's cores); each starts once its
        /// memory estimate fits beside the running cases'.
        #[arg(long)]
        jobs: Option<usize>,
    },
    /// Write a scenario's part (a library shape or a mesh file) as a welded STL, OBJ or PLY mesh.
    Mesh {
        scenario: PathBuf,
        /// Output mesh; the extension picks the format.
        #[arg(short = 'o', long = "out")]
        out: PathBuf,
    },
    /// The machine program of a planned DIR (its path.csv): program.json, program.mod (ABB
    /// RAPID), program.src (KUKA KRL) or program.nc (5-axis G-code for a tilt-rotary table), one
    /// linear move per path point with the full tool frame.
    Export {
        dir: PathBuf,
        #[arg(long, value_enum)]
        format: crate::commands::export::Format,
        /// G-code: the pivot (where the table's tilt axis A meets its rotary axis C) in machine
        /// coordinates, mm.
        #[arg(long, value_delimiter = ',', num_args = 1, default_values_t = [0.0, 0.0, 0.0], allow_hyphen_values = true)]
        pivot_mm: Vec<f64>,
        /// G-code: the part's origin on the rotary table, in the table's frame (z along its
        /// axis), mm.
        #[arg(long, value_delimiter = ',', num_args = 1, default_values_t = [0.0, 0.0, 0.0], allow_hyphen_values = true)]
        part_offset_mm: Vec<f64>,
        /// G-code: the tilt A's limits, degrees.
        #[arg(long, value_delimiter = ',', num_args = 1, default_values_t = [-120.0, 120.0], allow_hyphen_values = true)]
        tilt_limits_deg: Vec<f64>,
        /// The shortest move kept, mm: a path point closer than this to the move before is
        /// merged into the next (unless the arc is struck, put out or burns there, or a dwell
        /// waits before it); 0 keeps every point.
        #[arg(long, default_value_t = crate::commands::export::MIN_MOVE_MM)]
        min_move_mm: f64,
        /// G-code: the rotary axis C's top speed, rpm; moves that ask more are warned of
        /// (`table_speed`), with the torch's speed where the controller holds C to it.
        #[arg(long, allow_hyphen_values = true)]
        rotary_rpm_max: Option<f64>,
        /// G-code: the tilt A's top speed, rpm (as --rotary-rpm-max).
        #[arg(long, allow_hyphen_values = true)]
        tilt_rpm_max: Option<f64>,
    },
    /// Skeleton arc AM of an OBJ skeleton, drop by drop, closed and open loop: drops.csv,
    /// loops.csv, path.csv, skeleton.json, solidification.png, standoff.png.
    Skeleton {
        scenario: PathBuf,
        #[arg(short = 'o', long = "out")]
        out: PathBuf,
    },
    /// A built-in closed-part scenario, end to end.
    Demo {
        #[arg(short = 'o', long = "out", default_value = "out/demo")]
        out: PathBuf,
    },
}

/// Path-planning strategy.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Strategy {
    /// Continuous three-dimensional path planning: one spiral.
    Ctpp,
    /// The planar 2.5D baseline: horizontal slices every h.
    Planar,
    /// Chalvin et al. 2019 §2.1 on a quarter_torus part: layers square to the neutral axis.
    TubePerpendicular,
    /// Chalvin et al. 2019 §2.2 (Eq.2) on a quarter_torus part: non-planar layers.
    TubeNonPlanar,
}
