//! Inspection outputs: what an engineer opens in the tools they already use.
//!
//! A finished run becomes one [`Scene`] (what does not change: the part, the plan, the per-point
//! results) and a time-ordered stream of [`Moment`]s (a path point laid, a field frame, an
//! event). Each sink (rerun, MCAP, VTKHDF, plots) implements [`Sink`]; [`record`] feeds them
//! all from one thread, in time order, so rerun's per-thread timelines and MCAP's log-time order
//! hold by construction.
//!
//! Sizes stay bounded on long builds: fields are kept at most `[output] frames` times, and fewer
//! when the path is long ([`crate::pipeline::frame_times`]); the torch is sampled at most
//! [`TORCH_SAMPLES`] times.

mod colour;
#[cfg(feature = "recording")]
mod foxglove;
#[cfg(feature = "recording")]
pub mod live;
#[cfg(feature = "recording")]
mod mcap_json;
#[cfg(feature = "recording")]
mod plots;
#[cfg(feature = "recording")]
pub mod replay;
#[cfg(feature = "recording")]
mod report;
#[cfg(feature = "recording")]
mod rerun_layout;
#[cfg(feature = "recording")]
mod rerun_sink;
mod scene;
#[cfg(feature = "recording")]
mod skeleton;
#[cfg(feature = "recording")]
mod vtkhdf;

pub use colour::{Colour, temperature_colour};
#[cfg(feature = "recording")]
pub use plots::{
    Case, interlayer_map, pareto_plot, probe_plot, solidification_plot, standoff_plot, study_plots,
    write_png,
};
pub use scene::{
    Event, Frame, HOTTEST_SAMPLES, History, Level, PointRecord, Probe, Run, Scene, probe,
};
#[cfg(feature = "recording")]
pub use skeleton::{DropView, skeleton_recordings};

use crate::error::Result;
use crate::output::RunDir;
use crate::scenario::RawOutput;

/// The path points whose temperature history is plotted (and traced step by step): a quarter,
/// half and three quarters up the path.
pub fn history_points(n: usize) -> [usize; 3] {
    [n / 4, n / 2, 3 * n / 4]
}

/// Most torch poses logged over a run.
pub const TORCH_SAMPLES: usize = 20_000;

/// One moment of the build, in time order.
#[derive(Debug, Clone, Copy)]
pub enum Moment<'a> {
    /// The torch lays path point i (at `scene.points[i].t_s`).
    Point(usize),
    /// The temperature of the deposited wall at one time.
    Field(&'a Frame),
    /// Sample k of the hottest laid metal ([`Scene::hottest`]).
    Hottest(usize),
    Event(&'a Event),
}

impl Moment<'_> {
    pub fn time(&self, scene: &Scene) -> f64 {
        match self {
            Moment::Point(i) => scene.points[*i].t_s,
            Moment::Field(f) => f.t_s,
            Moment::Hottest(k) => scene.hottest[*k].0,
            Moment::Event(e) => e.t_s,
        }
    }
}

/// An output format. `begin` sees the scene once (and may stage a file in the run directory), `moment` every moment in time order, `finish`
/// writes the file into the run directory (under a temporary name, renamed into place).
pub trait Sink {
    fn begin(&mut self, scene: &Scene, dir: &RunDir) -> Result<()>;
    fn moment(&mut self, scene: &Scene, moment: Moment<'_>) -> Result<()>;
    fn finish(self: Box<Self>, scene: &Scene, dir: &mut RunDir) -> Result<()>;
}

/// The sinks `[output]` switches on (none in a build without the `recording` feature).
#[cfg(feature = "recording")]
pub fn sinks(o: &RawOutput) -> Vec<Box<dyn Sink>> {
    let mut v: Vec<Box<dyn Sink>> = Vec::new();
    if o.rerun {
        v.push(Box::new(rerun_sink::RerunSink::default()));
    }
    if o.mcap {
        v.push(Box::new(foxglove::McapSink::default()));
    }
    if o.hdf5 {
        v.push(Box::new(vtkhdf::VtkHdfSink));
    }
    if o.plots {
        v.push(Box::new(plots::PlotSink));
    }
    // Last: it inlines the plots written just before it.
    if o.report {
        v.push(Box::new(report::ReportSink));
    }
    v
}

#[cfg(not(feature = "recording"))]
pub fn sinks(_: &RawOutput) -> Vec<Box<dyn Sink>> {
    Vec::new()
}

/// Feed every sink the scene and then every moment in time order, from this one thread.
pub fn record(scene: &Scene, mut sinks: Vec<Box<dyn Sink>>, dir: &mut RunDir) -> Result<()> {
    if sinks.is_empty() {
        return Ok(());
    }
    for s in &mut sinks {
        s.begin(scene, dir)?;
    }
    let stride = scene.points.len().div_ceil(TORCH_SAMPLES).max(1);
    let mut moments: Vec<Moment> = (0..scene.points.len())
        .filter(|i| i % stride == 0 || *i + 1 == scene.points.len())
        .map(Moment::Point)
        .chain(scene.frames.iter().map(Moment::Field))
        .chain((0..scene.hottest.len()).map(Moment::Hottest))
        .chain(scene.events.iter().map(Moment::Event))
        .collect();
    // Stable: a point, then the field at the same time, then the events it caused.
    moments.sort_by(|a, b| a.time(scene).total_cmp(&b.time(scene)));
    for m in moments {
        for s in &mut sinks {
            s.moment(scene, m)?;
        }
    }
    for s in sinks {
        s.finish(scene, dir)?;
    }
    Ok(())
}
