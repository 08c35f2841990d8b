//! A run's checkpoint folder, `OUT/checkpoint/`: one file per stage the engine keeps
//! ([`crate::pipeline::checkpoint`]), written under a temporary name and renamed: work in
//! progress at most every `--checkpoint-every-s` seconds, a stage's result as it ends;
//! `--resume` goes on from them. A finished run removes the folder.
//!
//! A file is one header line and the engine's bytes:
//!
//! ```text
//! waamtwin-checkpoint {"command":"dwell","version":"0.1.0","format":2,"fingerprint":"…","stage":"before.run","bytes":812345,"crc32":305419896}
//! <bytes>
//! ```
//!
//! The fingerprint is a SHA-256 of what the run computes from (the command, the scenario as
//! resolved, the deposition schedule): a checkpoint from another scenario, part, command or
//! version, or a damaged one, is refused with exit 2 before any work starts, never used.

use crate::error::{Error, Result};
use crate::output::write_atomic_parts;
use crate::pipeline::checkpoint::Store;
use serde::{Deserialize, Serialize};
use sha2::{Digest, Sha256};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// Bumped whenever a kept state's layout changes within one version.
pub const FORMAT: u32 = 2;
const MAGIC: &str = "waamtwin-checkpoint ";
/// The longest header line read.
const HEADER_MAX: usize = 4096;
/// Testing: abort the process (as a kill would) right after this many checkpoints were written
/// (`N`), or this many of one stage (`STAGE:N`).
pub const ABORT_AFTER: &str = "WAAMTWIN_ABORT_AFTER_CHECKPOINTS";
const VERSION: &str = env!("CARGO_PKG_VERSION");

/// `--resume` and `--checkpoint-every-s`, as the commands take them.
#[derive(Debug, Clone, Copy, clap::Args)]
pub struct Options {
    /// Go on from the checkpoints a killed run of the same command, scenario and version left
    /// in OUT/checkpoint (refused if they are another's).
    #[arg(long)]
    pub resume: bool,
    /// Keep the work in progress in OUT/checkpoint at most this often, s (0: at every chance);
    /// a stage's result is kept as the stage ends.
    #[arg(long, default_value_t = 60.0)]
    pub checkpoint_every_s: f64,
}

impl Default for Options {
    fn default() -> Options {
        Options {
            resume: false,
            checkpoint_every_s: 60.0,
        }
    }
}

#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
struct Header {
    command: String,
    version: String,
    format: u32,
    fingerprint: String,
    stage: String,
    bytes: u64,
    crc32: u32,
}

/// SHA-256 (hex) of `parts`, each length-prefixed so that no two lists hash alike by accident.
pub fn fingerprint(parts: &[&[u8]]) -> String {
    let mut h = Sha256::new();
    for p in parts {
        h.update((p.len() as u64).to_le_bytes());
        h.update(p);
    }
    h.finalize().iter().map(|b| format!("{b:02x}")).collect()
}

/// `N` or `STAGE:N` ([`ABORT_AFTER`]).
fn abort_after(v: &str) -> Option<(Option<String>, usize)> {
    match v.rsplit_once(':') {
        Some((stage, n)) => Some((Some(stage.into()), n.parse().ok()?)),
        None => Some((None, v.parse().ok()?)),
    }
}

/// The fingerprint of `command` on a scenario (as resolved: `to_json`) and the schedule it
/// made from its part.
pub fn of_run(
    command: &str,
    scenario: &serde_json::Value,
    deps: &[thermal::schedule::Deposit],
) -> String {
    let schedule = postcard::to_stdvec(deps).unwrap_or_default();
    fingerprint(&[
        command.as_bytes(),
        scenario.to_string().as_bytes(),
        &schedule,
    ])
}

/// The checkpoint folder of one run.
pub struct Folder {
    dir: PathBuf,
    command: String,
    fingerprint: String,
    every: Duration,
    last: Instant,
    /// States read on `--resume`, checked, by stage: each is handed over once.
    found: BTreeMap<String, Vec<u8>>,
    /// Checkpoints written, in all and by stage.
    saved: BTreeMap<String, usize>,
    abort_after: Option<(Option<String>, usize)>,
    warned: bool,
}

impl Folder {
    /// The folder of the run writing to `out`. Without `resume` what an earlier run left there
    /// is removed; with it, every file there is checked now.
    pub fn open(out: &Path, command: &str, fingerprint: String, o: Options) -> Result<Folder> {
        if !(o.checkpoint_every_s.is_finite() && o.checkpoint_every_s >= 0.0) {
            return Err(Error::input(format!(
                "--checkpoint-every-s {}; expected seconds, 0 or more",
                o.checkpoint_every_s
            )));
        }
        let dir = out.join("checkpoint");
        let mut f = Folder {
            dir,
            command: command.into(),
            fingerprint,
            every: Duration::from_secs_f64(o.checkpoint_every_s.min(1e9)),
            last: Instant::now(),
            found: BTreeMap::new(),
            saved: BTreeMap::new(),
            abort_after: std::env::var(ABORT_AFTER)
                .ok()
                .and_then(|v| abort_after(&v)),
            warned: false,
        };
        if o.resume {
            f.found = f.read_all()?;
            if f.found.is_empty() {
                eprintln!(
                    "--resume: no checkpoint in {}: starting from the beginning",
                    f.dir.display()
                );
            }
        } else if f.dir.exists() {
            std::fs::remove_dir_all(&f.dir)
                .map_err(|e| Error::failure(format!("cannot remove {}: {e}", f.dir.display())))?;
        }
        Ok(f)
    }

    /// The run finished: its checkpoints are no longer needed.
    pub fn close(self) -> Result<()> {
        match std::fs::remove_dir_all(&self.dir) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => Err(Error::failure(format!(
                "cannot remove {}: {e}",
                self.dir.display()
            ))),
            _ => Ok(()),
        }
    }

    fn read_all(&self) -> Result<BTreeMap<String, Vec<u8>>> {
        let mut found = BTreeMap::new();
        let Ok(entries) = std::fs::read_dir(&self.dir) else {
            return Ok(found);
        };
        for e in entries.flatten() {
            let path = e.path();
            let name = e.file_name().to_string_lossy().into_owned();
            if name.starts_with(".tmp-") {
                // A checkpoint being written when the run was killed: never renamed, never used.
                let _ = std::fs::remove_file(&path);
                continue;
            }
            if !name.ends_with(".ckpt") {
                continue;
            }
            let (stage, bytes) = self.check(&path)?;
            found.insert(stage, bytes);
        }
        Ok(found)
    }

    /// A checkpoint file's stage and bytes, if it is this run's and whole.
    fn check(&self, path: &Path) -> Result<(String, Vec<u8>)> {
        let shown = path.display();
        let refuse = |why: String| {
            Error::input(format!(
                "{shown}: {why}; a checkpoint that is not this run's is never used: run without \
                 --resume to start again"
            ))
        };
        let data =
            std::fs::read(path).map_err(|e| Error::failure(format!("cannot read {shown}: {e}")))?;
        let head = &data[..data.len().min(HEADER_MAX)];
        let line_end = head.iter().position(|&b| b == b'\n');
        let header = line_end
            .and_then(|n| std::str::from_utf8(&head[..n]).ok())
            .and_then(|l| l.strip_prefix(MAGIC))
            .and_then(|l| serde_json::from_str::<Header>(l).ok());
        let (Some(h), Some(n)) = (header, line_end) else {
            return Err(refuse(format!(
                "not a waamtwin checkpoint (expected a first line `{}{{…}}`)",
                MAGIC.trim_end()
            )));
        };
        if h.version != VERSION || h.format != FORMAT {
            return Err(refuse(format!(
                "written by waamtwin {} (checkpoint format {}), this is waamtwin {VERSION} \
                 (format {FORMAT})",
                h.version, h.format
            )));
        }
        if h.command != self.command {
            return Err(refuse(format!(
                "written by `waamtwin {}`, this is `waamtwin {}`",
                h.command, self.command
            )));
        }
        if h.fingerprint != self.fingerprint {
            return Err(refuse(format!(
                "written for another scenario, part or schedule (fingerprint {}…, this run's {}…)",
                h.fingerprint.chars().take(12).collect::<String>(),
                self.fingerprint.chars().take(12).collect::<String>()
            )));
        }
        let body = &data[n + 1..];
        let crc = crc32fast::hash(body);
        if body.len() as u64 != h.bytes || crc != h.crc32 {
            return Err(refuse(format!(
                "damaged: {} bytes with CRC-32 {crc:08x}, its header says {} bytes, {:08x}",
                body.len(),
                h.bytes,
                h.crc32
            )));
        }
        Ok((h.stage, body.to_vec()))
    }

    fn file(&self, stage: &str) -> PathBuf {
        self.dir.join(format!("{stage}.ckpt"))
    }

    fn write(&self, stage: &str, bytes: &[u8]) -> std::io::Result<()> {
        std::fs::create_dir_all(&self.dir)?;
        let header = Header {
            command: self.command.clone(),
            version: VERSION.into(),
            format: FORMAT,
            fingerprint: self.fingerprint.clone(),
            stage: stage.into(),
            bytes: bytes.len() as u64,
            crc32: crc32fast::hash(bytes),
        };
        let line = format!("{MAGIC}{}\n", serde_json::to_string(&header)?);
        write_atomic_parts(&self.file(stage), &[line.as_bytes(), bytes])
            .map_err(|e| std::io::Error::other(e.message))
    }
}

impl Store for Folder {
    fn due(&self) -> bool {
        self.last.elapsed() >= self.every
    }

    fn load(&mut self, stage: &str) -> Option<Vec<u8>> {
        let bytes = self.found.remove(stage)?;
        eprintln!("resuming {stage} from {}", self.file(stage).display());
        Some(bytes)
    }

    fn unreadable(&mut self, stage: &str, why: &str) {
        eprintln!(
            "warning: {} did not read as the state of stage {stage} ({why}): the stage starts \
             again. This version wrote it for this work, so this is a bug; the outputs are \
             those of a run that was not resumed",
            self.file(stage).display()
        );
    }

    fn save(&mut self, stage: &str, bytes: &[u8]) {
        match self.write(stage, bytes) {
            Ok(()) => {
                *self.saved.entry(String::new()).or_default() += 1;
                *self.saved.entry(stage.into()).or_default() += 1;
            }
            // A run that cannot keep its state goes on: it only cannot resume.
            Err(e) if !self.warned => {
                self.warned = true;
                eprintln!(
                    "warning: cannot write the checkpoint {}: {e}; the run goes on without",
                    self.file(stage).display()
                );
            }
            Err(_) => {}
        }
        self.last = Instant::now();
        if let Some((only, n)) = &self.abort_after {
            let key = only.as_deref().unwrap_or("");
            if self.saved.get(key).is_some_and(|k| k >= n) {
                std::process::abort();
            }
        }
    }

    fn remove(&mut self, stage: &str) {
        let _ = std::fs::remove_file(self.file(stage));
    }
}
