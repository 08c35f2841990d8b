//! What a heat run will cost, known before it starts (issue 19): the voxel model's active cells
//! (the plate's and the deposits' metal), its memory (bytes per active voxel, times the copies
//! a command keeps, plus the field frames) and its time (explicit steps of the stable length
//! over the build time, times the mean active set, at a rate per voxel-step measured on this
//! machine's kind). The thin-wall model is small beside it: its nodes follow the path.
//!
//! Arithmetic on the schedule: no model is built and nothing is allocated for the cells (but
//! the thin wall's plate columns, a few bytes each, laid out to count its merged cells up to
//! `COUNTED_COLUMNS_MAX`), so a run too large for the machine is refused at once.

use super::deposition::PLATE_LAYERS;
use super::params::{ThermalModel, ThermalSettings};
use thermal::schedule::Deposit;

/// Bytes per active voxel: the index map (key, value and its spare room), the cell, six
/// neighbours, six face weights, the areas, four f32 fields and the laid lists; measured as
/// (peak RSS − [`BASE_BYTES`]) over active voxels, 143 B on the cylinder of docs/PERFORMANCE.md.
pub const VOXEL_BYTES: f64 = 140.0;

/// What the process holds besides the model (the binary, the part, the plan), bytes: the peak
/// RSS of a run of a few thousand voxels.
pub const BASE_BYTES: f64 = 12e6;

/// Nanoseconds per active voxel and explicit step on one thread (the kernel's 7-point update
/// and losses), and the time every step costs besides (the source, the ledger, the readings),
/// fitted to three runs on this machine's kind (docs/PERFORMANCE.md, "Cost estimates").
pub const VOXEL_NS_PER_STEP: f64 = 3.2;
pub const STEP_OVERHEAD_S: f64 = 6.8e-5;

/// What a coarsened plate's block costs a step, against a cell's: it steps once in 3–11 steps
/// (`thermal::voxel`'s coarse cells at their own rate, docs/PHYSICS.md "The coarse cells at
/// their own rate"), but its seams with the cells of edge dx are conducted at every step. Fitted
/// to the GAMMA wall's replay (2026-11-30: the heat 6.9 → 5.5 s with its blocks, some 13 500
/// by this estimate's count, at their own rate; counted at a third, the estimate fell to 0.91
/// of the heat's time).
pub const COARSE_BLOCK_COST: f64 = 0.5;

/// Past [`VOXEL_CACHED`] mean active voxels the step's state no longer stays in the cache (an
/// AMD EPYC guest's 32 MB L3 here) and a voxel-step takes longer, as the power
/// [`VOXEL_UNCACHED_GROWTH`] of the mean over it. Fitted to the closed dome R 400 (2026-11-28,
/// 6.7e5 mean voxels, plate coarsened: 2.48 ns an update taken on two threads, 2.14 ns at
/// R 200's 2.0e5), where the rate without it put the estimate at 0.83 of the heat's time; now
/// 1.07 (docs/PERFORMANCE.md "Cost estimates").
pub const VOXEL_CACHED: f64 = 2e5;
pub const VOXEL_UNCACHED_GROWTH: f64 = 0.22;

/// Nanoseconds a voxel-step takes on one thread with `mean` active voxels.
fn voxel_ns_per_step(mean: f64) -> f64 {
    VOXEL_NS_PER_STEP * (mean / VOXEL_CACHED).max(1.0).powf(VOXEL_UNCACHED_GROWTH)
}

/// On a GPU (`[thermal] device = "gpu"`): the time each step costs whatever its voxels (the
/// host's recording and submitting of the step's passes, some 28 µs at R 300, and the device's
/// waits between its dispatches), the
/// rate at which the mean active voxels add to it (a dome's cells, slower than `voxel_rate`'s
/// regular plate), and the time each deposit costs (the field read back at the end of each
/// call, and the host's laying of the metal and its source). Fitted to five closed domes on an
/// NVIDIA H200 (docs/PERFORMANCE.md "Where a GPU step's time goes", 2026-11-27;
/// [`gpu_seconds`]): R 50 to 400, 8.9e4 to 1.3e6 mean voxels, 162, 131, 113, 105 and 124 µs a
/// step, each within 7 %. Another GPU differs: the estimate is the H200's pace, and says so.
pub const GPU_STEP_S: f64 = 6.88e-5;
pub const GPU_UPDATES_PER_S: f64 = 3.0e10;
pub const GPU_DEPOSIT_S: f64 = 4.65e-4;

/// A voxel run's time on a GPU at the H200's pace: `steps` explicit steps over `mean` active
/// voxels on average, `deposits` deposits.
pub fn gpu_seconds(steps: f64, mean: f64, deposits: f64) -> f64 {
    steps * (GPU_STEP_S + mean / GPU_UPDATES_PER_S) + deposits * GPU_DEPOSIT_S
}

/// Bytes per thin-wall node, all it keeps (its matrices' rows included).
pub const NODE_BYTES: f64 = 2_000.0;

/// Nanoseconds per active thin-wall node and deposit (its steps' conjugate-gradient
/// iterations included), measured on this machine's kind (docs/PERFORMANCE.md).
pub const NODE_NS_PER_STEP: f64 = 200.0;

/// The most plate columns the thin wall's estimate lays out to count its merged cells (about
/// 12 bytes a column while it counts: 120 MB here); past it, a plate no machine could step,
/// the uniform grid's count bounds them without allocating anything.
const COUNTED_COLUMNS_MAX: f64 = 1e7;

/// Local time stepping on the thin wall ([`thermal::rates`]): the nodes stepped at every
/// deposit (within the near zone, or just left it and still cooling fast), per (near zone /
/// node)²; the steps each other node takes at its own rate, per layer laid over another (each
/// revolution warms it again). Fitted to the closed domes R 100, 200 and 400 on the uniform
/// plate (docs/PERFORMANCE.md "Cost estimates"): near sets of 3 640, 4 250 and 6 070 nodes,
/// 7.4, 7.2 and 6.6 steps a node and layer. With the plate merged (2026-11-28) the count is
/// 0.66 to 1.14 of the node steps fourteen parts took, 2.6 on the quarter torus, whose nodes
/// are fewer than a near set.
pub const NEAR_SET: f64 = 8.0;
pub const FAR_STEPS_PER_NODE_LAYER: f64 = 7.0;

/// The time per counted node step on [`LOCAL_NS_NODES`] nodes, ns, and the power of the
/// nodes it grows as (the larger the part, the longer a step: 235 ns a node step on the R 50
/// dome's 6 500 nodes, 442 ns on R 400's 72 000). Fitted to the closed domes R 50 to 400 with
/// the plate merged (2026-11-28, this 2-core machine: 250, 380, 480 and 585 ns a counted
/// step; the power by least squares, the rate at the domes' largest times 1.15), which puts
/// the estimate 1.02 to 1.55 times the heat's time on the shipped parts not fitted, 0.97 on
/// the Chalvin torus, 3.4 on the quarter torus (docs/PERFORMANCE.md "Cost estimates").
pub const LOCAL_NS_PER_STEP: f64 = 540.0;
pub const LOCAL_NS_NODES: f64 = 3e4;
pub const LOCAL_NS_GROWTH: f64 = 0.35;

/// Nanoseconds a counted node step takes with local steps on a model of `nodes` nodes.
fn local_ns_per_step(nodes: f64) -> f64 {
    LOCAL_NS_PER_STEP * (nodes / LOCAL_NS_NODES).powf(LOCAL_NS_GROWTH)
}

const LOCAL_NEAR_M: f64 = super::params::documented::LOCAL_NEAR_MM * 1e-3;

/// The estimate of one run.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Estimate {
    pub model: ThermalModel,
    /// The voxel model on a GPU: `seconds` at the H200's pace ([`gpu_seconds`]).
    pub on_gpu: bool,
    /// Active cells at the end (voxels, or thin-wall nodes).
    pub cells: f64,
    pub plate_cells: f64,
    /// Explicit steps (voxels), or deposits (thin wall).
    pub steps: f64,
    /// The heat model's work: voxel updates, or thin-wall node steps (what thermal.json's
    /// `cell_updates` counts once the run is made).
    pub updates: f64,
    /// The heat run's memory, bytes (what is held against the machine once the plan is made).
    pub bytes: f64,
    /// The plan's peak before it, bytes (0: the command plans nothing, or it is not counted).
    pub plan_bytes: f64,
    pub seconds: f64,
}

impl Estimate {
    /// A line for the terminal.
    pub fn line(&self) -> String {
        let what = match self.model {
            ThermalModel::Voxel => "voxels",
            ThermalModel::ThinWall => "thin-wall nodes",
        };
        let pace = if self.on_gpu {
            " on a GPU at the pace measured on an H200"
        } else {
            ""
        };
        // The command's peak is the plan's where planning holds more than the run.
        let memory = match self.plan_bytes > self.bytes {
            true => format!(
                "{} ({} while planning)",
                bytes(self.bytes),
                bytes(self.plan_bytes)
            ),
            false => bytes(self.bytes),
        };
        format!(
            "estimate: {:.3e} {what} ({:.3e} of them the plate), {:.3e} steps ({:.3e} cell updates a run), {memory}, about {}{pace}",
            self.cells,
            self.plate_cells,
            self.steps,
            self.updates,
            duration(self.seconds)
        )
    }
}

/// The estimate of a run of `deposits` over `build_s` seconds on the model `t` names, keeping
/// `copies` of the model (a dwell search keeps checkpoints) and `frames` field frames, on
/// `threads` threads.
pub fn estimate(
    t: &ThermalSettings,
    m: &thermal::material::Material,
    deposits: &[Deposit],
    build_s: f64,
    copies: f64,
    frames: usize,
    threads: usize,
) -> Estimate {
    match t.model {
        ThermalModel::Voxel => {
            let dx = t.voxel_m;
            let [px, py, pz] = t.plate_m;
            let disc = if t.plate_disc {
                std::f64::consts::FRAC_PI_4
            } else {
                1.0
            };
            let columns = (px / dx).ceil() * (py / dx).ceil() * disc;
            let layers = (pz / dx).round().max(1.0);
            // The plate's cells, and of them the coarse blocks (`COARSE_BLOCK_COST` a step).
            let (plate, blocks) = match t.coarse_plate {
                false => (columns * layers, 0.0),
                // Blocks of 8 cells, an odd plate's top layer, and two layers of cells of edge
                // dx under the first layers' band (`thermal::voxel`'s fine columns).
                true => {
                    let band: f64 = deposits
                        .iter()
                        .enumerate()
                        .filter(|(_, d)| d.support.is_none())
                        .map(|(i, d)| (segment(deposits, i) + dx) * (3.0 * d.width + 6.0 * dx))
                        .sum::<f64>()
                        / (dx * dx);
                    let block_layers = (layers / 2.0).floor();
                    let band = if block_layers >= 1.0 {
                        band.min(columns)
                    } else {
                        0.0
                    };
                    let blocks = block_layers * columns / 4.0 - band / 4.0;
                    (columns * (layers % 2.0) + blocks + 2.0 * band, blocks)
                }
            };
            // The beads' own metal: the grid lays it within some 5 % on the grids measured
            // (docs/PHYSICS.md "The voxel grid against the layer", `metal_mm3`).
            let metal = thermal::schedule::bead_volume(deposits) / dx.powi(3);
            let cells = plate + metal;
            let steps = voxel_steps(deposits, build_s, stable_step(m, dx));
            let mean = plate - blocks * (1.0 - COARSE_BLOCK_COST) + metal / 2.0;
            let on_gpu = t.device == thermal::voxel::Device::Gpu;
            let updates = steps * mean;
            let seconds = match on_gpu {
                true => gpu_seconds(steps, mean, deposits.len() as f64),
                false => {
                    steps * (STEP_OVERHEAD_S + mean * voxel_ns_per_step(mean) * 1e-9)
                        / speedup(threads)
                }
            };
            Estimate {
                model: t.model,
                on_gpu,
                cells,
                plate_cells: plate,
                steps,
                updates,
                bytes: BASE_BYTES
                    + cells * VOXEL_BYTES * copies
                    + frame_bytes(deposits.len(), frames),
                plan_bytes: 0.0,
                seconds,
            }
        }
        ThermalModel::ThinWall => {
            // Nodes group deposits at least `node_m` long (never fewer than one a deposit
            // shorter); the plate is a grid of cells a few layers deep, its columns merged
            // away from the part (counted as the model will lay them out).
            let path: f64 = (0..deposits.len()).map(|i| segment(deposits, i)).sum();
            let wall = (path / t.node_m)
                .ceil()
                .clamp(1.0, deposits.len().max(1) as f64);
            let [px, py, _] = t.plate_m;
            let columns =
                (px / t.plate_cell_m).round().max(1.0) * (py / t.plate_cell_m).round().max(1.0);
            let plate = match columns <= COUNTED_COLUMNS_MAX {
                true => {
                    let p = super::deposition::plate_of(t, deposits);
                    thermal::wall::plate_cells(&p, deposits, t.merge_plate) as f64
                }
                false => columns * PLATE_LAYERS as f64,
            };
            let nodes = wall + plate;
            let steps = deposits.len() as f64;
            // Every node at every deposit, or (local steps) the near set at every deposit and
            // the rest at their own rates.
            let every = steps * (plate + wall / 2.0);
            let (updates, seconds) = match t.local_steps {
                false => (every, every * NODE_NS_PER_STEP * 1e-9),
                true => {
                    let near = NEAR_SET * (LOCAL_NEAR_M / t.node_m).powi(2);
                    let far = FAR_STEPS_PER_NODE_LAYER * layers(deposits);
                    let local = (steps * near.min(nodes) + nodes * far).min(every);
                    (local, local * local_ns_per_step(nodes) * 1e-9)
                }
            };
            Estimate {
                model: t.model,
                on_gpu: false,
                cells: nodes,
                plate_cells: plate,
                steps,
                updates,
                bytes: BASE_BYTES
                    + nodes * NODE_BYTES * copies
                    + frame_bytes(deposits.len(), frames),
                plan_bytes: 0.0,
                seconds,
            }
        }
    }
}

/// How many layers the path lays over one another: the longest chain of deposits each laid
/// on the one before (a revolution's, on a spiral).
fn layers(deposits: &[Deposit]) -> f64 {
    let mut depth = vec![0u32; deposits.len()];
    for (i, d) in deposits.iter().enumerate() {
        depth[i] = d.support.filter(|&s| s < i).map_or(1, |s| depth[s] + 1);
    }
    f64::from(depth.iter().copied().max().unwrap_or(0))
}

/// The explicit steps a voxel run of `deposits` takes at the stable step `dt`
/// (`thermal::voxel::VoxelRun`): each arc and each gap between arcs stepped to its end, the
/// last step of each the shorter, so an arc shorter than a step still takes one (a path cut
/// into 0.002 mm deposits took 50 001 steps where its 10 s counted 259); from the last
/// deposit to `build_s` (the schedule's clock: a replay's last reading, a skeleton's waits)
/// cooled at full steps.
fn voxel_steps(deposits: &[Deposit], build_s: f64, dt: f64) -> f64 {
    // `left > 1e-12` and `now < end - 1e-9` end the run's loops.
    let pieces = |s: f64| match s > 1e-9 {
        true => (s / dt - 1e-9).ceil(),
        false => 0.0,
    };
    let Some(last) = deposits.last() else {
        return build_s / dt;
    };
    let counted: f64 = deposits
        .iter()
        .enumerate()
        .map(|(i, d)| {
            let gap = i
                .checked_sub(1)
                .map_or(0.0, |p| d.arc_start() - deposits[p].time);
            pieces(gap) + pieces(d.arc_time)
        })
        .sum();
    counted + (build_s - last.time).max(0.0) / dt
}

/// Length of deposit i's bead segment, m.
fn segment(deposits: &[Deposit], i: usize) -> f64 {
    let (d, start) = (&deposits[i], thermal::schedule::segment_start(deposits, i));
    (0..3)
        .map(|k| (d.position[k] - start[k]).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// What recording a run's frames holds besides the frames themselves, bytes per point and
/// frame: the scene's per-point values in interface units, the sinks' buffers (rerun's batches,
/// the HDF5 file built in memory). Measured as the peak RSS with every output on less the same
/// run with none, over points × frames: 196 B on the demo dome (4 501 points), 283 B on the
/// cylinder (10 440), 100 frames each (docs/PERFORMANCE.md).
pub const RECORDED_BYTES_PER_POINT_FRAME: f64 = 300.0;

/// What each deposit of a logged path holds in a replay, bytes: the schedule, its copy in each
/// run and the run's per-deposit state. Measured as (peak RSS − the same path's at 100
/// deposits) over the deposits, one 100 mm track cut finer and finer on 2 mm voxels: 676 B at
/// 10 000 deposits, 803 B at 50 001 (docs/PERFORMANCE.md "A logged path's deposits counted
/// first").
pub const REPLAY_DEPOSIT_BYTES: f64 = 800.0;

/// What each further copy of a logged path's run holds per deposit beside its cells, bytes (its
/// points, its laid lists, its own share of the schedule): a command that keeps many copies (a
/// `follow`'s members and their forecasts, a calibration's kept runs) holds them in each.
/// Measured on the ORNL pad's twin (10 108 deposits, `[live] ensemble` 4 against 16 on the log's
/// first 1 200 rows, 80.0 and 202.1 MB peak resident): 5.08 MB a copy, 2.85 MB of it the cells
/// at [`VOXEL_BYTES`] as the estimate counts them, the rest 220 B a deposit (docs/PERFORMANCE.md
/// "`follow`'s memory").
pub const RUN_DEPOSIT_BYTES: f64 = 220.0;

/// What each measured reading a replay holds costs besides the model, bytes: the reading, its
/// prediction and comparison, and its rows in the recording (rerun's and the MCAP's). Measured
/// as (peak RSS − the model's estimate) over the readings: 0.85 kB on the GAMMA wall's replay
/// (174 425 readings), 1.2 kB its calibration, 1.5 kB the ORNL pad's replay (about 37 000,
/// reckoned); about the largest, the ORNL pad's estimate 0.94 of its peak (docs/PERFORMANCE.md
/// "Replays, calibrations and the twin estimated too").
pub const READING_BYTES: f64 = 1400.0;

/// The memory the recording of `frames` field frames of `deposits` points takes, bytes.
pub fn recording_bytes(deposits: usize, frames: usize) -> f64 {
    let n = frames.min(super::FIELD_BUDGET / deposits.max(1));
    RECORDED_BYTES_PER_POINT_FRAME * (n * deposits) as f64
}

/// The field frames kept: one temperature per deposit per frame (f64), the frames bounded as
/// [`super::frame_times`] bounds them.
fn frame_bytes(deposits: usize, frames: usize) -> f64 {
    let n = frames.min(super::FIELD_BUDGET / deposits.max(1));
    8.0 * (n * deposits) as f64
}

/// The voxel model's stable explicit step at the pipeline's margin, without building it.
pub fn stable_step(m: &thermal::material::Material, dx: f64) -> f64 {
    thermal::voxel::stable_step(m, dx, super::deposition::VOXEL_COURANT)
}

/// The kernel's speed-up on n threads, measured: 1.7 on 2 (docs/PERFORMANCE.md); beyond, the
/// issue's 16-core figures (3.1 on 16), interpolated on log₂ n.
pub fn speedup(threads: usize) -> f64 {
    let n = threads.max(1) as f64;
    match n {
        n if n <= 1.0 => 1.0,
        n if n <= 2.0 => 1.0 + 0.7 * (n - 1.0),
        n => (1.7 + (3.1 - 1.7) * (n.log2() - 1.0) / 3.0).min(3.1),
    }
}

/// What `bytes` say in words.
pub fn bytes(b: f64) -> String {
    match b {
        b if b >= 1e12 => format!("{:.1} TB", b / 1e12),
        b if b >= 1e9 => format!("{:.1} GB", b / 1e9),
        b if b >= 1e6 => format!("{:.0} MB", b / 1e6),
        b => format!("{:.0} kB", b / 1e3),
    }
}

fn duration(s: f64) -> String {
    match s {
        s if s >= 86_400.0 => format!("{:.1} days", s / 86_400.0),
        s if s >= 3600.0 => format!("{:.1} h", s / 3600.0),
        s if s >= 60.0 => format!("{:.1} min", s / 60.0),
        s if s >= 10.0 => format!("{s:.0} s"),
        s => format!("{s:.1} s"),
    }
}

/// What planning a part of `vertices` mesh vertices holds at its peak, bytes per vertex and
/// doubling of the vertices past [`PLAN_FILL_START`]: the heat method's geodesic distances
/// (Crane, Weischedel and Wardetzky 2013) keep five sparse Cholesky factors of the mesh's
/// operators at once (the heat flow's two, the Poisson matrix's, and two pinned sets cached:
/// 213 MB each of the R 400 dome's 1.07 GB, `heaptrack`), and a factor of a surface mesh's
/// operator, ordered to cut its fill, holds O(V log V) entries (George 1973; Lipton, Rose and
/// Tarjan 1979); the mesh, its operators and the fields add O(V). Fitted to the peak RSS of
/// `waamtwin plan` on the closed domes R 50 to 400 at 2 mm edges (4 581 to 291 027 vertices:
/// 0.95 to 1.04 of it), it holds at R 400 with 1 mm edges (1.16e6 vertices: 1.02) and on
/// thirteen other parts not fitted within 0.90 to 1.38, the most over on tubes, whose factors
/// fill less (docs/PERFORMANCE.md "The plan's memory").
pub const PLAN_BYTES_PER_DOUBLING: f64 = 427.0;
pub const PLAN_FILL_START: f64 = 68.0;

/// The peak memory of planning a part meshed with `vertices` vertices, bytes ([`BASE_BYTES`]
/// for the process included).
pub fn plan_bytes(vertices: usize) -> f64 {
    let v = vertices as f64;
    BASE_BYTES + v * PLAN_BYTES_PER_DOUBLING * (v / PLAN_FILL_START).log2().max(1.0)
}

/// The most vertices a plan can have within `available` bytes (0 where not even the process
/// fits): [`plan_bytes`] grows with the vertices, so bisection finds it.
pub fn plan_vertices_to_fit(available: f64) -> usize {
    if plan_bytes(0) > available {
        return 0;
    }
    let (mut lo, mut hi) = (0usize, 1usize);
    while plan_bytes(hi) <= available {
        lo = hi;
        hi *= 2;
    }
    while hi - lo > 1 {
        let mid = lo + (hi - lo) / 2;
        match plan_bytes(mid) <= available {
            true => lo = mid,
            false => hi = mid,
        }
    }
    lo
}

/// The voxel edge that would bring `bytes` under `available`: memory goes as 1/dx³.
pub fn voxel_to_fit(voxel_m: f64, bytes: f64, available: f64) -> f64 {
    voxel_m * (bytes / available).cbrt()
}

#[cfg(test)]
mod tests {
    use super::*;
    use thermal::run::Cells;

    /// The plan's memory against the peak RSS of `waamtwin plan` on parts it was not fitted to
    /// (`docs/scaling/plan_memory.sh`, 2026-11-29; mesh vertices, MB): held within 0.85–1.45,
    /// under by at most 10 % (small parts) and over by at most 38 % (a long tube).
    #[test]
    fn the_plans_memory_meets_the_peaks_measured() {
        let measured = [
            ("dome R 400, 1 mm edges", 1_162_836, 6855.6),
            ("dome R 100, 2.76 mm edges", 9_678, 45.9),
            ("bottle.toml", 11_530, 50.3),
            ("vase.toml", 14_792, 57.7),
            ("cylinder.toml", 23_343, 83.9),
            ("chalvin_torus.toml", 13_860, 55.6),
            ("quarter_torus.toml", 9_100, 38.8),
            ("asymmetric_dome.toml", 18_076, 76.5),
            ("asymmetric dome R 240", 161_951, 820.0),
            ("bottle R 150", 103_063, 432.0),
            ("cone frustum R 240", 131_710, 530.6),
            ("cylinder R 200 × 400", 145_696, 507.5),
            ("quarter torus 300 / 60, 1 mm edges", 205_465, 940.6),
            ("vase R 180", 132_637, 552.6),
        ];
        for (part, vertices, mb) in measured {
            let ratio = plan_bytes(vertices) / (mb * 1e6);
            assert!((0.85..=1.45).contains(&ratio), "{part}: {ratio:.3}");
        }
    }

    /// The most vertices that fit is the largest the estimate keeps within the memory given.
    #[test]
    fn the_vertices_to_fit_are_the_most_within_the_memory() {
        for avail in [5e6, 40e6, 1.5e9, 24e9, 1e12] {
            let v = plan_vertices_to_fit(avail);
            match v {
                0 => assert!(plan_bytes(0) > avail),
                v => assert!(
                    plan_bytes(v) <= avail && plan_bytes(v + 1) > avail,
                    "{avail}"
                ),
            }
        }
        assert_eq!(plan_vertices_to_fit(5e6), 0);
        assert!(plan_vertices_to_fit(24e9) > 3_000_000);
    }

    /// The issue's plate, 1000 × 1000 × 50 mm at 0.25 mm: 3.2e9 voxels, far past any memory.
    #[test]
    fn the_plate_of_the_issue() {
        let t = ThermalSettings {
            model: ThermalModel::Voxel,
            voxel_m: 0.25e-3,
            plate_m: [1.0, 1.0, 0.05],
            plate_fit: false,
            plate_disc: false,
            ..crate::scenario::Scenario::parse(
                "[part]\nshape = \"hemisphere\"\nradius_mm = 20\n",
                "t.toml",
                std::path::Path::new("."),
            )
            .unwrap()
            .thermal
        };
        let m = thermal::material::Material::g3si();
        let e = estimate(&t, &m, &[], 100.0, 1.0, 0, 2);
        assert!((e.cells - 3.2e9).abs() < 1e6, "{}", e.cells);
        assert!(e.bytes > 4e11 && e.bytes < 5e11, "{}", e.bytes);
        // 0.25 mm × (bytes / 20 GB)^(1/3).
        let dx = voxel_to_fit(t.voxel_m, e.bytes, 20e9);
        assert!((dx / 0.25e-3 - (e.bytes / 20e9).cbrt()).abs() < 1e-12);
        assert!(speedup(2) == 1.7 && speedup(16) == 3.1 && speedup(1) == 1.0);
    }

    /// A coarsened plate is counted as its blocks: the issue's plate (200 cells thick) as an
    /// eighth of its cells; one a cell thicker keeps its top layer of cells beside them. No
    /// deposits, so no band of cells kept under the first layers.
    #[test]
    fn a_coarsened_plate_counts_its_blocks() {
        let t = ThermalSettings {
            model: ThermalModel::Voxel,
            voxel_m: 0.25e-3,
            plate_m: [1.0, 1.0, 0.05],
            plate_fit: false,
            plate_disc: false,
            coarse_plate: true,
            ..ThermalSettings::default()
        };
        let m = thermal::material::Material::g3si();
        let e = estimate(&t, &m, &[], 100.0, 1.0, 0, 2);
        assert!(
            (e.plate_cells - 3.2e9 / 8.0).abs() < 1e6,
            "{}",
            e.plate_cells
        );
        let odd = ThermalSettings {
            plate_m: [1.0, 1.0, 0.05025],
            ..t
        };
        let e = estimate(&odd, &m, &[], 100.0, 1.0, 0, 2);
        assert!(
            (e.plate_cells - (1.6e7 + 3.2e9 / 8.0)).abs() < 1e6,
            "{}",
            e.plate_cells
        );
    }

    /// The GPU's pace against the five domes it was fitted to (docs/PERFORMANCE.md, the H200's
    /// heat runs: steps, the estimate's mean active voxels, deposits, seconds measured). Three
    /// constants follow R 50 to 400 within 7 %, not closer: the per-step time falls from R 50 to
    /// R 300 (the deposits' reads shared by more steps) and rises to R 400 (the voxels).
    #[test]
    fn the_gpu_pace_meets_the_domes_measured() {
        let domes = [
            (23_692.0, 88_600.0, 4_921.0, 3.84),
            (93_270.0, 113_000.0, 10_201.0, 12.23),
            (366_768.0, 360_000.0, 20_641.0, 41.32),
            (820_353.0, 749_000.0, 31_081.0, 85.87),
            (1_454_976.0, 1_276_000.0, 41_521.0, 180.54),
        ];
        for (steps, mean, deposits, measured) in domes {
            let s = gpu_seconds(steps, mean, deposits);
            assert!(
                (s / measured - 1.0).abs() < 0.07,
                "{s} s against {measured} s"
            );
        }
    }

    /// 2 mm voxels on an 80 × 80 × 6 mm plate, G3Si.
    fn small_voxel_plate() -> (ThermalSettings, thermal::material::Material) {
        let t = ThermalSettings {
            model: ThermalModel::Voxel,
            voxel_m: 2e-3,
            plate_m: [0.08, 0.08, 0.006],
            plate_fit: false,
            ..ThermalSettings::default()
        };
        (t, thermal::material::Material::g3si())
    }

    /// The estimate's steps are the voxel run's: a helix whose arcs are longer than a step
    /// (each stepped to its end, the last step shorter), the same with a dwell before each
    /// revolution, and a path cut into arcs far shorter than a step (each still one). Before,
    /// the build's seconds over the step: 651, 840 and 41 steps for the runs' 720, 910 and 300.
    #[test]
    fn the_voxel_steps_counted_are_the_runs() {
        let (t, m) = small_voxel_plate();
        let helix = thermal::schedule::helix(0.02, 40, 2, 0.0015, 0.004, 0.01, 1500.0);
        let mut dwelled = helix.clone();
        for (i, d) in dwelled.iter_mut().enumerate() {
            d.time += 7.3 * (i / 40) as f64;
        }
        // 5 ms arcs, 0.05 mm apart: a tenth of the 0.05 s step each.
        let fine: Vec<Deposit> =
            thermal::schedule::helix(0.02, 2400, 1, 0.0015, 0.004, 0.01, 1500.0)
                .into_iter()
                .take(300)
                .collect();
        for deps in [helix, dwelled, fine] {
            let model =
                super::super::deposition::heat_model_of(m.clone(), &t, &deps, vec![], vec![]);
            let run = model.simulate(&deps).unwrap();
            let end = deps.last().unwrap().time;
            let e = estimate(&t, &m, &deps, end, 1.0, 0, 1);
            assert_eq!(e.steps, run.steps as f64, "{} deposits", deps.len());
        }
    }

    /// The metal counted is the metal the voxel run lays: a helix of 3.1 mm deposits and a
    /// track cut into 0.05 mm ones, 5 × 2 mm beads on 2 mm voxels, within 10 % of the run's
    /// own cells and voxels. Before, each deposit was counted a voxel longer than its segment:
    /// 1.7 and 41 times the metal laid.
    #[test]
    fn the_metal_counted_is_the_metal_laid() {
        let (t, m) = small_voxel_plate();
        let helix = thermal::schedule::helix(0.02, 40, 2, 0.002, 0.005, 0.01, 1500.0);
        let fine: Vec<Deposit> =
            thermal::schedule::helix(0.02, 2400, 1, 0.002, 0.005, 0.01, 1500.0)
                .into_iter()
                .take(600)
                .collect();
        for deps in [helix, fine] {
            let model =
                super::super::deposition::heat_model_of(m.clone(), &t, &deps, vec![], vec![]);
            let run = model.simulate(&deps).unwrap();
            let Cells::Voxel {
                voxels, metal_m3, ..
            } = run.cells
            else {
                panic!("a voxel run")
            };
            let e = estimate(&t, &m, &deps, deps.last().unwrap().time, 1.0, 0, 1);
            let counted = e.cells - e.plate_cells;
            let laid = metal_m3 / 8e-9;
            assert!(
                (counted / laid - 1.0).abs() < 0.1,
                "{} deposits: {counted} cells counted, {laid} laid",
                deps.len()
            );
            assert!(
                (e.cells / voxels as f64 - 1.0).abs() < 0.1,
                "{} voxels counted, {voxels} in the run",
                e.cells
            );
        }
    }

    /// On a GPU the estimate is the same on any number of threads, and its line says whose
    /// pace it is.
    #[test]
    fn a_gpu_estimate_is_the_h200s_pace() {
        let deps = thermal::schedule::helix(0.05, 60, 10, 0.0018, 0.005, 0.01, 2000.0);
        let t = ThermalSettings {
            model: ThermalModel::Voxel,
            voxel_m: 2e-3,
            plate_m: [0.2, 0.2, 0.01],
            plate_fit: false,
            device: thermal::voxel::Device::Gpu,
            ..ThermalSettings::default()
        };
        let m = thermal::material::Material::g3si();
        let gpu = estimate(&t, &m, &deps, 1000.0, 1.0, 0, 1);
        assert_eq!(gpu, estimate(&t, &m, &deps, 1000.0, 1.0, 0, 16));
        assert!(gpu.line().contains("H200"), "{}", gpu.line());
        let cpu = ThermalSettings {
            device: thermal::voxel::Device::Cpu,
            ..t
        };
        let cpu = estimate(&cpu, &m, &deps, 1000.0, 1.0, 0, 1);
        assert!(!cpu.line().contains("H200"), "{}", cpu.line());
        assert!(cpu.seconds != gpu.seconds && cpu.steps == gpu.steps);
    }

    /// A plate no machine could step (10 m square of 0.5 mm cells, 4e8 columns) is counted as
    /// the uniform grid, without laying its columns out, and refused on its memory.
    #[test]
    fn a_huge_thin_wall_plate_is_counted_without_laying_it_out() {
        let deps = thermal::schedule::helix(0.2, 600, 2, 0.0018, 0.005, 0.01, 2000.0);
        let t = ThermalSettings {
            model: ThermalModel::ThinWall,
            plate_m: [10.0, 10.0, 0.01],
            plate_cell_m: 5e-4,
            plate_fit: false,
            ..ThermalSettings::default()
        };
        let m = thermal::material::Material::g3si();
        let e = estimate(&t, &m, &deps, 1e4, 1.0, 0, 1);
        assert_eq!(e.plate_cells, 4e8 * PLATE_LAYERS as f64);
        assert!(e.bytes > 1e11, "{e:?}");
    }

    /// The thin wall with local steps: the near set at every deposit and a few steps a node
    /// and layer, below every node at every deposit (a third of it as measured at R 200 on the
    /// uniform plate; 0.55 here, where merging the plate's far columns took 30 000 cells to
    /// 15 123 and with them most of what every node at every deposit costs); the layers
    /// counted down the chain of supports.
    #[test]
    fn local_steps_cost_the_near_set_and_each_nodes_own_steps() {
        let deps = thermal::schedule::helix(0.2, 600, 40, 0.0018, 0.005, 0.01, 2000.0);
        assert_eq!(layers(&deps), 40.0);
        let t = ThermalSettings {
            model: ThermalModel::ThinWall,
            plate_m: [0.5, 0.5, 0.01],
            plate_fit: false,
            ..ThermalSettings::default()
        };
        let m = thermal::material::Material::g3si();
        let local = estimate(&t, &m, &deps, 1e4, 1.0, 0, 1);
        let every = estimate(
            &ThermalSettings {
                local_steps: false,
                ..t
            },
            &m,
            &deps,
            1e4,
            1.0,
            0,
            1,
        );
        assert_eq!(local.cells, every.cells);
        let near = NEAR_SET * (LOCAL_NEAR_M / t.node_m).powi(2);
        let want = (24_000.0 * near + local.cells * FAR_STEPS_PER_NODE_LAYER * 40.0)
            * LOCAL_NS_PER_STEP
            * (local.cells / LOCAL_NS_NODES).powf(LOCAL_NS_GROWTH)
            * 1e-9;
        assert!((local.seconds / want - 1.0).abs() < 1e-12, "{local:?}");
        assert!(local.seconds < 0.6 * every.seconds, "{local:?} {every:?}");

        // The reference's uniform plate: 100 × 100 columns of 5 mm, three layers.
        let uniform = ThermalSettings {
            merge_plate: false,
            ..t
        };
        let uniform = estimate(&uniform, &m, &deps, 1e4, 1.0, 0, 1);
        assert_eq!(uniform.plate_cells, 30_000.0);
        assert_eq!(local.plate_cells, 15_123.0);
    }

    /// The thin wall's count of node steps against the steps its model takes on a dome it was
    /// not fitted to (R 40, 40 points a layer, the plate merged; 4 425 nodes, half of them
    /// within a near set): the count was 0.66 to 1.14 of the steps on fourteen of the project's
    /// parts, 2.6 on the quarter torus, whose 3 038 nodes are fewer than a near set
    /// (docs/PERFORMANCE.md "Cost estimates"); 1.21 here.
    #[test]
    fn the_thin_walls_count_meets_its_models_node_steps() {
        let b = crate::pipeline::test_parts::dome(40.0, "");
        let t = &b.params.thermal;
        assert!(t.local_steps && t.merge_plate);
        let e = estimate(
            t,
            &crate::pipeline::deposition::material(&b.params.material, t),
            b.deposits(),
            b.deposits().last().unwrap().time,
            1.0,
            0,
            1,
        );
        let r = b
            .simulate(&vec![0.0; b.plan.points.len()], 0)
            .unwrap()
            .result;
        let thermal::Cells::ThinWall { node_steps, .. } = r.cells else {
            panic!("{:?}", r.cells)
        };
        let ratio = e.updates / node_steps as f64;
        assert!((0.6..1.5).contains(&ratio), "{e:?} against {node_steps}");
    }

    /// A step's time per cell grows with the part: a thin-wall node step as a power of the
    /// nodes; a voxel-step flat while the step's state stays cached, growing past it.
    #[test]
    fn a_cells_step_takes_longer_on_a_larger_part() {
        assert!(local_ns_per_step(LOCAL_NS_NODES) == LOCAL_NS_PER_STEP);
        let ten = local_ns_per_step(10.0 * LOCAL_NS_NODES) / LOCAL_NS_PER_STEP;
        assert!((ten - 10f64.powf(LOCAL_NS_GROWTH)).abs() < 1e-12);
        assert!(voxel_ns_per_step(1e3) == VOXEL_NS_PER_STEP);
        assert!(voxel_ns_per_step(VOXEL_CACHED) == VOXEL_NS_PER_STEP);
        let three = voxel_ns_per_step(3.0 * VOXEL_CACHED) / VOXEL_NS_PER_STEP;
        assert!((three - 3f64.powf(VOXEL_UNCACHED_GROWTH)).abs() < 1e-12);
    }
}
