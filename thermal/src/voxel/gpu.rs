//! The voxel model's steps on a GPU, through wgpu's compute shaders (Vulkan, Metal, DX12), as
//! `[thermal] device = "gpu"` asks. The host's [`VoxelModel`] stays the model: it lays the
//! metal, places the arc's heat and reads the results; a [`Field`] holds a copy of its active
//! set on the device and steps it (`gpu.wgsl`: the same arithmetic as `kernel.rs`, in f32).
//!
//! One rule keeps the two copies straight: between two calls of the run (a deposit, a cooling)
//! the host's copy is current; within a call the device's is, and the host's is read back at
//! its end and wherever the run must read a temperature in between (a preheat during the arc,
//! a probe or snapshot falling due). What the host changes between calls (voxels laid, their
//! neighbours' faces, a temperature put by an assimilation) it lists in `VoxelModel::dirty`,
//! and the next batch of steps begins by writing those voxels. The loss sums of the energy
//! ledger are kept per workgroup on the device (Kahan's compensated sum, f32) and summed in f64
//! when read back; each laid deposit's peak and time above the threshold likewise.
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
use std::sync::{Arc, OnceLock};
use wgpu::util::DeviceExt;

/// Threads per workgroup: the shader's `WG`.
const WG: usize = 256;
/// Steps recorded before the commands go to the device (and uniform slots in one buffer).
const SLOTS: usize = 256;
/// Bytes between two uniform slots (the largest `min_uniform_buffer_offset_alignment` allowed).
const SLOT_BYTES: u64 = 256;
/// Whole kelvins in the conductivity tables, 0 ..= K_LAST.
const K_LAST: usize = 4000;

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
        if limits.max_storage_buffers_per_shader_stage < 18 {
            return Err(format!(
                "the adapter {} binds {} storage buffers to a compute shader; the voxel model needs 18",
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
        let read_only = [7, 8, 10, 11, 13, 14, 18];
        let mut entries = vec![entry(0, wgpu::BufferBindingType::Uniform, true)];
        for b in 1..=18 {
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
    pub h_conv: f32,
    pub eps_sigma: f32,
    pub h_table: f32,
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
    pub pad: [u32; 2],
}

/// A voxel the host wrote: the shader's `Record`.
#[repr(C)]
#[derive(Clone, Copy, Pod, Zeroable)]
struct Record {
    v: u32,
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
}

/// The bind groups of both parities: Φ read from `phi[parity]`, written to the other.
fn groups_of(g: &Gpu, b: &Buffers) -> [wgpu::BindGroup; 2] {
    let group = |parity: usize| {
        let bufs: [&wgpu::Buffer; 18] = [
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

/// What a field was made for: past any of these it is made again, from the host's copy.
#[derive(Clone, Copy)]
struct Capacity {
    voxels: usize,
    pairs: usize,
    sources: usize,
    records: usize,
}

/// The model's active set on the device, and the steps recorded but not yet read back.
pub(super) struct Field {
    gpu: Arc<Gpu>,
    cap: Capacity,
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
    n_sources: usize,
    encoder: Option<wgpu::CommandEncoder>,
    /// The read-back buffer, kept between reads.
    staging: Option<wgpu::Buffer>,
    /// Uniforms of the steps recorded since the last submission.
    slots: Vec<Params>,
    /// The time at the end of each step since the last read of the hottest metal.
    hot_times: Vec<f64>,
    /// Workgroups whose loss sums may be non-zero.
    acc_groups: usize,
    /// The arc's heat the device has (voxel, W), as the host gave it.
    staged_sources: Vec<(u32, f32)>,
}

/// What a read brings back beside the loss sums and the hottest metal.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
pub(super) enum Read {
    Sums,
    /// The voxels' temperatures: what the host reads within a call (a preheat, a probe, a
    /// snapshot, a trace).
    Temperatures,
    /// The whole field and the deposits' peaks: the host's copy current, as at a call's end.
    All,
}

/// What a read back brings: the loss sums (Σ dt·exposed·(T − T_a), Σ dt·exposed·(T⁴ − T_a⁴),
/// Σ dt·table·(T − T_a)).
pub(super) struct Readback {
    pub sums: [f64; 3],
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

impl Field {
    /// A field holding the model's whole active set, with room to grow; `points` give the
    /// deposits' peaks so far.
    pub(super) fn new(
        gpu: Arc<Gpu>,
        m: &VoxelModel,
        points: &[PointResult],
    ) -> Result<Field, ThermalError> {
        let n = m.h.len();
        let pairs = m.substrate.as_deref().map_or(0, |s| s.interface.len());
        // The neighbour table is the largest buffer: 24 bytes a voxel.
        let most = (gpu.max_binding / 24) as usize;
        if n > most {
            return Err(ThermalError::Device {
                reason: format!(
                    "{n} voxels need a {} MB buffer; the adapter {} binds at most {} MB",
                    24 * n as u64 / 1_000_000,
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
        let b = Buffers {
            uniform: g.device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("params"),
                size: SLOTS as u64 * SLOT_BYTES,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            nb: storage(g, "nb", 24 * cap.voxels),
            area: storage(g, "area", 8 * cap.voxels),
            h: storage(g, "h", 4 * cap.voxels),
            t: storage(g, "t", 4 * cap.voxels),
            phi: [
                storage(g, "phi 0", 4 * cap.voxels),
                storage(g, "phi 1", 4 * cap.voxels),
            ],
            acc: storage(g, "acc", 24 * cap.voxels.div_ceil(WG)),
            sources: storage(g, "sources", 8 * cap.sources),
            pairs: storage(g, "pairs", 8 * cap.pairs),
            dep_off: storage(g, "dep_off", 4 * (deps + 1)),
            dep_vox: storage(g, "dep_vox", 4 * cap.voxels),
            peak: storage(g, "peak", 4 * deps),
            above: storage(g, "above", 4 * deps),
            hot: storage(g, "hot", 4 * SLOTS),
            records: storage(g, "records", std::mem::size_of::<Record>() * cap.records),
            tables: init("tables", bytemuck::cast_slice(&t_phi)),
            conductivity: init("conductivity", bytemuck::cast_slice(&cond)),
            delta: storage(g, "delta", 4 * cap.pairs),
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
        write(q, &b.h, &m.h);
        write(q, &b.t, &m.t);
        write(q, &b.phi[0], &m.phi);
        write(q, &b.phi[1], &m.phi);
        let peaks: Vec<f32> = points.iter().map(|p| p.peak as f32).collect();
        write(q, &b.peak, &peaks);
        let mut field = Field {
            gpu: gpu.clone(),
            cap,
            b,
            groups,
            parity: 0,
            strides,
            regular,
            n,
            pairs: 0,
            deps: 0,
            dep_vox: 0,
            n_sources: 0,
            encoder: None,
            staging: None,
            slots: Vec::new(),
            hot_times: Vec::new(),
            acc_groups: 0,
            staged_sources: Vec::new(),
        };
        write(q, &field.b.dep_off, &[0u32]);
        field.append_pairs(m);
        Ok(field)
    }

    /// Whether the model as it stands fits this field: else it is made again.
    pub(super) fn fits(&self, m: &VoxelModel) -> bool {
        let pairs = m.substrate.as_deref().map_or(0, |s| s.interface.len());
        m.h.len() <= self.cap.voxels && pairs <= self.cap.pairs && m.dirty.len() <= self.cap.records
    }

    fn append_pairs(&mut self, m: &VoxelModel) {
        let Some(s) = m.substrate.as_deref() else {
            return;
        };
        let new: Vec<[u32; 2]> = s.interface[self.pairs..]
            .iter()
            .map(|&(i, j)| [i, j])
            .collect();
        let q = &self.gpu.queue;
        q.write_buffer(
            &self.b.pairs,
            8 * self.pairs as u64,
            bytemuck::cast_slice(&new),
        );
        self.pairs = s.interface.len();
    }

    /// Bring the device up to the host's changes since the last batch: voxels switched on and
    /// the faces they closed, temperatures put, interface pairs, the deposits laid up to
    /// `laid` (whose metal is observed), and the arc's heat. Called before a step; a batch in
    /// flight is submitted first, so that its steps see the state they were recorded on.
    pub(super) fn sync(&mut self, m: &VoxelModel, laid: usize, source: &[(u32, f32)]) {
        let source_changed = source != self.staged_sources.as_slice();
        let dirty = !m.dirty.is_empty()
            || m.h.len() != self.n
            || laid > self.deps
            || m.substrate
                .as_deref()
                .is_some_and(|s| s.interface.len() != self.pairs);
        if !(dirty || source_changed) {
            return;
        }
        self.submit();
        let gpu = self.gpu.clone();
        let q = &gpu.queue;
        if source_changed {
            // Distinct voxels, as the prologue adds without atomics.
            let mut merged: Vec<(u32, f32)> = Vec::with_capacity(source.len());
            let mut sorted = source.to_vec();
            sorted.sort_by_key(|s| s.0);
            for (v, w) in sorted {
                match merged.last_mut() {
                    Some(last) if last.0 == v => last.1 += w,
                    _ => merged.push((v, w)),
                }
            }
            if merged.len() > self.cap.sources {
                self.cap.sources = 2 * merged.len();
                self.b.sources = storage(&self.gpu, "sources", 8 * self.cap.sources);
                self.groups = groups_of(&self.gpu, &self.b);
            }
            let data: Vec<[u32; 2]> = merged.iter().map(|&(v, w)| [v, w.to_bits()]).collect();
            write(&self.gpu.queue, &self.b.sources, &data);
            self.n_sources = merged.len();
            self.staged_sources = source.to_vec();
        }
        if !dirty {
            return;
        }
        self.n = m.h.len();
        self.append_pairs(m);
        if laid > self.deps {
            let mut off = Vec::with_capacity(laid - self.deps);
            let mut vox = Vec::new();
            let mut end = self.dep_vox;
            for list in &m.laid[self.deps..laid] {
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
            (self.deps, self.dep_vox) = (laid, end);
        }
        if !m.dirty.is_empty() {
            let records: Vec<Record> = m
                .dirty
                .iter()
                .map(|&v| {
                    let i = v as usize;
                    let [exposed, table] = area_of(m, i, self.strides);
                    Record {
                        v,
                        nb: std::array::from_fn(|f| m.neighbours[f][i]),
                        exposed,
                        table,
                        h: m.h[i],
                        t: m.t[i],
                        phi: m.phi[i],
                    }
                })
                .collect();
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

    /// Record one step with constants `p` (its sizes and nx are set here): the prologue, the
    /// stencil, the interface, the observation of deposits 0..p.n_deps.
    pub(super) fn step(&mut self, p: Params, now: f64) {
        let mut p = Params {
            n: self.n as u32,
            n_sources: self.n_sources as u32,
            n_pairs: self.pairs as u32,
            n_deps: p.n_deps.min(self.deps as u32),
            cap: self.cap.voxels as u32,
            hot_slot: self.hot_times.len() as u32,
            k_offset: (K_LAST + 1) as u32,
            k_last: K_LAST as f32,
            sy: self.strides[0],
            sz: self.strides[1],
            ..p
        };
        let widest = self.n.max(self.n_sources).max(self.pairs).max(self.deps);
        p.nx = self.gpu.grid(widest).0;
        self.acc_groups = self.acc_groups.max(self.n.div_ceil(WG));
        self.hot_times.push(now);
        self.record(p, |f, pass, p| {
            let g = &f.gpu;
            let prologue = p.n_sources.max(p.n_pairs) as usize;
            if prologue > 0 {
                let (x, y) = g.grid(prologue);
                pass.set_pipeline(&g.pipelines.prologue);
                pass.dispatch_workgroups(x, y, 1);
            }
            let (x, y) = g.grid(p.n as usize);
            pass.set_pipeline(&g.pipelines.step);
            pass.dispatch_workgroups(x, y, 1);
            if p.n_pairs > 0 {
                let (x, y) = g.grid(p.n_pairs as usize);
                pass.set_pipeline(&g.pipelines.bond);
                pass.dispatch_workgroups(x, y, 1);
            }
            if p.n_deps > 0 {
                let (x, y) = g.grid(p.n_deps as usize);
                pass.set_pipeline(&g.pipelines.observe);
                pass.dispatch_workgroups(x, y, 1);
            }
        });
        self.parity ^= 1;
    }

    /// Steps recorded since the last read of the hottest metal: past `SLOTS` the caller reads.
    pub(super) fn full(&self) -> bool {
        self.hot_times.len() >= SLOTS || self.slots.len() >= SLOTS
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

    /// Read back what the steps since the last read left: always the loss sums and the
    /// hottest laid metal of each step (into `hottest` when `on`), and as `what` asks the
    /// voxels' temperatures, or the whole field (h, T, Φ) with each laid deposit's peak and
    /// time above (into `points`). Clears the device's running sums.
    pub(super) fn read(
        &mut self,
        m: &mut VoxelModel,
        points: &mut [PointResult],
        hottest: &mut Hottest,
        on: bool,
        what: Read,
    ) -> Result<Readback, String> {
        let (n_t, n) = match what {
            Read::Sums => (0, 0),
            Read::Temperatures => (self.n, 0),
            Read::All => (self.n, self.n),
        };
        let deps = if what == Read::All { self.deps } else { 0 };
        let (acc, hot) = (6 * self.acc_groups, self.hot_times.len());
        let words = n_t + 2 * n + 2 * deps + acc + hot;
        let g = self.gpu.clone();
        let bytes = (4 * words.max(4)) as u64;
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
        let mut at = 0u64;
        let b = &self.b;
        let phi = &b.phi[self.parity];
        let parts: [(&wgpu::Buffer, usize); 7] = [
            (&b.h, n),
            (&b.t, n_t),
            (phi, n),
            (&b.peak, deps),
            (&b.above, deps),
            (&b.acc, acc),
            (&b.hot, hot),
        ];
        for (buf, len) in parts {
            if len > 0 {
                encoder.copy_buffer_to_buffer(buf, 0, &staging, at, (4 * len) as u64);
                at += 4 * len as u64;
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
        let (h, rest) = words.split_at(n);
        let (t, rest) = rest.split_at(n_t);
        let (p, rest) = rest.split_at(n);
        let (peak, rest) = rest.split_at(deps);
        let (above, rest) = rest.split_at(deps);
        let (sums, rest) = rest.split_at(acc);
        let hot_bits = &rest[..hot];
        if n_t > 0 {
            m.t.copy_from_slice(t);
        }
        if what == Read::All {
            m.h.copy_from_slice(h);
            m.phi.copy_from_slice(p);
            m.phi_next.copy_from_slice(p);
            for ((pt, &pk), &up) in points.iter_mut().zip(peak).zip(above) {
                pt.peak = pt.peak.max(pk as f64);
                pt.time_above += up as f64;
            }
        }
        let mut total = [0.0f64; 3];
        for group in sums.chunks_exact(6) {
            for k in 0..3 {
                total[k] += group[k] as f64 - group[3 + k] as f64;
            }
        }
        for (&now, &bits) in self.hot_times.iter().zip(hot_bits) {
            let t = match bits.to_bits() {
                0 => f64::NAN,
                b => f32::from_bits(b) as f64,
            };
            hottest.push(on, now, t);
        }
        drop(view);
        staging.unmap();
        self.hot_times.clear();
        self.acc_groups = 0;
        Ok(Readback { sums: total })
    }
}

fn write<T: Pod>(q: &wgpu::Queue, buf: &wgpu::Buffer, data: &[T]) {
    if !data.is_empty() {
        q.write_buffer(buf, 0, bytemuck::cast_slice(data));
    }
}

/// The device's copy of a model, if it has one. A clone has none: it makes its own from the
/// host's copy, which is current between calls.
/// And the first failure of the device, which ends the run at its next check.
#[derive(Default)]
pub(super) struct Resident(Option<Box<Field>>, Option<String>);

impl Clone for Resident {
    fn clone(&self) -> Resident {
        Resident(None, None)
    }
}

impl VoxelModel {
    /// Make the device's copy where there is none (or it has outgrown its buffers), from the
    /// host's; `points` give the deposits' peaks so far. The host's copy must be current.
    pub(super) fn gpu_ready(&mut self, points: &[PointResult]) -> Result<(), ThermalError> {
        if self.field.0.as_ref().is_some_and(|f| f.fits(self)) {
            return Ok(());
        }
        let gpu = shared().map_err(|reason| ThermalError::Device { reason })?;
        self.field.0 = Some(Box::new(Field::new(gpu, self, points)?));
        self.dirty.clear();
        Ok(())
    }

    /// Record one step of dt on the device with `source` watts, deposits 0..laid observed;
    /// `now` is the time at its end. The ledger's source and counts are booked here, its
    /// losses when the device is read.
    pub(super) fn gpu_step(&mut self, dt: f64, source: &[(u32, f32)], laid: usize, now: f64) {
        let mut field = self.field.0.take().expect("gpu_ready before a step");
        field.sync(self, laid, source);
        self.dirty.clear();
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
            h_conv: c.h_conv,
            eps_sigma: c.eps_sigma,
            h_table: c.h_table,
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
        field.step(p, now);
        self.field.0 = Some(field);
        self.ledger.source += dt * source.iter().map(|&(_, w)| w as f64).sum::<f64>();
        self.updates += self.h.len() as u64;
        self.steps += 1;
    }

    /// Whether the steps recorded fill the device's slots: the run reads it then.
    pub(super) fn gpu_full(&self) -> bool {
        self.field.0.as_ref().is_some_and(|f| f.full())
    }

    /// Read the device back: the losses into the ledger, the hottest laid metal of each step
    /// into `hottest` (when `on`), and what `what` asks into the host's copy (the deposits'
    /// peaks and times above into `points`).
    pub(super) fn gpu_read(
        &mut self,
        points: &mut [PointResult],
        hottest: &mut Hottest,
        on: bool,
        what: Read,
    ) {
        let Some(mut field) = self.field.0.take() else {
            return;
        };
        let r = field.read(self, points, hottest, on, what);
        self.field.0 = Some(field);
        let r = match r {
            Ok(r) => r,
            Err(reason) => {
                self.field.1.get_or_insert(reason);
                return;
            }
        };
        let sur = self.settings.surroundings;
        self.ledger.convection += sur.convection_w_m2k as f32 as f64 * r.sums[0];
        self.ledger.radiation += (sur.emissivity * SIGMA) as f32 as f64 * r.sums[1];
        self.ledger.table += sur.table_w_m2k as f32 as f64 * r.sums[2];
    }

    /// Why the device failed, if it did (a device lost, a read that did not come back).
    pub(super) fn gpu_failure(&self) -> Option<&str> {
        self.field.1.as_deref()
    }

    /// The adapter's name, where the model has a device.
    pub fn gpu_name(&self) -> Option<String> {
        self.field.0.as_ref().map(|f| f.gpu.name.clone())
    }

    /// Of the voxels on the device when its copy was made, those it steps without reading
    /// their neighbour table (`area_of`), where the model has a device.
    pub fn gpu_regular(&self) -> Option<usize> {
        self.field.0.as_ref().map(|f| f.regular)
    }
}
