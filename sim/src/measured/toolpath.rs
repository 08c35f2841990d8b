//! A toolpath as the machine ran it: waypoints in time, each saying whether metal was laid on
//! the way to it.
//!
//! The event-series CSV: `t_s, x_mm, y_mm, z_mm, on` per line, optionally under a preamble (lines
//! before the first whose time reads, at most `MOST_PREAMBLE_LINES`, a header among them);
//! `on` is 0 or 1 (the segment ending at this waypoint deposits), a power in W (deposits when
//! above 0), or `_POWER_` (deposits at the scenario's power: ORNL's event series leaves the
//! power to the machine log). Times must increase.

use super::probes::{MOST_PREAMBLE_LINES, time_reads};
use super::{at_line, cells};
use crate::error::Result;

/// Where the torch is at a time, and what it did on the way there.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Waypoint {
    pub t_s: f64,
    pub position_mm: [f64; 3],
    /// Metal is laid on the segment ending here.
    pub on: bool,
    /// The power on that segment, W, where the file gives it.
    pub power_w: Option<f64>,
}

/// Read an event series; `file` names it in messages.
pub fn event_series(text: &str, file: &str) -> Result<Vec<Waypoint>> {
    let mut out: Vec<Waypoint> = Vec::new();
    let mut preamble = 0;
    for (k, line) in text.lines().enumerate() {
        let n = k + 1;
        let f = cells(line);
        if f.iter().all(|c| c.is_empty()) || line.trim_start().starts_with('#') {
            continue;
        }
        // The preamble: lines before the first whose time reads (an exporter's name, a header,
        // a line of units under it), each held to the columns it names (`header`).
        if out.is_empty() && !time_reads(line, 0) {
            preamble += 1;
            if preamble > MOST_PREAMBLE_LINES {
                return Err(at_line(
                    file,
                    n,
                    format!(
                        "no time in column 0 in the first {MOST_PREAMBLE_LINES} lines; expected \
                         rows of t_s, x_mm, y_mm, z_mm, on"
                    ),
                ));
            }
            header(&f).map_err(|e| at_line(file, n, e))?;
            continue;
        }
        if f.len() < 5 {
            return Err(at_line(
                file,
                n,
                format!("{} fields; expected 5: t_s, x_mm, y_mm, z_mm, on", f.len()),
            ));
        }
        let number = |i: usize, name: &str| -> Result<f64> {
            match f[i].parse::<f64>() {
                Ok(v) if v.is_finite() => Ok(v),
                _ => Err(at_line(
                    file,
                    n,
                    format!("{name} = {:?}; expected a finite number", f[i]),
                )),
            }
        };
        let t_s = number(0, "t_s")?;
        let position_mm = [number(1, "x_mm")?, number(2, "y_mm")?, number(3, "z_mm")?];
        let (on, power_w) = match &*f[4] {
            "_POWER_" => (true, None),
            _ => match number(4, "on")? {
                v if v == 0.0 || v == 1.0 => (v == 1.0, None),
                v if v > 0.0 => (true, Some(v)),
                v => {
                    return Err(at_line(
                        file,
                        n,
                        format!("on = {v}; expected 0, 1, a power in W or _POWER_"),
                    ));
                }
            },
        };
        if let Some(last) = out.last()
            && t_s <= last.t_s
        {
            return Err(at_line(
                file,
                n,
                format!("t_s = {t_s} after {}; expected increasing times", last.t_s),
            ));
        }
        out.push(Waypoint {
            t_s,
            position_mm,
            on,
            power_w,
        });
    }
    if out.len() < 2 {
        return Err(crate::error::Error::input(format!(
            "{file}: {} waypoints; expected at least 2",
            out.len()
        )));
    }
    Ok(out)
}

/// The event series' columns in their order, and the units their values are read in.
const COLUMNS: [(&str, Option<&str>); 5] = [
    ("t_s", Some("s")),
    ("x_mm", Some("mm")),
    ("y_mm", Some("mm")),
    ("z_mm", Some("mm")),
    ("on", None),
];

/// A header cell read as a column's name and unit: `x_mm`, `X (mm)`, `t [s]`, `time_s` are
/// (1, "mm"), (1, "mm"), (0, "s"), (0, "s"); None where it names none of the columns (GAMMA's
/// `laser_on_in_segment_ending_here`).
fn named(cell: &str) -> Option<(usize, String)> {
    let cell = cell.to_ascii_lowercase();
    let (name, unit) = cell.split_once(['_', ' ', '(', '[']).unwrap_or((&cell, ""));
    let column = match name {
        "t" | "time" => 0,
        "x" => 1,
        "y" => 2,
        "z" => 3,
        "on" => 4,
        _ => return None,
    };
    let unit = unit.trim_matches(|c: char| matches!(c, '_' | ' ' | '(' | ')' | '[' | ']'));
    Some((column, unit.to_string()))
}

/// A header that names the columns is held to them: each in its place and in its unit, so
/// that a file in another order (`t_s, on, x_mm, …`) or unit (`x_m`, `t_ms`) is refused rather
/// than read by position.
fn header(cells: &[std::borrow::Cow<'_, str>]) -> std::result::Result<(), String> {
    for (k, cell) in cells.iter().enumerate().take(COLUMNS.len()) {
        let Some((column, unit)) = named(cell) else {
            continue;
        };
        let (name, want) = COLUMNS[column];
        if column != k {
            return Err(format!(
                "the header's column {k} is {cell:?}; expected {:?} there: the event series' \
                 columns are t_s, x_mm, y_mm, z_mm, on, in that order",
                COLUMNS[k].0
            ));
        }
        // Only a unit known to be another is refused: `z_top_mm` is z, in mm.
        let other = match want {
            Some("s") => ["ms", "us", "µs", "min", "h"].contains(&unit.as_str()),
            Some(_) => ["m", "cm", "dm", "um", "µm", "in", "inch", "ft"].contains(&unit.as_str()),
            None => false,
        };
        if let (true, Some(want)) = (other, want) {
            return Err(format!(
                "the header's column {k} is {cell:?}, in {unit}; expected {name}, in {want}"
            ));
        }
    }
    Ok(())
}

/// Re-read flags written for the segment starting at each waypoint (the event-series
/// convention: a power holds from its time on) as this module's, for the segment ending there.
pub fn flags_start_segments(path: &mut [Waypoint]) {
    for i in (1..path.len()).rev() {
        (path[i].on, path[i].power_w) = (path[i - 1].on, path[i - 1].power_w);
    }
    if let Some(first) = path.first_mut() {
        (first.on, first.power_w) = (false, None);
    }
}

#[cfg(test)]
mod tests {
    use super::{event_series, flags_start_segments};

    /// A header that names the columns is read for their order and units: GAMMA's and the
    /// usual forms pass; another order, positions in metres or inches, a time in ms are
    /// refused naming the column.
    #[test]
    fn a_header_is_held_to_the_columns_it_names() {
        let rows = "0,0,0,0,0\n1,10,0,0,1\n";
        for ok in [
            "t_s,x_mm,y_mm,z_mm,laser_on_in_segment_ending_here",
            "time (s),X (mm),Y (mm),Z (mm),on",
            "t [s], x, y, z, power_w",
            "Zeit,a,b,c,d",
            "t_s,x_mm,y_mm,z_top_mm,on",
        ] {
            let w = event_series(&format!("{ok}\n{rows}"), "e.csv");
            assert_eq!(w.map(|w| w.len()).ok(), Some(2), "{ok}");
        }
        for (bad, says) in [
            (
                "t_s,on,x_mm,y_mm,z_mm",
                "column 1 is \"on\"; expected \"x_mm\" there",
            ),
            (
                "t_s,y_mm,x_mm,z_mm,on",
                "column 1 is \"y_mm\"; expected \"x_mm\"",
            ),
            (
                "t_s,x_m,y_m,z_m,on",
                "column 1 is \"x_m\", in m; expected x_mm, in mm",
            ),
            (
                "t_ms,x_mm,y_mm,z_mm,on",
                "column 0 is \"t_ms\", in ms; expected t_s, in s",
            ),
            ("t,x (in),y (in),z (in),on", "in in; expected x_mm, in mm"),
        ] {
            let e = event_series(&format!("{bad}\n{rows}"), "e.csv").unwrap_err();
            assert!(
                e.message.contains("e.csv line 1") && e.message.contains(says),
                "{}",
                e.message
            );
        }
    }

    /// A header under a comment or an exporter's lines is read as a header (it was a bad row,
    /// "t_s = \"t_s\""), and held to its columns there too; a file of no rows in its first 100
    /// lines says so.
    #[test]
    fn a_preamble_is_passed_over_and_its_header_read() {
        let rows = "0,0,0,0,0\n1,10,0,0,1\n";
        for preamble in [
            "# exported 2026-11-30\nt_s,x_mm,y_mm,z_mm,on\n",
            "robot: KUKA KR 60\nt_s,x_mm,y_mm,z_mm,on\ns,mm,mm,mm,-\n",
        ] {
            let w = event_series(&format!("{preamble}{rows}"), "e.csv");
            assert_eq!(w.map(|w| w.len()).ok(), Some(2), "{preamble}");
        }
        let e = event_series(&format!("robot\nt_s,x_m,y_m,z_m,on\n{rows}"), "e.csv").unwrap_err();
        assert!(
            e.message.contains("e.csv line 2: the header's column 1"),
            "{}",
            e.message
        );
        let e = event_series(&"log\n".repeat(101), "e.csv").unwrap_err();
        assert!(
            e.message.contains("e.csv line 101: no time"),
            "{}",
            e.message
        );
    }

    #[test]
    fn a_flag_from_here_on_moves_to_the_segment_it_starts() {
        let mut w = event_series(
            "0,0,0,0,_POWER_\n74,0,500,0,0\n194,0,500,2.31,_POWER_\n",
            "e.csv",
        )
        .unwrap();
        flags_start_segments(&mut w);
        assert_eq!(
            w.iter().map(|w| w.on).collect::<Vec<_>>(),
            [false, true, false]
        );
    }

    #[test]
    fn reads_the_gamma_form_and_the_ornl_form() {
        let gamma = "t_s,x_mm,y_mm,z_mm,laser_on_in_segment_ending_here\n\
                     0.0,-22,0,0.75,0\n6.2857143,22,0,0.75,1\n";
        let w = event_series(gamma, "toolpath.csv").unwrap();
        assert_eq!(w.len(), 2);
        assert!(!w[0].on && w[1].on);
        assert_eq!(w[1].position_mm, [22.0, 0.0, 0.75]);
        let ornl = "0.0000,-20.25,-249.998,0.0,_POWER_\n73.9016,-20.25,249.998,0.0,_POWER_\n";
        let w = event_series(ornl, "events.csv").unwrap();
        assert!(w[1].on && w[1].power_w.is_none());
        let watts = "0,0,0,0,0\n1,1,0,0,2500\n";
        assert_eq!(
            event_series(watts, "p.csv").unwrap()[1].power_w,
            Some(2500.0)
        );
    }

    #[test]
    fn a_bad_line_names_its_file_line_and_value() {
        let e = event_series("0,0,0,0,0\n1,0,x,0,1\n", "p.csv").unwrap_err();
        assert!(
            e.message.contains("p.csv line 2: y_mm = \"x\""),
            "{}",
            e.message
        );
        let e = event_series("0,0,0,0,0\n0,1,0,0,1\n", "p.csv").unwrap_err();
        assert!(
            e.message.contains("line 2: t_s = 0 after 0"),
            "{}",
            e.message
        );
        let e = event_series("0,0,0,0,0\n1,1,0,0,-3\n", "p.csv").unwrap_err();
        assert!(e.message.contains("on = -3"), "{}", e.message);
        let e = event_series("0,0,0\n", "p.csv").unwrap_err();
        assert!(e.message.contains("3 fields"), "{}", e.message);
        assert_eq!(e.exit_code(), 2);
        // An empty cell is named where it stands, not read as the next column's value: the
        // sixth column (a note the logger adds) is not the `on` flag.
        let e = event_series("0,0,0,0,0,1\n1,1,,0,1,1\n", "p.csv").unwrap_err();
        assert!(e.message.contains("line 2: y_mm = \"\""), "{}", e.message);
        // Semicolons and whitespace separate as commas do.
        let w = event_series("0;0;0;0;0\n1 2 0 0 1\n", "p.csv").unwrap();
        assert_eq!(w[1].position_mm, [2.0, 0.0, 0.0]);
    }
}
