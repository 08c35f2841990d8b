//! Mesh file formats: one module per format, bytes in and bytes out (the `sim` crate owns files).
//!
//! Parsers never trust a count a header claims: a binary body must be long enough for it before
//! anything is allocated, and text formats grow their buffers only with what they actually read.

mod obj;
mod ply;
mod stl;

pub use obj::{Polylines, read_obj, read_obj_polylines, write_obj};
pub use ply::{read_ply, write_ply};
pub use stl::{read_stl, write_stl};

use crate::mesh::TriMesh;
use std::fmt;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MeshFormat {
    Stl,
    Obj,
    Ply,
}

impl MeshFormat {
    /// The format a file name's extension says, case-insensitive.
    pub fn from_extension(name: &str) -> Option<MeshFormat> {
        let ext = name.rsplit_once('.')?.1.to_ascii_lowercase();
        match ext.as_str() {
            "stl" => Some(MeshFormat::Stl),
            "obj" => Some(MeshFormat::Obj),
            "ply" => Some(MeshFormat::Ply),
            _ => None,
        }
    }
}

/// Text or binary flavour for writers.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Encoding {
    Ascii,
    Binary,
}

/// A parse failure, with the line (text formats) or byte offset (binary) where it happened.
#[derive(Debug, Clone, PartialEq)]
pub struct FormatError {
    pub format: &'static str,
    pub line: Option<usize>,
    pub byte: Option<usize>,
    pub message: String,
}

impl FormatError {
    pub(crate) fn at_line(format: &'static str, line: usize, message: impl Into<String>) -> Self {
        Self {
            format,
            line: Some(line),
            byte: None,
            message: message.into(),
        }
    }
    pub(crate) fn at_byte(format: &'static str, byte: usize, message: impl Into<String>) -> Self {
        Self {
            format,
            line: None,
            byte: Some(byte),
            message: message.into(),
        }
    }
}

impl fmt::Display for FormatError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match (self.line, self.byte) {
            (Some(l), _) => write!(f, "{} line {}: {}", self.format, l, self.message),
            (None, Some(b)) => write!(f, "{} byte {}: {}", self.format, b, self.message),
            _ => write!(f, "{}: {}", self.format, self.message),
        }
    }
}

impl std::error::Error for FormatError {}

pub fn read_mesh(bytes: &[u8], format: MeshFormat) -> Result<TriMesh, FormatError> {
    match format {
        MeshFormat::Stl => read_stl(bytes),
        MeshFormat::Obj => read_obj(bytes),
        MeshFormat::Ply => read_ply(bytes),
    }
}

pub fn write_mesh(mesh: &TriMesh, format: MeshFormat, encoding: Encoding) -> Vec<u8> {
    match format {
        MeshFormat::Stl => write_stl(mesh, encoding),
        MeshFormat::Obj => write_obj(mesh),
        MeshFormat::Ply => write_ply(mesh, encoding),
    }
}

/// Parse one float token; `what` names the field for the message.
pub(crate) fn parse_f64(
    fmt: &'static str,
    line: usize,
    tok: Option<&str>,
    what: &str,
) -> Result<f64, FormatError> {
    let tok = tok.ok_or_else(|| {
        FormatError::at_line(fmt, line, format!("missing {what}; expected a number"))
    })?;
    tok.parse::<f64>().map_err(|_| {
        FormatError::at_line(fmt, line, format!("{what} is '{tok}'; expected a number"))
    })
}

/// Text formats may be read as UTF-8 lossily: only ASCII tokens matter.
pub(crate) fn text(bytes: &[u8]) -> std::borrow::Cow<'_, str> {
    String::from_utf8_lossy(bytes)
}

#[cfg(test)]
mod tests;
