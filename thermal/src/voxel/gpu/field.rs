//! The active set of one or more members on the device ([`Field`]): its buffers, what a member
//! sends before a step ([`Changes`]) and what a read hands back ([`Parts`]); a round of steps
//! recorded by every member run as one batch of dispatches.

use super::{BINDINGS, Gpu, K_LAST, NONE, Read, SLOT_BYTES, SLOTS, WG};
use crate::error::ThermalError;
use crate::material::Material;
use crate::network::SIGMA;
use crate::voxel::VoxelModel;
use bytemuck::{Pod, Zeroable};
use std::sync::Arc;
use wgpu::util::DeviceExt;

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
pub(super) struct Record {
    pub(super) v: u32,
    pub(super) m: u32,
    pub(super) nb: [u32; 6],
    pub(super) exposed: f32,
    pub(super) table: f32,
    pub(super) h: f32,
    pub(super) t: f32,
    pub(super) phi: f32,
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
pub(super) struct Changes {
    /// Voxels switched on, their neighbours' faces, temperatures put.
    pub(super) records: Vec<Record>,
    /// Interface pairs appended.
    pub(super) pairs: Vec<[u32; 2]>,
    /// The voxels of the deposits newly observed.
    pub(super) laid: Vec<Vec<u32>>,
    /// The arc's heat (voxel, W bits; distinct voxels, as the prologue adds without atomics).
    pub(super) sources: Option<Vec<[u32; 2]>>,
    /// Convection, εσ and the table's conductance (W/m²K, W/m²K⁴, W/m²K), and a pad.
    pub(super) losses: Option<[f32; 4]>,
}

/// One step as a member recorded it.
pub(super) struct Step {
    /// The geometry it stands on (active voxels, interface pairs, deposits on the device): the
    /// members of a batch must agree.
    pub(super) shape: [usize; 3],
    pub(super) changes: Option<Changes>,
    pub(super) p: Params,
}

/// A member's steps since the device was last read, and the read that ends them.
pub(super) struct Round {
    /// In a batch: the member's host copy, from which the field is made again first.
    pub(super) remake: Option<(Box<VoxelModel>, Vec<f32>)>,
    pub(super) steps: Vec<Step>,
    pub(super) what: Read,
}

/// What a read brings one member: the loss sums (Σ dt·exposed·(T − T_a), Σ dt·exposed·(T⁴ −
/// T_a⁴), Σ dt·table·(T − T_a)), each step's hottest laid metal, and as the read asks the
/// temperatures, or the whole field with the deposits' peaks and times above. Borrowed from
/// the read-back buffer, where a lone run takes it; a batch's members take it owned.
pub(super) struct Parts<'a> {
    pub(super) h: &'a [f32],
    pub(super) t: &'a [f32],
    pub(super) phi: &'a [f32],
    pub(super) peak: &'a [f32],
    pub(super) above: &'a [f32],
    pub(super) sums: [f64; 3],
    pub(super) hot: &'a [f32],
}

/// [`Parts`] owned: what a batch hands a member.
pub(super) struct Reply {
    h: Vec<f32>,
    t: Vec<f32>,
    phi: Vec<f32>,
    peak: Vec<f32>,
    above: Vec<f32>,
    sums: [f64; 3],
    hot: Vec<f32>,
}

impl Reply {
    pub(super) fn of(p: Parts) -> Reply {
        Reply {
            h: p.h.to_vec(),
            t: p.t.to_vec(),
            phi: p.phi.to_vec(),
            peak: p.peak.to_vec(),
            above: p.above.to_vec(),
            sums: p.sums,
            hot: p.hot.to_vec(),
        }
    }

    pub(super) fn parts(&self) -> Parts<'_> {
        Parts {
            h: &self.h,
            t: &self.t,
            phi: &self.phi,
            peak: &self.peak,
            above: &self.above,
            sums: self.sums,
            hot: &self.hot,
        }
    }
}

/// The active set of one or more members on the device, and the steps recorded but not yet
/// sent.
pub(super) struct Field {
    pub(super) gpu: Arc<Gpu>,
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
    pub(super) regular: usize,
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
pub(super) fn strides(m: &VoxelModel) -> [u32; 2] {
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
pub(super) fn area_of(m: &VoxelModel, i: usize, [sy, sz]: [u32; 2]) -> [f32; 2] {
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
pub(super) fn losses_of(m: &VoxelModel) -> [f32; 4] {
    let sur = m.settings.surroundings;
    [
        sur.convection_w_m2k as f32,
        (sur.emissivity * SIGMA) as f32,
        sur.table_w_m2k as f32,
        0.0,
    ]
}

pub(super) fn interface_len(m: &VoxelModel) -> usize {
    m.substrate.as_deref().map_or(0, |s| s.interface.len())
}

impl Field {
    /// A field holding the active sets of `models` (one grid: the first's geometry, each its
    /// own state, losses and the deposits' `peaks` so far), with room to grow.
    pub(super) fn new(
        gpu: Arc<Gpu>,
        models: &[&VoxelModel],
        peaks: &[&[f32]],
    ) -> Result<Field, ThermalError> {
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
    pub(super) fn fits(&self, m: &VoxelModel) -> bool {
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
    /// step one dispatch per pass for every member, then the read they end with, handed to
    /// `deliver` member by member.
    pub(super) fn run(
        &mut self,
        rounds: &[Round],
        deliver: &mut dyn FnMut(usize, Parts),
    ) -> Result<(), String> {
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
        self.read(first.what, steps, deliver)
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
    fn read(
        &mut self,
        what: Read,
        hot: usize,
        deliver: &mut dyn FnMut(usize, Parts),
    ) -> Result<(), String> {
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
        for j in 0..self.members {
            let w = &words[j * per..(j + 1) * per];
            let (h, rest) = w.split_at(n);
            let (t, rest) = rest.split_at(n_t);
            let (phi, rest) = rest.split_at(n);
            let (peak, rest) = rest.split_at(deps);
            let (above, rest) = rest.split_at(deps);
            let (sums, rest) = rest.split_at(acc);
            let mut total = [0.0f64; 3];
            for group in sums.chunks_exact(6) {
                for k in 0..3 {
                    total[k] += group[k] as f64 - group[3 + k] as f64;
                }
            }
            let parts = Parts {
                h,
                t,
                phi,
                peak,
                above,
                sums: total,
                hot: &rest[..hot],
            };
            deliver(j, parts);
        }
        drop(view);
        staging.unmap();
        self.acc_groups = 0;
        Ok(())
    }
}

fn write<T: Pod>(q: &wgpu::Queue, buf: &wgpu::Buffer, data: &[T]) {
    if !data.is_empty() {
        q.write_buffer(buf, 0, bytemuck::cast_slice(data));
    }
}
