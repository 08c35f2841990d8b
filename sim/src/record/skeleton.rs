//! A skeleton run's recordings (skeleton arc AM): `run.rrd` (rerun 0.36: the skeleton's
//! polylines as line strips, each drop a sphere of its R_deposit appearing as its arc strikes,
//! `world/drops/NNNN`, coloured from blue to red by its solidification time, the torch as an
//! arrow, and `plots/ctdwp_mm` and `plots/solidification_s` on the `sim_time` timeline; mm) and
//! `run.mcap` (`/drops`: one JSON message per drop, `{i, t_s, branch, position_mm, radius_mm,
//! ctdwp_mm, weld_time_s, solidification_s}`, in time order, for Foxglove).

use super::rerun_layout::{Node, view};
use crate::error::{Error, Result};
use crate::output::RunDir;
use serde_json::json;
use std::collections::BTreeMap;

const TIMELINE: &str = "sim_time";
/// The torch arrow's length, mm.
const TORCH_MM: f32 = 25.0;

/// One drop as recorded, mm and s.
pub struct DropView {
    pub position_mm: [f64; 3],
    pub radius_mm: f64,
    /// From the drop to the torch.
    pub tool: [f64; 3],
    /// When its arc strikes.
    pub t_s: f64,
    pub branch: usize,
    pub ctdwp_mm: f64,
    pub weld_time_s: f64,
    pub solidification_s: Option<f64>,
}

fn fail(what: &'static str) -> impl Fn(String) -> Error {
    move |e| Error::failure(format!("{what}: {e}"))
}

fn f32x3(p: [f64; 3]) -> [f32; 3] {
    p.map(|x| x as f32)
}

/// Write run.rrd and run.mcap of a skeleton run, as `(rerun, mcap)` ask; `polylines` the
/// skeleton's branches (mm).
pub fn skeleton_recordings(
    dir: &mut RunDir,
    title: &str,
    polylines: &[Vec<[f64; 3]>],
    drops: &[DropView],
    (rerun, mcap_on): (bool, bool),
) -> Result<()> {
    if rerun {
        rrd(dir, title, polylines, drops)?;
    }
    if mcap_on {
        mcap(dir, title, drops)?;
    }
    Ok(())
}

/// Blue (quick) to red (slowest) by solidification time; grey without heat.
fn colour(s: Option<f64>, max: f64) -> rerun::Color {
    match s {
        None => rerun::Color::from_rgb(200, 200, 200),
        Some(s) => {
            let f = (s / max.max(1e-9)).clamp(0.0, 1.0);
            rerun::Color::from_rgb(
                (50.0 + 180.0 * f) as u8,
                (100.0 - 40.0 * f) as u8,
                (220.0 - 190.0 * f) as u8,
            )
        }
    }
}

fn rrd(
    dir: &mut RunDir,
    title: &str,
    polylines: &[Vec<[f64; 3]>],
    drops: &[DropView],
) -> Result<()> {
    let e = fail("run.rrd");
    let (rec, staged) = super::rerun_sink::open(dir, title)?;
    let layout = Node::Row(vec![
        (2.0, view("3D", "drops", "world", &["world/**"])),
        (
            1.0,
            Node::Column(vec![
                (
                    1.0,
                    view("TimeSeries", "CTDWP, mm", "/", &["plots/ctdwp_mm"]),
                ),
                (
                    1.0,
                    view(
                        "TimeSeries",
                        "solidification, s",
                        "/",
                        &["plots/solidification_s"],
                    ),
                ),
            ]),
        ),
    ]);
    super::rerun_layout::send(&rec, &layout, TIMELINE).map_err(|x| e(x.to_string()))?;
    let log = |r: rerun::RecordingStreamResult<()>| r.map_err(|x| e(x.to_string()));
    log(rec.log_static("world", &rerun::ViewCoordinates::RIGHT_HAND_Z_UP()))?;
    log(rec.log_static(
        "world/skeleton",
        &rerun::LineStrips3D::new(polylines.iter().map(|t| t.iter().copied().map(f32x3)))
            .with_colors([rerun::Color::from_rgb(120, 120, 130)])
            .with_radii([rerun::Radius::new_ui_points(1.0)]),
    ))?;
    let max = drops
        .iter()
        .filter_map(|d| d.solidification_s)
        .fold(0.0, f64::max);
    for (i, d) in drops.iter().enumerate() {
        rec.set_duration_secs(TIMELINE, d.t_s);
        log(rec.log(
            format!("world/drops/{i:04}"),
            &rerun::Points3D::new([f32x3(d.position_mm)])
                .with_radii([rerun::Radius::new_scene_units(d.radius_mm as f32)])
                .with_colors([colour(d.solidification_s, max)]),
        ))?;
        let tip = f32x3(d.position_mm);
        let axis = f32x3(d.tool);
        let origin: [f32; 3] = std::array::from_fn(|k| tip[k] + axis[k] * TORCH_MM);
        log(rec.log(
            "world/torch",
            &rerun::Arrows3D::from_vectors([axis.map(|a| -a * TORCH_MM)])
                .with_origins([origin])
                .with_colors([rerun::Color::from_rgb(255, 140, 0)]),
        ))?;
        log(rec.log("plots/ctdwp_mm", &rerun::Scalars::single(d.ctdwp_mm)))?;
        if let Some(s) = d.solidification_s {
            log(rec.log("plots/solidification_s", &rerun::Scalars::single(s)))?;
        }
    }
    rec.flush_blocking().map_err(|x| e(x.to_string()))?;
    drop(rec);
    dir.commit(&staged, "run.rrd").map(|_| ())
}

fn mcap(dir: &mut RunDir, title: &str, drops: &[DropView]) -> Result<()> {
    let number = json!({"type": "number"});
    let schema = json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "waamtwin.Drop",
        "type": "object",
        "properties": {
            "i": {"type": "integer"}, "t_s": number, "branch": {"type": "integer"},
            "position_mm": {"type": "array", "items": number, "minItems": 3, "maxItems": 3},
            "radius_mm": number, "ctdwp_mm": number, "weld_time_s": number,
            "solidification_s": {"type": ["number", "null"]},
        },
        "required": ["i", "t_s", "branch", "position_mm", "radius_mm", "ctdwp_mm", "weld_time_s"],
    });
    let messages = drops.iter().enumerate().map(|(i, d)| {
        (
            d.t_s,
            json!({"i": i, "t_s": d.t_s, "branch": d.branch, "position_mm": d.position_mm,
                "radius_mm": d.radius_mm, "ctdwp_mm": d.ctdwp_mm, "weld_time_s": d.weld_time_s,
                "solidification_s": d.solidification_s}),
        )
    });
    super::mcap_json::write(
        dir,
        "run.mcap",
        super::mcap_json::Topic {
            schema_name: "waamtwin.Drop",
            schema,
            topic: "/drops",
            metadata_name: "skeleton",
            metadata: BTreeMap::from([
                ("title".to_string(), title.to_string()),
                ("units".to_string(), "length mm, time s".to_string()),
            ]),
        },
        messages,
    )
}
