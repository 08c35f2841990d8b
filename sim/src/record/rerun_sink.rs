//! `run.rrd`: a rerun recording (rerun 0.36), right-handed z-up, lengths in mm, on the
//! `sim_time` timeline (seconds of build time).
//!
//! Entities: `world/part` (mesh), `world/plate` (box), `world/plan/spiral` and
//! `world/plan/generators` (static line strips), `world/deposited/NNNN` (the path laid between two
//! frames, so the deposit grows), `world/torch` (arrow from the torch to the deposit),
//! `world/wall` (the deposited wall with per-vertex temperature colours, see
//! [`super::temperature_colour`], and the raw values as `temperature_c`), `plots/*` (scalars),
//! `events` (text log). The scenario is a recording property; the blueprint opens on the 3-D
//! view beside the plots.

use super::{Moment, Scene, Sink, temperature_colour};
use crate::error::{Error, Result};
use crate::output::RunDir;
use crate::record::Level;
use rerun::blueprint::{
    Blueprint, BlueprintActivation, Horizontal, Spatial3DView, TextLogView, TimeSeriesView,
    Vertical,
};
use rerun::{RecordingStream, RecordingStreamBuilder};

const TIMELINE: &str = "sim_time";
/// Length of the torch arrow, mm.
const TORCH_MM: f32 = 25.0;

#[derive(Default)]
pub struct RerunSink {
    rec: Option<RecordingStream>,
    staged: Option<std::path::PathBuf>,
    /// Path points already drawn as deposited.
    drawn: usize,
    segment: usize,
}

fn fail(e: impl std::fmt::Display) -> Error {
    Error::failure(format!("run.rrd: {e}"))
}

fn f32x3(p: [f64; 3]) -> [f32; 3] {
    [p[0] as f32, p[1] as f32, p[2] as f32]
}

impl RerunSink {
    fn rec(&self) -> &RecordingStream {
        self.rec.as_ref().expect("begin() opens the recording")
    }
}

impl Sink for RerunSink {
    fn begin(&mut self, scene: &Scene, dir: &RunDir) -> Result<()> {
        let staged = dir.stage("run.rrd");
        let rec = RecordingStreamBuilder::new("waamtwin")
            .save(&staged)
            .map_err(fail)?;
        rec.send_recording_name(scene.title.clone()).map_err(fail)?;
        rec.send_property(
            "scenario",
            &rerun::AnyValues::default()
                .with_component::<rerun::components::Text>("json", [scene.scenario.to_string()]),
        )
        .map_err(fail)?;
        blueprint()
            .send(&rec, BlueprintActivation::default())
            .map_err(fail)?;
        rec.log_static("world", &rerun::ViewCoordinates::RIGHT_HAND_Z_UP())
            .map_err(fail)?;
        let part = &scene.part;
        rec.log_static(
            "world/part",
            &rerun::Mesh3D::new(
                part.positions
                    .iter()
                    .map(|p| [p.x as f32, p.y as f32, p.z as f32]),
            )
            .with_triangle_indices(part.faces.iter().map(|f| rerun::TriangleIndices::from(*f)))
            .with_albedo_factor(rerun::Rgba32::from_unmultiplied_rgba(170, 170, 180, 60)),
        )
        .map_err(fail)?;
        let [cx, cy] = scene.plate_centre_mm;
        let [sx, sy, sz] = scene.plate_size_mm;
        rec.log_static(
            "world/plate",
            &rerun::Boxes3D::from_centers_and_sizes(
                [[cx as f32, cy as f32, -(sz / 2.0) as f32]],
                [[sx as f32, sy as f32, sz as f32]],
            )
            .with_colors([rerun::Color::from_rgb(110, 110, 120)]),
        )
        .map_err(fail)?;
        rec.log_static(
            "world/plan/spiral",
            &rerun::LineStrips3D::new([scene.points.iter().map(|p| f32x3(p.position_mm))])
                .with_colors([rerun::Color::from_rgb(90, 140, 255)])
                .with_radii([rerun::Radius::new_ui_points(0.5)]),
        )
        .map_err(fail)?;
        rec.log_static(
            "world/plan/generators",
            &rerun::LineStrips3D::new(
                scene
                    .generators
                    .iter()
                    .map(|g| g.iter().copied().map(f32x3)),
            )
            .with_colors([rerun::Color::from_rgb(200, 200, 200)])
            .with_radii([rerun::Radius::new_ui_points(0.5)]),
        )
        .map_err(fail)?;
        rec.log_static(
            "world/wall",
            &rerun::Mesh3D::new(scene.points.iter().map(|p| f32x3(p.position_mm))),
        )
        .map_err(fail)?;
        self.rec = Some(rec);
        self.staged = Some(staged);
        Ok(())
    }

    fn moment(&mut self, scene: &Scene, m: Moment<'_>) -> Result<()> {
        let t = m.time(scene);
        let rec = self.rec().clone();
        rec.set_duration_secs(TIMELINE, t);
        match m {
            Moment::Point(i) => {
                let p = &scene.points[i];
                let tip = f32x3(p.position_mm);
                let axis = f32x3(p.tool);
                let origin: [f32; 3] = std::array::from_fn(|k| tip[k] + axis[k] * TORCH_MM);
                rec.log(
                    "world/torch",
                    &rerun::Arrows3D::from_vectors([axis.map(|a| -a * TORCH_MM)])
                        .with_origins([origin])
                        .with_colors([rerun::Color::from_rgb(255, 140, 0)]),
                )
                .map_err(fail)?;
                for (name, v) in [
                    ("plots/preheat_c", p.preheat_c),
                    ("plots/interpass_max_c", scene.interpass_c),
                    ("plots/power_w", p.power_w),
                    ("plots/dwell_s", p.dwell_s),
                ] {
                    rec.log(name, &rerun::Scalars::single(v)).map_err(fail)?;
                }
            }
            Moment::Field(f) => {
                let end = f.laid.min(scene.points.len());
                if end > self.drawn {
                    let from = self.drawn.saturating_sub(1);
                    rec.log(
                        format!("world/deposited/{:04}", self.segment),
                        &rerun::LineStrips3D::new([scene.points[from..end]
                            .iter()
                            .map(|p| f32x3(p.position_mm))])
                        .with_colors([rerun::Color::from_rgb(230, 230, 230)])
                        .with_radii([rerun::Radius::new_scene_units(1.2)]),
                    )
                    .map_err(fail)?;
                    self.segment += 1;
                    self.drawn = end;
                }
                let tris = scene
                    .wall
                    .iter()
                    .filter(|t| t.iter().all(|&v| (v as usize) < f.laid))
                    .map(|t| rerun::TriangleIndices::from(*t));
                let colours = f.temperature_c.iter().map(|&t| {
                    let [r, g, b, a] =
                        temperature_colour(t as f64, scene.ambient_c, scene.interpass_c);
                    rerun::Color::from_unmultiplied_rgba(r, g, b, a)
                });
                rec.log(
                    "world/wall",
                    &rerun::Mesh3D::update_fields()
                        .with_triangle_indices(tris)
                        .with_vertex_colors(colours),
                )
                .map_err(fail)?;
                rec.log(
                    "world/wall",
                    &rerun::AnyValues::default().with_component::<rerun::components::Scalar>(
                        "temperature_c",
                        f.temperature_c.iter().map(|&t| t as f64),
                    ),
                )
                .map_err(fail)?;
                rec.log(
                    "plots/max_temperature_c",
                    &rerun::Scalars::single(f.max_c() as f64),
                )
                .map_err(fail)?;
            }
            Moment::Event(e) => {
                let level = match e.level {
                    Level::Info => rerun::TextLogLevel::INFO,
                    Level::Warning => rerun::TextLogLevel::WARN,
                };
                rec.log(
                    "events",
                    &rerun::TextLog::new(e.text.clone()).with_level(level),
                )
                .map_err(fail)?;
            }
        }
        Ok(())
    }

    fn finish(self: Box<Self>, _scene: &Scene, dir: &mut RunDir) -> Result<()> {
        let rec = self.rec.expect("begin() opens the recording");
        rec.flush_blocking().map_err(fail)?;
        drop(rec);
        dir.commit(
            self.staged.as_deref().expect("staged in begin()"),
            "run.rrd",
        )
        .map(|_| ())
    }
}

/// The 3-D view on the left, the plots and the event log on the right.
fn blueprint() -> Blueprint {
    Blueprint::new(Horizontal::new([
        Spatial3DView::new("part").with_origin("world").into(),
        Vertical::new([
            TimeSeriesView::new("preheat °C")
                .with_contents(["plots/preheat_c", "plots/interpass_max_c"])
                .into(),
            TimeSeriesView::new("max wall temperature °C")
                .with_contents(["plots/max_temperature_c"])
                .into(),
            TimeSeriesView::new("arc power W, dwell s")
                .with_contents(["plots/power_w", "plots/dwell_s"])
                .into(),
            TextLogView::new("events").with_origin("events").into(),
        ])
        .into(),
    ]))
}
