//! What a real machine did and what a real part measured, read from text: a toolpath as an
//! event series ([`toolpath`]) or a welding cell's machine log ([`machine_log`]), probe time
//! series ([`probes`]), property tables ([`table`]) and a planned path as laid ([`path`]). The
//! readers take the text and the file's name (for messages) and do no IO themselves; each bad
//! line is a one-line error naming the file, the line, the value and what was expected.

pub mod gcode;
pub mod machine_log;
pub mod path;
pub mod probes;
pub mod table;
pub mod toolpath;

use crate::error::Error;

/// "FILE line N: ..." as an input error.
fn at_line(file: &str, line: usize, what: impl std::fmt::Display) -> Error {
    Error::input(format!("{file} line {line}: {what}"))
}

/// The cells of a logger's line: split on each comma (or, where it has none, each semicolon),
/// trimmed, an empty cell kept (a reading missing keeps its column's place, and the columns
/// after it theirs); on runs of whitespace where it has neither.
fn cells(line: &str) -> Vec<&str> {
    match [',', ';'].into_iter().find(|&c| line.contains(c)) {
        Some(c) => line.split(c).map(str::trim).collect(),
        None => line.split_whitespace().collect(),
    }
}

/// The fields of a CSV or whitespace-separated line of numbers alone, where no cell is ever
/// empty (a property table, a plan's path.csv read back).
fn fields(line: &str) -> Vec<&str> {
    line.split(|c: char| c == ',' || c == ';' || c.is_whitespace())
        .filter(|f| !f.is_empty())
        .collect()
}
