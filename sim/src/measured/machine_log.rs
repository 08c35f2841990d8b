//! A machine log as a welding cell's logger writes it: a header naming the columns, one row per
//! sample, among them the time, the arc voltage and current, the arc on/off flag and the torch
//! position. The power on the way to a sample is V·I there when the arc is on.
//!
//! The column names default to those of ORNL's calibration log (`t_s`, `weld_voltage_v`,
//! `weld_current_a`, `weld_on`, `x_mm`, `y_mm`, `z_mm`); a first row of the logger starting up
//! (time, power and position all 0) is skipped. The header is the first line that names the
//! time column, within the first `MOST_PREAMBLE_LINES` (a logger's name and start may come
//! before it), else the first line.

use super::probes::MOST_PREAMBLE_LINES;
use super::toolpath::Waypoint;
use super::{at_line, cells};
use crate::error::{Error, Result};

/// Which columns hold what, by header name.
#[derive(Debug, Clone, PartialEq)]
pub struct Columns {
    pub t_s: String,
    pub voltage_v: String,
    pub current_a: String,
    pub on: String,
    pub xyz_mm: [String; 3],
}

impl Default for Columns {
    fn default() -> Columns {
        Columns {
            t_s: "t_s".into(),
            voltage_v: "weld_voltage_v".into(),
            current_a: "weld_current_a".into(),
            on: "weld_on".into(),
            xyz_mm: ["x_mm".into(), "y_mm".into(), "z_mm".into()],
        }
    }
}

/// The log as waypoints; `file` names it in messages.
pub fn waypoints(text: &str, file: &str, c: &Columns) -> Result<Vec<Waypoint>> {
    let names_time = |l: &str| cells(l).iter().any(|h| *h == c.t_s.as_str());
    let at = text
        .lines()
        .take(MOST_PREAMBLE_LINES)
        .position(names_time)
        .unwrap_or(0);
    let mut lines = text.lines().enumerate().skip(at);
    let header = lines.next().map(|(_, l)| cells(l)).unwrap_or_default();
    let find = |name: &str| {
        header.iter().position(|h| *h == name).ok_or_else(|| {
            Error::input(format!(
                "{file} line {}: no column {name:?}; the header has {}",
                at + 1,
                header.join(", ")
            ))
        })
    };
    let cols = [
        find(&c.t_s)?,
        find(&c.voltage_v)?,
        find(&c.current_a)?,
        find(&c.on)?,
        find(&c.xyz_mm[0])?,
        find(&c.xyz_mm[1])?,
        find(&c.xyz_mm[2])?,
    ];
    let names = [
        &c.t_s,
        &c.voltage_v,
        &c.current_a,
        &c.on,
        &c.xyz_mm[0],
        &c.xyz_mm[1],
        &c.xyz_mm[2],
    ];
    let widest = cols.iter().copied().max().unwrap_or(0);
    let mut out: Vec<Waypoint> = Vec::new();
    for (k, line) in lines {
        let n = k + 1;
        // A sensor's empty cell keeps its place: the columns after it are read where the
        // header has them (runs of commas merged would read the current from the next column).
        let f = cells(line);
        if f.iter().all(|c| c.is_empty()) {
            continue;
        }
        if f.len() <= widest {
            return Err(at_line(
                file,
                n,
                format!("{} fields; expected at least {}", f.len(), widest + 1),
            ));
        }
        let mut v = [0.0; 7];
        for (slot, (&col, name)) in v.iter_mut().zip(cols.iter().zip(names)) {
            *slot = match f[col].parse::<f64>() {
                Ok(x) if x.is_finite() => x,
                _ => {
                    return Err(at_line(
                        file,
                        n,
                        format!("{name} = {:?}; expected a finite number", f[col]),
                    ));
                }
            };
        }
        let [t_s, volts, amps, on, x, y, z] = v;
        // The logger's start-up row: every column read zero at time 0.
        if out.is_empty() && v.iter().all(|&x| x == 0.0) {
            continue;
        }
        if let Some(last) = out.last()
            && t_s <= last.t_s
        {
            return Err(at_line(
                file,
                n,
                format!(
                    "{} = {t_s} after {}; expected increasing times",
                    c.t_s, last.t_s
                ),
            ));
        }
        let on = on >= 0.5;
        out.push(Waypoint {
            t_s,
            position_mm: [x, y, z],
            on,
            power_w: on.then_some((volts * amps).max(0.0)),
        });
    }
    if out.len() < 2 {
        return Err(Error::input(format!(
            "{file}: {} samples; expected at least 2",
            out.len()
        )));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::{Columns, waypoints};

    const LOG: &str = "t_s,clock,tc1_c,weld_voltage_v,weld_current_a,weld_on,x_mm,y_mm,z_mm\n\
        0.000,12:00:00,0,0,0,0,0,0,0\n\
        1.000,12:00:01,26.3,0,0,0,-20.25,-250,0\n\
        2.000,12:00:02,26.4,16.4,158,1,-20.25,-243.2,0\n";

    #[test]
    fn power_is_volts_times_amps_while_on() {
        let w = waypoints(LOG, "log.csv", &Columns::default()).unwrap();
        assert_eq!(w.len(), 2, "the start-up row is skipped");
        assert!(!w[0].on && w[0].power_w.is_none());
        assert!(w[1].on);
        assert!((w[1].power_w.unwrap() - 16.4 * 158.0).abs() < 1e-9);
        assert_eq!(w[1].position_mm, [-20.25, -243.2, 0.0]);
    }

    /// A sensor's empty cell (a reading missing, as the probe files have them) keeps its
    /// column's place: the power and the position after it are read from their own columns.
    #[test]
    fn an_empty_cell_keeps_its_columns_place() {
        let gap = LOG.replace("26.4,16.4,158", ",16.4,158");
        let w = waypoints(&gap, "log.csv", &Columns::default()).unwrap();
        assert!((w[1].power_w.unwrap() - 16.4 * 158.0).abs() < 1e-9);
        assert_eq!(w[1].position_mm, [-20.25, -243.2, 0.0]);
        // With a column after z (the wire feed), runs of commas merged read every column from
        // the next one along, silently: the voltage from the current, the flag from x.
        let fed = LOG
            .replace("z_mm\n", "z_mm,wire_m_min\n")
            .replace(",0\n", ",0,6.5\n");
        let w = waypoints(
            &fed.replace("26.4,16.4,158", ",16.4,158"),
            "log.csv",
            &Columns::default(),
        )
        .unwrap();
        assert!((w[1].power_w.unwrap() - 16.4 * 158.0).abs() < 1e-9);
        assert_eq!(w[1].position_mm, [-20.25, -243.2, 0.0]);
        let e = waypoints(
            &LOG.replace("16.4,158", ",158"),
            "log.csv",
            &Columns::default(),
        )
        .unwrap_err();
        assert!(
            e.message.contains("line 4: weld_voltage_v = \"\""),
            "{}",
            e.message
        );
    }

    /// A logger's lines before its header are passed over, the rows read as under a first-line
    /// header (they were "no column" errors); a missing column is named at the header's line.
    #[test]
    fn a_preamble_before_the_header_is_passed_over() {
        let with = format!("Logger: cell 3\nstarted 2026-11-30 12:00\n{LOG}");
        let w = waypoints(&with, "log.csv", &Columns::default()).unwrap();
        assert_eq!(w, waypoints(LOG, "log.csv", &Columns::default()).unwrap());
        let c = Columns {
            on: "arc".into(),
            ..Columns::default()
        };
        let e = waypoints(&with, "log.csv", &c).unwrap_err();
        assert!(
            e.message.contains("log.csv line 3: no column \"arc\""),
            "{}",
            e.message
        );
    }

    #[test]
    fn a_missing_column_or_bad_value_is_named() {
        let c = Columns {
            on: "arc".into(),
            ..Columns::default()
        };
        let e = waypoints(LOG, "log.csv", &c).unwrap_err();
        assert!(
            e.message.contains("log.csv line 1: no column \"arc\""),
            "{}",
            e.message
        );
        let bad = LOG.replace("16.4,158", "16.4,x");
        let e = waypoints(&bad, "log.csv", &Columns::default()).unwrap_err();
        assert!(
            e.message.contains("line 4: weld_current_a = \"x\""),
            "{}",
            e.message
        );
    }
}
