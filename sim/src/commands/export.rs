//! `waamtwin export DIR --format json|rapid|krl|gcode`: the machine program of a planned DIR
//! ([`crate::pipeline::program`]), from its path.csv (a `plan`, `simulate`, `dwell` or
//! `skeleton` run), written beside it as program.json, program.mod (ABB RAPID), program.src
//! (KUKA KRL) or program.nc (5-axis G-code for a tilt-rotary table).

use crate::error::{Error, Result};
use crate::output::write_atomic;
use crate::pipeline::program::program;
pub use crate::pipeline::program::{Arc, Format, MIN_MOVE_MM, Move, merge_short, moves};
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

pub fn run(dir: &Path, format: Format, table: &Table, min_move_mm: f64) -> Result<String> {
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
    let (name, body) = program(&moves, format, table)?;
    write_atomic(&dir.join(name), body.as_bytes())?;
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
        "{}: {} moves{merged}, the arc struck {strikes}",
        dir.join(name).display(),
        moves.len()
    ))
}
