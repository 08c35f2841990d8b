//! Probe time series: one time column and one column per probe (thermocouples, IR spots), as
//! acquisition software writes them. A value of 0 or an empty field is no reading (the GAMMA IR
//! columns read 0 until metal is there). A preamble (a header, a logger's lines before it) is
//! skipped.

use super::at_line;
use crate::error::Result;

/// Measured series, as read: per probe one value or none per time.
#[derive(Debug, Clone, PartialEq)]
pub struct Series {
    pub t_s: Vec<f64>,
    /// Per probe (in the order asked for), per time.
    pub values: Vec<Vec<Option<f64>>>,
}

/// One line of a probe file, read.
#[derive(Debug, Clone, PartialEq)]
pub enum Line {
    /// Blank, a comment, or a header (a first line whose time is not a number).
    Nothing,
    /// Its time and, per probe asked for, its reading.
    Row(f64, Vec<Option<f64>>),
}

/// The hottest reading a probe file may hold, in its own unit (°C or K alike): no metal is
/// liquid above it (iron boils at 3 134 K, tungsten, the highest, at 5 828 K: CRC Handbook of
/// Chemistry and Physics), and a camera calibrated for metal saturates far below it. A value
/// above it is a logger's sentinel or a broken field, not a temperature, and the file is
/// refused where it stands rather than compared (a reading of 1e30 °C made replay's RMS 4e29).
pub const HOTTEST_READING: f64 = 6000.0;

/// What a column holds: a probe's temperature, or a machine's signal.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Kind {
    /// 0 is no reading (a logger starting up writes zeros: the ORNL log's first row), and
    /// nothing reads above [`HOTTEST_READING`].
    Temperature,
    /// 0 is a value (an arc off, no current).
    Signal,
}

/// Line `n` (1-based) of a probe file: columns `columns` (0-based) against `time_column`. A
/// message without the file's name where it does not read (the caller names the file, and in
/// live mode counts it and goes on). A reading of exactly 0 is none; one above
/// [`HOTTEST_READING`] does not read.
pub fn line(
    text: &str,
    n: usize,
    time_column: usize,
    columns: &[usize],
) -> std::result::Result<Line, String> {
    read(text, n, time_column, columns, Kind::Temperature)
}

/// [`line`] for a machine's signals, whose 0 is a value (an arc off, no current).
pub fn signals(
    text: &str,
    n: usize,
    time_column: usize,
    columns: &[usize],
) -> std::result::Result<Line, String> {
    read(text, n, time_column, columns, Kind::Signal)
}

fn read(
    text: &str,
    n: usize,
    time_column: usize,
    columns: &[usize],
    kind: Kind,
) -> std::result::Result<Line, String> {
    if text.trim().is_empty() || text.trim_start().starts_with('#') {
        return Ok(Line::Nothing);
    }
    // Empty fields are readings missing: split on the separator, not on runs of it.
    let f = super::cells(text);
    if n == 1 && f[0].parse::<f64>().is_err() {
        return Ok(Line::Nothing);
    }
    let widest = columns
        .iter()
        .copied()
        .chain([time_column])
        .max()
        .unwrap_or(0);
    if f.len() <= widest {
        return Err(format!(
            "{} fields; expected at least {}",
            f.len(),
            widest + 1
        ));
    }
    let t = match f[time_column].parse::<f64>() {
        Ok(t) if t.is_finite() => t,
        _ => {
            return Err(format!(
                "time {:?}; expected a finite number",
                f[time_column]
            ));
        }
    };
    let mut values = Vec::with_capacity(columns.len());
    for &c in columns {
        values.push(match &*f[c] {
            "" => None,
            text => match (text.parse::<f64>(), kind) {
                (Ok(v), Kind::Temperature) if v > HOTTEST_READING => {
                    return Err(format!(
                        "column {c} = {text}; expected a temperature of at most \
                         {HOTTEST_READING} (°C or K: hotter than any metal boils)"
                    ));
                }
                (Ok(v), Kind::Temperature) if v.is_finite() => (v != 0.0).then_some(v),
                (Ok(v), Kind::Signal) if v.is_finite() => Some(v),
                _ => return Err(format!("column {c} = {text:?}; expected a number")),
            },
        });
    }
    Ok(Line::Row(t, values))
}

/// The unit a header cell names for its column's readings, where it names one plainly:
/// kelvin as `(K)`, `[K]`, `/K` or `kelvin`; °C as `°C`, `(C)`, `[C]`, `degC`, `celsius` or a
/// `_c` suffix (ORNL's `tc1_c`). A bare `K` after a name is not read: `TC1 type K` is a
/// thermocouple's type. Some(true) for kelvin.
fn unit_named(cell: &str) -> Option<bool> {
    let c = cell.trim().to_lowercase();
    let kelvin = ["(k)", "[k]", "/k"].iter().any(|u| c.ends_with(u)) || c.contains("kelvin");
    let celsius = ["(c)", "[c]", "degc", "deg c", "_c"]
        .iter()
        .any(|u| c.ends_with(u))
        || c.contains("celsius")
        || c.contains("°c");
    match (kelvin, celsius) {
        (true, false) => Some(true),
        (false, true) => Some(false),
        _ => None,
    }
}

/// Where the preamble of a probe file (the lines before its first row) names the unit of a
/// probe's column other than `kelvin` says: (its line, the column, the cell). The header read
/// for what it says of the readings beneath it.
pub fn unit_against_header(
    text: &str,
    time_column: usize,
    columns: &[usize],
    kelvin: bool,
) -> Option<(usize, usize, String)> {
    for (k, line) in text.lines().enumerate().take(MOST_PREAMBLE_LINES) {
        if time_reads(line, time_column) {
            return None;
        }
        if let Some((c, cell)) = unit_in_line(line, columns, kelvin) {
            return Some((k + 1, c, cell));
        }
    }
    None
}

/// The refusal of a header's `cell` that names column `column`'s unit against `kelvin`
/// (after the file and line, which the caller names).
pub fn unit_against(column: usize, cell: &str, kelvin: bool) -> String {
    let (said, named) = if kelvin {
        ("K", "°C")
    } else {
        ("C", "kelvin")
    };
    format!(
        "column {column} is {cell:?}, in {named}; expected [probes] unit (\"{said}\") to say the \
         file's unit"
    )
}

/// Where one preamble line names the unit of one of `columns` other than `kelvin` says: the
/// column and the cell.
pub fn unit_in_line(line: &str, columns: &[usize], kelvin: bool) -> Option<(usize, String)> {
    let cells = super::cells(line);
    columns.iter().find_map(|&c| {
        let cell = cells.get(c)?;
        unit_named(cell)
            .is_some_and(|k| k != kelvin)
            .then(|| (c, cell.to_string()))
    })
}

/// The most lines a file may hold before its first row (a logger's preamble and header).
pub const MOST_PREAMBLE_LINES: usize = 100;

/// Whether a line's `time_column` reads as a time: a row, not a preamble's line.
pub fn time_reads(text: &str, time_column: usize) -> bool {
    super::cells(text)
        .get(time_column)
        .is_some_and(|t| t.parse::<f64>().is_ok_and(f64::is_finite))
}

/// Read columns `columns` (0-based) against column `time_column`, after any preamble (lines,
/// at most 100, before the first whose time reads); `file` names it in messages.
pub fn series(text: &str, file: &str, time_column: usize, columns: &[usize]) -> Result<Series> {
    let mut s = Series {
        t_s: Vec::new(),
        values: vec![Vec::new(); columns.len()],
    };
    let mut preamble = 0;
    for (k, text) in text.lines().enumerate() {
        let n = k + 1;
        // A logger's preamble (its name, the start, a header, a line of units) runs until the
        // first line whose time reads; a line after that which does not read is named.
        if s.t_s.is_empty() && !time_reads(text, time_column) {
            preamble += 1;
            if preamble > MOST_PREAMBLE_LINES {
                return Err(at_line(
                    file,
                    n,
                    format!(
                        "no time in column {time_column} in the first {MOST_PREAMBLE_LINES} \
                         lines; expected a time series, its times in column {time_column}"
                    ),
                ));
            }
            continue;
        }
        let (t, values) = match line(text, n, time_column, columns) {
            Ok(Line::Nothing) => continue,
            Ok(Line::Row(t, v)) => (t, v),
            Err(e) => return Err(at_line(file, n, e)),
        };
        if let Some(&last) = s.t_s.last()
            && t <= last
        {
            return Err(at_line(
                file,
                n,
                format!("time {t} after {last}; expected increasing times"),
            ));
        }
        s.t_s.push(t);
        for (j, v) in values.into_iter().enumerate() {
            s.values[j].push(v);
        }
    }
    if s.t_s.is_empty() {
        return Err(crate::error::Error::input(format!(
            "{file}: no rows with a time in column {time_column}; expected a time series"
        )));
    }
    Ok(s)
}

#[cfg(test)]
mod tests {
    use super::series;

    #[test]
    fn zero_and_empty_are_no_reading() {
        let s = series("t,a,b\n0.0,0,25.1\n0.5,300.5,\n", "tc.csv", 0, &[2, 1]).unwrap();
        assert_eq!(s.t_s, vec![0.0, 0.5]);
        assert_eq!(s.values[0], vec![Some(25.1), None]);
        assert_eq!(s.values[1], vec![None, Some(300.5)]);
    }

    /// A file as a logger or spreadsheet in a German or French locale writes it: semicolons
    /// between cells, decimal commas in the numbers, an empty reading kept in its place, and a
    /// preamble whose date holds a comma; read as the same file with commas and points.
    #[test]
    fn semicolons_and_decimal_commas_read_as_points() {
        let german = "Messung 30.11.2026, 12:00\nZeit;TC1;TC2\n0,0;25,3;-1,5e1\n0,5;;26\n";
        let s = series(german, "tc.csv", 0, &[1, 2]).unwrap();
        let plain = series("t,a,b\n0.0,25.3,-15\n0.5,,26\n", "tc.csv", 0, &[1, 2]).unwrap();
        assert_eq!((s.t_s, s.values), (plain.t_s, plain.values));
        // A cell with two commas is no number: named, not read as another.
        let e = series("Zeit;TC1\n0,0;25,3,1\n", "tc.csv", 0, &[1]).unwrap_err();
        assert!(e.message.contains("tc.csv line 2"), "{}", e.message);
    }

    /// A logger's preamble (its name, the start, the header, a line of units) is passed over;
    /// a line after the first row that does not read is named; a file with no time in its
    /// column says so.
    #[test]
    fn a_preamble_is_passed_over() {
        let text = "Logger TC-08\nStart: 2026-11-30, 12:00\nt,tc1,tc2\ns,C,C\n0,20,21\n1,25,\n";
        let s = series(text, "tc.csv", 0, &[1, 2]).unwrap();
        assert_eq!(s.t_s, vec![0.0, 1.0]);
        assert_eq!(s.values[1], vec![Some(21.0), None]);
        let e = series("t,a\n0,1\ns,C\n", "tc.csv", 0, &[1]).unwrap_err();
        assert!(e.message.contains("tc.csv line 3"), "{}", e.message);
        let e = series("a,b\nx,1\n", "tc.csv", 0, &[1]).unwrap_err();
        assert!(
            e.message.contains("no rows with a time in column 0"),
            "{}",
            e.message
        );
        let long = "x,1\n".repeat(101);
        let e = series(&long, "tc.csv", 0, &[1]).unwrap_err();
        assert!(
            e.message.contains("tc.csv line 101: no time in column 0"),
            "{}",
            e.message
        );
    }

    /// A header that names its columns' unit plainly is read for it (ORNL's `tc1_c`, `T (K)`,
    /// `tc [°C]`); a thermocouple's type (`TC1 type K`) and a name alone are not units.
    #[test]
    fn a_header_names_its_unit() {
        use super::unit_against_header as against;
        let ornl = "t_s,clock,tc1_c,tc2_c\n0,12:00,0,0\n";
        assert_eq!(against(ornl, 0, &[2, 3], false), None);
        assert_eq!(
            against(ornl, 0, &[2, 3], true),
            Some((1, 2, "tc1_c".into()))
        );
        let k = "time,T (K),tc [°C]\ns,K,C\n0,300,25\n";
        assert_eq!(against(k, 0, &[1], true), None);
        assert_eq!(against(k, 0, &[1], false), Some((1, 1, "T (K)".into())));
        assert_eq!(against(k, 0, &[2], true), Some((1, 2, "tc [°C]".into())));
        let plain = "t,TC1 type K,tc2\n0,20,20\n";
        assert_eq!(against(plain, 0, &[1, 2], false), None);
        assert_eq!(against(plain, 0, &[1, 2], true), None);
        assert_eq!(against("0,20\n", 0, &[1], true), None, "no header");
    }

    #[test]
    fn a_bad_row_names_its_line() {
        let e = series("0,1\n1,x\n", "ir.csv", 0, &[1]).unwrap_err();
        assert!(
            e.message.contains("ir.csv line 2: column 1 = \"x\""),
            "{}",
            e.message
        );
        let e = series("0,1\n1\n", "ir.csv", 0, &[1]).unwrap_err();
        assert!(e.message.contains("line 2: 1 fields"), "{}", e.message);
        let e = series("1,1\n0,1\n", "ir.csv", 0, &[1]).unwrap_err();
        assert!(e.message.contains("time 0 after 1"), "{}", e.message);
    }

    /// A sentinel or a broken field far above any metal's temperature is refused at its line,
    /// not compared; the hottest a file may hold still reads, and a signal is not a temperature.
    #[test]
    fn a_reading_hotter_than_any_metal_names_its_line() {
        let e = series("t,tc1\n0,20\n1,1e30\n", "tc.csv", 0, &[1]).unwrap_err();
        assert!(
            e.message
                .contains("tc.csv line 3: column 1 = 1e30; expected a temperature"),
            "{}",
            e.message
        );
        let e = series("0,20\n1,9999\n", "tc.csv", 0, &[1]).unwrap_err();
        assert!(
            e.message.contains("line 2: column 1 = 9999"),
            "{}",
            e.message
        );
        let s = series("0,20\n1,6000\n", "tc.csv", 0, &[1]).unwrap();
        assert_eq!(s.values[0], vec![Some(20.0), Some(6000.0)]);
        let super::Line::Row(_, v) = super::signals("1,7000", 2, 0, &[1]).unwrap() else {
            panic!("a row expected");
        };
        assert_eq!(v, vec![Some(7000.0)]);
    }
}
