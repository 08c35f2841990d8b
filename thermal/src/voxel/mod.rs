//! The voxel model: 3-D finite differences on a uniform grid, the reference for local detail and
//! for checking the thin-wall model. Only active voxels (deposited metal and the plate) are
//! stored, each with its six neighbours; a step visits the active set alone. Explicit in time at
//! the stability limit, f32 state, enthalpy update (latent heat included) with conduction on the
//! Kirchhoff potential (`kernel`), fixed chunks of the active set shared by threads (`team`,
//! the same arithmetic on one thread or two); the same tasks read the laid metal's peaks
//! (`watch`). Beads settle on what they lie on and switch their cells on (`lay`). The arc's heat
//! is a Goldak double ellipsoid (Goldak, Chakravarti, Bibby 1984), cut at three semi-axes and
//! scaled so that its discrete sum is exactly the heat of the segment (`source`). The laid
//! metal is read where a preheat, a pool or a peak asks (`metal`), and a run goes one deposit
//! at a time through the heat-model contract (`run`). The plate may be of its own material
//! (`substrate`): its voxels come first in the active set and step with its tables; the faces
//! where deposit meets plate are corrected after each step to a conductance in series. Away
//! from the metal laid on it, the plate may be coarsened (`VoxelSettings::coarse_plate`):
//! blocks of 2 × 2 × 2 cells, switched on before anything else, step as cells of edge 2·dx,
//! and meet cells of edge dx across `seams` (docs/PHYSICS.md "A coarsened plate").

mod coarse;
#[cfg(feature = "gpu")]
mod gpu;
mod kernel;
mod lay;
mod metal;
mod run;
mod source;
mod team;
mod vec3;
mod watch;

#[cfg(feature = "gpu")]
use gpu::Read;
/// What a read of the device brings back (none without the `gpu` feature).
#[cfg(not(feature = "gpu"))]
#[derive(Clone, Copy)]
#[allow(dead_code)]
enum Read {
    Sums,
    Temperatures,
    All,
}

use crate::error::ThermalError;
use crate::material::Material;
use crate::network::{Ledger, SIGMA, Surroundings};
use crate::run::{HeatRun, Plate, PointResult, RunResult, replay};
use crate::schedule::{Deposit, validate};
use kernel::{Chunk, Coefficients, Geometry, Group, Tables};
use rustc_hash::FxHashMap as HashMap;
use std::ops::Range;
use std::sync::{Mutex, OnceLock};
use watch::{Pieces, Runs, Watch, mean_of, watch_points};

use coarse::fine_columns;
use lay::settle;
pub use run::VoxelRun;

/// Active voxels per chunk: the unit of the ledger's partial sums, so results do not depend on
/// how chunks are spread over threads.
const CHUNK: usize = 4096;

/// A chunk's share of a step: its slices of h, T and the next Φ, and its piece of the watch
/// (`watch::Pieces`), taken by the thread that steps it.
type Slices<'s> = (
    &'s mut [f32],
    &'s mut [f32],
    &'s mut [f32],
    (usize, &'s mut [PointResult]),
);
/// A step over fewer than twice this many chunks runs as one task: it costs less than handing
/// work to another thread (measured: a 16 000-voxel set ran slower on two threads than on one).
const CHUNKS_PER_TASK: usize = 4;
/// Deposits a thread takes at least when their peaks are read after a step (`observe`); few
/// in tests, so that their runs of a few hundred deposits share it.
const OBSERVED_PER_TASK: usize = if cfg!(test) { 16 } else { 1024 };

/// Chunks per task of a step over `chunks` chunks on `threads` threads: one task on one thread
/// or for a set under 2·`CHUNKS_PER_TASK` chunks; else one chunk a task, shared out by `team`
/// (each thread from its own end of the set), so that a thread done early takes the other's
/// next. Cut by count into a few pieces, the threads' shares cost unequal time: the plate's
/// voxels, first in the active set, step in regular groups of eight, the deposit's by scalar
/// loads of their neighbours (docs/PERFORMANCE.md, "Two cores"; eight tasks a thread measured
/// slower than one chunk a task).
fn chunks_per_task(chunks: usize, threads: usize) -> usize {
    match threads < 2 || chunks < 2 * CHUNKS_PER_TASK {
        true => chunks.max(1),
        false => 1,
    }
}

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct VoxelSettings {
    pub material: Material,
    pub surroundings: Surroundings,
    pub plate: Plate,
    /// Voxel edge, m.
    pub size: f64,
    pub deposit_temperature: f64,
    pub lead: f64,
    /// Temperature for the time-above-threshold count, K.
    pub hot_threshold: f64,
    /// Times at which to keep the field, s (ascending).
    pub snapshot_times: Vec<f64>,
    /// Deposits whose metal's temperature is kept at every step from when it is laid: a
    /// history finer than the snapshots, which shows every pass of the torch.
    pub traces: Vec<usize>,
    /// Watch the laid metal at every step: each deposit's peak and time above `hot_threshold`
    /// (`PointResult::peak`, `time_above`) and the hottest of it ([`crate::run::Hottest`]),
    /// what `simulate` writes. Off where nothing reads them (the dwell search, replays,
    /// calibration, the live twin): the peaks and times above are then NaN, not read. On a
    /// grid of many small deposits the watch is a sixth of the run (the ORNL pad followed
    /// live: docs/PERFORMANCE.md, "CI time").
    pub watch_metal: bool,
    /// Stability margin on the explicit step (≤ 1).
    pub courant: f64,
    /// Points whose temperature is kept ([`crate::run::ProbeTrace`]), m.
    pub probes: Vec<[f64; 3]>,
    /// Least time between two kept probe samples, s (0: every step).
    pub probe_every: f64,
    /// How a deposit's heat enters the part.
    pub source: HeatSource,
    /// Merge the plate's cells two by two by two (edge 2·`size`) away from where metal is laid
    /// on it (`coarse`): the plate is most of the cells under a small part, and far from the
    /// arc its field varies slowly. Off: every plate cell of edge `size`.
    #[serde(default)]
    pub coarse_plate: bool,
    /// Where the steps run: the CPU, or a GPU through wgpu (the `gpu` feature).
    #[serde(default)]
    pub device: Device,
}

/// Where the voxel model steps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, serde::Serialize, serde::Deserialize)]
pub enum Device {
    /// Rayon over the active set, with the AVX2 kernel where the processor has it.
    #[default]
    Cpu,
    /// A GPU's compute shaders (`gpu.wgsl`), f32 state as on the CPU.
    Gpu,
}

/// How the heat of a deposit enters the part.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub enum HeatSource {
    /// Goldak's double ellipsoid sized by the bead: the arc's, heating through the pool.
    #[default]
    DoubleEllipsoid,
    /// A Gaussian flux of 1/e² radius `radius` (m) on the exposed tops around the pool, within
    /// a layer of it: a laser's, absorbed at the surface (q = 2P/(πR²)·exp(−2r²/R²), cut at 2R
    /// and normalised over the voxels it falls on).
    Gaussian { radius: f64 },
}

#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub struct VoxelModel {
    settings: VoxelSettings,
    tables: Tables,
    origin: [f64; 3],
    dims: [usize; 3],
    /// Grid cell → active index.
    index: HashMap<usize, u32>,
    cell: Vec<usize>,
    /// Per face (−x, +x, −y, +y, −z, +z), each voxel's neighbour across it; a face with no
    /// active neighbour points at the voxel itself, so that its flux Φ_v − Φ_v is zero without
    /// a branch. Invariant the kernel relies on: every entry is an active index (voxels are only
    /// ever added, and an entry is written when both its voxels exist).
    neighbours: [Vec<u32>; 6],
    /// Exposed-area weight of each of the six faces, |n_face·n_wall| + |n_face·axis| for bead
    /// voxels (1 for the plate): a voxelised wall at angle θ has a staircase surface of
    /// (|cos θ| + |sin θ|) times the wall's area; weighted faces add up to the wall's own area.
    face_weight: Vec<[f32; 6]>,
    /// Per voxel: weighted area of its faces without neighbour (convection, radiation), m².
    exposed: Vec<f32>,
    /// Per voxel: area on the table (the plate's bottom face), m².
    on_table: Vec<f32>,
    /// The voxels eight by eight as the vector kernel reads them, derived from `neighbours` and
    /// `on_table` (refreshed whenever an entry of a whole group changes).
    groups: Vec<Group>,
    /// State: specific enthalpy (J/kg), temperature (K) and Kirchhoff potential (W/m), the last
    /// double-buffered because neighbours read it.
    h: Vec<f32>,
    t: Vec<f32>,
    phi: Vec<f32>,
    phi_next: Vec<f32>,
    ledger: Ledger,
    h_ambient: f64,
    /// Per deposit: the voxels it switched on.
    laid: Vec<Vec<u32>>,
    /// The deposits that switched a voxel on, ascending: where a walk back along the path
    /// finds metal of a deposit's own (`pool`, `metal_t`) without visiting every deposit that
    /// laid none (a path cut finer than the voxels: most of them).
    filled: Vec<u32>,
    /// Per deposit, along its build direction from its path point: how far down what it lies
    /// on is, and how far down its metal's top is (`settle`).
    below: Vec<f64>,
    sink: Vec<f64>,
    plate_top: HashMap<(usize, usize), u32>,
    updates: u64,
    steps: usize,
    /// The processor runs the AVX2 kernel: asked of the processor a run resumes on, never
    /// taken from a saved state.
    #[serde(skip, default = "kernel::simd_available")]
    simd: bool,
    /// Active voxels 0..plate_voxels are the plate's (it is switched on first).
    plate_voxels: usize,
    /// The plate's own material, where it has one.
    substrate: Option<Box<Substrate>>,
    /// Active voxels 0..coarse are coarse plate cells, edge 2·dx (`coarse`); all of them are
    /// switched on before any cell of edge dx, so a cell of edge dx meets a coarse one only
    /// across a `seam`.
    coarse: usize,
    /// (coarse cell, cell of edge dx of the same material) across one face of the smaller:
    /// conducted before the kernel (`VoxelModel::seams`), which sees no neighbour there.
    seams: Vec<(u32, u32)>,
    /// The same where the cell of edge dx is deposit on a plate of its own material.
    mixed_seams: Vec<(u32, u32)>,
    /// The coarse cells' own rate (`coarse_due`): each coarse cell's conductance to its
    /// neighbours, in metres (the area over the distance of each face, a seam's in series),
    /// their largest, and the time since the coarse cells were last stepped (s).
    coarse_g: Vec<f32>,
    coarse_g_max: f32,
    coarse_behind: f64,
    /// The largest diffusivity of the coarse cells' material, m²/s, and the stable step of the
    /// cells of edge dx ([`VoxelModel::stable_step`]), s: what the coarse cells' period is
    /// held to.
    coarse_alpha: f64,
    fine_step: f64,
    /// The coarse cells stepped at their own rate (false: at every step, the reference the
    /// tests hold them to).
    coarse_own_rate: bool,
    /// On a GPU: the voxels the host changed since the device last took them (switched on,
    /// a face closed, a temperature put).
    #[serde(skip)]
    dirty: Vec<u32>,
    /// Deposits 0..n's voxels as runs of the active set (`laid`'s lists, each a run, one after
    /// another in laying order), for the step to read each deposit's metal in the chunk that
    /// holds it (`Watch`); taken from `laid` as deposits are watched, so none in a saved state.
    #[serde(skip)]
    runs: Runs,
    /// On a GPU: the device's copy of the active set; none in a clone or a resumed run, which
    /// make their own from the host's copy.
    #[cfg(feature = "gpu")]
    #[serde(skip)]
    field: gpu::Lane,
}

/// A plate of another material than the deposit: its tables, and the faces where the two meet.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
struct Substrate {
    material: Material,
    tables: Tables,
    h_ambient: f64,
    /// (plate voxel, deposit voxel) across a face, in the order they met.
    interface: Vec<(u32, u32)>,
}

/// A chunk of the active set cut at `bounds` (where the coarse cells end, where the plate's
/// end): each span with its region (0 coarse, 1 the plate's cells of edge dx, 2 the deposit's).
/// After a cut, the voxels up to the next multiple of 8 make a span of their own, so that the
/// rest starts a group of eight. A chunk inside one region is one span.
fn spans(r: std::ops::Range<usize>, bounds: [usize; 2]) -> Vec<(std::ops::Range<usize>, usize)> {
    let mut out = Vec::new();
    let mut start = r.start;
    while start < r.end {
        let region = bounds.iter().filter(|&&b| b <= start).count();
        let next = bounds
            .iter()
            .copied()
            .filter(|&b| b > start)
            .min()
            .map_or(r.end, |b| b.min(r.end));
        let end = match start % 8 {
            0 => next,
            _ => start.next_multiple_of(8).min(next),
        };
        out.push((start..end, region));
        start = end;
    }
    out
}

/// A member's place in a batch on the device ([`share_device`]), held by the thread that runs
/// it.
#[cfg(feature = "gpu")]
pub use gpu::Seat;
#[cfg(not(feature = "gpu"))]
pub struct Seat(());

/// Put `models` on the GPU as one batch, where they step there (`device = Gpu`): one dispatch
/// steps them all, and each must then run on a thread of its own holding its seat, through
/// the same calls as the others (runs of one program on one grid that differ in their state,
/// their arc's heat and their losses: the members of an ensemble). None where they run
/// otherwise (the CPU, a build without the `gpu` feature, fewer than two, no adapter: a run
/// that needs one says so at its first call).
pub fn share_device(models: &mut [&mut VoxelModel]) -> Option<Vec<Seat>> {
    if models.len() < 2 || models.iter().any(|m| m.settings.device != Device::Gpu) {
        return None;
    }
    #[cfg(feature = "gpu")]
    {
        gpu::share(models).ok()
    }
    #[cfg(not(feature = "gpu"))]
    None
}

/// Whether the voxel model can step on the device `s` asks for: a GPU needs the `gpu` feature,
/// an adapter, and a plate of one cell size.
fn open_device(s: &VoxelSettings) -> Result<(), ThermalError> {
    if s.coarse_plate {
        return Err(ThermalError::Device {
            reason: "the coarsened plate (coarse_plate = true) steps on the CPU alone; set it \
                     false with the GPU"
                .into(),
        });
    }
    #[cfg(feature = "gpu")]
    {
        gpu::shared()
            .map(|_| ())
            .map_err(|reason| ThermalError::Device { reason })
    }
    #[cfg(not(feature = "gpu"))]
    Err(ThermalError::Device {
        reason: "this build has no GPU backend: build it with the cargo feature `gpu`".into(),
    })
}

/// The outward axis of each face, up to sign.
const FACE_NORMALS: [[f64; 3]; 6] = [
    [1.0, 0.0, 0.0],
    [1.0, 0.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 1.0, 0.0],
    [0.0, 0.0, 1.0],
    [0.0, 0.0, 1.0],
];

/// The six face directions, in the order of `neighbours`.
const FACES: [(isize, isize, isize); 6] = [
    (-1, 0, 0),
    (1, 0, 0),
    (0, -1, 0),
    (0, 1, 0),
    (0, 0, -1),
    (0, 0, 1),
];

/// The stable explicit step of cells of edge `dx` of material `m`: dx²/(6·α_max), α_max the
/// largest diffusivity over the material's temperatures ([`Material::fastest_diffusivity`]),
/// times `courant` (< 1: the margin that also covers the surface losses, a few per cent of
/// the conduction's rate at 1–2 mm; docs/PHYSICS.md "Voxel model").
pub fn stable_step(m: &Material, dx: f64, courant: f64) -> f64 {
    courant * dx * dx / (6.0 * m.fastest_diffusivity())
}

impl VoxelModel {
    pub fn new(deps: &[Deposit], s: &VoxelSettings) -> Result<VoxelModel, ThermalError> {
        validate(deps)?;
        let dx = s.size;
        let p = &s.plate;
        let mut lo = [
            p.centre[0] - p.size[0] / 2.0,
            p.centre[1] - p.size[1] / 2.0,
            -p.size[2],
        ];
        let mut hi = [
            p.centre[0] + p.size[0] / 2.0,
            p.centre[1] + p.size[1] / 2.0,
            0.0,
        ];
        for d in deps {
            for k in 0..3 {
                lo[k] = lo[k].min(d.position[k] - 2.0 * d.width);
                hi[k] = hi[k].max(d.position[k] + 2.0 * d.width);
            }
        }
        // Align the grid so that z = 0 (the plate's top) is a cell boundary.
        lo[2] = (lo[2] / dx).floor() * dx;
        let dims: [usize; 3] = std::array::from_fn(|k| ((hi[k] - lo[k]) / dx).ceil() as usize + 1);
        let (below, sink) = settle(deps);
        let mut settings = s.clone();
        settings.snapshot_times.sort_by(f64::total_cmp);
        let mut m = VoxelModel {
            settings,
            tables: Tables::new(&s.material, s.surroundings.ambient_k),
            origin: lo,
            dims,
            index: HashMap::default(),
            cell: vec![],
            neighbours: Default::default(),
            face_weight: vec![],
            exposed: vec![],
            on_table: vec![],
            groups: vec![],
            h: vec![],
            t: vec![],
            phi: vec![],
            phi_next: vec![],
            ledger: Ledger::default(),
            h_ambient: s.material.enthalpy(s.surroundings.ambient_k),
            laid: vec![Vec::new(); deps.len()],
            filled: Vec::new(),
            below,
            sink,
            plate_top: HashMap::default(),
            updates: 0,
            steps: 0,
            simd: kernel::simd_available(),
            // Every voxel added until the plate is whole is the plate's.
            plate_voxels: usize::MAX,
            substrate: p.material.as_ref().map(|material| {
                Box::new(Substrate {
                    tables: Tables::new(material, s.surroundings.ambient_k),
                    h_ambient: material.enthalpy(s.surroundings.ambient_k),
                    material: material.clone(),
                    interface: Vec::new(),
                })
            }),
            coarse: 0,
            seams: Vec::new(),
            mixed_seams: Vec::new(),
            coarse_g: Vec::new(),
            coarse_g_max: 0.0,
            coarse_behind: 0.0,
            coarse_alpha: p
                .material
                .as_ref()
                .unwrap_or(&s.material)
                .fastest_diffusivity(),
            fine_step: 0.0,
            coarse_own_rate: true,
            dirty: Vec::new(),
            runs: Runs::default(),
            #[cfg(feature = "gpu")]
            field: Default::default(),
        };
        if s.device == Device::Gpu {
            open_device(s)?;
        }
        // The plate: every cell whose centre lies inside it; or, coarsened, every block of
        // 2 × 2 × 2 cells inside it (on a box all its cells' centres, on a disc its own), but
        // under the metal laid on the plate (`fine_columns`), then the cells left.
        let k_plate = (p.size[2] / dx).round() as usize;
        let z0 = ((0.0 - lo[2]) / dx).round() as usize; // first cell above the plate
        let bottom_z = z0.saturating_sub(k_plate);
        let inside = |c: [f64; 3]| {
            let (ox, oy) = (c[0] - p.centre[0], c[1] - p.centre[1]);
            match p.disc {
                true => ox.hypot(oy) <= p.size[0] / 2.0,
                false => ox.abs() <= p.size[0] / 2.0 && oy.abs() <= p.size[1] / 2.0,
            }
        };
        if s.coarse_plate {
            m.coarse = usize::MAX;
            let fine = fine_columns(deps, &m);
            // Block layers from the plate's bottom up (a plate of an odd number of cells keeps
            // its top layer of edge dx), switched on in grid order: consecutive blocks are
            // neighbours in x, so that the kernel's groups are regular.
            let layers = (z0 - bottom_z) / 2;
            for b in 0..layers {
                let iz = bottom_z + 2 * b;
                let top = iz + 2 == z0;
                for by in 0..m.dims[1] / 2 {
                    for bx in 0..m.dims[0] / 2 {
                        // On a box, whole blocks only: its edges run along the grid, so the
                        // cells left are at most a column a side, and the plate is the uncut
                        // one's (a block whose centre alone was inside made a box of an odd
                        // number of cells a cell wider on one side). A disc's rim is a
                        // staircase either way: a block is taken where its centre is inside,
                        // as cells of edge dx along all of it cost more than they read
                        // (docs/PHYSICS.md "A coarsened plate").
                        let take = match p.disc {
                            true => inside(m.centre(2 * bx, 2 * by, iz).map(|x| x + dx / 2.0)),
                            false => {
                                (0..4).all(|q| inside(m.centre(2 * bx + q % 2, 2 * by + q / 2, iz)))
                            }
                        };
                        if take && !(b + 1 == layers && fine.contains(&(bx, by))) {
                            let corner = [2 * bx, 2 * by, iz];
                            m.add_coarse(corner, s.surroundings.ambient_k, b == 0, top);
                        }
                    }
                }
            }
            m.coarse = m.cell.len();
        }
        for iz in bottom_z..z0 {
            for iy in 0..dims[1] {
                for ix in 0..dims[0] {
                    if inside(m.centre(ix, iy, iz)) && !m.index.contains_key(&m.flat(ix, iy, iz)) {
                        let bottom = iz == bottom_z;
                        let v = m.add([ix, iy, iz], s.surroundings.ambient_k, [1.0; 6], bottom);
                        if iz == z0 - 1 {
                            m.plate_top.insert((ix, iy), v);
                        }
                    }
                }
            }
        }
        m.plate_voxels = m.cell.len();
        m.ledger.deposited = 0.0;
        m.fine_step = m.stable_step_of_cells();
        Ok(m)
    }

    /// Whether a step reads the laid metal's peaks (the settings' `watch_metal`; always on a
    /// GPU, where the device reads them alongside its step).
    fn watches(&self) -> bool {
        self.settings.watch_metal || self.settings.device == Device::Gpu
    }

    /// Whether voxel v is of the plate's own material.
    fn of_substrate(&self, v: u32) -> Option<&Substrate> {
        self.substrate
            .as_deref()
            .filter(|_| (v as usize) < self.plate_voxels)
    }

    /// The material, tables, ambient enthalpy and mass of voxel v.
    fn material_of(&self, v: u32) -> (&Material, &Tables, f64, f64) {
        let cells = if (v as usize) < self.coarse { 8.0 } else { 1.0 };
        let cube = cells * self.settings.size.powi(3);
        match self.of_substrate(v) {
            Some(s) => (
                &s.material,
                &s.tables,
                s.h_ambient,
                s.material.density * cube,
            ),
            None => (
                &self.settings.material,
                &self.tables,
                self.h_ambient,
                cells * self.mass(),
            ),
        }
    }

    fn centre(&self, ix: usize, iy: usize, iz: usize) -> [f64; 3] {
        let dx = self.settings.size;
        [
            self.origin[0] + (ix as f64 + 0.5) * dx,
            self.origin[1] + (iy as f64 + 0.5) * dx,
            self.origin[2] + (iz as f64 + 0.5) * dx,
        ]
    }

    fn flat(&self, ix: usize, iy: usize, iz: usize) -> usize {
        (iz * self.dims[1] + iy) * self.dims[0] + ix
    }

    /// The active index of the cell one face away from `cell`, if that cell is active.
    fn neighbour(&self, cell: [usize; 3], face: usize) -> Option<u32> {
        let (dx, dy, dz) = FACES[face];
        let c = [
            cell[0] as isize + dx,
            cell[1] as isize + dy,
            cell[2] as isize + dz,
        ];
        if (0..3).any(|k| c[k] < 0 || c[k] >= self.dims[k] as isize) {
            return None;
        }
        let f = self.flat(c[0] as usize, c[1] as usize, c[2] as usize);
        self.index.get(&f).copied()
    }

    /// Switch on a cell at temperature `temp` with the given face weights; `bottom` puts its
    /// −z face on the table. Returns its active index (the existing one if already active).
    fn add(&mut self, cell: [usize; 3], temp: f64, weights: [f32; 6], bottom: bool) -> u32 {
        let f = self.flat(cell[0], cell[1], cell[2]);
        if let Some(&v) = self.index.get(&f) {
            return v;
        }
        let v = self.cell.len() as u32;
        let area = (self.settings.size * self.settings.size) as f32;
        self.index.insert(f, v);
        self.cell.push(f);
        let mut exposed = 0.0;
        let mut touched = [v; 6];
        let plate = (v as usize) < self.plate_voxels;
        for face in 0..6 {
            match self.neighbour(cell, face) {
                // A coarse cell across the face: a seam, which the kernel does not see.
                Some(u) if (u as usize) < self.coarse => {
                    let dx = self.settings.size;
                    match self.substrate.is_some() && !plate {
                        true => {
                            self.mixed_seams.push((u, v));
                            self.conduct_coarse(u, dx);
                        }
                        false => {
                            self.seams.push((u, v));
                            self.conduct_coarse(u, dx / 1.5);
                        }
                    }
                    self.neighbours[face].push(v);
                    self.exposed[u as usize] -= area;
                }
                Some(u) => {
                    touched[face] = u;
                    if let Some(s) = self.substrate.as_deref_mut()
                        && plate != ((u as usize) < self.plate_voxels)
                    {
                        s.interface.push(if plate { (v, u) } else { (u, v) });
                    }
                    self.neighbours[face].push(u);
                    // The neighbour's face toward v is face ^ 1; it is no longer exposed.
                    self.neighbours[face ^ 1][u as usize] = v;
                    self.exposed[u as usize] -= area * self.face_weight[u as usize][face ^ 1];
                }
                None if face == 4 && bottom => self.neighbours[face].push(v),
                None => {
                    self.neighbours[face].push(v);
                    exposed += area * weights[face];
                }
            }
        }
        self.face_weight.push(weights);
        self.exposed.push(exposed);
        self.on_table.push(if bottom { area } else { 0.0 });
        self.switch_on(v, temp, touched);
        v
    }

    /// Voxel v's state at temperature `temp`, its heat booked as deposited, and the groups of
    /// it and of the voxels it `touched` refreshed.
    fn switch_on(&mut self, v: u32, temp: f64, touched: [u32; 6]) {
        let (material, tables, h_ambient, mass) = self.material_of(v);
        let h = material.enthalpy(temp);
        let (t, phi) = tables.at(h as f32);
        self.ledger.deposited += mass * (h - h_ambient);
        self.h.push(h as f32);
        self.t.push(t);
        self.phi.push(phi);
        self.phi_next.push(phi);
        self.refresh_group(v as usize / 8);
        for u in touched {
            self.refresh_group(u as usize / 8);
        }
        if self.settings.device == Device::Gpu {
            self.dirty.push(v);
            self.dirty.extend(touched.into_iter().filter(|&u| u != v));
        }
    }

    /// Recompute group g from the neighbour lists, if all its eight voxels exist.
    fn refresh_group(&mut self, g: usize) {
        if 8 * g + 8 > self.h.len() {
            return;
        }
        let group = Group::of(&self.neighbours, &self.on_table, 8 * g);
        match self.groups.get_mut(g) {
            Some(old) => *old = group,
            None => self.groups.push(group),
        }
    }

    fn mass(&self) -> f64 {
        self.settings.material.density * self.settings.size.powi(3)
    }

    pub fn active(&self) -> usize {
        self.h.len()
    }

    /// Every active voxel at ambient at once, the heat taken out booked as quenched.
    fn quench(&mut self) {
        for v in 0..self.h.len() {
            let (_, tables, h_ambient, mass) = self.material_of(v as u32);
            let (t, phi) = tables.at(h_ambient as f32);
            self.ledger.quenched += mass * (self.h[v] as f64 - h_ambient);
            self.h[v] = h_ambient as f32;
            self.t[v] = t;
            self.phi[v] = phi;
            self.phi_next[v] = phi;
        }
        self.all_dirty();
    }

    /// Put active voxel `v` at temperature `temp` (K): its enthalpy from its material, T and
    /// Φ from the tables as a step leaves them. The heat this adds (or takes) is booked as
    /// `assimilated`, so the energy balance still closes.
    pub fn set_temperature(&mut self, v: u32, temp: f64) {
        let (material, tables, _, mass) = self.material_of(v);
        let h = material.enthalpy(temp);
        let (t, phi) = tables.at(h as f32);
        let i = v as usize;
        self.ledger.assimilated += mass * (h - self.h[i] as f64);
        self.h[i] = h as f32;
        self.t[i] = t;
        self.phi[i] = phi;
        self.phi_next[i] = phi;
        if self.settings.device == Device::Gpu {
            self.dirty.push(v);
        }
    }

    /// Take convection, emissivity and the table's contact conductance from now on (the
    /// ambient stays: the tables are built on it).
    pub fn set_losses(&mut self, convection_w_m2k: f64, emissivity: f64, table_w_m2k: f64) {
        let s = &mut self.settings.surroundings;
        (s.convection_w_m2k, s.emissivity, s.table_w_m2k) =
            (convection_w_m2k, emissivity, table_w_m2k);
    }

    /// The stable explicit step ([`stable_step`]) of the deposit's material and the plate's
    /// cells of edge dx (the coarse cells step at their own rate: `coarse_due`).
    pub fn stable_step(&self) -> f64 {
        self.fine_step
    }

    fn stable_step_of_cells(&self) -> f64 {
        let one = |m: &Material, dx: f64| stable_step(m, dx, self.settings.courant);
        let dx = self.settings.size;
        let deposit = one(&self.settings.material, dx);
        // A plate of the deposit's material steps at the deposit's limit.
        let plate = match (self.substrate.as_deref(), self.plate_voxels > self.coarse) {
            (Some(s), true) => one(&s.material, dx),
            _ => f64::INFINITY,
        };
        deposit.min(plate).min(self.coarse_period())
    }

    /// The constants of a step of dt: a coarse plate cell's, a plate cell's of edge dx, a
    /// deposit cell's.
    fn coefficients(&self, dt: f64) -> [Coefficients; 3] {
        let sur = self.settings.surroundings;
        let ta = sur.ambient_k as f32;
        let c = Coefficients {
            inv_cap: (dt / self.mass()) as f32,
            dx: self.settings.size as f32,
            ta,
            ta4: ta * ta * ta * ta,
            h_conv: sur.convection_w_m2k as f32,
            eps_sigma: (sur.emissivity * SIGMA) as f32,
            h_table: sur.table_w_m2k as f32,
            area: (self.settings.size * self.settings.size) as f32,
        };
        // A plate of its own material differs in its heat capacity and its tables alone; its
        // coarse cells (edge 2·dx) in their edge, face and heat capacity (8 cells').
        let cp = match self.substrate.as_deref() {
            Some(s) => Coefficients {
                inv_cap: (dt / (s.material.density * self.settings.size.powi(3))) as f32,
                ..c
            },
            None => c,
        };
        let cc = Coefficients {
            inv_cap: cp.inv_cap / 8.0,
            dx: 2.0 * c.dx,
            area: 4.0 * c.area,
            ..c
        };
        [cc, cp, c]
    }

    /// Every voxel to be written to the device again (a lone run's copy dropped, a batch's
    /// member sending all of its voxels: `gpu_all_dirty`).
    fn all_dirty(&mut self) {
        #[cfg(feature = "gpu")]
        self.gpu_all_dirty();
        #[cfg(not(feature = "gpu"))]
        self.dirty.clear();
    }

    /// One explicit step of length dt with `source` watts into the listed voxels: the 7-point
    /// update of h on Φ over the active set, losses from each voxel's exposed and table areas,
    /// then T and Φ from the new h.
    pub fn step(&mut self, dt: f64, source: &[(u32, f32)]) {
        self.step_watched(dt, source, None);
    }

    /// A step (`step`) that also reads the laid metal's peaks and times above (`observe`), each
    /// deposit's in the task that stepped the chunk holding its voxels, while they are in that
    /// core's cache, so that a step hands work to the threads once, not twice; a deposit across
    /// two chunks is read after the step. The same numbers to the bit as `step` then `observe`
    /// (each mean summed in the same order). Returns the hottest laid metal's temperature (NaN
    /// before any is laid, or without a watch).
    fn step_watched(&mut self, dt: f64, source: &[(u32, f32)], watch: Option<Watch>) -> f64 {
        let [cc, cp, c] = self.coefficients(dt);
        // The coarse cells' own step, when they step (`coarse_due`).
        let coarse_dt = self.coarse_due(dt);
        let cc_own = coarse_dt.map(|dt| self.coefficients(dt)[0]);
        let (coarse, plate_voxels) = (self.coarse, self.plate_voxels);
        let inv_cap = |v: usize| match v {
            v if v < coarse => cc.inv_cap,
            v if v < plate_voxels => cp.inv_cap,
            _ => c.inv_cap,
        };
        let mut q = 0.0;
        for &(v, w) in source {
            self.h[v as usize] += inv_cap(v as usize) * w;
            q += w as f64;
        }
        self.seams([cc.inv_cap, cp.inv_cap, c.inv_cap]);
        // The interface's temperatures as the step starts (the kernel overwrites them).
        let before: Vec<[f32; 2]> = self.substrate.as_deref().map_or(Vec::new(), |s| {
            s.interface
                .iter()
                .map(|&(i, j)| [self.t[i as usize], self.t[j as usize]])
                .collect()
        });
        let (phi, simd) = (&self.phi, self.simd);
        let (nb, groups) = (&self.neighbours, &self.groups);
        debug_assert_eq!(groups.len(), self.h.len() / 8);
        let (exposed, table) = (&self.exposed, &self.on_table);
        // Without a plate material the plate's cells of edge dx step as the deposit's.
        let bounds = match self.substrate {
            Some(_) => [coarse, plate_voxels],
            None => [coarse, coarse],
        };
        let plate_tables = self
            .substrate
            .as_deref()
            .map_or(&self.tables, |s| &s.tables);
        let cc_step = cc_own.unwrap_or(cc);
        let regions = [
            (&cc_step, plate_tables),
            (&cp, plate_tables),
            (&c, &self.tables),
        ];
        let chunks = self.h.len().div_ceil(CHUNK);
        let per_task = chunks_per_task(chunks, rayon::current_num_threads());
        let hot = self.settings.hot_threshold;
        // Read after the step: on a plate of another material, whose faces with the deposit
        // are conducted once the chunks are done (`interface`), and deposits not laid as runs
        // (never, as `lay` lays them).
        let (mut watched, mut apart) = (None, None);
        if let Some(w) = watch {
            let cut = match self.substrate {
                None => self.runs.cut(&self.laid, w.laid, chunks),
                Some(_) => None,
            };
            match cut {
                Some(cut) => watched = Some((w, cut)),
                None => apart = Some(w),
            }
        }
        let (pieces, runs): (Pieces, &[Range<u32>]) = match watched {
            Some((ref mut w, ref cut)) => (cut.pieces(&mut w.points[..w.laid]), &self.runs.runs),
            None => ((0..chunks).map(|_| (0, &mut [][..])).collect(), &[]),
        };
        // Each chunk's slices, taken by the thread that steps it, and what it returns, kept by
        // its index (`team`).
        let slices: Vec<Mutex<Option<Slices>>> = self
            .h
            .chunks_mut(CHUNK)
            .zip(self.t.chunks_mut(CHUNK))
            .zip(self.phi_next.chunks_mut(CHUNK))
            .zip(pieces)
            .map(|(((h, t), phi_next), piece)| Mutex::new(Some((h, t, phi_next, piece))))
            .collect();
        // Per chunk: its losses' sums over the coarse cells and over the rest (`Coefficients`),
        // and the hottest metal it watched.
        let stepped: Vec<OnceLock<([[f32; 3]; 2], f64)>> =
            (0..chunks).map(|_| OnceLock::new()).collect();
        let chunk = |k: usize| {
            let taken = slices[k].lock().unwrap_or_else(|e| e.into_inner()).take();
            let (mut h, t_chunk, mut phi_next, (first, points)) =
                taken.expect("each chunk is stepped once");
            let mut sums = [[0.0f32; 3]; 2];
            let mut t = &mut *t_chunk;
            for (r, region) in spans(k * CHUNK..k * CHUNK + h.len(), bounds) {
                let n = r.len();
                let (h_r, h_rest) = std::mem::take(&mut h).split_at_mut(n);
                let (t_r, t_rest) = std::mem::take(&mut t).split_at_mut(n);
                let (p_r, p_rest) = std::mem::take(&mut phi_next).split_at_mut(n);
                (h, t, phi_next) = (h_rest, t_rest, p_rest);
                // Coarse cells not due keep their state; Φ carried to the next buffer.
                if region == 0 && cc_own.is_none() {
                    p_r.copy_from_slice(&phi[r]);
                    continue;
                }
                // Groups start at multiples of 8; a span that does not (the few deposit
                // voxels after the plate's last) goes to the plain kernel.
                let whole = match r.start % 8 {
                    0 => &groups[r.start / 8..(r.end / 8).min(groups.len())],
                    _ => &[],
                };
                let g = Geometry {
                    neighbours: std::array::from_fn(|f| &nb[f][r.clone()]),
                    groups: whole,
                    exposed: &exposed[r.clone()],
                    table: &table[r.clone()],
                };
                let s = Chunk {
                    first: r.start,
                    h: h_r,
                    t: t_r,
                    phi_next: p_r,
                };
                let (c, tables) = regions[region];
                // SAFETY: the neighbour invariant of `VoxelModel::neighbours`; `simd` comes
                // from `simd_available` (or is false).
                let part = unsafe { kernel::update(c, tables, phi, &g, s, simd) };
                let sums = &mut sums[usize::from(region != 0)];
                for (acc, x) in sums.iter_mut().zip(part) {
                    *acc += x;
                }
            }
            let base = (k * CHUNK) as u32;
            let mean = |r: &Range<u32>| {
                mean_of(&t_chunk[(r.start - base) as usize..(r.end - base) as usize])
            };
            let hottest = watch_points(points, &runs[first..], hot, dt, mean);
            let _ = stepped[k].set((sums, hottest));
        };
        match per_task < chunks {
            true => team::step(chunks, &chunk),
            false => (0..chunks).for_each(chunk),
        }
        let partial: Vec<([[f32; 3]; 2], f64)> = stepped
            .into_iter()
            .map(|s| s.into_inner().expect("every chunk is stepped"))
            .collect();
        let mut hottest = partial.iter().map(|p| p.1).fold(f64::NAN, f64::max);
        if let Some((w, cut)) = watched {
            let t = &self.t;
            let mean = |r: &Range<u32>| mean_of(&t[r.start as usize..r.end as usize]);
            for k in cut.across() {
                let one = std::slice::from_mut(&mut w.points[k]);
                hottest = hottest.max(watch_points(one, &self.runs.runs[k..], hot, dt, mean));
            }
        }
        self.interface(&before, cp.inv_cap, c.inv_cap);
        std::mem::swap(&mut self.phi, &mut self.phi_next);
        // The losses' sums weighted by each region's own step: the coarse cells' is the time
        // since their last (0 when they did not step, and nothing summed).
        let mut sums = [0.0f64; 3];
        for (p, _) in &partial {
            for (acc, (coarse_lost, lost)) in sums.iter_mut().zip(p[0].iter().zip(&p[1])) {
                *acc += (*lost as f64) * dt + (*coarse_lost as f64) * coarse_dt.unwrap_or(0.0);
            }
        }
        self.ledger.source += dt * q;
        self.ledger.convection += c.h_conv as f64 * sums[0];
        self.ledger.radiation += c.eps_sigma as f64 * sums[1];
        self.ledger.table += c.h_table as f64 * sums[2];
        self.updates += (self.h.len() - coarse_dt.map_or(self.coarse, |_| 0)) as u64;
        self.steps += 1;
        match apart {
            Some(w) => self.observe(w.laid, dt, w.points),
            None => hottest,
        }
    }

    /// The faces where deposit meets a plate of its own material: the kernel conducted them on
    /// Φ, whose two materials' tables do not share a scale; replace that by two half-voxel
    /// conductances in series, k = 2·k_p·k_d/(k_p + k_d) at the temperatures `before` the step
    /// (`before[n]` of `interface[n]`; Patankar 1980 §4.2-4), the same heat leaving one side as
    /// enters the other, and read T and Φ again where h changed.
    fn interface(&mut self, before: &[[f32; 2]], inv_cap_plate: f32, inv_cap_deposit: f32) {
        let Some(s) = self.substrate.as_deref() else {
            return;
        };
        let dx = self.settings.size;
        for (&(i, j), &[ti, tj]) in s.interface.iter().zip(before) {
            let (i, j) = (i as usize, j as usize);
            let kp = s.material.conductivity(ti as f64);
            let kd = self.settings.material.conductivity(tj as f64);
            let series = 2.0 * kp * kd / (kp + kd);
            let kernel = dx * (self.phi[j] - self.phi[i]) as f64;
            let delta = (dx * series * (tj - ti) as f64 - kernel) as f32;
            self.h[i] += inv_cap_plate * delta;
            self.h[j] -= inv_cap_deposit * delta;
        }
        for &(i, j) in &s.interface {
            let (i, j) = (i as usize, j as usize);
            (self.t[i], self.phi_next[i]) = s.tables.at(self.h[i]);
            (self.t[j], self.phi_next[j]) = self.tables.at(self.h[j]);
        }
    }

    /// Run the schedule as its times say (dwells are the gaps between arcs).
    pub fn run(self, deps: &[Deposit]) -> Result<RunResult, ThermalError> {
        let mut run = VoxelRun::new(self, deps)?;
        replay(&mut run, deps)?;
        Ok(run.finish())
    }
}

#[cfg(test)]
mod tests;
