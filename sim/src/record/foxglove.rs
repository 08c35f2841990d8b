//! `run.mcap`: JSON messages with JSON-schema'd Foxglove types, so the Foxglove app shows them
//! without configuration. zstd chunks, messages in log-time order (the recorder's contract), the
//! scenario as a metadata record. Lengths in metres, Foxglove's convention; log time is build
//! time from 0 (a deterministic file: the same run gives the same bytes).
//!
//! Topics: `/part` and `/plan` (`foxglove.SceneUpdate`, once), `/deposited` (SceneUpdate, the
//! path laid since the previous frame), `/wall/temperature` (`foxglove.PointCloud`, x, y, z and
//! a float32 `temperature` in °C), `/tf` (`foxglove.FrameTransform` world → torch, the torch's z
//! axis along the tool axis), `/torch` (SceneUpdate, the nozzle drawn in the torch frame),
//! `/events` (`foxglove.Log`), `/plot/point`, `/plot/field` and `/plot/hottest` (the hottest
//! laid metal every step) (plain JSON for plot panels).

use super::{Level, Moment, Scene, Sink};
use crate::error::{Error, Result};
use crate::output::RunDir;
use mcap::records::{MessageHeader, Metadata};
use mcap::{Compression, WriteOptions, Writer};
use serde_json::{Value, json};
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::PathBuf;

const M: f64 = 1e-3;

/// Topic, schema name (empty: a plain JSON message of our own).
const CHANNELS: [(&str, &str); 10] = [
    ("/part", "foxglove.SceneUpdate"),
    ("/plan", "foxglove.SceneUpdate"),
    ("/deposited", "foxglove.SceneUpdate"),
    ("/wall/temperature", "foxglove.PointCloud"),
    ("/tf", "foxglove.FrameTransform"),
    ("/torch", "foxglove.SceneUpdate"),
    ("/events", "foxglove.Log"),
    ("/plot/point", "waamtwin.PointResult"),
    ("/plot/field", "waamtwin.FieldSummary"),
    ("/plot/hottest", "waamtwin.Hottest"),
];

#[derive(Default)]
pub struct McapSink {
    writer: Option<Writer<BufWriter<File>>>,
    staged: Option<PathBuf>,
    channels: BTreeMap<&'static str, u16>,
    sequence: u32,
    drawn: usize,
    segment: usize,
}

fn fail(e: impl std::fmt::Display) -> Error {
    Error::failure(format!("run.mcap: {e}"))
}

fn stamp(t_s: f64) -> Value {
    let ns = nanos(t_s);
    json!({"sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000})
}

fn nanos(t_s: f64) -> u64 {
    (t_s.max(0.0) * 1e9).round() as u64
}

fn vec3(p: [f64; 3]) -> Value {
    json!({"x": p[0] * M, "y": p[1] * M, "z": p[2] * M})
}

fn colour(r: f64, g: f64, b: f64, a: f64) -> Value {
    json!({"r": r, "g": g, "b": b, "a": a})
}

fn identity_pose() -> Value {
    json!({"position": {"x": 0.0, "y": 0.0, "z": 0.0}, "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}})
}

/// A scene entity with every primitive list present (Foxglove expects them all).
fn entity(t_s: f64, frame: &str, id: &str, prims: &[(&str, Value)]) -> Value {
    let mut e = json!({
        "timestamp": stamp(t_s), "frame_id": frame, "id": id,
        "lifetime": {"sec": 0, "nsec": 0}, "frame_locked": frame != "world", "metadata": [],
        "arrows": [], "cubes": [], "spheres": [], "cylinders": [], "lines": [],
        "triangles": [], "texts": [], "models": [],
    });
    for (kind, p) in prims {
        e[*kind] = json!([p]);
    }
    e
}

fn line_strip(points: impl Iterator<Item = [f64; 3]>, thickness_mm: f64, c: Value) -> Value {
    json!({
        "type": 0, "pose": identity_pose(), "thickness": thickness_mm * M, "scale_invariant": false,
        "points": points.map(vec3).collect::<Vec<_>>(), "color": c, "colors": [], "indices": [],
    })
}

/// The rotation taking z to the unit vector `a` (shortest arc), as a quaternion.
fn z_to(a: [f64; 3]) -> Value {
    let (x, y, z) = (-a[1], a[0], 0.0);
    let w = 1.0 + a[2];
    let n = (x * x + y * y + z * z + w * w).sqrt();
    if n < 1e-9 {
        return json!({"x": 1.0, "y": 0.0, "z": 0.0, "w": 0.0});
    }
    json!({"x": x / n, "y": y / n, "z": z / n, "w": w / n})
}

/// RFC 4648 base64: the JSON encoding of a `bytes` field.
pub fn base64(data: &[u8]) -> String {
    const A: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
    let mut out = String::with_capacity(data.len().div_ceil(3) * 4);
    for c in data.chunks(3) {
        let n = (c[0] as u32) << 16
            | (c.get(1).copied().unwrap_or(0) as u32) << 8
            | c.get(2).copied().unwrap_or(0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                out.push(A[(n >> (18 - 6 * k)) as usize & 63] as char);
            } else {
                out.push('=');
            }
        }
    }
    out
}

impl McapSink {
    fn send(&mut self, topic: &str, t_s: f64, msg: &Value) -> Result<()> {
        let channel_id = self.channels[topic];
        let data = serde_json::to_vec(msg).map_err(fail)?;
        self.sequence += 1;
        let header = MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time: nanos(t_s),
            publish_time: nanos(t_s),
        };
        self.writer
            .as_mut()
            .expect("begin() opens the writer")
            .write_to_known_channel(&header, &data)
            .map_err(fail)
    }
}

impl Sink for McapSink {
    fn begin(&mut self, scene: &Scene, dir: &RunDir) -> Result<()> {
        let staged = dir.stage("run.mcap");
        let file = File::create(&staged).map_err(fail)?;
        let mut w = WriteOptions::new()
            .compression(Some(Compression::Zstd))
            .profile("")
            .library(concat!("waamtwin ", env!("CARGO_PKG_VERSION")))
            .create(BufWriter::new(file))
            .map_err(fail)?;
        let mut schemas = BTreeMap::new();
        for (topic, name) in CHANNELS {
            let schema = match schemas.get(name) {
                Some(&id) => id,
                None => {
                    let text = serde_json::to_vec(&schema(name)).map_err(fail)?;
                    let id = w.add_schema(name, "jsonschema", &text).map_err(fail)?;
                    schemas.insert(name, id);
                    id
                }
            };
            let id = w
                .add_channel(schema, topic, "json", &BTreeMap::new())
                .map_err(fail)?;
            self.channels.insert(topic, id);
        }
        w.write_metadata(&Metadata {
            name: "scenario".into(),
            metadata: BTreeMap::from([
                ("json".to_string(), scene.scenario.to_string()),
                ("title".to_string(), scene.title.clone()),
                (
                    "units".to_string(),
                    "lengths m, temperature °C, time s".to_string(),
                ),
            ]),
        })
        .map_err(fail)?;
        self.writer = Some(w);
        self.staged = Some(staged);

        let part = &scene.part;
        let tri = json!({
            "pose": identity_pose(),
            "points": part.faces.iter().flatten().map(|&v| {
                let p = part.positions[v as usize];
                vec3([p.x, p.y, p.z])
            }).collect::<Vec<_>>(),
            "color": colour(0.67, 0.67, 0.7, 0.25), "colors": [], "indices": [],
        });
        let [cx, cy] = scene.plate_centre_mm;
        let [sx, sy, sz] = scene.plate_size_mm;
        let mut plate = json!({
            "pose": {"position": vec3([cx, cy, -sz / 2.0]), "orientation": {"x": 0.0, "y": 0.0, "z": 0.0, "w": 1.0}},
            "size": vec3([sx, sy, sz]), "color": colour(0.43, 0.43, 0.47, 1.0),
        });
        let shape = match scene.plate_disc {
            true => {
                plate["bottom_scale"] = json!(1.0);
                plate["top_scale"] = json!(1.0);
                "cylinders"
            }
            false => "cubes",
        };
        let part_msg = json!({"deletions": [], "entities": [
            entity(0.0, "world", "part", &[("triangles", tri)]),
            entity(0.0, "world", "plate", &[(shape, plate)]),
        ]});
        self.send("/part", 0.0, &part_msg)?;
        let spiral = line_strip(
            scene.points.iter().map(|p| p.position_mm),
            0.5,
            colour(0.35, 0.55, 1.0, 1.0),
        );
        let mut plan = vec![entity(0.0, "world", "spiral", &[("lines", spiral)])];
        for (k, g) in scene.generators.iter().enumerate() {
            let l = line_strip(g.iter().copied(), 0.3, colour(0.8, 0.8, 0.8, 1.0));
            plan.push(entity(
                0.0,
                "world",
                &format!("generator {k}"),
                &[("lines", l)],
            ));
        }
        self.send("/plan", 0.0, &json!({"deletions": [], "entities": plan}))?;
        // An arrow points along +x; a quarter turn about y points it down the torch's −z, from
        // 25 mm above the deposit to the deposit.
        let q = std::f64::consts::FRAC_1_SQRT_2;
        let nozzle = json!({
            "pose": {"position": {"x": 0.0, "y": 0.0, "z": 0.025}, "orientation": {"x": 0.0, "y": q, "z": 0.0, "w": q}},
            "shaft_length": 0.015, "shaft_diameter": 0.004, "head_length": 0.01, "head_diameter": 0.012,
            "color": colour(1.0, 0.55, 0.0, 1.0),
        });
        let torch = entity(0.0, "torch", "nozzle", &[("arrows", nozzle)]);
        self.send(
            "/torch",
            0.0,
            &json!({"deletions": [], "entities": [torch]}),
        )
    }

    fn moment(&mut self, scene: &Scene, m: Moment<'_>) -> Result<()> {
        let t = m.time(scene);
        match m {
            Moment::Point(i) => {
                let p = &scene.points[i];
                self.send(
                    "/tf",
                    t,
                    &json!({
                        "timestamp": stamp(t), "parent_frame_id": "world", "child_frame_id": "torch",
                        "translation": vec3(p.position_mm), "rotation": z_to(p.tool),
                    }),
                )?;
                self.send(
                    "/plot/point",
                    t,
                    &json!({
                        "t_s": t, "i": i, "layer": p.layer, "preheat_c": p.preheat_c,
                        "interpass_max_c": scene.interpass_c, "power_w": p.power_w, "dwell_s": p.dwell_s,
                        "pace": p.pace, "drop": p.in_drop,
                    }),
                )
            }
            Moment::Field(f) => {
                let end = f.laid.min(scene.points.len());
                if end > self.drawn {
                    let from = self.drawn.saturating_sub(1);
                    let l = line_strip(
                        scene.points[from..end].iter().map(|p| p.position_mm),
                        1.2,
                        colour(0.9, 0.9, 0.9, 1.0),
                    );
                    let id = format!("segment {}", self.segment);
                    let msg = json!({"deletions": [], "entities": [entity(t, "world", &id, &[("lines", l)])]});
                    self.send("/deposited", t, &msg)?;
                    self.segment += 1;
                    self.drawn = end;
                }
                let mut data = Vec::with_capacity(end * 16);
                for (p, &temp) in scene.points[..end].iter().zip(&f.temperature_c) {
                    for v in p.position_mm {
                        data.extend_from_slice(&((v * M) as f32).to_le_bytes());
                    }
                    data.extend_from_slice(&temp.to_le_bytes());
                }
                let fields: Vec<Value> = ["x", "y", "z", "temperature"]
                    .iter()
                    .enumerate()
                    .map(|(k, n)| json!({"name": n, "offset": 4 * k, "type": 7}))
                    .collect();
                let cloud = json!({
                    "timestamp": stamp(t), "frame_id": "world", "pose": identity_pose(),
                    "point_stride": 16, "fields": fields, "data": base64(&data),
                });
                self.send("/wall/temperature", t, &cloud)?;
                self.send(
                    "/plot/field",
                    t,
                    &json!({"t_s": t, "laid": f.laid, "max_temperature_c": f.max_c()}),
                )
            }
            Moment::Hottest(k) => self.send(
                "/plot/hottest",
                t,
                &json!({"t_s": t, "max_temperature_c": scene.hottest[k].1}),
            ),
            Moment::Event(e) => {
                let level = match e.level {
                    Level::Info => 2,
                    Level::Warning => 3,
                };
                self.send(
                    "/events",
                    t,
                    &json!({"timestamp": stamp(t), "level": level, "message": e.text, "name": "waamtwin", "file": "", "line": 0}),
                )
            }
        }
    }

    fn finish(self: Box<Self>, _scene: &Scene, dir: &mut RunDir) -> Result<()> {
        let mut me = *self;
        let mut w = me.writer.take().expect("begin() opens the writer");
        w.finish().map_err(fail)?;
        drop(w);
        dir.commit(me.staged.as_deref().expect("staged in begin()"), "run.mcap")?;
        Ok(())
    }
}

// ---- JSON schemas of the messages above, written from Foxglove's published message definitions.

fn number() -> Value {
    json!({"type": "number"})
}

fn integer(min: Option<i64>, max: Option<i64>) -> Value {
    let mut v = json!({"type": "integer"});
    if let Some(m) = min {
        v["minimum"] = json!(m);
    }
    if let Some(m) = max {
        v["maximum"] = json!(m);
    }
    v
}

fn string() -> Value {
    json!({"type": "string"})
}

fn boolean() -> Value {
    json!({"type": "boolean"})
}

fn array(items: Value) -> Value {
    json!({"type": "array", "items": items})
}

fn enumeration(values: std::ops::RangeInclusive<i64>) -> Value {
    json!({"type": "integer", "enum": values.collect::<Vec<_>>()})
}

/// An object whose every property is required.
fn object(title: &str, props: &[(&str, Value)]) -> Value {
    let mut p = serde_json::Map::new();
    for (k, v) in props {
        p.insert(k.to_string(), v.clone());
    }
    json!({
        "title": title, "type": "object", "properties": p,
        "required": props.iter().map(|x| x.0).collect::<Vec<_>>(),
    })
}

fn time() -> Value {
    object(
        "time",
        &[
            ("sec", integer(Some(0), None)),
            ("nsec", integer(Some(0), Some(999_999_999))),
        ],
    )
}

fn duration() -> Value {
    object(
        "duration",
        &[
            ("sec", integer(None, None)),
            ("nsec", integer(Some(0), Some(999_999_999))),
        ],
    )
}

fn xyz(title: &str) -> Value {
    object(title, &[("x", number()), ("y", number()), ("z", number())])
}

fn quaternion() -> Value {
    object(
        "foxglove.Quaternion",
        &[
            ("x", number()),
            ("y", number()),
            ("z", number()),
            ("w", number()),
        ],
    )
}

fn pose() -> Value {
    object(
        "foxglove.Pose",
        &[
            ("position", xyz("foxglove.Vector3")),
            ("orientation", quaternion()),
        ],
    )
}

fn rgba() -> Value {
    object(
        "foxglove.Color",
        &[
            ("r", number()),
            ("g", number()),
            ("b", number()),
            ("a", number()),
        ],
    )
}

fn scene_entity() -> Value {
    let point3 = || xyz("foxglove.Point3");
    let arrow = object(
        "foxglove.ArrowPrimitive",
        &[
            ("pose", pose()),
            ("shaft_length", number()),
            ("shaft_diameter", number()),
            ("head_length", number()),
            ("head_diameter", number()),
            ("color", rgba()),
        ],
    );
    let cube = object(
        "foxglove.CubePrimitive",
        &[
            ("pose", pose()),
            ("size", xyz("foxglove.Vector3")),
            ("color", rgba()),
        ],
    );
    let line = object(
        "foxglove.LinePrimitive",
        &[
            ("type", enumeration(0..=2)),
            ("pose", pose()),
            ("thickness", number()),
            ("scale_invariant", boolean()),
            ("points", array(point3())),
            ("color", rgba()),
            ("colors", array(rgba())),
            ("indices", array(integer(Some(0), None))),
        ],
    );
    let triangles = object(
        "foxglove.TriangleListPrimitive",
        &[
            ("pose", pose()),
            ("points", array(point3())),
            ("color", rgba()),
            ("colors", array(rgba())),
            ("indices", array(integer(Some(0), None))),
        ],
    );
    let key_value = object(
        "foxglove.KeyValuePair",
        &[("key", string()), ("value", string())],
    );
    let any = || json!({"type": "object"});
    object(
        "foxglove.SceneEntity",
        &[
            ("timestamp", time()),
            ("frame_id", string()),
            ("id", string()),
            ("lifetime", duration()),
            ("frame_locked", boolean()),
            ("metadata", array(key_value)),
            ("arrows", array(arrow)),
            ("cubes", array(cube)),
            ("spheres", array(any())),
            ("cylinders", array(any())),
            ("lines", array(line)),
            ("triangles", array(triangles)),
            ("texts", array(any())),
            ("models", array(any())),
        ],
    )
}

/// The JSON schema of a channel's messages.
pub fn schema(name: &str) -> Value {
    let mut s = match name {
        "foxglove.SceneUpdate" => object(
            name,
            &[
                (
                    "deletions",
                    array(object(
                        "foxglove.SceneEntityDeletion",
                        &[
                            ("timestamp", time()),
                            ("type", enumeration(0..=1)),
                            ("id", string()),
                        ],
                    )),
                ),
                ("entities", array(scene_entity())),
            ],
        ),
        "foxglove.PointCloud" => object(
            name,
            &[
                ("timestamp", time()),
                ("frame_id", string()),
                ("pose", pose()),
                ("point_stride", integer(Some(0), None)),
                (
                    "fields",
                    array(object(
                        "foxglove.PackedElementField",
                        &[
                            ("name", string()),
                            ("offset", integer(Some(0), None)),
                            ("type", enumeration(0..=8)),
                        ],
                    )),
                ),
                (
                    "data",
                    json!({"type": "string", "contentEncoding": "base64"}),
                ),
            ],
        ),
        "foxglove.FrameTransform" => object(
            name,
            &[
                ("timestamp", time()),
                ("parent_frame_id", string()),
                ("child_frame_id", string()),
                ("translation", xyz("foxglove.Vector3")),
                ("rotation", quaternion()),
            ],
        ),
        "foxglove.Log" => object(
            name,
            &[
                ("timestamp", time()),
                ("level", enumeration(0..=5)),
                ("message", string()),
                ("name", string()),
                ("file", string()),
                ("line", integer(Some(0), None)),
            ],
        ),
        "waamtwin.PointResult" => object(
            name,
            &[
                ("t_s", number()),
                ("i", integer(Some(0), None)),
                ("layer", integer(Some(0), None)),
                ("preheat_c", number()),
                ("interpass_max_c", number()),
                ("power_w", number()),
                ("dwell_s", number()),
                ("pace", number()),
                ("drop", boolean()),
            ],
        ),
        "waamtwin.FieldSummary" => object(
            name,
            &[
                ("t_s", number()),
                ("laid", integer(Some(0), None)),
                ("max_temperature_c", number()),
            ],
        ),
        "waamtwin.Hottest" => object(name, &[("t_s", number()), ("max_temperature_c", number())]),
        _ => unreachable!("no schema named {name}"),
    };
    s["$schema"] = json!("https://json-schema.org/draft/2020-12/schema");
    s
}

#[cfg(test)]
mod tests {
    #[test]
    fn base64_matches_rfc4648_vectors() {
        for (plain, coded) in [
            ("", ""),
            ("f", "Zg=="),
            ("fo", "Zm8="),
            ("foo", "Zm9v"),
            ("foob", "Zm9vYg=="),
            ("fooba", "Zm9vYmE="),
            ("foobar", "Zm9vYmFy"),
        ] {
            assert_eq!(super::base64(plain.as_bytes()), coded);
        }
    }

    #[test]
    fn z_to_turns_z_onto_the_axis() {
        let q = super::z_to([1.0, 0.0, 0.0]);
        let (x, y, z, w) = (
            q["x"].as_f64().unwrap(),
            q["y"].as_f64().unwrap(),
            q["z"].as_f64().unwrap(),
            q["w"].as_f64().unwrap(),
        );
        // The third column of the rotation matrix is the image of z.
        let image = [
            2.0 * (x * z + w * y),
            2.0 * (y * z - w * x),
            1.0 - 2.0 * (x * x + y * y),
        ];
        assert!((image[0] - 1.0).abs() < 1e-12 && image[1].abs() < 1e-12 && image[2].abs() < 1e-12);
    }
}
