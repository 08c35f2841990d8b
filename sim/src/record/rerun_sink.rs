//! `run.rrd`: a rerun recording (rerun 0.36), right-handed z-up, lengths in mm, on the
//! `sim_time` timeline (seconds of build time).
//!
//! Entities: `world/part` (mesh), `world/plate` (box), `world/plan/spiral` and
//! `world/plan/generators` (static line strips), `world/deposited/NNNN` (the path laid between two
//! frames, so the deposit grows), `world/torch` (arrow from
//! the torch to the deposit), `world/wall` (the deposited wall with per-vertex temperature
//! colours, see [`super::temperature_colour`]; logged whole at the first frame, so the viewer
//! never sees vertices without triangles), `world/temperature` (the laid points in the same
//! colours, each carrying its `temperature_c`: hover a point to read it), `legend` (the colour
//! scale as an image), `plots/*` (one quantity per plot: preheat against the limit, the hottest
//! laid metal every step, arc power, dwells), `events` (text log, one event per run of
//! consecutive points). The scenario is a recording property. The layout ([`layout`]) opens at
//! the end of the build on the wall coloured by temperature, the plan and the beads a tab away
//! (they would hide the wall), beside the plots over the whole build.

use super::rerun_layout::{Node, view};
use super::{Moment, Scene, Sink, temperature_colour};
use crate::error::{Error, Result};
use crate::output::RunDir;
use crate::record::Level;
use rerun::{RecordingStream, RecordingStreamBuilder};

const TIMELINE: &str = "sim_time";
/// Length of the torch arrow, mm.
const TORCH_MM: f32 = 25.0;
/// The colour scale's image, pixels.
const LEGEND_PX: (u32, u32) = (640, 90);

#[derive(Default)]
pub struct RerunSink {
    rec: Option<RecordingStream>,
    staged: Option<std::path::PathBuf>,
    /// Path points already drawn as deposited.
    drawn: usize,
    segment: usize,
    /// The wall mesh's vertices are logged (with the first frame).
    wall_logged: bool,
}

fn fail(e: impl std::fmt::Display) -> Error {
    Error::failure(format!("run.rrd: {e}"))
}

/// A rerun recording named `title`, saving to run.rrd's staged name in `dir` (renamed into place
/// by `RunDir::commit` once written): every run.rrd this crate writes starts here.
pub(crate) fn open(dir: &RunDir, title: &str) -> Result<(RecordingStream, std::path::PathBuf)> {
    let staged = dir.stage("run.rrd");
    let rec = RecordingStreamBuilder::new("waamtwin")
        .save(&staged)
        .map_err(fail)?;
    rec.send_recording_name(title).map_err(fail)?;
    Ok((rec, staged))
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
        let (rec, staged) = open(dir, &scene.title)?;
        rec.send_property(
            "scenario",
            &rerun::AnyValues::default()
                .with_component::<rerun::components::Text>("json", [scene.scenario.to_string()]),
        )
        .map_err(fail)?;
        super::rerun_layout::send(&rec, &layout(), TIMELINE).map_err(fail)?;
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
        let centre = [cx as f32, cy as f32, -(sz / 2.0) as f32];
        let grey = rerun::Color::from_rgb(110, 110, 120);
        if scene.plate_disc {
            rec.log_static(
                "world/plate",
                &rerun::Cylinders3D::from_lengths_and_radii([sz as f32], [(sx / 2.0) as f32])
                    .with_centers([centre])
                    .with_colors([grey]),
            )
        } else {
            rec.log_static(
                "world/plate",
                &rerun::Boxes3D::from_centers_and_sizes(
                    [centre],
                    [[sx as f32, sy as f32, sz as f32]],
                )
                .with_colors([grey]),
            )
        }
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
        let legend = super::plots::colour_scale(scene.ambient_c, scene.interpass_c, LEGEND_PX)?;
        rec.log_static(
            "legend",
            &rerun::Image::from_rgb24(legend, [LEGEND_PX.0, LEGEND_PX.1]),
        )
        .map_err(fail)?;
        series_styles(&rec)?;
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
                ] {
                    rec.log(name, &rerun::Scalars::single(v)).map_err(fail)?;
                }
                // A dwell is an event, not a level: a marker where there is one.
                if p.dwell_s > 0.0 {
                    rec.log("plots/dwell_s", &rerun::Scalars::single(p.dwell_s))
                        .map_err(fail)?;
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
                let colour = |t: f32| {
                    let [r, g, b, a] =
                        temperature_colour(t as f64, scene.ambient_c, scene.interpass_c);
                    rerun::Color::from_unmultiplied_rgba(r, g, b, a)
                };
                let colours = f.temperature_c.iter().map(|&t| colour(t));
                let mesh = if self.wall_logged {
                    rerun::Mesh3D::update_fields()
                } else {
                    self.wall_logged = true;
                    rerun::Mesh3D::new(scene.points.iter().map(|p| f32x3(p.position_mm)))
                };
                rec.log(
                    "world/wall",
                    &mesh.with_triangle_indices(tris).with_vertex_colors(colours),
                )
                .map_err(fail)?;
                let laid = &f.temperature_c[..end];
                rec.log(
                    "world/temperature",
                    &rerun::Points3D::new(scene.points[..end].iter().map(|p| f32x3(p.position_mm)))
                        .with_colors(laid.iter().map(|&t| colour(t)))
                        .with_radii([rerun::Radius::new_ui_points(2.0)]),
                )
                .map_err(fail)?;
                rec.log(
                    "world/temperature",
                    &rerun::AnyValues::default().with_component::<rerun::components::Scalar>(
                        "temperature_c",
                        laid.iter().map(|&t| t as f64),
                    ),
                )
                .map_err(fail)?;
            }
            Moment::Hottest(k) => {
                rec.log(
                    "plots/max_temperature_c",
                    &rerun::Scalars::single(scene.hottest[k].1),
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

/// Names and colours of the plotted series, so each plot reads without a legend of its own.
fn series_styles(rec: &RecordingStream) -> Result<()> {
    let line = |name: &str, [r, g, b]: [u8; 3]| {
        rerun::SeriesLines::new()
            .with_names([name])
            .with_colors([rerun::Color::from_rgb(r, g, b)])
    };
    for (path, style) in [
        ("plots/preheat_c", line("preheat, °C", [40, 90, 220])),
        (
            "plots/interpass_max_c",
            line("interpass limit, °C", [220, 40, 40]),
        ),
        (
            "plots/max_temperature_c",
            line("hottest laid metal, °C", [230, 120, 20]),
        ),
        ("plots/power_w", line("arc power, W", [90, 90, 90])),
    ] {
        rec.log_static(path, &style).map_err(fail)?;
    }
    rec.log_static(
        "plots/dwell_s",
        &rerun::SeriesPoints::new()
            .with_names(["dwell before the point, s"])
            .with_colors([rerun::Color::from_rgb(40, 150, 90)])
            .with_marker_sizes([3.0]),
    )
    .map_err(fail)
}

/// On the left the 3-D view above the colour scale: the wall coloured by temperature on
/// opening, the planned spiral, generators and laid beads in a second tab. On the right one
/// plot per quantity over the whole build, then the event log.
fn layout() -> Node {
    let plot = |name: &str, contents: &[&str]| (1.0, view("TimeSeries", name, "/", contents));
    Node::Row(vec![
        (
            3.0,
            Node::Column(vec![
                (
                    6.0,
                    Node::Tabs(vec![
                        view(
                            "3D",
                            "wall temperature",
                            "world",
                            &["world/**", "- world/plan/**", "- world/deposited/**"],
                        ),
                        view(
                            "3D",
                            "plan and beads",
                            "world",
                            &["world/**", "- world/wall", "- world/temperature"],
                        ),
                    ]),
                ),
                (1.0, view("2D", "colour scale", "legend", &["legend"])),
            ]),
        ),
        (
            2.0,
            Node::Column(vec![
                plot(
                    "preheat against the interpass limit, °C",
                    &["plots/preheat_c", "plots/interpass_max_c"],
                ),
                plot("hottest laid metal, °C", &["plots/max_temperature_c"]),
                plot("arc power, W", &["plots/power_w"]),
                plot("dwells, s", &["plots/dwell_s"]),
                (1.2, view("TextLog", "events", "events", &["events"])),
            ]),
        ),
    ])
}
