//! Following a file as a logger writes it: what was appended since the last look, line by
//! line, a partial last line kept until its newline comes. A file that shrinks or is replaced
//! (another inode) is read again from its start, and said so.

use std::fs::File;
use std::io::{Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

/// The most read in one look: a file that grows faster is read over several.
const CHUNK: u64 = 4 << 20;
/// A line longer than this is cut off where it stands.
const LONGEST: u64 = 1 << 20;

/// Where a followed file was read to: what a checkpoint keeps to go on from.
#[derive(Debug, Clone, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Mark {
    /// Bytes read up to the end of the last whole line.
    pub offset: u64,
    /// Whole lines read (the next is line `lines + 1`).
    pub lines: usize,
    /// The file's identity where the platform gives one (device, inode).
    pub id: Option<(u64, u64)>,
}

/// What one look found.
#[derive(Debug, Default, PartialEq)]
pub struct Look {
    /// Whole lines: each with where the file is read to once it is (a checkpoint's mark
    /// after it) and its text.
    pub lines: Vec<(Mark, String)>,
    /// The file shrank or was replaced since the last look: read again from its start.
    pub restarted: Option<String>,
}

pub struct Tail {
    path: PathBuf,
    pub mark: Mark,
    partial: Vec<u8>,
}

#[cfg(unix)]
fn identity(m: &std::fs::Metadata) -> Option<(u64, u64)> {
    use std::os::unix::fs::MetadataExt;
    Some((m.dev(), m.ino()))
}

#[cfg(not(unix))]
fn identity(_: &std::fs::Metadata) -> Option<(u64, u64)> {
    None
}

impl Tail {
    /// Follow `path` from `mark` (the start, or where a checkpoint left it).
    pub fn new(path: &Path, mark: Mark) -> Tail {
        Tail {
            path: path.to_path_buf(),
            mark,
            partial: Vec::new(),
        }
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Read what was appended since the last look. A file not there yet is nothing new.
    pub fn look(&mut self) -> std::io::Result<Look> {
        let mut out = Look::default();
        let meta = match std::fs::metadata(&self.path) {
            Ok(m) => m,
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(out),
            Err(e) => return Err(e),
        };
        let id = identity(&meta);
        let read_to = self.mark.offset + self.partial.len() as u64;
        let replaced = self.mark.id.is_some() && id != self.mark.id;
        if replaced || meta.len() < read_to {
            out.restarted = Some(match replaced {
                true => "replaced by another file".into(),
                false => format!("shrank from {read_to} to {} bytes", meta.len()),
            });
            self.mark = Mark::default();
            self.partial.clear();
        }
        self.mark.id = id;
        let from = self.mark.offset + self.partial.len() as u64;
        if meta.len() <= from {
            return Ok(out);
        }
        let mut f = File::open(&self.path)?;
        f.seek(SeekFrom::Start(from))?;
        let mut chunk = Vec::new();
        f.take(CHUNK).read_to_end(&mut chunk)?;
        self.partial.extend_from_slice(&chunk);
        let end = match self.partial.iter().rposition(|&b| b == b'\n') {
            Some(end) => end,
            // No logger writes a line this long: taken as one (it will not read, and is
            // counted) rather than held without end.
            None if self.partial.len() as u64 >= LONGEST => self.partial.len() - 1,
            None => return Ok(out),
        };
        let whole: Vec<u8> = self.partial.drain(..=end).collect();
        // `whole` ends with a newline (or is cut at `LONGEST`): its last byte ends the line.
        for line in whole[..whole.len() - 1].split(|&b| b == b'\n') {
            self.mark.offset += line.len() as u64 + 1;
            self.mark.lines += 1;
            let text = String::from_utf8_lossy(line);
            out.lines
                .push((self.mark.clone(), text.trim_end_matches('\r').to_string()));
        }
        Ok(out)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Write;

    /// A partial last line waits for its newline; a file cut short is read again from its
    /// start and said so.
    #[test]
    fn partial_lines_wait_and_a_truncated_file_restarts() {
        let dir = std::env::temp_dir().join(format!("waamtwin-tail-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("log.csv");
        std::fs::write(&path, "t,a\n1,2").unwrap();
        let mut t = Tail::new(&path, Mark::default());
        let text = |l: &Look| -> Vec<(usize, String)> {
            l.lines.iter().map(|(m, t)| (m.lines, t.clone())).collect()
        };
        let l = t.look().unwrap();
        assert_eq!(text(&l), vec![(1, "t,a".to_string())]);
        assert_eq!(l.lines[0].0.offset, 4);
        let mut f = std::fs::OpenOptions::new()
            .append(true)
            .open(&path)
            .unwrap();
        f.write_all(b"0\n2,30\n").unwrap();
        let l = t.look().unwrap();
        assert_eq!(text(&l), vec![(2, "1,20".into()), (3, "2,30".into())]);
        assert_eq!(t.look().unwrap(), Look::default());
        std::fs::write(&path, "5,1\n").unwrap();
        let l = t.look().unwrap();
        assert!(l.restarted.is_some(), "{l:?}");
        assert_eq!(text(&l), vec![(1, "5,1".to_string())]);
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
