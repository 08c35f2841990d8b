//! G-code as a machine runs it: linear moves (G0, G1) in absolute coordinates (G90), feed F,
//! dwells (G4 P in ms or S in s), and the codes that strike and stop the arc, named by the
//! scenario (welding cells differ: ORNL's Wolf dialect uses M101 and M103). Comments (`;` and
//! parentheses) are dropped; words may run together (`M5T2D1F0`); a line that is not G-code
//! (Wolf's `BEGINNING LAYER`) is skipped; any other code is ignored. Time is distance over feed,
//! or over `travel_mm_s` with the arc off where the controller moves faster than programmed.

use super::at_line;
use super::toolpath::Waypoint;
use crate::error::{Error, Result};

/// What the dialect needs said.
#[derive(Debug, Clone, PartialEq)]
pub struct Dialect {
    /// Codes that strike the arc and stop it, e.g. "M101", "M103".
    pub arc_on: String,
    pub arc_off: String,
    /// F's unit in mm/s: 1/60 for mm/min (the standard), 1 for mm/s.
    pub feed_scale: f64,
    /// Speed of moves with the arc off, mm/s; None: their programmed feed.
    pub travel_mm_s: Option<f64>,
}

/// The words of a line: (letter, number text), comments removed.
fn words(line: &str) -> Vec<(char, &str)> {
    let code = line.split(';').next().unwrap_or("");
    let mut out = Vec::new();
    let b = code.as_bytes();
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'(' {
            while i < b.len() && b[i] != b')' {
                i += 1;
            }
            i += 1;
            continue;
        }
        if b[i].is_ascii_alphabetic() {
            let letter = (b[i] as char).to_ascii_uppercase();
            let start = i + 1;
            let mut end = start;
            while end < b.len() && (b[end].is_ascii_digit() || b"+-.eE".contains(&b[end])) {
                // An 'E' that starts a word of its own is a letter, not an exponent.
                if (b[end] == b'e' || b[end] == b'E') && end == start {
                    break;
                }
                end += 1;
            }
            out.push((letter, &code[start..end]));
            i = end.max(start);
            continue;
        }
        i += 1;
    }
    out
}

/// Read G-code; `file` names it in messages.
pub fn waypoints(text: &str, file: &str, d: &Dialect) -> Result<Vec<Waypoint>> {
    let (mut t, mut at, mut feed, mut arc) = (0.0f64, [0.0f64; 3], None::<f64>, false);
    let mut out = vec![Waypoint {
        t_s: 0.0,
        position_mm: at,
        on: false,
        power_w: None,
    }];
    for (k, line) in text.lines().enumerate() {
        let n = k + 1;
        let w = words(line);
        // Not G-code (a label the slicer writes): every word's number is empty.
        if w.is_empty() || w.iter().all(|(_, v)| v.is_empty()) {
            continue;
        }
        let number = |letter: char, v: &str| -> Result<f64> {
            match v.parse::<f64>() {
                Ok(x) if x.is_finite() => Ok(x),
                _ => Err(at_line(
                    file,
                    n,
                    format!("{letter}{v}; expected a finite number after {letter}"),
                )),
            }
        };
        let code = |c: &str| {
            w.iter()
                .any(|(l, v)| c.starts_with(*l) && v.parse::<f64>().ok() == c[1..].parse().ok())
        };
        if code(&d.arc_on) {
            arc = true;
        }
        if code(&d.arc_off) {
            arc = false;
        }
        let g = w.iter().find(|(l, _)| *l == 'G').map(|(_, v)| *v);
        match g {
            Some("0" | "00" | "1" | "01") => {
                let mut to = at;
                for (l, v) in &w {
                    match l {
                        'X' => to[0] = number(*l, v)?,
                        'Y' => to[1] = number(*l, v)?,
                        'Z' => to[2] = number(*l, v)?,
                        'F' => {
                            let f = number(*l, v)?;
                            if f <= 0.0 {
                                return Err(at_line(
                                    file,
                                    n,
                                    format!("F{v}; expected a positive feed"),
                                ));
                            }
                            feed = Some(f * d.feed_scale);
                        }
                        _ => {}
                    }
                }
                let length = (0..3).map(|i| (to[i] - at[i]).powi(2)).sum::<f64>().sqrt();
                if length == 0.0 {
                    continue;
                }
                let speed = match (arc, d.travel_mm_s) {
                    (false, Some(v)) => v,
                    _ => feed.ok_or_else(|| {
                        at_line(
                            file,
                            n,
                            "a move before any feed F; expected F on or before it",
                        )
                    })?,
                };
                t += length / speed;
                at = to;
                out.push(Waypoint {
                    t_s: t,
                    position_mm: at,
                    on: arc,
                    power_w: None,
                });
            }
            Some("4" | "04") => {
                let pause = w.iter().find_map(|(l, v)| match l {
                    'P' => Some(number('P', v).map(|ms| ms / 1e3)),
                    'S' => Some(number('S', v)),
                    _ => None,
                });
                let pause = pause.transpose()?.unwrap_or(0.0);
                if pause < 0.0 {
                    return Err(at_line(
                        file,
                        n,
                        format!("G4 of {pause} s; expected a pause ≥ 0"),
                    ));
                }
                if pause > 0.0 {
                    t += pause;
                    out.push(Waypoint {
                        t_s: t,
                        position_mm: at,
                        on: false,
                        power_w: None,
                    });
                }
            }
            Some("91") => {
                return Err(at_line(
                    file,
                    n,
                    "G91 (relative moves); expected absolute coordinates (G90)",
                ));
            }
            _ => {}
        }
    }
    if out.len() < 2 {
        return Err(Error::input(format!(
            "{file}: no moves; expected G0 or G1 lines"
        )));
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::{Dialect, waypoints};

    fn wolf() -> Dialect {
        Dialect {
            arc_on: "M101".into(),
            arc_off: "M103".into(),
            feed_scale: 1.0,
            travel_mm_s: Some(1000.0),
        }
    }

    #[test]
    fn reads_the_wolf_dialect() {
        let g = "; comment\nBEGINNING LAYER ; new layer\nM5T2D1F0;\nG1 Z40.0 F6.7657 ; lift\n\
                 G1 X-20.25 Y-250.0\nG1 Z0.0\nM101 ; Turn Pump on\nG1 X-20.25 Y250.0 ; bead\n\
                 M103 ; off\nG4 S120 ;\n";
        let w = waypoints(g, "part.gcode", &wolf()).unwrap();
        let on: Vec<bool> = w.iter().map(|w| w.on).collect();
        assert_eq!(on, [false, false, false, false, true, false]);
        // 500 mm at 6.7657 mm/s, travel at 1000 mm/s, then the 120 s dwell.
        let bead = w[4].t_s - w[3].t_s;
        assert!((bead - 500.0 / 6.7657).abs() < 1e-9, "{bead}");
        assert!((w[5].t_s - w[4].t_s - 120.0).abs() < 1e-9);
        assert_eq!(w[4].position_mm, [-20.25, 250.0, 0.0]);
    }

    #[test]
    fn standard_feed_is_per_minute_and_bad_words_are_named() {
        let d = Dialect {
            arc_on: "M3".into(),
            arc_off: "M5".into(),
            feed_scale: 1.0 / 60.0,
            travel_mm_s: None,
        };
        let w = waypoints("G1 X60 F600\nM3\nG1 X120\nG4 P500\n", "p.nc", &d).unwrap();
        assert!((w[1].t_s - 6.0).abs() < 1e-9 && (w[2].t_s - 12.0).abs() < 1e-9);
        assert!(w[2].on && (w[3].t_s - 12.5).abs() < 1e-9);
        let e = waypoints("G1 X1.0.0 F10\n", "p.nc", &d).unwrap_err();
        assert!(e.message.contains("p.nc line 1: X1.0.0"), "{}", e.message);
        let e = waypoints("G1 X10\n", "p.nc", &d).unwrap_err();
        assert!(e.message.contains("before any feed"), "{}", e.message);
        let e = waypoints("G91\nG1 X1 F1\n", "p.nc", &d).unwrap_err();
        assert!(e.message.contains("G91"), "{}", e.message);
    }
}
