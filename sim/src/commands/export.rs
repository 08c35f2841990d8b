//! `waamtwin export DIR --format json|rapid|krl|gcode`: the machine program of a planned DIR
//! ([`crate::pipeline::program`]), from its path.csv (a `plan`, `simulate`, `dwell` or
//! `skeleton` run), written beside it as program.json, program.mod (ABB RAPID), program.src
//! (KUKA KRL) or program.nc (5-axis G-code for a tilt-rotary table).

use crate::error::{Error, Result};
use crate::output::write_atomic;
pub use crate::pipeline::program::{Arc, Format, MIN_MOVE_MM, Move, merge_short, moves};
use crate::pipeline::program::{Turn, program};
use planner::table::Table;
use std::path::Path;

/// The table's kinematics from the command line, checked.
pub fn table(pivot: &[f64], offset: &[f64], tilt: &[f64]) -> Result<Table> {
    let all = pivot.iter().chain(offset).chain(tilt);
    if pivot.len() != 3
        || offset.len() != 3
        || tilt.len() != 2
        || !all.clone().all(|v| v.is_finite())
    {
        return Err(Error::input(format!(
            "--pivot-mm {pivot:?}, --part-offset-mm {offset:?}, --tilt-limits-deg {tilt:?}; expected three, three and two finite numbers"
        )));
    }
    if !(tilt[0] < tilt[1] && tilt[0] >= -180.0 && tilt[1] <= 180.0) {
        return Err(Error::input(format!(
            "--tilt-limits-deg {},{}; expected MIN,MAX with -180 <= MIN < MAX <= 180",
            tilt[0], tilt[1]
        )));
    }
    Ok(Table {
        pivot_mm: [pivot[0], pivot[1], pivot[2]],
        part_offset_mm: [offset[0], offset[1], offset[2]],
        tilt_min_deg: tilt[0],
        tilt_max_deg: tilt[1],
    })
}

/// How fast the tilt-rotary table may turn, rpm (none: not limited, only reported).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct TableSpeed {
    pub rotary_rpm: Option<f64>,
    pub tilt_rpm: Option<f64>,
}

/// The table's speed limits from the command line, checked: G-code's alone, each a speed in
/// (0, 1000] rpm.
pub fn table_speed(rotary: Option<f64>, tilt: Option<f64>, format: Format) -> Result<TableSpeed> {
    for (flag, v) in [("--rotary-rpm-max", rotary), ("--tilt-rpm-max", tilt)] {
        let Some(v) = v else { continue };
        if format != Format::Gcode {
            return Err(Error::input(format!(
                "{flag} {v}: the G-code's tilt-rotary table's; --format {} has none",
                format!("{format:?}").to_lowercase()
            )));
        }
        if !(v.is_finite() && v > 0.0 && v <= 1000.0) {
            return Err(Error::input(format!(
                "{flag} {v}; expected a speed in (0, 1000] rpm"
            )));
        }
    }
    Ok(TableSpeed {
        rotary_rpm: rotary,
        tilt_rpm: tilt,
    })
}

pub fn run(
    dir: &Path,
    format: Format,
    table: &Table,
    speed: TableSpeed,
    min_move_mm: f64,
) -> Result<String> {
    if !(min_move_mm.is_finite() && (0.0..=10.0).contains(&min_move_mm)) {
        return Err(Error::input(format!(
            "--min-move-mm {min_move_mm}; expected a length in [0, 10] mm (0 keeps every point)"
        )));
    }
    let file = dir.join("path.csv");
    let text = std::fs::read_to_string(&file).map_err(|e| {
        Error::input(format!(
            "{}: {e}; expected a planned run's path.csv",
            file.display()
        ))
    })?;
    let (moves, merged) = merge_short(moves(&text, &file.display().to_string())?, min_move_mm);
    let p = program(&moves, format, table)?;
    write_atomic(&dir.join(p.name), p.text.as_bytes())?;
    if let Some(w) = too_fast(&p.turns, speed) {
        eprintln!("warning: table_speed: {w}");
    }
    let name = p.name;
    let strikes = moves.iter().filter(|m| m.arc != Arc::On).count();
    let merged = match merged {
        0 => String::new(),
        k => format!(
            " ({k} path points under {min_move_mm} mm from the move before merged into the next)"
        ),
    };
    let strikes = match strikes {
        1 => "once".to_string(),
        k => format!("{k} times"),
    };
    Ok(format!(
        "{}: {} moves{merged}, the arc struck {strikes}{}",
        dir.join(name).display(),
        moves.len(),
        fastest(&p.turns)
    ))
}

/// The table's fastest turns on each axis, said after the program's line: ", the table turning
/// up to R rpm on C (path point i) and r rpm on A (path point j)"; nothing without turns.
fn fastest(turns: &[Turn]) -> String {
    let top = |f: fn(&Turn) -> f64| {
        turns
            .iter()
            .max_by(|x, y| f(x).total_cmp(&f(y)))
            .map(|t| (f(t) / 6.0, t.point))
    };
    match (top(|t| t.c_deg_s), top(|t| t.a_deg_s)) {
        (Some((c, i)), Some((a, j))) => format!(
            ", the table turning up to {c:.1} rpm on C (path point {i}) and {a:.1} rpm on A (path point {j})"
        ),
        _ => String::new(),
    }
}

/// Where the moves ask the table to turn faster than it may: how many, from which path point,
/// the fastest, and how slow the torch goes there when the controller holds the axes to their
/// limits (the heat the plan's run put in over the planned time goes in over the longer one:
/// the metal runs hotter than simulated). None where every move keeps to the limits.
pub fn too_fast(turns: &[Turn], speed: TableSpeed) -> Option<String> {
    let over = |t: &Turn| {
        let c = speed.rotary_rpm.map_or(0.0, |l| t.c_deg_s / (6.0 * l));
        let a = speed.tilt_rpm.map_or(0.0, |l| t.a_deg_s / (6.0 * l));
        c.max(a)
    };
    let fast: Vec<(&Turn, f64)> = turns
        .iter()
        .map(|t| (t, over(t)))
        .filter(|&(_, f)| f > 1.0)
        .collect();
    let (first, _) = fast.first()?;
    let (worst, factor) = fast.iter().max_by(|x, y| x.1.total_cmp(&y.1))?;
    let limits = [
        speed
            .rotary_rpm
            .map(|l| format!("--rotary-rpm-max {l} (C)")),
        speed.tilt_rpm.map(|l| format!("--tilt-rpm-max {l} (A)")),
    ];
    let limits: Vec<String> = limits.into_iter().flatten().collect();
    Some(format!(
        "{} of {} moves ask the table to turn faster than {}, from path point {}; at path point \
         {} C turns at {:.1} rpm and A at {:.1} rpm, {factor:.1} times the limit: a controller \
         holding the axes to it slows the torch there to {:.2} mm/s (planned {:.1} mm/s), and \
         the metal runs hotter than the plan's thermal run says",
        fast.len(),
        turns.len(),
        limits.join(" and "),
        first.point,
        worst.point,
        worst.c_deg_s / 6.0,
        worst.a_deg_s / 6.0,
        worst.travel_mm_s / factor,
        worst.travel_mm_s,
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn turn(point: usize, c_rpm: f64, a_rpm: f64) -> Turn {
        Turn {
            point,
            c_deg_s: 6.0 * c_rpm,
            a_deg_s: 6.0 * a_rpm,
            travel_mm_s: 10.0,
        }
    }

    /// Moves within the limits say nothing; over them, the count, the first and the fastest,
    /// and the torch's speed where the controller holds the fastest to its limit (C at 40 rpm
    /// against 10: a quarter of the travel speed).
    #[test]
    fn a_table_asked_to_turn_too_fast_is_said() {
        let turns = [turn(3, 5.0, 1.0), turn(7, 12.0, 1.0), turn(9, 40.0, 2.0)];
        let none = TableSpeed::default();
        assert_eq!(too_fast(&turns, none), None);
        let slow_c = TableSpeed {
            rotary_rpm: Some(10.0),
            tilt_rpm: None,
        };
        let w = too_fast(&turns, slow_c).unwrap();
        assert!(w.starts_with("2 of 3 moves"), "{w}");
        assert!(w.contains("from path point 7"), "{w}");
        assert!(w.contains("at path point 9 C turns at 40.0 rpm"), "{w}");
        assert!(
            w.contains("4.0 times the limit") && w.contains("to 2.50 mm/s"),
            "{w}"
        );
        let slow_a = TableSpeed {
            rotary_rpm: Some(100.0),
            tilt_rpm: Some(1.5),
        };
        let w = too_fast(&turns, slow_a).unwrap();
        assert!(
            w.starts_with("1 of 3 moves") && w.contains("--tilt-rpm-max 1.5"),
            "{w}"
        );
        assert_eq!(
            fastest(&turns),
            ", the table turning up to 40.0 rpm on C (path point 9) and 2.0 rpm on A (path point 9)"
        );
    }

    /// A limit is G-code's alone, and a speed.
    #[test]
    fn a_table_speed_is_checked() {
        assert!(table_speed(Some(10.0), None, Format::Gcode).is_ok());
        for (r, t, f) in [
            (Some(10.0), None, Format::Krl),
            (Some(0.0), None, Format::Gcode),
            (None, Some(f64::NAN), Format::Gcode),
            (Some(5000.0), None, Format::Gcode),
        ] {
            let e = table_speed(r, t, f).unwrap_err().to_string();
            assert!(e.contains("rpm-max"), "{e}");
        }
    }
}
