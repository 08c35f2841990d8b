//! The voxel model's steps on a GPU, through wgpu's compute shaders (Vulkan, Metal, DX12), as
//! `[thermal] device = "gpu"` asks. The host's [`VoxelModel`] stays the model: it lays the
//! metal, places the arc's heat and reads the results; a [`Field`] holds a copy of its active
//! set on the device and steps it (`gpu.wgsl`: the same arithmetic as `kernel.rs`, in f32).
//!
//! One rule keeps the two copies straight: between two calls of the run (a deposit, a cooling)
//! the host's copy is current; within a call the device's is, and the host's is read back at
//! its end and wherever the run must read a temperature in between (a preheat during the arc,
//! a probe or snapshot falling due). A model's [`Lane`] records its steps, each with what the
//! host changed before it (voxels laid, their neighbours' faces, a temperature put by an
//! assimilation, the arc's heat, the losses), and hands them to the device at the next read.
//! The loss sums of the energy ledger are kept per workgroup on the device (Kahan's compensated
//! sum, f32) and summed in f64 when read back; each laid deposit's peak and time above the
//! threshold likewise.
//!
//! A field may hold several members: runs of one program on one grid that differ in their
//! state, their arc's heat and their losses (the members of `follow`'s ensemble). They share
//! the geometry and one dispatch steps them all (`share_device`): each runs on a thread of its
//! own, and at each read the last member to arrive sends every member's steps as one batch
//! ([`Batch`]). Their steps must agree (the same program, the same reads); where they do not,
//! every member's run fails with a message that says so, none waits for ever.
//!
//! Not done on the device: the coarsened plate's seams (`coarse_plate` is refused with the
//! GPU: the device has the throughput that coarsening buys on a CPU). The price of the rule:
//! every call reads the whole field back (12 bytes a voxel), so a run's cost on the device
//! still grows as deposits × voxels, if with a far smaller constant; reading back only the
//! voxels the host asks for would take that out, and needs the host's reads (a clone, a
//! checkpoint written) to come through the device.

use super::VoxelModel;
use crate::error::ThermalError;
use crate::material::Material;
use crate::network::SIGMA;
use crate::run::{Hottest, PointResult};
use bytemuck::{Pod, Zeroable};
use std::sync::{Arc, Condvar, Mutex, OnceLock};
use wgpu::util::DeviceExt;

/// Threads per workgroup: the shader's `WG`.
const WG: usize = 256;
/// Steps recorded before the commands go to the device (and uniform slots in one buffer).
const SLOTS: usize = 256;
/// Bytes between two uniform slots (the largest `min_uniform_buffer_offset_alignment` allowed).
const SLOT_BYTES: u64 = 256;
/// Whole kelvins in the conductivity tables, 0 ..= K_LAST.
const K_LAST: usize = 4000;
/// Storage buffers bound to the shader (bindings 1..=BINDINGS).
const BINDINGS: u32 = 19;
/// A source's voxel that pads a member's list to the longest: the shader skips it.
const NONE: u32 = u32::MAX;

/// The device: one per process, shared by every run (the dwell planner's many).
pub struct Gpu {
    device: wgpu::Device,
    queue: wgpu::Queue,
    /// The adapter's name and backend, as the report gives it.
    pub name: String,
    layout: wgpu::BindGroupLayout,
    pipelines: Pipelines,
    max_workgroups: u32,
    /// The largest storage buffer a shader may bind, bytes.
    max_binding: u64,
}

struct Pipelines {
    scatter: wgpu::ComputePipeline,
    prologue: wgpu::ComputePipeline,
    step: wgpu::ComputePipeline,
    bond: wgpu::ComputePipeline,
    observe: wgpu::ComputePipeline,
}

static SHARED: OnceLock<Result<Arc<Gpu>, String>> = OnceLock::new();

/// The process's device, opened on first use; Err says why none could be (no adapter, too few
/// storage bindings).
pub fn shared() -> Result<Arc<Gpu>, String> {
    SHARED.get_or_init(|| Gpu::open().map(Arc::new)).clone()
}

impl Gpu {
    fn open() -> Result<Gpu, String> {
        let instance = wgpu::Instance::new(wgpu::InstanceDescriptor {
            // WGPU_BACKEND (vulkan, metal, dx12) picks one; by default the three.
            backends: wgpu::Backends::from_env().unwrap_or(wgpu::Backends::PRIMARY),
            ..wgpu::InstanceDescriptor::new_without_display_handle_from_env()
        });
        let adapter = pollster::block_on(instance.request_adapter(&wgpu::RequestAdapterOptions {
            power_preference: wgpu::PowerPreference::HighPerformance,
            ..Default::default()
        }))
        .map_err(|e| format!("no GPU adapter (Vulkan, Metal or DX12) was found: {e}"))?;
        let info = adapter.get_info();
        let limits = adapter.limits();
        if limits.max_storage_buffers_per_shader_stage < BINDINGS {
            return Err(format!(
                "the adapter {} binds {} storage buffers to a compute shader; the voxel model needs {BINDINGS}",
                info.name, limits.max_storage_buffers_per_shader_stage
            ));
        }
        let (device, queue) = pollster::block_on(adapter.request_device(&wgpu::DeviceDescriptor {
            label: Some("waamtwin voxel model"),
            required_limits: limits.clone(),
            ..Default::default()
        }))
        .map_err(|e| format!("the adapter {} gave no device: {e}", info.name))?;
        // A shader or pipeline the device refuses is an error to report, not a panic.
        let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
        let module = device.create_shader_module(wgpu::ShaderModuleDescriptor {
            label: Some("gpu.wgsl"),
            source: wgpu::ShaderSource::Wgsl(include_str!("gpu.wgsl").into()),
        });
        let entry =
            |binding: u32, ty: wgpu::BufferBindingType, dynamic: bool| wgpu::BindGroupLayoutEntry {
                binding,
                visibility: wgpu::ShaderStages::COMPUTE,
                ty: wgpu::BindingType::Buffer {
                    ty,
                    has_dynamic_offset: dynamic,
                    min_binding_size: None,
                },
                count: None,
            };
        let read_only = [7, 8, 10, 11, 13, 14, 18, 19];
        let mut entries = vec![entry(0, wgpu::BufferBindingType::Uniform, true)];
        for b in 1..=BINDINGS {
            let read_only = read_only.contains(&b);
            entries.push(entry(
                b,
                wgpu::BufferBindingType::Storage { read_only },
                false,
            ));
        }
        let layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("voxel field"),
            entries: &entries,
        });
        let pipeline_layout = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("voxel field"),
            bind_group_layouts: &[Some(&layout)],
            immediate_size: 0,
        });
        let pipeline = |name: &str| {
            device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(name),
                layout: Some(&pipeline_layout),
                module: &module,
                entry_point: Some(name),
                compilation_options: Default::default(),
                cache: None,
            })
        };
        let pipelines = Pipelines {
            scatter: pipeline("scatter"),
            prologue: pipeline("prologue"),
            step: pipeline("step"),
            bond: pipeline("bond"),
            observe: pipeline("observe"),
        };
        if let Some(e) = pollster::block_on(scope.pop()) {
            return Err(format!(
                "the adapter {} refused the voxel shader: {e}",
                info.name
            ));
        }
        Ok(Gpu {
            name: format!("{} ({:?})", info.name, info.backend),
            max_workgroups: limits.max_compute_workgroups_per_dimension,
            max_binding: limits
                .max_storage_buffer_binding_size
                .min(limits.max_buffer_size),
            device,
            queue,
            layout,
            pipelines,
        })
    }

    /// Workgroups (x, y) covering `items` threads, wrapped to y past the device's limit.
    fn grid(&self, items: usize) -> (u32, u32) {
        let groups = items.div_ceil(WG).max(1) as u64;
        let x = groups.min(self.max_workgroups as u64);
        (x as u32, groups.div_ceil(x) as u32)
    }
}

/// One step's constants: the shader's `Params`, field for field.
#[repr(C)]
#[derive(Clone, Copy, Default, Pod, Zeroable)]
pub(super) struct Params {
    pub n: u32,
    pub plate_end: u32,
    pub n_sources: u32,
    pub n_pairs: u32,
    pub n_deps: u32,
    pub hot_slot: u32,
    pub n_records: u32,
    pub cap: u32,
    pub dt: f32,
    pub dx: f32,
    pub ta: f32,
    pub ta4: f32,
    pub threshold: f32,
    pub cap_d: f32,
    pub cap_p: f32,
    pub d_h0: f32,
    pub d_inv_dh: f32,
    pub d_last: f32,
    pub p_h0: f32,
    pub p_inv_dh: f32,
    pub p_last: f32,
    pub p_offset: u32,
    pub k_offset: u32,
    pub k_last: f32,
    pub nx: u32,
    pub sy: u32,
    pub sz: u32,
    pub src_cap: u32,
    pub pair_cap: u32,
    pub dep_cap: u32,
    pub acc_stride: u32,
    pub pad: u32,
}

/// A voxel the host wrote: the shader's `Record`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Record {
    v: u32,
    m: u32,
    nb: [u32; 6],
    exposed: f32,
    table: f32,
    h: f32,
    t: f32,
    phi: f32,
}

struct Buffers {
    uniform: wgpu::Buffer,
    nb: wgpu::Buffer,
    area: wgpu::Buffer,
    h: wgpu::Buffer,
    t: wgpu::Buffer,
    phi: [wgpu::Buffer; 2],
    acc: wgpu::Buffer,
    sources: wgpu::Buffer,
    pairs: wgpu::Buffer,
    dep_off: wgpu::Buffer,
    dep_vox: wgpu::Buffer,
    peak: wgpu::Buffer,
    above: wgpu::Buffer,
    hot: wgpu::Buffer,
    records: wgpu::Buffer,
    tables: wgpu::Buffer,
    conductivity: wgpu::Buffer,
    delta: wgpu::Buffer,
    losses: wgpu::Buffer,
}

/// The bind groups of both parities: Φ read from `phi[parity]`, written to the other.
fn groups_of(g: &Gpu, b: &Buffers) -> [wgpu::BindGroup; 2] {
    let group = |parity: usize| {
        let bufs: [&wgpu::Buffer; BINDINGS as usize] = [
            &b.nb,
            &b.area,
            &b.h,
            &b.t,
            &b.phi[parity],
            &b.phi[1 - parity],
            &b.tables,
            &b.conductivity,
            &b.acc,
            &b.sources,
            &b.pairs,
            &b.delta,
            &b.dep_off,
            &b.dep_vox,
            &b.peak,
            &b.above,
            &b.hot,
            &b.records,
            &b.losses,
        ];
        let mut entries = vec![wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                buffer: &b.uniform,
                offset: 0,
                size: wgpu::BufferSize::new(std::mem::size_of::<Params>() as u64),
            }),
        }];
        entries.extend(
            bufs.iter()
                .enumerate()
                .map(|(k, buf)| wgpu::BindGroupEntry {
                    binding: k as u32 + 1,
                    resource: buf.as_entire_binding(),
                }),
        );
        g.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("voxel field"),
            layout: &g.layout,
            entries: &entries,
        })
    };
    [group(0), group(1)]
}

/// What a field was made for, per member: past any of these it is made again (voxels, pairs)
/// or the buffer grows (sources, records).
#[derive(Clone, Copy)]
struct Capacity {
    voxels: usize,
    pairs: usize,
    sources: usize,
    /// All members' together.
    records: usize,
}

/// What one member changed on the host before a step: written to the device before it.
#[derive(Default)]
struct Changes {
    /// Voxels switched on, their neighbours' faces, temperatures put.
    records: Vec<Record>,
    /// Interface pairs appended.
    pairs: Vec<[u32; 2]>,
    /// The voxels of the deposits newly observed.
    laid: Vec<Vec<u32>>,
    /// The arc's heat (voxel, W bits; distinct voxels, as the prologue adds without atomics).
    sources: Option<Vec<[u32; 2]>>,
    /// Convection, εσ and the table's conductance (W/m²K, W/m²K⁴, W/m²K), and a pad.
    losses: Option<[f32; 4]>,
}

/// One step as a member recorded it.
struct Step {
    /// The geometry it stands on (active voxels, interface pairs, deposits on the device): the
    /// members of a batch must agree.
    shape: [usize; 3],
    changes: Option<Changes>,
    p: Params,
}

/// A member's steps since the device was last read, and the read that ends them.
struct Round {
    /// In a batch: the member's host copy, from which the field is made again first.
    remake: Option<(Box<VoxelModel>, Vec<f32>)>,
    steps: Vec<Step>,
    what: Read,
}

/// What a read brings one member: the loss sums (Σ dt·exposed·(T − T_a), Σ dt·exposed·(T⁴ −
/// T_a⁴), Σ dt·table·(T − T_a)), each step's hottest laid metal, and as the read asks the
/// temperatures, or the whole field with the deposits' peaks and times above.
struct Reply {
    h: Vec<f32>,
    t: Vec<f32>,
    phi: Vec<f32>,
    peak: Vec<f32>,
    above: Vec<f32>,
    sums: [f64; 3],
    hot: Vec<f32>,
}

/// The active set of one or more members on the device, and the steps recorded but not yet
/// sent.
pub(super) struct Field {
    gpu: Arc<Gpu>,
    members: usize,
    cap: Capacity,
    /// Deposits in the program: a member's stride in `peak` and `above`.
    dep_cap: usize,
    b: Buffers,
    /// Per parity: Φ read from `phi[parity]`, written to the other.
    groups: [wgpu::BindGroup; 2],
    parity: usize,
    /// A regular voxel's strides across y and z (`area_of`).
    strides: [u32; 2],
    /// Voxels regular when the field was made.
    regular: usize,
    /// Voxels, interface pairs and laid deposits the device has.
    n: usize,
    pairs: usize,
    deps: usize,
    dep_vox: usize,
    /// Per member, the arc's heat the device has; the longest list's length.
    sources: Vec<Vec<[u32; 2]>>,
    n_sources: usize,
    encoder: Option<wgpu::CommandEncoder>,
    /// The read-back buffer, kept between reads.
    staging: Option<wgpu::Buffer>,
    /// Uniforms of the steps recorded since the last submission.
    slots: Vec<Params>,
    /// Workgroups whose loss sums may be non-zero.
    acc_groups: usize,
}

/// What a read back asks, beside the loss sums and the hottest metal.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Read {
    Sums,
    /// The voxels' temperatures: what the host reads within a call (a preheat, a probe, a
    /// snapshot, a trace).
    Temperatures,
    /// The whole field and the deposits' peaks: the host's copy current, as at a call's end.
    All,
}

fn storage(gpu: &Gpu, label: &str, bytes: usize) -> wgpu::Buffer {
    gpu.device.create_buffer(&wgpu::BufferDescriptor {
        label: Some(label),
        size: bytes.max(16).next_multiple_of(4) as u64,
        usage: wgpu::BufferUsages::STORAGE
            | wgpu::BufferUsages::COPY_DST
            | wgpu::BufferUsages::COPY_SRC,
        mapped_at_creation: false,
    })
}

/// A regular voxel's strides across y and z: those of the first plate voxel with all six
/// neighbours and its x neighbours next to it (a box plate is laid in grid order, row by row
/// across the plate, so its inside has one pair of strides); none where no voxel has them.
fn strides(m: &VoxelModel) -> [u32; 2] {
    let nb = &m.neighbours;
    (0..m.plate_voxels.min(m.h.len()))
        .find(|&i| {
            i > 0
                && nb[0][i] as usize == i - 1
                && nb[1][i] as usize == i + 1
                && nb[3][i] as usize > i + 1
                && nb[5][i] > nb[3][i]
        })
        .map_or([u32::MAX; 2], |i| {
            [nb[3][i] - i as u32, nb[5][i] - i as u32]
        })
}

/// Voxel i's (exposed, table) areas for the device: (−1, 0) where it is regular, its six
/// neighbours at i ± 1, i ± sy, i ± sz (`strides`) and nothing exposed (the shader's fast
/// path).
fn area_of(m: &VoxelModel, i: usize, [sy, sz]: [u32; 2]) -> [f32; 2] {
    let (a, b) = (m.exposed[i], m.on_table[i]);
    let (sy, sz) = (sy as i64, sz as i64);
    let step = [-1, 1, -sy, sy, -sz, sz];
    // A face closed after it was counted open leaves its area's rounding (1e-22 m²), not 0.
    let closed = 1e-6 * (m.settings.size * m.settings.size) as f32;
    let regular = a.abs() <= closed
        && b == 0.0
        && (0..6).all(|f| m.neighbours[f][i] as i64 == i as i64 + step[f]);
    if regular { [-1.0, 0.0] } else { [a, b] }
}

fn tables_of(m: &VoxelModel) -> (Vec<[f32; 2]>, Vec<f32>) {
    let plate = m.substrate.as_deref();
    let mut t_phi = m.tables.t_phi.clone();
    t_phi.extend_from_slice(plate.map_or(&m.tables.t_phi, |s| &s.tables.t_phi));
    let k = |mat: &Material| -> Vec<f32> {
        (0..=K_LAST)
            .map(|t| mat.conductivity(t as f64) as f32)
            .collect()
    };
    let mut cond = k(&m.settings.material);
    cond.extend(k(plate.map_or(&m.settings.material, |s| &s.material)));
    (t_phi, cond)
}

/// A model's losses as the shader takes them: h_conv, εσ, h_table (and a pad).
fn losses_of(m: &VoxelModel) -> [f32; 4] {
    let sur = m.settings.surroundings;
    [
        sur.convection_w_m2k as f32,
        (sur.emissivity * SIGMA) as f32,
        sur.table_w_m2k as f32,
        0.0,
    ]
}

fn interface_len(m: &VoxelModel) -> usize {
    m.substrate.as_deref().map_or(0, |s| s.interface.len())
}

impl Field {
    /// A field holding the active sets of `models` (one grid: the first's geometry, each its
    /// own state, losses and the deposits' `peaks` so far), with room to grow.
    fn new(gpu: Arc<Gpu>, models: &[&VoxelModel], peaks: &[&[f32]]) -> Result<Field, ThermalError> {
        let m = models[0];
        let members = models.len();
        let n = m.h.len();
        let pairs = interface_len(m);
        // The neighbour table is the largest buffer shared (24 bytes a voxel); a member's state
        // takes 4 bytes a voxel in each of h, T, Φ (two).
        let most = ((gpu.max_binding / 24) as usize).min((gpu.max_binding / 4) as usize / members);
        if n > most {
            return Err(ThermalError::Device {
                reason: format!(
                    "{members} × {n} voxels need {} MB buffers; the adapter {} binds at most {} MB",
                    (24 * n as u64).max(4 * (members * n) as u64) / 1_000_000,
                    gpu.name,
                    gpu.max_binding / 1_000_000
                ),
            });
        }
        let cap = Capacity {
            voxels: (2 * n).max(1 << 16).min(most),
            pairs: (2 * pairs).max(1024),
            sources: 4096,
            records: 1 << 14,
        };
        let g = &*gpu;
        let (t_phi, cond) = tables_of(m);
        let init = |label: &str, contents: &[u8]| {
            g.device
                .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                    label: Some(label),
                    contents,
                    usage: wgpu::BufferUsages::STORAGE,
                })
        };
        let deps = m.laid.len();
        let state = |label: &str| storage(g, label, 4 * members * cap.voxels);
        let b = Buffers {
            uniform: g.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("params"),
                size: SLOTS as u64 * SLOT_BYTES,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            nb: storage(g, "nb", 24 * cap.voxels),
            area: storage(g, "area", 8 * cap.voxels),
            h: state("h"),
            t: state("t"),
            phi: [state("phi 0"), state("phi 1")],
            acc: storage(g, "acc", 24 * members * cap.voxels.div_ceil(WG)),
            sources: storage(g, "sources", 8 * members * cap.sources),
            pairs: storage(g, "pairs", 8 * cap.pairs),
            dep_off: storage(g, "dep_off", 4 * (deps + 1)),
            dep_vox: storage(g, "dep_vox", 4 * cap.voxels),
            peak: storage(g, "peak", 4 * members * deps),
            above: storage(g, "above", 4 * members * deps),
            hot: storage(g, "hot", 4 * members * SLOTS),
            records: storage(g, "records", std::mem::size_of::<Record>() * cap.records),
            tables: init("tables", bytemuck::cast_slice(&t_phi)),
            conductivity: init("conductivity", bytemuck::cast_slice(&cond)),
            delta: storage(g, "delta", 4 * members * cap.pairs),
            losses: storage(g, "losses", 16 * members),
        };
        let groups = groups_of(g, &b);
        let q = &g.queue;
        for (f, nb) in m.neighbours.iter().enumerate() {
            q.write_buffer(&b.nb, (4 * f * cap.voxels) as u64, bytemuck::cast_slice(nb));
        }
        let strides = strides(m);
        let area: Vec<[f32; 2]> = (0..n).map(|i| area_of(m, i, strides)).collect();
        let regular = area.iter().filter(|a| a[0] < 0.0).count();
        write(q, &b.area, &area);
        for (k, (member, peaks)) in models.iter().zip(peaks).enumerate() {
            let at = (4 * k * cap.voxels) as u64;
            q.write_buffer(&b.h, at, bytemuck::cast_slice(&member.h));
            q.write_buffer(&b.t, at, bytemuck::cast_slice(&member.t));
            q.write_buffer(&b.phi[0], at, bytemuck::cast_slice(&member.phi));
            q.write_buffer(&b.phi[1], at, bytemuck::cast_slice(&member.phi));
            q.write_buffer(&b.peak, (4 * k * deps) as u64, bytemuck::cast_slice(peaks));
            q.write_buffer(
                &b.losses,
                16 * k as u64,
                bytemuck::cast_slice(&losses_of(member)),
            );
        }
        let mut field = Field {
            gpu: gpu.clone(),
            members,
            cap,
            dep_cap: deps,
            b,
            groups,
            parity: 0,
            strides,
            regular,
            n,
            pairs: 0,
            deps: 0,
            dep_vox: 0,
            sources: vec![Vec::new(); members],
            n_sources: 0,
            encoder: None,
            staging: None,
            slots: Vec::new(),
            acc_groups: 0,
        };
        write(q, &field.b.dep_off, &[0u32]);
        if let Some(s) = m.substrate.as_deref() {
            let all: Vec<[u32; 2]> = s.interface.iter().map(|&(i, j)| [i, j]).collect();
            field.append_pairs(&all);
        }
        Ok(field)
    }

    /// Whether a model as it stands fits this field: else it is made again.
    fn fits(&self, m: &VoxelModel) -> bool {
        m.h.len() <= self.cap.voxels && interface_len(m) <= self.cap.pairs
    }

    fn append_pairs(&mut self, new: &[[u32; 2]]) {
        let q = &self.gpu.queue;
        q.write_buffer(
            &self.b.pairs,
            8 * self.pairs as u64,
            bytemuck::cast_slice(new),
        );
        self.pairs += new.len();
    }

    /// Run the members' rounds (one each, in member order): their steps as one batch, each
    /// step one dispatch per pass for every member, then the read they end with.
    fn run(&mut self, rounds: &[Round]) -> Result<Vec<Reply>, String> {
        let first = &rounds[0];
        let steps = first.steps.len();
        for (j, r) in rounds.iter().enumerate() {
            if r.steps.len() != steps || r.what != first.what {
                return Err(format!(
                    "the batch's members fell out of step: member {j} read the device after {} \
                     steps, member 0 after {steps}",
                    r.steps.len()
                ));
            }
        }
        for k in 0..steps {
            let shape = first.steps[k].shape;
            if let Some(j) = rounds.iter().position(|r| r.steps[k].shape != shape) {
                return Err(format!(
                    "the batch's members fell out of step: at step {k} member {j} has {:?} \
                     (voxels, interface pairs, deposits), member 0 {shape:?}",
                    rounds[j].steps[k].shape
                ));
            }
            if rounds.iter().any(|r| r.steps[k].changes.is_some()) {
                // Buffers written now reach the device before the steps not yet sent.
                self.submit();
                self.take_changes(rounds, k)?;
            }
            self.step(first.steps[k].p, k);
        }
        self.read(first.what, steps)
    }

    /// Bring the device up to the members' changes before step k: the geometry (voxels
    /// switched on and the faces they closed, interface pairs, deposits observed) once, from
    /// member 0's; each member's temperatures put, arc's heat and losses.
    fn take_changes(&mut self, rounds: &[Round], k: usize) -> Result<(), String> {
        let [n, pairs, deps] = rounds[0].steps[k].shape;
        if n > self.cap.voxels || pairs > self.cap.pairs {
            return Err(format!(
                "{n} voxels and {pairs} interface pairs outgrew the device's copy ({} and {})",
                self.cap.voxels, self.cap.pairs
            ));
        }
        let none = Changes::default();
        let of = |j: usize| rounds[j].steps[k].changes.as_ref().unwrap_or(&none);
        let (new_pairs, laid) = (&of(0).pairs, &of(0).laid);
        if self.pairs + new_pairs.len() != pairs || self.deps + laid.len() != deps {
            return Err(format!(
                "the device's copy has {} interface pairs and {} deposits, member 0 sends {} \
                 and {} more and stands on {pairs} and {deps}",
                self.pairs,
                self.deps,
                new_pairs.len(),
                laid.len()
            ));
        }
        self.n = n;
        self.append_pairs(new_pairs);
        let gpu = self.gpu.clone();
        let q = &gpu.queue;
        if !laid.is_empty() {
            let mut off = Vec::with_capacity(laid.len());
            let mut vox = Vec::new();
            let mut end = self.dep_vox;
            for list in laid {
                vox.extend_from_slice(list);
                end += list.len();
                off.push(end as u32);
            }
            q.write_buffer(
                &self.b.dep_off,
                4 * (self.deps as u64 + 1),
                bytemuck::cast_slice(&off),
            );
            q.write_buffer(
                &self.b.dep_vox,
                4 * self.dep_vox as u64,
                bytemuck::cast_slice(&vox),
            );
            (self.deps, self.dep_vox) = (deps, end);
        }
        for j in 0..self.members {
            if let Some(l) = of(j).losses {
                q.write_buffer(&self.b.losses, 16 * j as u64, bytemuck::cast_slice(&l));
            }
        }
        if (0..self.members).any(|j| of(j).sources.is_some()) {
            for j in 0..self.members {
                if let Some(s) = &of(j).sources {
                    self.sources[j] = s.clone();
                }
            }
            self.write_sources();
        }
        let records: Vec<Record> = (0..self.members)
            .flat_map(|j| {
                of(j)
                    .records
                    .iter()
                    .map(move |r| Record { m: j as u32, ..*r })
            })
            .collect();
        if !records.is_empty() {
            if records.len() > self.cap.records {
                self.cap.records = 2 * records.len();
                let bytes = std::mem::size_of::<Record>() * self.cap.records;
                self.b.records = storage(&self.gpu, "records", bytes);
                self.groups = groups_of(&self.gpu, &self.b);
            }
            write(q, &self.b.records, &records);
            let params = Params {
                n_records: records.len() as u32,
                ..self.base_params()
            };
            self.record(params, |f, pass, p| {
                let (x, y) = f.gpu.grid(p.n_records as usize);
                pass.set_pipeline(&f.gpu.pipelines.scatter);
                pass.dispatch_workgroups(x, y, 1);
            });
        }
        Ok(())
    }

    /// Every member's arc's heat, each list padded to the longest with voxels the shader
    /// skips.
    fn write_sources(&mut self) {
        let longest = self.sources.iter().map(Vec::len).max().unwrap_or(0);
        if longest > self.cap.sources {
            self.cap.sources = 2 * longest;
            let bytes = 8 * self.members * self.cap.sources;
            self.b.sources = storage(&self.gpu, "sources", bytes);
            self.groups = groups_of(&self.gpu, &self.b);
        }
        for (j, list) in self.sources.iter().enumerate() {
            let mut padded = list.clone();
            padded.resize(longest, [NONE, 0]);
            self.gpu.queue.write_buffer(
                &self.b.sources,
                (8 * j * self.cap.sources) as u64,
                bytemuck::cast_slice(&padded),
            );
        }
        self.n_sources = longest;
    }

    fn base_params(&self) -> Params {
        let (x, _) = self.gpu.grid(self.n.max(self.deps).max(self.cap.records));
        Params {
            cap: self.cap.voxels as u32,
            nx: x,
            k_offset: (K_LAST + 1) as u32,
            k_last: K_LAST as f32,
            ..Params::default()
        }
    }

    /// Record one step with constants `p` (its sizes, strides and nx are set here) for every
    /// member, its hottest metal into slot `slot`: the prologue, the stencil, the interface,
    /// the observation of deposits 0..p.n_deps.
    fn step(&mut self, p: Params, slot: usize) {
        let mut p = Params {
            n: self.n as u32,
            n_sources: self.n_sources as u32,
            n_pairs: self.pairs as u32,
            n_deps: p.n_deps.min(self.deps as u32),
            cap: self.cap.voxels as u32,
            hot_slot: slot as u32,
            k_offset: (K_LAST + 1) as u32,
            k_last: K_LAST as f32,
            sy: self.strides[0],
            sz: self.strides[1],
            src_cap: self.cap.sources as u32,
            pair_cap: self.cap.pairs as u32,
            dep_cap: self.dep_cap as u32,
            acc_stride: self.cap.voxels.div_ceil(WG) as u32,
            ..p
        };
        let widest = self.n.max(self.n_sources).max(self.pairs).max(self.deps);
        p.nx = self.gpu.grid(widest).0;
        self.acc_groups = self.acc_groups.max(self.n.div_ceil(WG));
        let members = self.members as u32;
        self.record(p, |f, pass, p| {
            let g = &f.gpu;
            let prologue = p.n_sources.max(p.n_pairs) as usize;
            if prologue > 0 {
                let (x, y) = g.grid(prologue);
                pass.set_pipeline(&g.pipelines.prologue);
                pass.dispatch_workgroups(x, y, members);
            }
            let (x, y) = g.grid(p.n as usize);
            pass.set_pipeline(&g.pipelines.step);
            pass.dispatch_workgroups(x, y, members);
            if p.n_pairs > 0 {
                let (x, y) = g.grid(p.n_pairs as usize);
                pass.set_pipeline(&g.pipelines.bond);
                pass.dispatch_workgroups(x, y, members);
            }
            if p.n_deps > 0 {
                let (x, y) = g.grid(p.n_deps as usize);
                pass.set_pipeline(&g.pipelines.observe);
                pass.dispatch_workgroups(x, y, members);
            }
        });
        self.parity ^= 1;
    }

    /// Record a pass with uniform slot `p`, bound at this step's parity.
    fn record(&mut self, p: Params, pass_fn: impl FnOnce(&Field, &mut wgpu::ComputePass, &Params)) {
        if self.slots.len() >= SLOTS {
            self.submit();
        }
        let slot = self.slots.len();
        self.slots.push(p);
        let mut encoder = self.encoder.take().unwrap_or_else(|| {
            self.gpu
                .device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None })
        });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: None,
                timestamp_writes: None,
            });
            let offset = (slot as u64 * SLOT_BYTES) as u32;
            pass.set_bind_group(0, &self.groups[self.parity], &[offset]);
            pass_fn(self, &mut pass, &p);
        }
        self.encoder = Some(encoder);
    }

    /// Send the recorded steps to the device, their uniforms first.
    fn submit(&mut self) {
        let Some(encoder) = self.encoder.take() else {
            return;
        };
        let mut bytes = vec![0u8; self.slots.len() * SLOT_BYTES as usize];
        for (k, p) in self.slots.iter().enumerate() {
            let at = k * SLOT_BYTES as usize;
            bytes[at..at + std::mem::size_of::<Params>()].copy_from_slice(bytemuck::bytes_of(p));
        }
        self.gpu.queue.write_buffer(&self.b.uniform, 0, &bytes);
        self.gpu.queue.submit([encoder.finish()]);
        self.slots.clear();
    }

    /// Read back, per member, what the `hot` steps since the last read left: the loss sums
    /// and each step's hottest laid metal, and as `what` asks the voxels' temperatures, or the
    /// whole field (h, T, Φ) with each laid deposit's peak and time above. Clears the device's
    /// running sums.
    fn read(&mut self, what: Read, hot: usize) -> Result<Vec<Reply>, String> {
        let (n_t, n) = match what {
            Read::Sums => (0, 0),
            Read::Temperatures => (self.n, 0),
            Read::All => (self.n, self.n),
        };
        let deps = if what == Read::All { self.deps } else { 0 };
        let acc = 6 * self.acc_groups;
        let per = n_t + 2 * n + 2 * deps + acc + hot;
        let g = self.gpu.clone();
        let bytes = (4 * (self.members * per).max(4)) as u64;
        if self.staging.as_ref().is_none_or(|b| b.size() < bytes) {
            self.staging = Some(g.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("read back"),
                size: bytes.next_power_of_two(),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        let staging = self.staging.clone().expect("made above");
        let mut encoder = self.encoder.take().unwrap_or_else(|| {
            g.device
                .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None })
        });
        let b = &self.b;
        let phi = &b.phi[self.parity];
        let (voxels, acc_stride) = (self.cap.voxels, 6 * self.cap.voxels.div_ceil(WG));
        // (buffer, words read, a member's stride in it)
        let parts: [(&wgpu::Buffer, usize, usize); 7] = [
            (&b.h, n, voxels),
            (&b.t, n_t, voxels),
            (phi, n, voxels),
            (&b.peak, deps, self.dep_cap),
            (&b.above, deps, self.dep_cap),
            (&b.acc, acc, acc_stride),
            (&b.hot, hot, SLOTS),
        ];
        let mut at = 0u64;
        for j in 0..self.members {
            for &(buf, len, stride) in &parts {
                if len > 0 {
                    let from = (4 * j * stride) as u64;
                    encoder.copy_buffer_to_buffer(buf, from, &staging, at, (4 * len) as u64);
                    at += 4 * len as u64;
                }
            }
        }
        if deps > 0 {
            encoder.clear_buffer(&b.above, 0, None);
        }
        encoder.clear_buffer(&b.acc, 0, None);
        encoder.clear_buffer(&b.hot, 0, None);
        self.encoder = Some(encoder);
        self.submit();
        let slice = staging.slice(..bytes);
        let (sent, mapped) = std::sync::mpsc::channel();
        slice.map_async(wgpu::MapMode::Read, move |r| {
            let _ = sent.send(r);
        });
        g.device
            .poll(wgpu::PollType::wait_indefinitely())
            .map_err(|e| format!("the device did not finish its steps: {e}"))?;
        mapped
            .recv()
            .map_err(|e| e.to_string())
            .and_then(|r| r.map_err(|e| e.to_string()))
            .map_err(|e| format!("the device's results could not be read: {e}"))?;
        let view = slice
            .get_mapped_range()
            .map_err(|e| format!("the device's results could not be read: {e}"))?;
        let words: &[f32] = bytemuck::cast_slice(&view);
        let replies = (0..self.members)
            .map(|j| {
                let w = &words[j * per..(j + 1) * per];
                let (h, rest) = w.split_at(n);
                let (t, rest) = rest.split_at(n_t);
                let (p, rest) = rest.split_at(n);
                let (peak, rest) = rest.split_at(deps);
                let (above, rest) = rest.split_at(deps);
                let (sums, rest) = rest.split_at(acc);
                let mut total = [0.0f64; 3];
                for group in sums.chunks_exact(6) {
                    for k in 0..3 {
                        total[k] += group[k] as f64 - group[3 + k] as f64;
                    }
                }
                Reply {
                    h: h.to_vec(),
                    t: t.to_vec(),
                    phi: p.to_vec(),
                    peak: peak.to_vec(),
                    above: above.to_vec(),
                    sums: total,
                    hot: rest[..hot].to_vec(),
                }
            })
            .collect();
        drop(view);
        staging.unmap();
        self.acc_groups = 0;
        Ok(replies)
    }
}

fn write<T: Pod>(q: &wgpu::Queue, buf: &wgpu::Buffer, data: &[T]) {
    if !data.is_empty() {
        q.write_buffer(buf, 0, bytemuck::cast_slice(data));
    }
}

/// The members of one field on the device, each run on a thread of its own: at each read, a
/// member leaves its round and waits; the last to arrive runs every member's round as one
/// batch and hands each its reply.
pub(super) struct Batch {
    gpu: Arc<Gpu>,
    members: usize,
    turn: Mutex<Turn>,
    done: Condvar,
}

struct Turn {
    field: Option<Field>,
    rounds: Vec<Option<Round>>,
    replies: Vec<Option<Reply>>,
    /// Members whose run stopped since the batch was last begun.
    left: Vec<bool>,
    /// Why the batch failed: every member's run fails with it.
    failed: Option<String>,
    generation: u64,
}

impl Batch {
    fn new(gpu: Arc<Gpu>, members: usize) -> Batch {
        Batch {
            gpu,
            members,
            turn: Mutex::new(Turn {
                field: None,
                rounds: (0..members).map(|_| None).collect(),
                replies: (0..members).map(|_| None).collect(),
                left: vec![false; members],
                failed: None,
                generation: 0,
            }),
            done: Condvar::new(),
        }
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, Turn> {
        // A member that panicked holding the lock leaves the batch failed, not the others
        // panicking in turn.
        self.turn.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Every member back at the start: the next rounds may begin.
    fn begin(&self) {
        self.lock().left.iter_mut().for_each(|l| *l = false);
    }

    /// Whether the field has room for `m`.
    fn fits(&self, m: &VoxelModel) -> bool {
        self.lock().field.as_ref().is_some_and(|f| f.fits(m))
    }

    /// Member k's round: wait for the others', and the reply when the batch has run.
    fn round(&self, k: usize, round: Round) -> Result<Reply, String> {
        let mut turn = self.lock();
        if let Some(e) = &turn.failed {
            return Err(e.clone());
        }
        if let Some(j) = turn.left.iter().position(|&l| l) {
            let e = format!("member {j} of the device's batch stopped before member {k} read");
            return Err(self.fail(&mut turn, e));
        }
        turn.rounds[k] = Some(round);
        if turn.rounds.iter().all(Option::is_some) {
            let rounds: Vec<Round> = turn.rounds.iter_mut().map(|r| r.take().unwrap()).collect();
            match self.run(&mut turn.field, rounds) {
                Ok(replies) => {
                    for (slot, r) in turn.replies.iter_mut().zip(replies) {
                        *slot = Some(r);
                    }
                }
                Err(e) => {
                    self.fail(&mut turn, e);
                }
            }
            turn.generation += 1;
            self.done.notify_all();
        } else {
            let generation = turn.generation;
            while turn.generation == generation && turn.failed.is_none() {
                turn = self.done.wait(turn).unwrap_or_else(|e| e.into_inner());
            }
        }
        match (turn.replies[k].take(), &turn.failed) {
            (Some(r), _) => Ok(r),
            (None, Some(e)) => Err(e.clone()),
            (None, None) => Err(format!("the device's batch gave member {k} no reply")),
        }
    }

    /// The field made again where every round asks it, then the rounds run.
    fn run(&self, field: &mut Option<Field>, mut rounds: Vec<Round>) -> Result<Vec<Reply>, String> {
        let remakes = rounds.iter().filter(|r| r.remake.is_some()).count();
        if remakes == self.members {
            let copies: Vec<(Box<VoxelModel>, Vec<f32>)> = rounds
                .iter_mut()
                .map(|r| r.remake.take().unwrap())
                .collect();
            let models: Vec<&VoxelModel> = copies.iter().map(|c| &*c.0).collect();
            let peaks: Vec<&[f32]> = copies.iter().map(|c| c.1.as_slice()).collect();
            *field = None;
            *field =
                Some(Field::new(self.gpu.clone(), &models, &peaks).map_err(|e| e.to_string())?);
        } else if remakes > 0 {
            return Err(format!(
                "the batch's members fell out of step: {remakes} of {} made the device's copy again",
                self.members
            ));
        }
        let f = field
            .as_mut()
            .ok_or("the device's batch has no copy of the field")?;
        f.run(&rounds)
    }

    fn fail(&self, turn: &mut Turn, e: String) -> String {
        let e = turn.failed.get_or_insert(e).clone();
        self.done.notify_all();
        e
    }

    /// Member k's run stopped: a round the others began cannot be run.
    fn leave(&self, k: usize) {
        let mut turn = self.lock();
        turn.left[k] = true;
        if turn.rounds.iter().any(Option::is_some) {
            let e = format!("member {k} of the device's batch stopped before the others read");
            self.fail(&mut turn, e);
        }
    }
}

/// A member's place in a batch, held by the thread that runs it: when it is dropped (the run
/// done, failed or panicked) a round the others began fails rather than waits.
pub struct Seat {
    batch: Arc<Batch>,
    k: usize,
}

impl Drop for Seat {
    fn drop(&mut self) {
        self.batch.leave(self.k);
    }
}

/// Where a model's steps go.
#[derive(Default)]
enum Home {
    /// Nowhere yet: a field is made at the next call.
    #[default]
    None,
    /// A field of its own.
    Alone(Box<Field>),
    /// Member k of a batch.
    Batch(Arc<Batch>, usize),
}

/// What the device has of a model (its lane's side of the rule): the geometry, the arc's heat
/// and the losses last sent.
#[derive(Default)]
struct Sent {
    n: usize,
    pairs: usize,
    deps: usize,
    strides: [u32; 2],
    sources: Vec<(u32, f32)>,
    losses: [f32; 4],
}

/// A model's way to the device: where its steps go, what the device has of it, the steps
/// recorded since the last read (with the time at each one's end), and the device's first
/// failure, which ends the run at its next check. A clone has none of it: it makes its own
/// from the host's copy, which is current between calls.
#[derive(Default)]
pub(super) struct Lane {
    home: Home,
    sent: Sent,
    steps: Vec<Step>,
    times: Vec<f64>,
    /// In a batch: the next round makes the field again from this copy.
    remake: Option<(Box<VoxelModel>, Vec<f32>)>,
    failure: Option<String>,
}

impl Clone for Lane {
    fn clone(&self) -> Lane {
        Lane::default()
    }
}

/// Put `models` on the device as one batch: runs of one program on one grid, each to be run
/// on a thread of its own holding its seat. A batch they already make is begun again.
pub(super) fn share(models: &mut [&mut VoxelModel]) -> Result<Vec<Seat>, String> {
    let members = models.len();
    let same = match &models[0].field.home {
        Home::Batch(b, 0) if b.members == members => Some(b.clone()),
        _ => None,
    };
    let batch = match same.filter(|b| {
        models.iter().enumerate().all(
            |(k, m)| matches!(&m.field.home, Home::Batch(c, j) if Arc::ptr_eq(b, c) && *j == k),
        )
    }) {
        Some(b) => {
            b.begin();
            b
        }
        None => {
            let batch = Arc::new(Batch::new(shared()?, members));
            for (k, m) in models.iter_mut().enumerate() {
                m.field = Lane {
                    home: Home::Batch(batch.clone(), k),
                    ..Lane::default()
                };
            }
            batch
        }
    };
    Ok((0..members)
        .map(|k| Seat {
            batch: batch.clone(),
            k,
        })
        .collect())
}

impl VoxelModel {
    /// What the device will have of this model once a field is made from it.
    fn sent_now(&self) -> Sent {
        Sent {
            n: self.h.len(),
            pairs: interface_len(self),
            deps: 0,
            strides: strides(self),
            sources: Vec::new(),
            losses: losses_of(self),
        }
    }

    fn peaks(points: &[PointResult]) -> Vec<f32> {
        points.iter().map(|p| p.peak as f32).collect()
    }

    /// Make the device's copy where there is none (or it has outgrown its buffers), from the
    /// host's; `points` give the deposits' peaks so far. The host's copy must be current (a
    /// call's start: no steps recorded).
    pub(super) fn gpu_ready(&mut self, points: &[PointResult]) -> Result<(), ThermalError> {
        debug_assert!(self.field.steps.is_empty());
        match &self.field.home {
            Home::Alone(f) if f.fits(self) => return Ok(()),
            Home::Batch(b, _) if self.field.remake.is_none() && b.fits(self) => return Ok(()),
            Home::Batch(..) => {
                let copy = (Box::new(self.clone()), VoxelModel::peaks(points));
                self.field.remake = Some(copy);
            }
            Home::None | Home::Alone(_) => {
                let gpu = shared().map_err(|reason| ThermalError::Device { reason })?;
                let field = Field::new(gpu, &[self], &[&VoxelModel::peaks(points)])?;
                self.field.home = Home::Alone(Box::new(field));
            }
        }
        self.field.sent = self.sent_now();
        self.dirty.clear();
        Ok(())
    }

    /// Everything on the device to be written again: a lone run's copy is dropped; a member
    /// of a batch sends every voxel.
    pub(super) fn gpu_all_dirty(&mut self) {
        match self.field.home {
            Home::Batch(..) => self.dirty = (0..self.h.len() as u32).collect(),
            _ => {
                self.field.home = Home::None;
                self.dirty.clear();
            }
        }
    }

    /// What the host changed since the device last heard from it, against `sent`.
    fn changes(&mut self, source: &[(u32, f32)], laid: usize) -> Option<Changes> {
        let sent = &self.field.sent;
        let new_pairs = match self.substrate.as_deref() {
            Some(s) if s.interface.len() > sent.pairs => s.interface[sent.pairs..]
                .iter()
                .map(|&(i, j)| [i, j])
                .collect(),
            _ => Vec::new(),
        };
        let laid_new: Vec<Vec<u32>> = match laid > sent.deps {
            true => self.laid[sent.deps..laid].to_vec(),
            false => Vec::new(),
        };
        let sources = (source != sent.sources.as_slice()).then(|| {
            let mut sorted = source.to_vec();
            sorted.sort_by_key(|s| s.0);
            let mut merged: Vec<(u32, f32)> = Vec::with_capacity(sorted.len());
            for (v, w) in sorted {
                match merged.last_mut() {
                    Some(last) if last.0 == v => last.1 += w,
                    _ => merged.push((v, w)),
                }
            }
            merged.iter().map(|&(v, w)| [v, w.to_bits()]).collect()
        });
        let losses = losses_of(self);
        let losses = (losses != sent.losses).then_some(losses);
        let records: Vec<Record> = self
            .dirty
            .iter()
            .map(|&v| {
                let i = v as usize;
                let [exposed, table] = area_of(self, i, sent.strides);
                Record {
                    v,
                    m: 0,
                    nb: std::array::from_fn(|f| self.neighbours[f][i]),
                    exposed,
                    table,
                    h: self.h[i],
                    t: self.t[i],
                    phi: self.phi[i],
                }
            })
            .collect();
        let grown = self.h.len() != sent.n;
        let unchanged = !grown
            && records.is_empty()
            && new_pairs.is_empty()
            && laid_new.is_empty()
            && sources.is_none()
            && losses.is_none();
        if unchanged {
            return None;
        }
        let sent = &mut self.field.sent;
        sent.n = self.h.len();
        sent.pairs += new_pairs.len();
        sent.deps += laid_new.len();
        if sources.is_some() {
            sent.sources = source.to_vec();
        }
        if let Some(l) = losses {
            sent.losses = l;
        }
        self.dirty.clear();
        Some(Changes {
            records,
            pairs: new_pairs,
            laid: laid_new,
            sources,
            losses,
        })
    }

    /// Record one step of dt on the device with `source` watts, deposits 0..laid observed;
    /// `now` is the time at its end. The ledger's source and counts are booked here, its
    /// losses when the device is read.
    pub(super) fn gpu_step(&mut self, dt: f64, source: &[(u32, f32)], laid: usize, now: f64) {
        let changes = self.changes(source, laid);
        let [_, cp, c] = self.coefficients(dt);
        let plate = self
            .substrate
            .as_deref()
            .map_or(&self.tables, |s| &s.tables);
        let p = Params {
            n_deps: laid as u32,
            plate_end: match self.substrate {
                Some(_) => self.plate_voxels as u32,
                None => 0,
            },
            dt: dt as f32,
            dx: c.dx,
            ta: c.ta,
            ta4: c.ta4,
            threshold: self.settings.hot_threshold as f32,
            cap_d: c.inv_cap,
            cap_p: cp.inv_cap,
            d_h0: self.tables.h0,
            d_inv_dh: self.tables.inv_dh,
            d_last: self.tables.last,
            p_h0: plate.h0,
            p_inv_dh: plate.inv_dh,
            p_last: plate.last,
            p_offset: self.tables.t_phi.len() as u32,
            ..Params::default()
        };
        let sent = &self.field.sent;
        self.field.steps.push(Step {
            shape: [sent.n, sent.pairs, sent.deps],
            changes,
            p,
        });
        self.field.times.push(now);
        self.ledger.source += dt * source.iter().map(|&(_, w)| w as f64).sum::<f64>();
        self.updates += self.h.len() as u64;
        self.steps += 1;
    }

    /// Whether the steps recorded fill the device's slots for the hottest metal: the run
    /// reads it then.
    pub(super) fn gpu_full(&self) -> bool {
        self.field.steps.len() >= SLOTS
    }

    /// Send the steps recorded to the device and read it back: the losses into the ledger,
    /// the hottest laid metal of each step into `hottest` (when `on`), and what `what` asks
    /// into the host's copy (the deposits' peaks and times above into `points`).
    pub(super) fn gpu_read(
        &mut self,
        points: &mut [PointResult],
        hottest: &mut Hottest,
        on: bool,
        what: Read,
    ) {
        let round = Round {
            remake: self.field.remake.take(),
            steps: std::mem::take(&mut self.field.steps),
            what,
        };
        let reply = match &mut self.field.home {
            Home::None => return,
            Home::Alone(field) => field
                .run(std::slice::from_ref(&round))
                .map(|mut r| r.remove(0)),
            Home::Batch(batch, k) => batch.round(*k, round),
        };
        let times = std::mem::take(&mut self.field.times);
        let r = match reply {
            Ok(r) => r,
            Err(reason) => {
                self.field.failure.get_or_insert(reason);
                return;
            }
        };
        if !r.t.is_empty() {
            self.t.copy_from_slice(&r.t);
        }
        if what == Read::All {
            self.h.copy_from_slice(&r.h);
            self.phi.copy_from_slice(&r.phi);
            self.phi_next.copy_from_slice(&r.phi);
            for ((pt, &pk), &up) in points.iter_mut().zip(&r.peak).zip(&r.above) {
                pt.peak = pt.peak.max(pk as f64);
                pt.time_above += up as f64;
            }
        }
        for (&now, &bits) in times.iter().zip(&r.hot) {
            let t = match bits.to_bits() {
                0 => f64::NAN,
                b => f32::from_bits(b) as f64,
            };
            hottest.push(on, now, t);
        }
        let sur = self.settings.surroundings;
        self.ledger.convection += sur.convection_w_m2k as f32 as f64 * r.sums[0];
        self.ledger.radiation += (sur.emissivity * SIGMA) as f32 as f64 * r.sums[1];
        self.ledger.table += sur.table_w_m2k as f32 as f64 * r.sums[2];
    }

    /// Why the device failed, if it did (a device lost, a read that did not come back, a
    /// batch whose members fell out of step).
    pub(super) fn gpu_failure(&self) -> Option<&str> {
        self.field.failure.as_deref()
    }

    /// The adapter's name, where the model has a device.
    pub fn gpu_name(&self) -> Option<String> {
        match &self.field.home {
            Home::None => None,
            Home::Alone(f) => Some(f.gpu.name.clone()),
            Home::Batch(b, _) => Some(b.gpu.name.clone()),
        }
    }

    /// Of the voxels on the device when its copy was made, those it steps without reading
    /// their neighbour table (`area_of`), where the model has a device.
    pub fn gpu_regular(&self) -> Option<usize> {
        match &self.field.home {
            Home::None => None,
            Home::Alone(f) => Some(f.regular),
            Home::Batch(b, _) => b.lock().field.as_ref().map(|f| f.regular),
        }
    }
}
