//! The scene a run shows, built once from the plan and the simulation: plain data in the
//! interface units (mm, s, °C, W), so that every sink reads the same numbers.

use crate::pipeline::{Build, Simulation};
use crate::scenario::Scenario;
use planner::mesh::TriMesh;
use planner::plan::Plan;
use thermal::ZERO_CELSIUS_K as C;
use thermal::schedule::DropPart;

/// Per path point, in deposition order.
#[derive(Debug, Clone, PartialEq)]
pub struct PointRecord {
    /// When the torch finishes laying it, s.
    pub t_s: f64,
    pub position_mm: [f64; 3],
    /// Unit vector from the deposit to the torch.
    pub tool: [f64; 3],
    pub layer: usize,
    pub generator: usize,
    pub deposit_mm: f64,
    pub preheat_c: f64,
    /// As laid (at its pace), W.
    pub power_w: f64,
    /// The pause before it, s.
    pub dwell_s: f64,
    /// Wire feed and travel speed divided by this (1: as planned).
    pub pace: f64,
    /// The arc strikes a drop here (the closing strategy of skeleton arc AM).
    pub strikes_drop: bool,
    /// Laid as part of a drop.
    pub in_drop: bool,
    pub risk: Option<&'static str>,
    /// What its preheat is read on: the plate, an earlier revolution, or metal just laid.
    pub laid_on: thermal::Support,
}

/// Per revolution.
#[derive(Debug, Clone, PartialEq)]
pub struct LayerRecord {
    pub layer: usize,
    pub t_start_s: f64,
    pub preheat_max_c: f64,
    pub preheat_mean_c: f64,
    pub dwell_s: f64,
}

/// The wall's temperature at one time.
#[derive(Debug, Clone, PartialEq)]
pub struct Frame {
    pub t_s: f64,
    /// Path points laid by then.
    pub laid: usize,
    /// Per path point, °C; NaN where not yet laid.
    pub temperature_c: Vec<f32>,
}

impl Frame {
    pub fn max_c(&self) -> f32 {
        self.temperature_c[..self.laid]
            .iter()
            .copied()
            .fold(f32::NEG_INFINITY, f32::max)
    }
}

/// One path point's temperature at every step of the heat model from when it was laid.
#[derive(Debug, Clone, PartialEq)]
pub struct History {
    pub point: usize,
    pub t_s: Vec<f64>,
    pub temperature_c: Vec<f64>,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Level {
    Info,
    Warning,
}

/// Something the run decided or detected, at a time of the build.
#[derive(Debug, Clone, PartialEq)]
pub struct Event {
    pub t_s: f64,
    pub level: Level,
    pub text: String,
}

/// One field value that `thermal.json` states beside the files, for readers to check against.
#[derive(Debug, Clone, PartialEq)]
pub struct Probe {
    pub point: usize,
    pub frame: usize,
    pub t_s: f64,
    pub temperature_c: f64,
}

/// Everything a sink shows.
#[derive(Debug, Clone)]
pub struct Scene {
    pub title: String,
    /// A closed part: the spiral ends at a closing point.
    pub closed: bool,
    /// The scenario as the manifest echoes it.
    pub scenario: serde_json::Value,
    /// The part's mid-surface, mm.
    pub part: TriMesh,
    /// Centre of the plate's top face (x, y) and its size (x, y, thickness), mm.
    pub plate_centre_mm: [f64; 2],
    pub plate_size_mm: [f64; 3],
    /// The plate is a disc of diameter `plate_size_mm[0]`.
    pub plate_disc: bool,
    pub generators: Vec<Vec<[f64; 3]>>,
    pub points: Vec<PointRecord>,
    /// The deposited wall as triangles over the path points: each point joined to the point it
    /// is laid on and to its neighbours along the spiral.
    pub wall: Vec<[u32; 3]>,
    pub layers: Vec<LayerRecord>,
    /// The same revolutions without dwells, where the run planned dwells.
    pub layers_without_dwells: Option<Vec<LayerRecord>>,
    pub frames: Vec<Frame>,
    /// Step-by-step histories of a few points, where the run traced them.
    pub histories: Vec<History>,
    /// The hottest laid metal (s, °C) every step, or the hottest of each run of steps where
    /// there are more than [`HOTTEST_SAMPLES`].
    pub hottest: Vec<(f64, f64)>,
    pub events: Vec<Event>,
    pub probe: Option<Probe>,
    pub interpass_c: f64,
    pub ambient_c: f64,
    /// Deposit window h_min, h_max, mm.
    pub window_mm: [f64; 2],
    /// Deposits this close to the window count as inside it, mm (`[planner]
    /// deposit_tolerance_mm`).
    pub window_tolerance_mm: f64,
    /// Planar 2.5D slicing's deposits, for the comparison with CTPP.
    pub planar_deposits_mm: Option<Vec<f64>>,
    pub build_s: f64,
    /// The fewest arc stops any plan of the build can make (`pipeline::bound`), where dwells
    /// were planned.
    pub arc_stops_lower_bound: Option<usize>,
    /// How sure the plan is, where it was planned at a confidence (one sentence).
    pub confidence: Option<String>,
}

/// What a run hands over to be recorded.
pub struct Run<'a> {
    pub s: &'a Scenario,
    pub title: &'a str,
    pub part: &'a TriMesh,
    pub build: &'a Build,
    pub sim: &'a Simulation,
    /// The run without dwells, where dwells were planned.
    pub before: Option<&'a Simulation>,
    pub planar_deposits_mm: Option<Vec<f64>>,
    /// The fewest arc stops any plan of the build can make, where dwells were planned.
    pub arc_stops_lower_bound: Option<usize>,
    /// How sure the plan is, where it was planned at a confidence.
    pub confidence: Option<String>,
}

impl Scene {
    /// Every arc start after the first: each dwell and each drop struck.
    pub fn arc_stops(&self) -> usize {
        self.points
            .iter()
            .skip(1)
            .filter(|p| p.dwell_s > 0.0 || p.strikes_drop)
            .count()
    }

    pub fn build(r: Run<'_>) -> Scene {
        let (s, b, sim) = (r.s, r.build, r.sim);
        let pl = &b.plan;
        let risks = sim.risks(&b.criteria);
        let points: Vec<PointRecord> = pl
            .points
            .iter()
            .enumerate()
            .map(|(i, q)| PointRecord {
                t_s: sim.deposits[i].time,
                position_mm: [q.position.x, q.position.y, q.position.z],
                tool: [q.tool.x, q.tool.y, q.tool.z],
                layer: q.layer,
                generator: q.generator,
                deposit_mm: q.deposit_mm,
                preheat_c: sim.result.points[i].preheat - C,
                power_w: b.bead_as_laid(sim, i).power_w,
                dwell_s: sim.dwell_s[i],
                pace: sim.pace[i],
                strikes_drop: matches!(sim.drop[i], Some(DropPart::Strikes { .. })),
                in_drop: sim.drop[i].is_some(),
                risk: risks[i].map(|k| k.as_str()),
                laid_on: sim.result.support[i],
            })
            .collect();
        let frames = frames(sim);
        let probe = probe(sim);
        let centre = crate::pipeline::deposition::plate_centre(&sim.deposits).map(|c| c * 1e3);
        Scene {
            title: r.title.to_string(),
            closed: pl.closing_point.is_some(),
            scenario: s.to_json(),
            part: r.part.clone(),
            plate_centre_mm: centre,
            plate_size_mm: b.params.thermal.plate_m.map(|v| v * 1e3),
            plate_disc: b.params.thermal.plate_disc,
            generators: pl
                .generators
                .iter()
                .map(|g| g.points.iter().map(|p| [p.x, p.y, p.z]).collect())
                .collect(),
            wall: wall(points.len(), pl.generators.len()),
            layers: layer_records(b, sim),
            layers_without_dwells: r.before.map(|before| layer_records(b, before)),
            events: r
                .confidence
                .iter()
                .map(|text| Event {
                    t_s: 0.0,
                    level: Level::Info,
                    text: text.clone(),
                })
                .chain(events(b, &points, r.before))
                .collect(),
            frames,
            histories: sim
                .result
                .traces
                .iter()
                .map(|t| History {
                    point: t.deposit,
                    t_s: t.time.clone(),
                    temperature_c: t.temperature.iter().map(|&k| k - C).collect(),
                })
                .collect(),
            hottest: hottest(&sim.result.hottest),
            probe,
            interpass_c: b.params.dwell.interpass_max_k - C,
            ambient_c: b.params.thermal.ambient_k - C,
            window_mm: [
                b.params.process.deposit_min_m * 1e3,
                b.params.process.deposit_max_m * 1e3,
            ],
            window_tolerance_mm: r.s.plan_params().tolerance_mm,
            planar_deposits_mm: r.planar_deposits_mm,
            build_s: sim.deposits.last().map_or(0.0, |d| d.time),
            arc_stops_lower_bound: r.arc_stops_lower_bound,
            confidence: r.confidence.clone(),
            points,
        }
    }
}

fn layer_records(b: &Build, sim: &Simulation) -> Vec<LayerRecord> {
    b.layers(sim)
        .into_iter()
        .map(|l| LayerRecord {
            layer: l.layer,
            t_start_s: l.t_start_s,
            preheat_max_c: l.preheat_max_k - C,
            preheat_mean_c: l.preheat_mean_k - C,
            dwell_s: l.dwell_s,
        })
        .collect()
}

/// The spiral lays point i on point i − n (one revolution of n generators earlier), so the
/// deposited wall is the strip between consecutive revolutions.
pub fn wall(n_points: usize, n_generators: usize) -> Vec<[u32; 3]> {
    let n = n_generators;
    (n..n_points.saturating_sub(1))
        .flat_map(|i| {
            let (a, b, c, d) = ((i - n) as u32, (i - n + 1) as u32, (i + 1) as u32, i as u32);
            [[a, b, c], [a, c, d]]
        })
        .collect()
}

/// Most samples of the hottest laid metal kept for the recordings.
pub const HOTTEST_SAMPLES: usize = 20_000;

/// The run's hottest-metal series in °C, each run of `stride` steps down to its hottest step,
/// so that no pass's peak is lost when a long build is thinned.
fn hottest(h: &thermal::run::Hottest) -> Vec<(f64, f64)> {
    let stride = h.time.len().div_ceil(HOTTEST_SAMPLES).max(1);
    h.time
        .chunks(stride)
        .zip(h.temperature.chunks(stride))
        .map(|(t, k)| {
            let top = (0..k.len()).fold(0, |a, j| if k[j] > k[a] { j } else { a });
            (t[top], k[top] - C)
        })
        .collect()
}

/// The kept snapshots of the field, per path point.
fn frames(sim: &Simulation) -> Vec<Frame> {
    let r = &sim.result;
    r.snapshots
        .iter()
        .map(|snap| {
            let laid = sim.deposits.partition_point(|d| d.time <= snap.time + 1e-9);
            Frame {
                t_s: snap.time,
                laid,
                temperature_c: (0..sim.deposits.len())
                    .map(|i| {
                        if i < laid {
                            (snap.temperature[i] - C) as f32
                        } else {
                            f32::NAN
                        }
                    })
                    .collect(),
            }
        })
        .collect()
}

/// The middle of the path, at the first frame after it was laid: read straight from the
/// simulation's snapshot, not from a frame, so a reader can check the files against it.
pub fn probe(sim: &Simulation) -> Option<Probe> {
    let point = sim.deposits.len() / 2;
    let laid = sim.deposits.get(point)?.time;
    let r = &sim.result;
    let frame = r.snapshots.iter().position(|f| f.time + 1e-9 >= laid)?;
    let snap = &r.snapshots[frame];
    Some(Probe {
        point,
        frame,
        t_s: snap.time,
        temperature_c: snap.temperature[point] - C,
    })
}

/// Overheating found, dwells inserted (each an arc stop and restart), nozzle collisions.
fn events(b: &Build, points: &[PointRecord], before: Option<&Simulation>) -> Vec<Event> {
    let pl: &Plan = &b.plan;
    let mut ev = Vec::new();
    if let Some(before) = before
        && let Some((i, risk)) = before.first_risk(&b.criteria)
    {
        ev.push(Event {
            t_s: 0.0,
            level: Level::Warning,
            text: format!(
                "without dwells: at risk from point {i} (layer {}), {}",
                pl.points[i].layer,
                b.criteria.breach(&before.result.points[i], risk)
            ),
        });
    }
    for (i, p) in points.iter().enumerate() {
        if p.strikes_drop {
            ev.push(Event {
                t_s: p.t_s - p.dwell_s,
                level: Level::Info,
                text: format!(
                    "drop struck at point {i} (layer {}) after a wait of {:.1} s: the closing zone laid drop by drop",
                    p.layer, p.dwell_s
                ),
            });
        } else if p.dwell_s > 0.0 {
            ev.push(Event {
                t_s: p.t_s - p.dwell_s,
                level: Level::Info,
                text: format!(
                    "dwell inserted: {:.1} s before point {i} (layer {}): arc stop and restart",
                    p.dwell_s, p.layer
                ),
            });
        }
        let before = if i == 0 { 1.0 } else { points[i - 1].pace };
        if p.pace != before && !p.in_drop {
            ev.push(Event {
                t_s: p.t_s,
                level: Level::Info,
                text: format!(
                    "pace {:.2} from point {i} (layer {}): wire feed and travel speed divided by it, {:.0} W",
                    p.pace, p.layer, p.power_w
                ),
            });
        }
    }
    // One event per run of consecutive points, with its range, not one per point.
    let risky: Vec<usize> = (0..points.len())
        .filter(|&i| points[i].risk.is_some())
        .collect();
    for (a, z) in runs(&risky) {
        let run = &points[a..=z];
        let mut reasons: Vec<&str> = run.iter().filter_map(|p| p.risk).collect();
        reasons.sort_unstable();
        reasons.dedup();
        let hottest = run.iter().map(|p| p.preheat_c).fold(f64::NAN, f64::max);
        ev.push(Event {
            t_s: points[a].t_s,
            level: Level::Warning,
            text: format!(
                "overheating detected ({}) at {}: preheat up to {hottest:.0} °C",
                reasons.join(", "),
                stretch(points, a, z)
            ),
        });
    }
    for (a, z) in runs(&pl.collisions.unresolved) {
        ev.push(Event {
            t_s: points[a].t_s,
            level: Level::Warning,
            text: format!(
                "nozzle collision at {}: the nozzle meets deposited metal (unresolved)",
                stretch(points, a, z)
            ),
        });
    }
    ev.sort_by(|a, b| a.t_s.total_cmp(&b.t_s));
    ev
}

/// "point 7 (layer 2)" or "points 7–9 (layers 2–3, 3 points)".
fn stretch(points: &[PointRecord], a: usize, z: usize) -> String {
    if a == z {
        format!("point {a} (layer {})", points[a].layer)
    } else {
        format!(
            "points {a}–{z} (layers {}–{}, {} points)",
            points[a].layer,
            points[z].layer,
            z - a + 1
        )
    }
}

/// "3–5, 9" from ascending numbers.
#[cfg(feature = "recording")]
pub(super) fn ranges(v: &[usize]) -> String {
    runs(v)
        .iter()
        .map(|&(a, b)| {
            if a == b {
                a.to_string()
            } else {
                format!("{a}–{b}")
            }
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// Runs of consecutive indices, (first, last), from ascending indices.
pub(super) fn runs(v: &[usize]) -> Vec<(usize, usize)> {
    let mut out: Vec<(usize, usize)> = Vec::new();
    for &x in v {
        match out.last_mut() {
            Some(r) if r.1 + 1 == x => r.1 = x,
            _ => out.push((x, x)),
        }
    }
    out
}

#[cfg(test)]
mod tests {
    #[test]
    fn consecutive_points_make_one_run() {
        assert_eq!(
            super::runs(&[3, 4, 5, 9, 11, 12]),
            vec![(3, 5), (9, 9), (11, 12)]
        );
        assert!(super::runs(&[]).is_empty());
    }

    #[test]
    fn wall_joins_each_point_to_the_one_beneath() {
        // Two revolutions of three generators and one more point.
        let w = super::wall(7, 3);
        assert_eq!(w.len(), 6);
        assert_eq!(w[0], [0, 1, 4]);
        assert_eq!(w[1], [0, 4, 3]);
        assert!(w.iter().flatten().all(|&v| v < 7));
    }
}
