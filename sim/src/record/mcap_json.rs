//! An MCAP file of one topic of JSON messages with their JSON schema (Foxglove reads it as is):
//! zstd chunks, messages in log-time order, a metadata record naming what it holds. The
//! replay's `/probes` and a skeleton run's `/drops`.

use crate::error::{Error, Result};
use crate::output::RunDir;
use mcap::records::{MessageHeader, Metadata};
use mcap::{Compression, WriteOptions};
use serde_json::Value;
use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;

/// What the file holds besides its messages.
pub struct Topic<'a> {
    pub schema_name: &'a str,
    pub schema: Value,
    pub topic: &'a str,
    pub metadata_name: &'a str,
    pub metadata: BTreeMap<String, String>,
}

/// Write `name` (run.mcap) with `messages` (time in s, the message), already in time order.
pub fn write(
    dir: &mut RunDir,
    name: &str,
    t: Topic<'_>,
    messages: impl Iterator<Item = (f64, Value)>,
) -> Result<()> {
    let e = |x: String| Error::failure(format!("{name}: {x}"));
    let staged = dir.stage(name);
    let file = File::create(&staged).map_err(|x| e(x.to_string()))?;
    let mut w = WriteOptions::new()
        .compression(Some(Compression::Zstd))
        .profile("")
        .library(concat!("waamtwin ", env!("CARGO_PKG_VERSION")))
        .create(BufWriter::new(file))
        .map_err(|x| e(x.to_string()))?;
    let text = serde_json::to_vec(&t.schema).map_err(|x| e(x.to_string()))?;
    let id = w
        .add_schema(t.schema_name, "jsonschema", &text)
        .map_err(|x| e(x.to_string()))?;
    let channel = w
        .add_channel(id, t.topic, "json", &BTreeMap::new())
        .map_err(|x| e(x.to_string()))?;
    w.write_metadata(&Metadata {
        name: t.metadata_name.into(),
        metadata: t.metadata,
    })
    .map_err(|x| e(x.to_string()))?;
    for (sequence, (time, msg)) in messages.enumerate() {
        let data = serde_json::to_vec(&msg).map_err(|x| e(x.to_string()))?;
        let ns = (time.max(0.0) * 1e9).round() as u64;
        let header = MessageHeader {
            channel_id: channel,
            sequence: sequence as u32,
            log_time: ns,
            publish_time: ns,
        };
        w.write_to_known_channel(&header, &data)
            .map_err(|x| e(x.to_string()))?;
    }
    w.finish().map_err(|x| e(x.to_string()))?;
    drop(w);
    dir.commit(&staged, name).map(|_| ())
}
