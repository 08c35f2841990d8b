//! The voxel model's steps on a GPU, through wgpu's compute shaders (Vulkan, Metal, DX12), as
//! `[thermal] device = "gpu"` asks. The host's [`VoxelModel`] stays the model: it lays the
//! metal, places the arc's heat and reads the results; a `field::Field` holds a copy of its active
//! set on the device and steps it (`gpu.wgsl`: the same arithmetic as `kernel.rs`, in f32).
//!
//! One rule keeps the two copies straight: between two calls of the run (a deposit, a cooling)
//! the host's copy is current; within a call the device's is, and the host's is read back at
//! its end and wherever the run must read a temperature in between (a preheat during the arc,
//! a probe or snapshot falling due). A model's `lane::Lane` records its steps, each with what the
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
//! (`batch::Batch`). Their steps must agree (the same program, the same reads); where they do not,
//! every member's run fails with a message that says so, none waits for ever.
//!
//! Not done on the device: the coarsened plate's seams (`coarse_plate` is refused with the
//! GPU: the device has the throughput that coarsening buys on a CPU). The price of the rule:
//! every call reads the whole field back (12 bytes a voxel), so a run's cost on the device
//! still grows as deposits × voxels, if with a far smaller constant; reading back only the
//! voxels the host asks for would take that out, and needs the host's reads (a clone, a
//! checkpoint written) to come through the device.

mod batch;
mod field;
mod lane;

pub use batch::Seat;
pub(super) use batch::share;
pub(super) use lane::Lane;
use std::sync::{Arc, OnceLock};

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
