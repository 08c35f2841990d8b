//! The run directory: atomic file writes and the manifest every run leaves.

use crate::error::{Error, Result};
use std::path::{Path, PathBuf};
use std::time::{Instant, SystemTime, UNIX_EPOCH};

/// A run's output directory. Every file is written under a temporary name and renamed into
/// place, so a reader never sees a partial file under a final name.
pub struct RunDir {
    root: PathBuf,
    files: Vec<String>,
    started: SystemTime,
    clock: Instant,
}

impl RunDir {
    pub fn create(root: &Path) -> Result<RunDir> {
        std::fs::create_dir_all(root).map_err(|e| {
            Error::input(format!(
                "cannot create output directory {}: {e}",
                root.display()
            ))
        })?;
        Ok(RunDir {
            root: root.to_path_buf(),
            files: Vec::new(),
            started: SystemTime::now(),
            clock: Instant::now(),
        })
    }

    pub fn path(&self) -> &Path {
        &self.root
    }

    /// Write `bytes` to `name` atomically and record it for the manifest.
    pub fn write(&mut self, name: &str, bytes: &[u8]) -> Result<PathBuf> {
        let target = self.root.join(name);
        write_atomic(&target, bytes)?;
        self.list(name);
        Ok(target)
    }

    /// A temporary name in the run directory for a writer that streams to a file itself;
    /// [`RunDir::commit`] renames it into place.
    pub fn stage(&self, name: &str) -> PathBuf {
        staging_name(&self.root.join(name))
    }

    pub fn commit(&mut self, staged: &Path, name: &str) -> Result<PathBuf> {
        let target = self.root.join(name);
        std::fs::rename(staged, &target).map_err(|e| {
            let _ = std::fs::remove_file(staged);
            Error::failure(format!("cannot write {}: {e}", target.display()))
        })?;
        self.list(name);
        Ok(target)
    }

    fn list(&mut self, name: &str) {
        if !self.files.iter().any(|f| f == name) {
            self.files.push(name.to_string());
        }
    }

    pub fn write_json(&mut self, name: &str, value: &serde_json::Value) -> Result<PathBuf> {
        let mut text =
            serde_json::to_string_pretty(value).map_err(|e| Error::failure(e.to_string()))?;
        text.push('\n');
        self.write(name, text.as_bytes())
    }

    /// Write `manifest.json` last: its `files` lists what the run wrote.
    pub fn finish(mut self, command: &str, scenario: serde_json::Value) -> Result<PathBuf> {
        let started = self.started.duration_since(UNIX_EPOCH).unwrap_or_default();
        let manifest = serde_json::json!({
            "run_id": format!("{:x}-{:x}", started.as_millis(), std::process::id()),
            "version": env!("CARGO_PKG_VERSION"),
            "command": command,
            "scenario": scenario,
            "started_utc": utc_string(started.as_secs()),
            "wall_s": self.clock.elapsed().as_secs_f64(),
            "files": self.files.iter().chain(std::iter::once(&"manifest.json".to_string())).collect::<Vec<_>>(),
        });
        self.write_json("manifest.json", &manifest)
    }
}

pub fn write_atomic(target: &Path, bytes: &[u8]) -> Result<()> {
    write_atomic_parts(target, &[bytes])
}

/// [`write_atomic`] of `parts` one after the other, without joining them in memory first.
pub fn write_atomic_parts(target: &Path, parts: &[&[u8]]) -> Result<()> {
    use std::io::Write;
    let tmp = staging_name(target);
    let fail =
        |e: std::io::Error| Error::failure(format!("cannot write {}: {e}", target.display()));
    let write = || -> std::io::Result<()> {
        let mut f = std::fs::File::create(&tmp)?;
        for p in parts {
            f.write_all(p)?;
        }
        Ok(())
    };
    write().map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        fail(e)
    })?;
    std::fs::rename(&tmp, target).map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        fail(e)
    })
}

fn staging_name(target: &Path) -> PathBuf {
    let name = target.file_name().and_then(|n| n.to_str()).unwrap_or("out");
    // Hidden, and keeping the extension: some writers pick the format from it.
    target.with_file_name(format!(".tmp-{}-{name}", std::process::id()))
}

/// `YYYY-MM-DDTHH:MM:SSZ` from Unix seconds (civil-from-days, H. Hinnant's algorithm).
pub fn utc_string(secs: u64) -> String {
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!(
        "{y:04}-{m:02}-{d:02}T{:02}:{:02}:{:02}Z",
        rem / 3600,
        rem / 60 % 60,
        rem % 60
    )
}

#[cfg(test)]
mod tests {
    #[test]
    fn utc_dates() {
        assert_eq!(super::utc_string(0), "1970-01-01T00:00:00Z");
        assert_eq!(super::utc_string(951_782_400), "2000-02-29T00:00:00Z");
        assert_eq!(super::utc_string(1_795_246_401), "2026-11-21T07:33:21Z");
    }
}
