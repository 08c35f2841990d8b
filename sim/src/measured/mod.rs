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
use std::borrow::Cow;

/// "FILE line N: ..." as an input error.
fn at_line(file: &str, line: usize, what: impl std::fmt::Display) -> Error {
    Error::input(format!("{file} line {line}: {what}"))
}

/// The cells of a logger's line: split on each semicolon where it has one, else on each comma,
/// trimmed, an empty cell kept (a reading missing keeps its column's place, and the columns
/// after it theirs); on runs of whitespace where it has neither. Split on semicolons, a number
/// with a decimal comma (`25,3`: what a logger or a spreadsheet in a German or French locale
/// writes, its list separator the semicolon) reads with a point; such a file was refused
/// ("column 1 = \"0;25\"").
fn cells(line: &str) -> Vec<Cow<'_, str>> {
    if line.contains(';') {
        return line.split(';').map(|c| decimal_point(c.trim())).collect();
    }
    match line.contains(',') {
        true => line.split(',').map(|c| Cow::Borrowed(c.trim())).collect(),
        false => line.split_whitespace().map(Cow::Borrowed).collect(),
    }
}

/// A cell that is a number with one decimal comma (a sign, digits, the comma, digits, an
/// exponent), with a point in its place; any other cell as it is.
fn decimal_point(cell: &str) -> Cow<'_, str> {
    let Some((whole, fraction)) = cell.split_once(',') else {
        return Cow::Borrowed(cell);
    };
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    let whole_ok = digits(whole.trim_start_matches(['+', '-']));
    let (fraction, exponent) = match fraction.find(['e', 'E']) {
        Some(k) => (&fraction[..k], Some(&fraction[k + 1..])),
        None => (fraction, None),
    };
    let exponent_ok = exponent.is_none_or(|e| digits(e.trim_start_matches(['+', '-'])));
    match whole_ok && digits(fraction) && exponent_ok {
        true => Cow::Owned(cell.replacen(',', ".", 1)),
        false => Cow::Borrowed(cell),
    }
}

/// The fields of a CSV or whitespace-separated line of numbers alone, where no cell is ever
/// empty (a property table, a plan's path.csv read back).
fn fields(line: &str) -> Vec<&str> {
    line.split(|c: char| c == ',' || c == ';' || c.is_whitespace())
        .filter(|f| !f.is_empty())
        .collect()
}
