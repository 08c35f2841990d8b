//! A replay's recordings: the probes as series, measured beside predicted, and the path that
//! was laid. `run.rrd` (rerun 0.36: `world/path` line strips and `world/probes` labelled points
//! in mm, `probes/NAME/measured_c` and `probes/NAME/predicted_c` on the `sim_time` timeline,
//! a layout with the path beside six probes' plots over the whole build) and `run.mcap`
//! (`/probes`: one JSON message per sample, `{probe, t_s, measured_c, predicted_c}`, in time
//! order, for Foxglove's plot panel as `/probes{probe=="tc1"}.predicted_c`).

use super::rerun_layout::{Node, view};
use crate::error::{Error, Result};
use crate::output::RunDir;
use crate::pipeline::replay::Sample;
use serde_json::json;
use std::collections::BTreeMap;

const TIMELINE: &str = "sim_time";

/// One probe as recorded.
pub struct ProbeSeries<'a> {
    pub name: &'a str,
    pub position_mm: [f64; 3],
    pub samples: &'a [Sample],
}

fn fail(what: &'static str) -> impl Fn(String) -> Error {
    move |e| Error::failure(format!("{what}: {e}"))
}

/// Write run.rrd and run.mcap of a replay: `tracks` are the laid path's tracks (mm).
pub fn write(
    dir: &mut RunDir,
    title: &str,
    tracks: &[Vec<[f64; 3]>],
    probes: &[ProbeSeries],
) -> Result<()> {
    rrd(dir, title, tracks, probes)?;
    mcap(dir, title, probes)
}

fn f32x3(p: [f64; 3]) -> [f32; 3] {
    p.map(|x| x as f32)
}

/// The probes a person looks at first: up to six spread over all, first and last included.
pub fn shown(n: usize) -> Vec<usize> {
    match n {
        n if n <= 6 => (0..n).collect(),
        n => (0..6).map(|k| k * (n - 1) / 5).collect(),
    }
}

fn rrd(
    dir: &mut RunDir,
    title: &str,
    tracks: &[Vec<[f64; 3]>],
    probes: &[ProbeSeries],
) -> Result<()> {
    let e = fail("run.rrd");
    let (rec, staged) = super::rerun_sink::open(dir, title)?;
    let plots: Vec<(f32, Node)> = shown(probes.len())
        .into_iter()
        .map(|k| {
            let name = probes[k].name;
            let path = format!("probes/{name}/**");
            (
                1.0,
                view("TimeSeries", &format!("{name}, °C"), "/", &[path.as_str()]),
            )
        })
        .collect();
    let layout = Node::Row(vec![
        (2.0, view("3D", "path and probes", "world", &["world/**"])),
        (3.0, Node::Column(plots)),
    ]);
    super::rerun_layout::send(&rec, &layout, TIMELINE).map_err(|x| e(x.to_string()))?;
    let log = |r: rerun::RecordingStreamResult<()>| r.map_err(|x| e(x.to_string()));
    log(rec.log_static("world", &rerun::ViewCoordinates::RIGHT_HAND_Z_UP()))?;
    log(rec.log_static(
        "world/path",
        &rerun::LineStrips3D::new(tracks.iter().map(|t| t.iter().copied().map(f32x3)))
            .with_colors([rerun::Color::from_rgb(200, 200, 200)])
            .with_radii([rerun::Radius::new_ui_points(1.0)]),
    ))?;
    log(rec.log_static(
        "world/probes",
        &rerun::Points3D::new(probes.iter().map(|p| f32x3(p.position_mm)))
            .with_labels(probes.iter().map(|p| p.name))
            .with_colors([rerun::Color::from_rgb(230, 120, 20)])
            .with_radii([rerun::Radius::new_ui_points(4.0)]),
    ))?;
    for p in probes {
        for (what, colour) in [("measured", [230, 230, 230]), ("predicted", [230, 120, 20])] {
            let [r, g, b] = colour;
            log(rec.log_static(
                format!("probes/{}/{what}_c", p.name),
                &rerun::SeriesLines::new()
                    .with_names([format!("{what}, °C")])
                    .with_colors([rerun::Color::from_rgb(r, g, b)]),
            ))?;
        }
        for &(t, m, pr) in p.samples {
            rec.set_duration_secs(TIMELINE, t);
            log(rec.log(
                format!("probes/{}/measured_c", p.name),
                &rerun::Scalars::single(m),
            ))?;
            log(rec.log(
                format!("probes/{}/predicted_c", p.name),
                &rerun::Scalars::single(pr),
            ))?;
        }
    }
    rec.flush_blocking().map_err(|x| e(x.to_string()))?;
    drop(rec);
    dir.commit(&staged, "run.rrd").map(|_| ())
}

/// run.mcap of the probes.
pub fn mcap(dir: &mut RunDir, title: &str, probes: &[ProbeSeries]) -> Result<()> {
    let schema = json!({
        "$schema": "https://json-schema.org/draft/2020-12/schema",
        "title": "waamtwin.ProbeSample",
        "type": "object",
        "properties": {
            "probe": {"type": "string"},
            "t_s": {"type": "number"},
            "measured_c": {"type": "number"},
            "predicted_c": {"type": "number"},
        },
        "required": ["probe", "t_s", "measured_c", "predicted_c"],
    });
    // Every sample of every probe, in time order (MCAP readers expect log-time order).
    let mut all: Vec<(f64, usize, usize)> = probes
        .iter()
        .enumerate()
        .flat_map(|(k, p)| p.samples.iter().enumerate().map(move |(j, s)| (s.0, k, j)))
        .collect();
    all.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let messages = all.into_iter().map(|(t, k, j)| {
        let (_, m, p) = probes[k].samples[j];
        (
            t,
            json!({"probe": probes[k].name, "t_s": t, "measured_c": m, "predicted_c": p}),
        )
    });
    super::mcap_json::write(
        dir,
        "run.mcap",
        super::mcap_json::Topic {
            schema_name: "waamtwin.ProbeSample",
            schema,
            topic: "/probes",
            metadata_name: "replay",
            metadata: BTreeMap::from([
                ("title".to_string(), title.to_string()),
                ("units".to_string(), "temperature °C, time s".to_string()),
            ]),
        },
        messages,
    )
}
