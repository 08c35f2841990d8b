//! `follow`'s run.rrd, written as the run goes (at `.tmp-PID-run.rrd` in the output folder,
//! renamed to run.rrd at its end) and, with `--connect [URL]`, streamed to a running rerun
//! viewer over gRPC at the same time (rerun 0.36: one recording, a file sink and a gRPC sink).
//!
//! On the `sim_time` timeline (seconds of build time): `probes/NAME/measured_c` (every reading
//! as it arrives), `probes/NAME/forecast_H/{predicted_c,p05_c,p95_c}` (each forecast at its
//! target time, H the horizon: `60s`, `300s`, `next_layer`), `parameters/NAME/{mean,p05,p95}`
//! (the ensemble's parameters settling), `events` (a warning per alarm, with its advice),
//! `world/part` (the part's top surface, one point per voxel column, coloured by the members'
//! mean temperature, each point carrying its `temperature_c`; every [`FIELD_EVERY_S`] of build
//! time), and static `world/path` and `world/probes` (mm). The layout puts the part beside six
//! probes' plots and the parameters.

use super::rerun_layout::{Node, view};
use crate::error::{Error, Result};
use crate::output::RunDir;
use crate::pipeline::twin::follow::{Alarm, Forecast, Horizon, Progress};
use rerun::RecordingStream;
use std::path::PathBuf;
use std::time::Duration;

const TIMELINE: &str = "sim_time";
/// Build seconds between two views of the part's temperature.
pub const FIELD_EVERY_S: f64 = 60.0;
/// The colour scale's green: the interpass limit where none is set, °C.
const INTERPASS_C: f64 = 150.0;

/// The rerun viewer's own gRPC address, where `--connect` sends without a URL.
pub const DEFAULT_URL: &str = "rerun+http://127.0.0.1:9876/proxy";

/// The horizons' colours, shortest first.
const HUES: [[u8; 3]; 3] = [[230, 120, 20], [170, 110, 230], [60, 170, 230]];

/// How long the end of a run waits for a streamed viewer to take what is left.
const VIEWER_WAIT: Duration = Duration::from_secs(10);

/// A rerun viewer's gRPC URL (`--connect`), checked.
pub fn viewer(url: &str) -> Result<rerun::external::re_uri::ProxyUri> {
    url.parse().map_err(|e| {
        Error::input(format!(
            "--connect {url}: {e}; expected a rerun gRPC URL such as {DEFAULT_URL}"
        ))
    })
}

/// Whether something accepts a TCP connection at the URL's host and port (within 2 s).
fn listening(url: &str) -> bool {
    use std::net::ToSocketAddrs;
    let Some(authority) = url.split("://").nth(1).and_then(|r| r.split('/').next()) else {
        return false;
    };
    let Ok(addresses) = authority.to_socket_addrs() else {
        return false;
    };
    addresses
        .into_iter()
        .any(|a| std::net::TcpStream::connect_timeout(&a, Duration::from_secs(2)).is_ok())
}

fn fail(e: impl std::fmt::Display) -> Error {
    Error::failure(format!("run.rrd: {e}"))
}

/// The recording and how far into the follower's lists it has logged.
pub struct LiveRecording {
    rec: RecordingStream,
    staged: PathBuf,
    probes: Vec<String>,
    parameters: Vec<(String, [f64; 2])>,
    /// The forecast series already given their names and colours.
    styled: std::collections::BTreeSet<String>,
    horizons_s: Vec<f64>,
    forecasts: usize,
    settling: usize,
    alarms: usize,
    colours: (f64, f64),
    /// The build time of the last view of the part.
    pub field_at_s: Option<f64>,
    /// The viewer's URL, where streaming.
    connected: Option<String>,
}

/// What the recording shows that does not change.
pub struct Scene<'a> {
    pub title: &'a str,
    /// The program's tracks, mm.
    pub tracks: &'a [Vec<[f64; 3]>],
    /// Each probe's name and place, mm.
    pub probes: &'a [(String, [f64; 3])],
    pub horizons_s: &'a [f64],
    /// Each uncertain parameter's name and range.
    pub parameters: &'a [(&'static str, [f64; 2])],
    pub ambient_c: f64,
    /// Where the colour scale turns green, °C.
    pub interpass_c: Option<f64>,
}

impl LiveRecording {
    /// Open run.rrd (and the stream to `connect`, a rerun gRPC URL) and log the scene.
    pub fn open(dir: &RunDir, scene: &Scene, connect: Option<&str>) -> Result<LiveRecording> {
        let staged = dir.stage("run.rrd");
        let file = rerun::sink::FileSink::new(&staged).map_err(fail)?;
        let builder = rerun::RecordingStreamBuilder::new("waamtwin");
        // rerun's gRPC sink holds the logging back while it cannot send (a hundred messages
        // queue): a viewer that is not there would stop the run. One that answers is streamed to.
        let connect = match connect {
            Some(url) if !listening(url) => {
                eprintln!("follow: no rerun viewer answers at {url}; run.rrd only");
                None
            }
            other => other,
        };
        let rec = match connect {
            None => builder.set_sinks((file,)),
            Some(url) => builder.set_sinks((file, rerun::sink::GrpcSink::new(viewer(url)?))),
        }
        .map_err(fail)?;
        rec.send_recording_name(scene.title).map_err(fail)?;
        let r = LiveRecording {
            rec,
            staged,
            probes: scene.probes.iter().map(|p| p.0.clone()).collect(),
            parameters: scene
                .parameters
                .iter()
                .map(|(p, range)| (p.to_string(), *range))
                .collect(),
            styled: Default::default(),
            horizons_s: scene.horizons_s.to_vec(),
            forecasts: 0,
            settling: 0,
            alarms: 0,
            colours: (scene.ambient_c, scene.interpass_c.unwrap_or(INTERPASS_C)),
            field_at_s: None,
            connected: connect.map(String::from),
        };
        r.scene(scene)?;
        Ok(r)
    }

    fn scene(&self, scene: &Scene) -> Result<()> {
        let rec = &self.rec;
        let f32x3 = |p: [f64; 3]| p.map(|x| x as f32);
        let plots: Vec<(f32, Node)> = super::replay::shown(self.probes.len())
            .into_iter()
            .map(|k| {
                let name = &self.probes[k];
                let path = format!("probes/{name}/**");
                (
                    1.0,
                    view("TimeSeries", &format!("{name}, °C"), "/", &[path.as_str()]),
                )
            })
            .collect();
        let params = Node::Column(
            self.parameters
                .iter()
                .map(|(p, _)| {
                    let path = format!("parameters/{p}/**");
                    (1.0, view("TimeSeries", p, "/", &[path.as_str()]))
                })
                .chain([(1.0, view("TextLog", "alarms", "/", &["events"]))])
                .collect(),
        );
        let layout = Node::Row(vec![
            (
                2.0,
                view("3D", "part, path and probes", "world", &["world/**"]),
            ),
            (3.0, Node::Column(plots)),
            (2.0, params),
        ]);
        super::rerun_layout::send(rec, &layout, TIMELINE).map_err(fail)?;
        rec.log_static("world", &rerun::ViewCoordinates::RIGHT_HAND_Z_UP())
            .map_err(fail)?;
        rec.log_static(
            "world/path",
            &rerun::LineStrips3D::new(scene.tracks.iter().map(|t| t.iter().copied().map(f32x3)))
                .with_colors([rerun::Color::from_rgb(200, 200, 200)])
                .with_radii([rerun::Radius::new_ui_points(1.0)]),
        )
        .map_err(fail)?;
        rec.log_static(
            "world/probes",
            &rerun::Points3D::new(scene.probes.iter().map(|p| f32x3(p.1)))
                .with_labels(scene.probes.iter().map(|p| p.0.as_str()))
                .with_colors([rerun::Color::from_rgb(230, 120, 20)])
                .with_radii([rerun::Radius::new_ui_points(4.0)]),
        )
        .map_err(fail)?;
        for name in &self.probes {
            self.style(
                &format!("probes/{name}/measured_c"),
                "measured",
                [230, 230, 230],
            )?;
        }
        for (p, _) in &self.parameters {
            self.style(&format!("parameters/{p}/mean"), "mean", [80, 160, 230])?;
            for q in ["p05", "p95"] {
                self.style(&format!("parameters/{p}/{q}"), q, [60, 90, 130])?;
            }
        }
        Ok(())
    }

    fn style(&self, path: &str, name: &str, [r, g, b]: [u8; 3]) -> Result<()> {
        self.rec
            .log_static(
                path,
                &rerun::SeriesLines::new()
                    .with_names([name])
                    .with_colors([rerun::Color::from_rgb(r, g, b)]),
            )
            .map_err(fail)
    }

    fn scalar(&self, path: String, t: f64, v: f64) -> Result<()> {
        self.rec.set_duration_secs(TIMELINE, t);
        self.rec.log(path, &rerun::Scalars::single(v)).map_err(fail)
    }

    /// A row's readings, °C, as they arrive.
    pub fn readings(&self, t_s: f64, values_c: &[Option<f64>]) -> Result<()> {
        for (name, v) in self.probes.iter().zip(values_c) {
            if let Some(v) = v {
                self.scalar(format!("probes/{name}/measured_c"), t_s, *v)?;
            }
        }
        Ok(())
    }

    /// What the follower added since the last call: forecasts, parameters, alarms.
    pub fn progress(&mut self, p: &Progress) -> Result<()> {
        for f in &p.forecasts[self.forecasts.min(p.forecasts.len())..] {
            self.forecast(f)?;
        }
        self.forecasts = p.forecasts.len();
        for &(t, k, mean, sd) in &p.settling[self.settling.min(p.settling.len())..] {
            let (name, [low, high]) = &self.parameters[k];
            self.scalar(format!("parameters/{name}/mean"), t, mean)?;
            // The normal 5–95 % of the members' spread, within the parameter's range (the
            // members live on its logit: none is outside).
            let band = |z: f64| (mean + z * sd).clamp(*low, *high);
            self.scalar(format!("parameters/{name}/p05"), t, band(-1.645))?;
            self.scalar(format!("parameters/{name}/p95"), t, band(1.645))?;
        }
        self.settling = p.settling.len();
        for a in &p.alarms[self.alarms.min(p.alarms.len())..] {
            self.alarm(a)?;
        }
        self.alarms = p.alarms.len();
        Ok(())
    }

    /// The part at `t_s`: its top surface's points (mm) at their temperatures (°C).
    pub fn field(&mut self, t_s: f64, points_mm: &[[f64; 3]], temps_c: &[f64]) -> Result<()> {
        let (ambient, interpass) = self.colours;
        self.rec.set_duration_secs(TIMELINE, t_s);
        self.rec
            .log(
                "world/part",
                &rerun::Points3D::new(points_mm.iter().map(|p| p.map(|x| x as f32)))
                    .with_colors(temps_c.iter().map(|&t| {
                        let [r, g, b, a] = super::temperature_colour(t, ambient, interpass);
                        rerun::Color::from_unmultiplied_rgba(r, g, b, a)
                    }))
                    .with_radii([rerun::Radius::new_scene_units(1.0)]),
            )
            .map_err(fail)?;
        self.rec
            .log(
                "world/part",
                &rerun::AnyValues::default().with_component::<rerun::components::Scalar>(
                    "temperature_c",
                    temps_c.iter().copied(),
                ),
            )
            .map_err(fail)?;
        self.field_at_s = Some(t_s);
        Ok(())
    }

    fn forecast(&mut self, f: &Forecast) -> Result<()> {
        let horizon = match f.horizon.label().parse::<f64>() {
            Ok(_) => format!("{}s", f.horizon.label()),
            Err(_) => f.horizon.label(),
        };
        let base = format!("probes/{}/forecast_{horizon}", self.probes[f.probe]);
        if self.styled.insert(base.clone()) {
            // One hue a horizon, the band dimmer: the shortest orange, then violet…; the next
            // layer's start green.
            let hue = match f.horizon {
                Horizon::NextLayer => [90, 200, 120],
                Horizon::After(h) => {
                    let rank = self.horizons_s.iter().filter(|&&x| x < h).count();
                    HUES[rank.min(HUES.len() - 1)]
                }
            };
            let dim = hue.map(|c| c / 2 + 40);
            self.style(
                &format!("{base}/predicted_c"),
                &format!("{horizon} ahead"),
                hue,
            )?;
            self.style(&format!("{base}/p05_c"), &format!("{horizon} p05"), dim)?;
            self.style(&format!("{base}/p95_c"), &format!("{horizon} p95"), dim)?;
        }
        self.scalar(format!("{base}/predicted_c"), f.target_t_s, f.predicted_c)?;
        self.scalar(format!("{base}/p05_c"), f.target_t_s, f.p05_c)?;
        self.scalar(format!("{base}/p95_c"), f.target_t_s, f.p95_c)
    }

    fn alarm(&self, a: &Alarm) -> Result<()> {
        self.rec.set_duration_secs(TIMELINE, a.made_at_s);
        self.rec
            .log(
                "events",
                &rerun::TextLog::new(a.line()).with_level(rerun::TextLogLevel::WARN),
            )
            .map_err(fail)
    }

    /// Flush both sinks and put run.rrd in place. A viewer that has not taken the whole
    /// stream within [`VIEWER_WAIT`] (or was never there) is said so on stderr and left: the
    /// file is finished all the same.
    pub fn finish(self, dir: &mut RunDir) -> Result<()> {
        let wait = match self.connected {
            Some(_) => VIEWER_WAIT,
            None => Duration::MAX,
        };
        let flushed = self.rec.flush_with_timeout(wait);
        // The file's footer is written when its sink goes; the gRPC sink stays.
        self.rec.finalize_deferred_sinks();
        let staged = self.staged.clone();
        match (flushed, &self.connected) {
            (Ok(()), _) => drop(self.rec),
            (Err(e), Some(url)) => {
                eprintln!(
                    "follow: the rerun viewer at {url} did not take the whole recording ({e}); \
                     run.rrd has it"
                );
                // Dropping a stream whose gRPC sink never connected waits for it without end;
                // the process is about to end and takes the connection with it.
                std::mem::forget(self.rec);
            }
            (Err(e), None) => return Err(fail(e)),
        }
        dir.commit(&staged, "run.rrd").map(|_| ())
    }
}
