//! The machine program of a planned path ([`program`]): one linear move per path point with the
//! full tool frame ([`planner::frame`]), its wire feed and travel speed, the arc struck once at
//! the start, put out and struck again around each dwell and each drop the plan made (and before
//! each bead of a layered path, its `strike` column), and put out at the end; as documented JSON,
//! ABB RAPID, KUKA KRL, or 5-axis G-code for a tilt-rotary table ([`planner::table`]). Text in
//! (a path.csv's), text out: `waamtwin export` reads and writes the files.

use crate::error::{Error, Result};
use planner::frame::{Frame, frames};
use planner::nalgebra::{Point3, Vector3};
use planner::table::Table;
use serde_json::json;
use std::fmt::Write;

/// A program format.
#[derive(Debug, Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
pub enum Format {
    /// Documented JSON: per move the position, quaternion, tool axis, wire feed, travel speed,
    /// whether the arc is struck before it and the dwell before it.
    Json,
    /// ABB RAPID: MoveL with quaternions and speed data, WaitTime, SetDO/SetAO.
    Rapid,
    /// KUKA KRL: LIN with A, B, C, $VEL.CP, WAIT SEC, $OUT/$ANOUT.
    Krl,
    /// 5-axis G-code for a tilt-rotary table (A about X, C about the table's axis; the torch
    /// fixed along −Z): G1 X Y Z A C in inverse-time feed (G93), M3/M5 for the arc, M68 for the
    /// wire feed, G4 for dwells.
    Gcode,
}

/// A machine program: its file name, its text, and how fast a tilt-rotary table turns on each
/// of its moves (G-code's alone; empty for the robots' formats).
#[derive(Debug, Clone)]
pub struct Program {
    pub name: &'static str,
    pub text: String,
    pub turns: Vec<Turn>,
}

/// How fast the table turns on one G-code move: the rotary axis C and the tilt A, degrees per
/// second, at the travel speed the move was planned at (inverse-time feed holds the torch to it
/// over the part, so the axes turn as fast as the part's curvature under the torch asks: round
/// a dome's closing point, where the tool lies level, C turns a revolution for each small
/// revolution of the path).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Turn {
    /// The move's path point (path.csv's `i`).
    pub point: usize,
    pub c_deg_s: f64,
    pub a_deg_s: f64,
    pub travel_mm_s: f64,
}

/// The program of `moves` in `format`. G-code needs the table's kinematics, and refuses a tool
/// axis the table cannot reach.
pub fn program(moves: &[Move], format: Format, table: &Table) -> Result<Program> {
    let (name, text, turns) = match format {
        Format::Json => ("program.json", json_program(moves), Vec::new()),
        Format::Rapid => ("program.mod", rapid(moves), Vec::new()),
        Format::Krl => ("program.src", krl(moves), Vec::new()),
        Format::Gcode => {
            let (text, turns) = gcode(moves, table)?;
            ("program.nc", text, turns)
        }
    };
    Ok(Program { name, text, turns })
}

/// The arc on a move.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Arc {
    /// Laid from the point before with the arc burning.
    On,
    /// The arc put out, the dwell waited, the arc struck again where the torch stands, then
    /// this stretch laid (a dwell or a drop of the plan).
    Restruck,
    /// Reached with the arc off (the approach, or the move to the next bead of a layered
    /// path), the arc struck here.
    StruckHere,
}

/// One linear move: the frame at the path point and how it is reached.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Move {
    /// The path point's index in path.csv (0-based).
    pub point: usize,
    pub frame: Frame,
    pub wfs_m_min: f64,
    pub travel_mm_s: f64,
    pub arc: Arc,
    /// The arc's time standing at the point after it is struck there (a skeleton's drop, its
    /// welding time), then put out; 0 on a running bead, s.
    pub burn_s: f64,
    /// The wait with the arc off before it, s.
    pub dwell_s: f64,
}

/// The moves of a path.csv; `file` names it in messages.
pub fn moves(text: &str, file: &str) -> Result<Vec<Move>> {
    let mut lines = text.lines().enumerate();
    let header: Vec<&str> = lines
        .next()
        .map(|(_, h)| h.split(',').map(str::trim).collect())
        .unwrap_or_default();
    let col = |name: &str| {
        header.iter().position(|h| *h == name).ok_or_else(|| {
            Error::input(format!(
                "{file} line 1: no column {name}; expected path.csv's header"
            ))
        })
    };
    let names = [
        "x",
        "y",
        "z",
        "tool_x",
        "tool_y",
        "tool_z",
        "wfs_m_min",
        "travel_mm_s",
        "dwell_s",
    ];
    let at: Vec<usize> = names.iter().map(|n| col(n)).collect::<Result<_>>()?;
    let drop = header.iter().position(|h| *h == "drop");
    // A layered path (the tube strategies) says where each bead starts.
    let strike_col = header.iter().position(|h| *h == "strike");
    // A drop by drop path (a skeleton) says how long the arc burns at each point.
    let burn_col = header.iter().position(|h| *h == "arc_s");
    let (mut points, mut tools, mut rows) = (Vec::new(), Vec::new(), Vec::new());
    for (k, line) in lines {
        if line.trim().is_empty() {
            continue;
        }
        let f: Vec<&str> = line.split(',').collect();
        let number = |c: usize, name: &str| -> Result<f64> {
            f.get(c)
                .and_then(|v| v.trim().parse::<f64>().ok())
                .filter(|v| v.is_finite())
                .ok_or_else(|| {
                    Error::input(format!(
                        "{file} line {}: {name} {:?}; expected a number",
                        k + 1,
                        f.get(c).copied().unwrap_or("")
                    ))
                })
        };
        let v: Vec<f64> = at
            .iter()
            .zip(names)
            .map(|(&c, n)| number(c, n))
            .collect::<Result<_>>()?;
        let tool = Vector3::new(v[3], v[4], v[5]);
        if (tool.norm() - 1.0).abs() > 1e-3 {
            return Err(Error::input(format!(
                "{file} line {}: tool axis of length {}; expected a unit vector",
                k + 1,
                tool.norm()
            )));
        }
        if v[7] <= 0.0 || v[6] < 0.0 || v[8] < 0.0 {
            return Err(Error::input(format!(
                "{file} line {}: travel {} mm/s, wire feed {} m/min, dwell {} s; expected a positive travel speed and neither negative",
                k + 1,
                v[7],
                v[6],
                v[8]
            )));
        }
        let restrike = v[8] > 0.0
            || match drop {
                Some(c) => number(c, "drop")? == 1.0,
                None => false,
            };
        let new_bead = points.is_empty()
            || match strike_col {
                Some(c) => number(c, "strike")? == 1.0,
                None => false,
            };
        let arc = match (new_bead, restrike) {
            (true, _) => Arc::StruckHere,
            (false, true) => Arc::Restruck,
            (false, false) => Arc::On,
        };
        points.push(Point3::new(v[0], v[1], v[2]));
        tools.push(tool);
        let burn = match burn_col {
            Some(c) => number(c, "arc_s")?,
            None => 0.0,
        };
        if burn < 0.0 {
            return Err(Error::input(format!(
                "{file} line {}: arc_s {burn}; expected 0 or more seconds",
                k + 1
            )));
        }
        rows.push((v[6], v[7], v[8], arc, burn));
    }
    if points.is_empty() {
        return Err(Error::input(format!(
            "{file}: no path points; expected one row per point"
        )));
    }
    Ok(frames(&points, &tools)
        .into_iter()
        .zip(rows)
        .enumerate()
        .map(|(point, (frame, (wfs, travel, dwell, arc, burn)))| Move {
            point,
            frame,
            wfs_m_min: wfs,
            travel_mm_s: travel,
            arc,
            burn_s: burn,
            dwell_s: dwell,
        })
        .collect())
}

/// The shortest move a program keeps by default, mm (`waamtwin export --min-move-mm`). Where a
/// plan's generators converge (round a closing point, the inside of a bent tube, the lines a
/// square dome's generators bunch on) its points lie hundredths of a millimetre apart: half the
/// quarter torus's 10 744 moves are under 0.1 mm, a few milliseconds each at 10 mm/s, fewer than
/// a controller's look-ahead can plan at speed (the robot slows down or stops there while the
/// arc burns on). A tenth of a millimetre is a fiftieth of the bead's width.
pub const MIN_MOVE_MM: f64 = 0.1;

/// `moves` with every move shorter than `min_mm` from the move kept before it merged into the
/// next (its point dropped, the next move laying both), unless something happens there: the arc
/// struck, put out or burning, a dwell before it. The first and the last move are kept. Returns
/// the moves kept and how many were merged.
pub fn merge_short(moves: Vec<Move>, min_mm: f64) -> (Vec<Move>, usize) {
    let n = moves.len();
    let mut kept: Vec<Move> = Vec::with_capacity(n);
    for (k, m) in moves.into_iter().enumerate() {
        let eventful = m.arc != Arc::On || m.dwell_s > 0.0 || m.burn_s > 0.0;
        let short = kept
            .last()
            .is_some_and(|b| (m.frame.position - b.frame.position).norm() < min_mm);
        if !short || eventful || k + 1 == n {
            kept.push(m);
        }
    }
    let merged = n - kept.len();
    (kept, merged)
}

fn json_program(moves: &[Move]) -> String {
    let m: Vec<_> = moves
        .iter()
        .map(|m| {
            let p = m.frame.position;
            json!({"i": m.point, "position_mm": [p.x, p.y, p.z], "quaternion_wxyz": m.frame.quaternion(),
                "tool_axis": m.frame.tool().as_slice(), "wfs_m_min": m.wfs_m_min,
                "travel_mm_s": m.travel_mm_s, "arc": match m.arc { Arc::On => "on", Arc::Restruck => "restruck", Arc::StruckHere => "struck_here" },
                "dwell_before_s": m.dwell_s, "arc_burns_s": m.burn_s})
        })
        .collect();
    let doc = json!({
        "format": "waamtwin program",
        "version": 1,
        "frame": "tool z from the torch to the deposit, x along the travel, y = z × x; quaternion (w, x, y, z)",
        "arc": "on: laid from the point before with the arc burning; restruck: the arc put out, dwell_before_s waited, struck again, then laid; struck_here: reached with the arc off, struck at the point",
        "arc_strikes": moves.iter().filter(|m| m.arc != Arc::On).count(),
        "moves": m,
    });
    serde_json::to_string_pretty(&doc).unwrap_or_default()
}

/// RAPID: the arc as digital output doArc, the wire feed (m/min) as analogue output aoWireFeed;
/// zone z0 so that the torch runs on through the points (a stop at each would pile metal).
fn rapid(moves: &[Move]) -> String {
    let mut s = String::from(
        "MODULE WaamPath\n  ! waamtwin: one MoveL per path point; tool z from the torch to the deposit.\n  PROC main()\n",
    );
    let (mut wfs, mut on) = (f64::NAN, false);
    for (i, m) in moves.iter().enumerate() {
        if m.arc != Arc::On && std::mem::take(&mut on) {
            let _ = writeln!(s, "    SetDO doArc, 0;");
        }
        if m.arc != Arc::On && m.dwell_s > 0.0 {
            let _ = writeln!(s, "    WaitTime {:.3};", m.dwell_s);
        }
        if m.wfs_m_min != wfs {
            wfs = m.wfs_m_min;
            let _ = writeln!(s, "    SetAO aoWireFeed, {wfs:.6};");
        }
        if m.arc == Arc::Restruck {
            let _ = writeln!(s, "    SetDO doArc, 1;");
            on = true;
        }
        let (p, q) = (m.frame.position, m.frame.quaternion());
        let _ = writeln!(
            s,
            "    MoveL [[{:.6},{:.6},{:.6}],[{:.9},{:.9},{:.9},{:.9}],[0,0,0,0],[9E9,9E9,9E9,9E9,9E9,9E9]], [{:.6},500,5000,1000], {}, tWaam;",
            p.x,
            p.y,
            p.z,
            q[0],
            q[1],
            q[2],
            q[3],
            m.travel_mm_s,
            // The torch stops where the arc is struck.
            if moves.get(i + 1).is_some_and(|n| n.arc == Arc::StruckHere)
                || m.arc == Arc::StruckHere
            {
                "fine"
            } else {
                "z0"
            }
        );
        if m.arc == Arc::StruckHere {
            let _ = writeln!(s, "    SetDO doArc, 1;");
            on = true;
        }
        if m.burn_s > 0.0 && on {
            let _ = writeln!(s, "    WaitTime {:.3};\n    SetDO doArc, 0;", m.burn_s);
            on = false;
        }
    }
    if on {
        s.push_str("    SetDO doArc, 0;\n");
    }
    s.push_str("  ENDPROC\nENDMODULE\n");
    s
}

/// KRL: the arc as $OUT[1], the wire feed (m/min) as $ANOUT[1] over 10 m/min full scale;
/// C_DIS so that the torch runs on through the points.
fn krl(moves: &[Move]) -> String {
    let mut s = String::from(
        "DEF WaamPath()\n; waamtwin: one LIN per path point; tool z from the torch to the deposit.\n",
    );
    let mut on = false;
    for m in moves {
        if m.arc != Arc::On && std::mem::take(&mut on) {
            s.push_str("$OUT[1] = FALSE\n");
        }
        if m.arc != Arc::On && m.dwell_s > 0.0 {
            let _ = writeln!(s, "WAIT SEC {:.3}", m.dwell_s);
        }
        let _ = writeln!(s, "$ANOUT[1] = {:.6}", m.wfs_m_min / 10.0);
        let _ = writeln!(s, "$VEL.CP = {:.6}", m.travel_mm_s * 1e-3);
        if m.arc == Arc::Restruck {
            s.push_str("$OUT[1] = TRUE\n");
            on = true;
        }
        let (p, [a, b, c]) = (m.frame.position, m.frame.abc());
        let _ = writeln!(
            s,
            "LIN {{X {:.6}, Y {:.6}, Z {:.6}, A {:.9}, B {:.9}, C {:.9}}} C_DIS",
            p.x,
            p.y,
            p.z,
            a.to_degrees(),
            b.to_degrees(),
            c.to_degrees()
        );
        if m.arc == Arc::StruckHere {
            s.push_str("$OUT[1] = TRUE\n");
            on = true;
        }
        if m.burn_s > 0.0 && on {
            let _ = writeln!(s, "WAIT SEC {:.3}\n$OUT[1] = FALSE", m.burn_s);
            on = false;
        }
    }
    if on {
        s.push_str("$OUT[1] = FALSE\n");
    }
    s.push_str("END\n");
    s
}

/// G-code for a tilt-rotary table ([`Table`]): one G1 per path point with the machine's X, Y, Z
/// and the table's A, C (continuous, never a turn back round), in inverse-time feed (G93: F is
/// 1/minutes for the move, so the torch keeps the travel speed over the part however the table
/// turns); the arc M3/M5, the wire feed (m/min) as M68 E0 Q, dwells G4 P (seconds). A tool axis
/// the table cannot reach is refused, naming the point and the tilt. With it, how fast the
/// table turns on each move that goes somewhere ([`Turn`]).
fn gcode(moves: &[Move], table: &Table) -> Result<(String, Vec<Turn>)> {
    let mut s = format!(
        "; waamtwin: 5-axis G-code, tilt-rotary table (A about X, C about the table's axis), torch along -Z\n\
         ; pivot_mm = {:?}, part_offset_mm = {:?}, A within [{}, {}] degrees\n\
         G21 G90 G17\n",
        table.pivot_mm, table.part_offset_mm, table.tilt_min_deg, table.tilt_max_deg
    );
    let (mut c, mut a) = (0.0, 0.0);
    let (mut wfs, mut on) = (f64::NAN, false);
    let mut turns = Vec::new();
    for (i, m) in moves.iter().enumerate() {
        let ax = table
            .axes(&m.frame.position, &m.frame.tool(), c)
            .map_err(|e| {
                Error::input(format!(
                    "path point {}: the tool needs A = {:.1} degrees, outside --tilt-limits-deg {},{}",
                    m.point, e.tilt_deg, table.tilt_min_deg, table.tilt_max_deg
                ))
            })?;
        let (dc, da) = ((ax.c - c).abs(), (ax.a - a).abs());
        (c, a) = (ax.c, ax.a);
        if m.arc != Arc::On && std::mem::take(&mut on) {
            s.push_str("M5\n");
        }
        if m.arc != Arc::On && m.dwell_s > 0.0 {
            let _ = writeln!(s, "G4 P{:.3}", m.dwell_s);
        }
        if m.wfs_m_min != wfs {
            wfs = m.wfs_m_min;
            let _ = writeln!(s, "M68 E0 Q{wfs:.6}");
        }
        if m.arc == Arc::Restruck {
            s.push_str("M3\n");
            on = true;
        }
        let axes = format!(
            "X{:.9} Y{:.9} Z{:.9} A{:.9} C{:.9}",
            ax.x, ax.y, ax.z, ax.a, ax.c
        );
        if i == 0 {
            let _ = writeln!(s, "G94 G0 {axes}\nG93");
        } else {
            let length = (m.frame.position - moves[i - 1].frame.position).norm();
            let minutes = (length / m.travel_mm_s / 60.0).max(1e-9);
            let _ = writeln!(s, "G1 {axes} F{:.6}", 1.0 / minutes);
            // A move that goes nowhere (kept with --min-move-mm 0) has no pace of its own.
            if length > 1e-9 {
                let seconds = 60.0 * minutes;
                turns.push(Turn {
                    point: m.point,
                    c_deg_s: dc / seconds,
                    a_deg_s: da / seconds,
                    travel_mm_s: m.travel_mm_s,
                });
            }
        }
        if m.arc == Arc::StruckHere {
            s.push_str("M3\n");
            on = true;
        }
        if m.burn_s > 0.0 && on {
            let _ = writeln!(s, "G4 P{:.3}\nM5", m.burn_s);
            on = false;
        }
    }
    if on {
        s.push_str("M5\n");
    }
    s.push_str("G94\nM2\n");
    Ok((s, turns))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A line of points, 1 mm apart but for a bunch of five 0.02 mm apart, one of which restrikes
    /// the arc after a dwell, and a last point 0.05 mm after the one before it: the bunch is one
    /// move but for the restrike, the last point is kept, and nothing is merged at 0 mm.
    #[test]
    fn short_moves_merge_but_where_the_arc_is_struck() {
        let xs = [0.0, 1.0, 1.02, 1.04, 1.06, 1.08, 2.0, 3.0, 3.05];
        let text =
            std::iter::once("x,y,z,tool_x,tool_y,tool_z,wfs_m_min,travel_mm_s,dwell_s".to_string())
                .chain(xs.iter().enumerate().map(|(i, x)| {
                    let dwell = if i == 4 { 5.0 } else { 0.0 };
                    format!("{x},0,1,0,0,1,6,10,{dwell}")
                }))
                .collect::<Vec<_>>()
                .join("\n");
        let all = moves(&text, "path.csv").unwrap();
        let (kept, merged) = merge_short(all.clone(), MIN_MOVE_MM);
        let points: Vec<usize> = kept.iter().map(|m| m.point).collect();
        assert_eq!(points, [0, 1, 4, 6, 7, 8]);
        assert_eq!(merged, 3);
        assert_eq!(kept[2].arc, Arc::Restruck);
        assert_eq!(merge_short(all, 0.0).1, 0);
    }
}
