//! G-code as a machine runs it: moves (G0, G1) and arcs (G2, G3, by centre or radius, in the
//! XY, ZX or YZ plane of G17-G19, of P turns, cut into chords within `ARC_SAGITTA_MM`), modal
//! motion, absolute or relative coordinates (G90, G91) in mm or inches (G21, G20), feed F,
//! dwells (G4 P in ms or S in s), and the codes that strike and stop the arc, named by the
//! scenario (welding cells differ: ORNL's Wolf dialect uses M101 and M103). Comments (`;` and
//! parentheses) are dropped; words may run together (`M5T2D1F0`); a line that is not G-code
//! (Wolf's `BEGINNING LAYER`) is skipped; G92 sets the current point's coordinates (an offset
//! from then on; G92.1 and G92.2 take it away, G92.3 brings back the one G92.2 put aside;
//! `G92 E0`, a printer's extruder reset, leaves X, Y and Z as they are); codes that would put
//! the path after them in a frame this reader does not know or time it otherwise (G10, G28,
//! G30, G53, G93, G95, a rotary axis turned) are refused; any other code is ignored. Time is
//! distance over feed, or over `travel_mm_s` with the arc off where the controller moves
//! faster than programmed.

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

/// The words of a line: (letter, number text), comments removed. A number is a sign, digits
/// and a point, as RS-274 and every controller read it: no exponent, so that `X10E5` (a
/// printer's extrusion run into a coordinate, as posts that drop spaces write it) is X 10 and
/// E 5, where it was read as X 1 000 000.
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
            let start = skip_blanks(b, i + 1);
            let mut end = start + usize::from(b.get(start).is_some_and(|c| b"+-".contains(c)));
            while end < b.len() && (b[end].is_ascii_digit() || b[end] == b'.') {
                end += 1;
            }
            out.push((letter, &code[start..end]));
            i = end.max(i + 1);
            continue;
        }
        i += 1;
    }
    out
}

/// Past the spaces and tabs from `i`: a controller reads `X 10` as `X10`.
fn skip_blanks(b: &[u8], mut i: usize) -> usize {
    while i < b.len() && (b[i] == b' ' || b[i] == b'\t') {
        i += 1;
    }
    i
}

/// The most waypoints a program may make (0.56 GB of them at 56 bytes each): an arc's chords
/// are the only waypoints a line makes more than one of, up to `ARC_CHORDS_PER_TURN` a turn, so
/// a short file of arcs could otherwise claim far more memory than it holds.
pub const MOST_WAYPOINTS: usize = 10_000_000;

/// How far an arc's chord may stray from the arc (its sagitta), mm: a hundredth of a
/// millimetre, a fraction of a bead's width and of any controller's own tolerance.
const ARC_SAGITTA_MM: f64 = 0.01;

/// The most chords a whole turn of an arc is cut into (one a degree): on arcs of more than
/// 0.26 m radius they stray more than `ARC_SAGITTA_MM` (0.04 mm at 1 m, 0.19 mm at 5 m).
const ARC_CHORDS_PER_TURN: f64 = 360.0;

/// How far an arc's end may lie off the circle its start and centre make, mm, or this share
/// of its radius where that is more (LinuxCNC's check is of the same kind).
const ARC_END_MM: f64 = 0.05;
const ARC_END_SHARE: f64 = 1e-3;

/// The modal state a program runs under: what a line with coordinates and no motion code
/// does, and how its numbers are read.
struct Modal {
    motion: Option<Motion>,
    /// G91: coordinates are moves from the current point.
    relative: bool,
    /// G90.1: an arc's I and J are the centre itself, not its offset from the start.
    absolute_centre: bool,
    /// mm per unit of the program: 1 (G21) or 25.4 (G20).
    unit_mm: f64,
    /// The plane arcs turn in: G17 (XY), G18 (ZX), G19 (YZ).
    plane: Plane,
    /// G92's offset, mm: where the program's absolute coordinates (and G90.1's centres) lie in
    /// the path's frame, less what they say; and the offset G92.2 put aside for G92.3.
    offset: [f64; 3],
    suspended: [f64; 3],
}

/// The plane an arc turns in, as RS-274 names it: G17 XY, G18 ZX, G19 YZ, each with its two
/// axes in right-handed order and its normal (Z, Y, X), so that an arc clockwise seen from the
/// normal's tip (G2) is clockwise in the plane's own coordinates, as in XY.
#[derive(Clone, Copy, PartialEq)]
enum Plane {
    Xy,
    Zx,
    Yz,
}

impl Plane {
    /// The plane's first axis, second axis and normal, as indices into (x, y, z).
    fn axes(self) -> [usize; 3] {
        match self {
            Plane::Xy => [0, 1, 2],
            Plane::Zx => [2, 0, 1],
            Plane::Yz => [1, 2, 0],
        }
    }

    /// The words that give the centre's offset along the plane's two axes.
    fn centre_words(self) -> [char; 2] {
        match self {
            Plane::Xy => ['I', 'J'],
            Plane::Zx => ['K', 'I'],
            Plane::Yz => ['J', 'K'],
        }
    }

    /// A point in the plane's coordinates (its first axis, its second, the normal).
    fn into_plane(self, p: [f64; 3]) -> [f64; 3] {
        self.axes().map(|k| p[k])
    }

    /// A point in the plane's coordinates back in (x, y, z).
    fn out_of_plane(self, q: [f64; 3]) -> [f64; 3] {
        let mut p = [0.0; 3];
        for (k, a) in self.axes().into_iter().enumerate() {
            p[a] = q[k];
        }
        p
    }
}

#[derive(Clone, Copy, PartialEq)]
enum Motion {
    Rapid,
    Linear,
    /// G2 (clockwise seen from +Z) or G3.
    Arc {
        clockwise: bool,
    },
}

/// One line's words, and where it is for messages.
struct Line<'a> {
    words: Vec<(char, &'a str)>,
    file: &'a str,
    n: usize,
}

impl Line<'_> {
    fn fail(&self, what: impl std::fmt::Display) -> Error {
        at_line(self.file, self.n, what)
    }

    /// The text of the first word of this letter.
    fn word(&self, letter: char) -> Option<&str> {
        self.words
            .iter()
            .find(|(l, _)| *l == letter)
            .map(|(_, v)| *v)
    }

    fn number(&self, letter: char, v: &str) -> Result<f64> {
        match v.parse::<f64>() {
            Ok(x) if x.is_finite() => Ok(x),
            _ => Err(self.fail(format!(
                "{letter}{v}; expected a finite number after {letter}"
            ))),
        }
    }

    /// The number of the first word of this letter, where there is one.
    fn value(&self, letter: char) -> Result<Option<f64>> {
        self.word(letter)
            .map(|v| self.number(letter, v))
            .transpose()
    }

    /// Whether the line holds this code (e.g. "M101": the letter and its number's value).
    fn holds(&self, code: &str) -> bool {
        self.words
            .iter()
            .any(|(l, v)| code.starts_with(*l) && v.parse::<f64>().ok() == code[1..].parse().ok())
    }
}

/// What the line's G codes ask for this line alone.
struct Codes {
    dwell: bool,
    /// The line names G0-G3.
    motion: bool,
    /// G92 and its kin, in tenths (920 to 923): the line's X, Y and Z set the current point's
    /// coordinates, not a move.
    position: Option<i64>,
}

/// Apply the line's G codes to the modal state.
fn apply_codes(line: &Line, modal: &mut Modal) -> Result<Codes> {
    let mut codes = Codes {
        dwell: false,
        motion: false,
        position: None,
    };
    for (_, v) in line.words.iter().filter(|(l, _)| *l == 'G') {
        // Tenths: G90.1 and G91.1 are codes of their own.
        let g = (line.number('G', v)? * 10.0).round() as i64;
        codes.motion |= matches!(g, 0 | 10 | 20 | 30);
        match g {
            0 => modal.motion = Some(Motion::Rapid),
            10 => modal.motion = Some(Motion::Linear),
            20 => modal.motion = Some(Motion::Arc { clockwise: true }),
            30 => modal.motion = Some(Motion::Arc { clockwise: false }),
            40 => codes.dwell = true,
            170 => modal.plane = Plane::Xy,
            180 => modal.plane = Plane::Zx,
            190 => modal.plane = Plane::Yz,
            200 => modal.unit_mm = 25.4,
            210 => modal.unit_mm = 1.0,
            900 => modal.relative = false,
            910 => modal.relative = true,
            901 => modal.absolute_centre = true,
            911 => modal.absolute_centre = false,
            920..=923 => codes.position = Some(g),
            // Codes that move to, or redefine, a frame this reader does not know, or time a
            // move otherwise: the path after them would be laid somewhere else, or at another
            // pace (G93 is what `waamtwin export --format gcode` writes, with its A and C).
            100 | 280 | 300 | 530 | 930 | 950 => {
                let (what, expected) = match g {
                    100 => ("a frame's offsets set", FRAME),
                    280 | 300 => ("a return to a home position", FRAME),
                    530 => ("a move in the machine's frame", FRAME),
                    930 => ("inverse-time feed", FEED),
                    _ => ("feed per spindle turn", FEED),
                };
                return Err(line.fail(format!("G{v} ({what}); expected {expected}")));
            }
            _ => {}
        }
    }
    Ok(codes)
}

/// What a refused code's line expected instead: moves in the program's own frame, or a feed
/// in units a minute (G94, the default) that times them.
const FRAME: &str = "moves in the program's own frame (G0-G3, G90/G91)";
const FEED: &str = "feed in units a minute (G94, the default) or the dialect's per second";

/// G92 (`g` 920): the line's X, Y and Z say what the current point `at` is called from now on,
/// the axes it does not name keep their offset, and a line that names no axis at all (not even
/// a printer's E) is refused, as RS-274 has it; G92.1 and G92.2 (921, 922) take the offset
/// away, G92.2 keeping it for G92.3 (923), which brings it back (LinuxCNC's reading).
fn set_position(line: &Line, g: i64, modal: &mut Modal, at: [f64; 3]) -> Result<()> {
    match g {
        920 => {
            let axes = line.words.iter().filter(|(l, _)| l.is_ascii_alphabetic());
            if !axes
                .clone()
                .any(|(l, _)| matches!(l, 'X' | 'Y' | 'Z' | 'E' | 'A' | 'B' | 'C'))
            {
                return Err(line.fail(
                    "G92 naming no axis; expected the axes whose coordinates it sets (G92 X0 Y0)",
                ));
            }
            for (i, l) in ['X', 'Y', 'Z'].into_iter().enumerate() {
                if let Some(x) = line.value(l)? {
                    modal.offset[i] = at[i] - x * modal.unit_mm;
                }
            }
        }
        921 => modal.offset = [0.0; 3],
        922 => modal.suspended = std::mem::take(&mut modal.offset),
        _ => modal.offset = modal.suspended,
    }
    Ok(())
}

/// A G4 line's pause, s: P in ms or S in s.
fn pause_s(line: &Line) -> Result<f64> {
    let pause = line.words.iter().find_map(|(l, v)| match l {
        'P' => Some(line.number('P', v).map(|ms| ms / 1e3)),
        'S' => Some(line.number('S', v)),
        _ => None,
    });
    let pause = pause.transpose()?.unwrap_or(0.0);
    if pause < 0.0 {
        return Err(line.fail(format!("G4 of {pause} s; expected a pause ≥ 0")));
    }
    Ok(pause)
}

/// Where a line's coordinates take the torch from `at`.
fn target(line: &Line, modal: &Modal, at: [f64; 3]) -> Result<[f64; 3]> {
    let mut to = at;
    for (i, l) in ['X', 'Y', 'Z'].into_iter().enumerate() {
        if let Some(x) = line.value(l)? {
            let x = x * modal.unit_mm;
            to[i] = if modal.relative {
                at[i] + x
            } else {
                x + modal.offset[i]
            };
        }
    }
    if !to.iter().all(|x| x.is_finite()) {
        return Err(line.fail(format!("a move to {to:?} mm; expected finite coordinates")));
    }
    Ok(to)
}

/// The most turns one arc line may make (its P): a helix of a thousand turns is 360 000 chords.
const MOST_TURNS: f64 = 1000.0;

/// The turns a G2/G3 line makes: its P, a whole number from 1 (a partial turn and P − 1 whole
/// ones more, RS-274's reading), 1 without it.
fn arc_turns(line: &Line) -> Result<u32> {
    match line.value('P')? {
        None => Ok(1),
        Some(p) if (1.0..=MOST_TURNS).contains(&p) && p.fract() == 0.0 => Ok(p as u32),
        Some(p) => Err(line.fail(format!(
            "P{p} turns of an arc; expected a whole number of turns from 1 to {MOST_TURNS}"
        ))),
    }
}

/// The centre of a G2/G3 line's arc from `at` to `to` (both in the plane's coordinates,
/// [`Plane::into_plane`]), in the plane: by its centre words (I and J in XY), or by R.
fn arc_centre(
    line: &Line,
    modal: &Modal,
    (at, to): ([f64; 3], [f64; 3]),
    clockwise: bool,
) -> Result<[f64; 2]> {
    let [u, v] = modal.plane.centre_words();
    let axes = modal.plane.axes();
    let centre = |l: char, i: usize| -> Result<Option<f64>> {
        Ok(line.value(l)?.map(|x| {
            let x = x * modal.unit_mm;
            if modal.absolute_centre {
                x + modal.offset[axes[i]]
            } else {
                at[i] + x
            }
        }))
    };
    let c = match (centre(u, 0)?, centre(v, 1)?, line.value('R')?) {
        (None, None, Some(r)) => {
            centre_of_radius(at, to, r * modal.unit_mm, clockwise).map_err(|why| line.fail(why))
        }
        (None, None, None) => Err(line.fail(format!(
            "an arc with neither its centre ({u}, {v}) nor its radius (R)"
        ))),
        (i, j, None) => Ok([i.unwrap_or(at[0]), j.unwrap_or(at[1])]),
        (_, _, Some(_)) => Err(line.fail(format!(
            "an arc with both its centre ({u}, {v}) and its radius (R); expected one"
        ))),
    }?;
    if !c.iter().all(|x| x.is_finite()) {
        return Err(line.fail(format!(
            "an arc centred at {c:?} mm; expected a finite centre"
        )));
    }
    Ok(c)
}

/// Read G-code; `file` names it in messages.
pub fn waypoints(text: &str, file: &str, d: &Dialect) -> Result<Vec<Waypoint>> {
    let (mut t, mut at, mut feed, mut welding) = (0.0f64, [0.0f64; 3], None::<f64>, false);
    let mut modal = Modal {
        motion: None,
        relative: false,
        absolute_centre: false,
        unit_mm: 1.0,
        plane: Plane::Xy,
        offset: [0.0; 3],
        suspended: [0.0; 3],
    };
    let mut out = vec![Waypoint {
        t_s: 0.0,
        position_mm: at,
        on: false,
        power_w: None,
    }];
    for (k, text) in text.lines().enumerate() {
        let line = Line {
            words: words(text),
            file,
            n: k + 1,
        };
        // Not G-code (a label the slicer writes): every word's number is empty.
        if line.words.iter().all(|(_, v)| v.is_empty()) {
            continue;
        }
        if line.holds(&d.arc_on) {
            welding = true;
        }
        if line.holds(&d.arc_off) {
            welding = false;
        }
        let codes = apply_codes(&line, &mut modal)?;
        if let Some(g) = codes.position {
            set_position(&line, g, &mut modal, at)?;
            continue;
        }
        if codes.dwell {
            let pause = pause_s(&line)?;
            if pause > 0.0 {
                t += pause;
                out.push(Waypoint {
                    t_s: t,
                    position_mm: at,
                    on: false,
                    power_w: None,
                });
            }
            continue;
        }
        // A 5-axis program's X, Y and Z are in the turned table's frame (`waamtwin export`'s
        // program.nc): laid as they stand they would be another path. A rotary word on any
        // line but a dwell turns it.
        if let Some((axis, v)) = line
            .words
            .iter()
            .find(|(l, v)| matches!(l, 'A' | 'B' | 'C') && v.parse::<f64>().is_ok_and(|x| x != 0.0))
        {
            return Err(line.fail(format!(
                "{axis}{v} (a rotary axis turned); expected a 3-axis program: a tilt-rotary \
                 table's X, Y and Z are in its turned frame (a plan's path.csv is replayed by \
                 `waamtwin replay` on the part's own scenario)"
            )));
        }
        let moves = ['X', 'Y', 'Z'].iter().any(|&l| line.word(l).is_some());
        // F is read where the line moves, names a motion or stands alone (with a line number
        // at most): a dialect's F on a line of other codes (Wolf's `M5T2D1F0`) is not the feed.
        let feed_alone = line.words.iter().all(|(l, _)| matches!(l, 'F' | 'N'));
        if (moves || codes.motion || feed_alone)
            && let Some(f) = line.value('F')?
        {
            if f <= 0.0 {
                return Err(line.fail(format!("F{f}; expected a positive feed")));
            }
            feed = Some(f * modal.unit_mm * d.feed_scale);
        }
        if !moves {
            continue;
        }
        let Some(motion) = modal.motion else {
            return Err(line.fail(
                "coordinates with no motion mode before them; expected G0, G1, G2 or G3 on or \
                 before this line",
            ));
        };
        let to = target(&line, &modal, at)?;
        // The points the move passes, and the path's length to each from the one before.
        let (points, step_mm) = match motion {
            Motion::Rapid | Motion::Linear => (vec![to], distance(at, to)),
            Motion::Arc { clockwise } => {
                let plane = modal.plane;
                let ends = (plane.into_plane(at), plane.into_plane(to));
                let centre = arc_centre(&line, &modal, ends, clockwise)?;
                let turns = arc_turns(&line)?;
                let (points, step) =
                    arc_chords(ends, centre, clockwise, turns).map_err(|why| line.fail(why))?;
                let points = points.into_iter().map(|q| plane.out_of_plane(q));
                (points.collect(), step)
            }
        };
        if step_mm == 0.0 {
            continue;
        }
        let speed = match (welding, d.travel_mm_s) {
            (false, Some(v)) => v,
            _ => feed
                .ok_or_else(|| line.fail("a move before any feed F; expected F on or before it"))?,
        };
        if out.len() + points.len() > MOST_WAYPOINTS {
            return Err(line.fail(format!(
                "the program's moves and arcs' chords come to more than {MOST_WAYPOINTS} \
                 waypoints; expected fewer"
            )));
        }
        // An arc's time is its own length over the speed, shared evenly by its chords (each
        // spans the same angle), not the chords' length: that is short of the arc's by up to
        // θ²/24, 1.7e-4 of it for chords 0.01 mm off an arc of 20 mm radius.
        if !(t + points.len() as f64 * step_mm / speed).is_finite() {
            return Err(line.fail(format!(
                "{step_mm} mm at {speed} mm/s; expected a move the program's clock can time"
            )));
        }
        for p in points {
            t += step_mm / speed;
            at = p;
            out.push(Waypoint {
                t_s: t,
                position_mm: at,
                on: welding,
                power_w: None,
            });
        }
    }
    if out.len() < 2 {
        return Err(Error::input(format!(
            "{file}: no moves; expected G0, G1, G2 or G3 lines"
        )));
    }
    Ok(out)
}

/// By hypot: a distance a finite program makes stays finite (squares of 1e200 mm would not).
fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    (a[0] - b[0]).hypot(a[1] - b[1]).hypot(a[2] - b[2])
}

/// The centre of the arc of radius `r` from `from` to `to` in the plane (its coordinates, the
/// first two of [`Plane::into_plane`]): the arc of at most half a turn for r > 0, of more for
/// r < 0 (the standard's R form).
fn centre_of_radius(
    from: [f64; 3],
    to: [f64; 3],
    r: f64,
    clockwise: bool,
) -> std::result::Result<[f64; 2], String> {
    let (dx, dy) = (to[0] - from[0], to[1] - from[1]);
    let chord = dx.hypot(dy);
    if chord == 0.0 || r == 0.0 {
        return Err(format!(
            "an arc of radius R{r} over a chord of {chord} mm; expected a chord and a radius \
             (a whole turn needs its centre, I and J)"
        ));
    }
    let half = chord / 2.0;
    let reach = r.abs();
    // A radius a hair short of half the chord is the controller's rounding: a half turn.
    if reach < half * (1.0 - 1e-6) - 1e-6 {
        return Err(format!(
            "an arc of radius {reach:.4} mm over a chord of {chord:.4} mm; expected a radius of \
             at least half the chord"
        ));
    }
    let h = (reach * reach - half * half).max(0.0).sqrt();
    // Left of the chord for a counter-clockwise arc of at most half a turn.
    let left = [-dy / chord, dx / chord];
    let side = if clockwise { -1.0 } else { 1.0 } * r.signum();
    let mid = [from[0] + dx / 2.0, from[1] + dy / 2.0];
    Ok([mid[0] + side * h * left[0], mid[1] + side * h * left[1]])
}

/// The chords of the arc (a helix where the third coordinate changes) from `from` to `to` about
/// `centre`, all in the plane's coordinates ([`Plane::into_plane`]), each point after `from`,
/// the last `to` itself: a whole turn where they coincide, and `turns` − 1 whole turns more;
/// and the length of arc each chord stands for (each spans the same angle). The radius runs
/// from the start's to the end's (they may differ by `ARC_END_MM`).
fn arc_chords(
    (from, to): ([f64; 3], [f64; 3]),
    centre: [f64; 2],
    clockwise: bool,
    turns: u32,
) -> std::result::Result<(Vec<[f64; 3]>, f64), String> {
    let r0 = (from[0] - centre[0]).hypot(from[1] - centre[1]);
    let r1 = (to[0] - centre[0]).hypot(to[1] - centre[1]);
    if r0 == 0.0 || (r0 - r1).abs() > ARC_END_MM.max(ARC_END_SHARE * r0) {
        return Err(format!(
            "an arc whose end lies {r1:.4} mm from its centre and its start {r0:.4} mm; expected \
             both on one circle (within {ARC_END_MM} mm or {ARC_END_SHARE} of the radius)"
        ));
    }
    let a0 = (from[1] - centre[1]).atan2(from[0] - centre[0]);
    let a1 = (to[1] - centre[1]).atan2(to[0] - centre[0]);
    let tau = std::f64::consts::TAU;
    let mut sweep = a1 - a0;
    if clockwise {
        while sweep >= 0.0 {
            sweep -= tau;
        }
    } else {
        while sweep <= 0.0 {
            sweep += tau;
        }
    }
    // P turns: P − 1 whole turns more, the same way.
    sweep += sweep.signum() * tau * f64::from(turns - 1);
    let r = r0.max(r1);
    let by_sagitta = 2.0 * (1.0 - (ARC_SAGITTA_MM / r).min(1.0)).acos();
    let step = by_sagitta.max(tau / ARC_CHORDS_PER_TURN);
    let chords = (sweep.abs() / step).ceil().max(1.0) as usize;
    let length = ((r0 + r1) / 2.0 * sweep).hypot(to[2] - from[2]);
    let points = (1..=chords)
        .map(|k| {
            if k == chords {
                return to;
            }
            let f = k as f64 / chords as f64;
            let (a, radius) = (a0 + f * sweep, r0 + f * (r1 - r0));
            [
                centre[0] + radius * a.cos(),
                centre[1] + radius * a.sin(),
                from[2] + f * (to[2] - from[2]),
            ]
        })
        .collect();
    Ok((points, length / chords as f64))
}

#[cfg(test)]
mod tests {
    use super::{Dialect, distance, waypoints};

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
    }

    /// Arcs in the other planes and of several turns: G18's half turn from (0, 0, 0) to
    /// (10, 0, 0) about I5 lies in the ZX plane (y 0 throughout), G2 through z = −5 (clockwise
    /// seen from +Y, the plane's axes taken Z then X as RS-274 orders them), G3 through z = 5;
    /// G19's quarter turn lies in YZ; a G17 helix of P3 turns climbing 6 mm sweeps three whole
    /// turns on its circle, climbing all the way, in three times one turn's time.
    #[test]
    fn arcs_in_every_plane_and_of_several_turns() {
        let path = |g: &str| {
            let w = waypoints(&format!("G1 F600\nM3\n{g}\n"), "p.nc", &standard()).unwrap();
            w.iter().map(|p| p.position_mm).collect::<Vec<_>>()
        };
        for (g, below) in [("G18 G2 X10 I5", true), ("G18 G3 X10 I5", false)] {
            let p = path(g);
            assert_eq!(*p.last().unwrap(), [10.0, 0.0, 0.0], "{g}");
            let mid = p[p.len() / 2];
            assert!(p.iter().all(|q| q[1] == 0.0), "{g}: {p:?}");
            let z = if below { -5.0 } else { 5.0 };
            assert!((mid[2] - z).abs() < 0.1, "{g}: {mid:?}");
            for q in &p {
                let r = (q[0] - 5.0).hypot(q[2]);
                assert!((r - 5.0).abs() < 1e-9, "{g}: {q:?}");
            }
        }
        let p = path("G19 G3 Y5 Z5 J5");
        assert!(p.iter().all(|q| q[0] == 0.0), "{p:?}");
        assert_eq!(*p.last().unwrap(), [0.0, 5.0, 5.0]);
        let one = waypoints("G1 F600\nG2 X0 Y0 I10 Z2\n", "p.nc", &standard()).unwrap();
        let three = waypoints("G1 F600\nG2 X0 Y0 I10 Z6 P3\n", "p.nc", &standard()).unwrap();
        // Every point on the circle, z climbing, the angle swept three whole turns clockwise.
        let mut swept = 0.0;
        for pair in three.windows(2) {
            let [a, b] = [pair[0].position_mm, pair[1].position_mm];
            assert!(((b[0] - 10.0).hypot(b[1]) - 10.0).abs() < 1e-9, "{b:?}");
            assert!(b[2] > a[2], "{a:?} {b:?}");
            let turn = (b[1]).atan2(b[0] - 10.0) - (a[1]).atan2(a[0] - 10.0);
            swept += (turn + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
        }
        assert!(
            (swept + 3.0 * std::f64::consts::TAU).abs() < 1e-9,
            "{swept}"
        );
        assert_eq!(three.last().unwrap().position_mm, [0.0, 0.0, 6.0]);
        let (t1, t3) = (one.last().unwrap().t_s, three.last().unwrap().t_s);
        assert!((t3 / t1 - 3.0).abs() < 1e-3, "{t1} {t3}");
    }

    /// G92 as programs use it: a printer's `G92 E0` moves nothing; `G92 X0 Y0` at (11, 20)
    /// lays the next absolute move 11 and 20 mm on, and a G90.1 arc's centre with it (a whole
    /// turn whose every point lies on the circle about the shifted centre); a relative move is
    /// not shifted; G92.2 puts the offset aside and G92.3 brings it back, G92.1 takes it away;
    /// a G92 line is not a move (its X is the point's new name, not a target).
    #[test]
    fn g92_sets_the_current_points_coordinates() {
        let g = "G1 X10 Y20 F600\nG92 E0\nG1 X11 Y20\nG92 X0 Y0\nG1 X5\nG91\nG1 Y1\nG90\n\
                 G92.2\nG1 X5\nG92.3\nG1 X0 Y0\nG90.1 G2 X0 Y0 I3 J0\nG92.1\nG1 X1 Y1\n";
        let w = waypoints(g, "p.nc", &standard()).unwrap();
        let at: Vec<[f64; 2]> = w
            .iter()
            .map(|p| [p.position_mm[0], p.position_mm[1]])
            .collect();
        assert_eq!(
            &at[..6],
            [
                [0.0, 0.0],
                [10.0, 20.0],
                [11.0, 20.0],
                [16.0, 20.0],
                [16.0, 21.0],
                [5.0, 21.0]
            ]
        );
        assert_eq!(at[6], [11.0, 20.0]);
        // The turn about (14, 20), radius 3, ends where it began.
        let turn = &at[7..at.len() - 1];
        assert!(turn.len() > 30, "{}", turn.len());
        for p in turn {
            let r = (p[0] - 14.0).hypot(p[1] - 20.0);
            assert!((r - 3.0).abs() < 1e-9, "{p:?} {r}");
        }
        assert_eq!(*turn.last().unwrap(), [11.0, 20.0]);
        assert_eq!(*at.last().unwrap(), [1.0, 1.0]);
    }

    fn standard() -> Dialect {
        Dialect {
            arc_on: "M3".into(),
            arc_off: "M5".into(),
            feed_scale: 1.0 / 60.0,
            travel_mm_s: None,
        }
    }

    /// A whole turn (G2 back to its start, the centre by I and J): every waypoint on the
    /// circle, every chord within the sagitta of it, clockwise seen from +Z, and the turn taking
    /// its length over the feed.
    #[test]
    fn an_arc_is_laid_along_its_circle_in_its_time() {
        let w = waypoints("G1 F600\nM3\nG2 X0 Y0 I20 J0\n", "p.nc", &standard()).unwrap();
        let centre = [20.0, 0.0, 0.0];
        for p in &w {
            assert!(
                (distance(p.position_mm, centre) - 20.0).abs() < 1e-9,
                "{p:?}"
            );
        }
        for c in w.windows(2) {
            let mid = [0, 1, 2].map(|i| (c[0].position_mm[i] + c[1].position_mm[i]) / 2.0);
            assert!(20.0 - distance(mid, centre) <= 0.01 + 1e-12, "{c:?}");
        }
        assert!(
            w[1].position_mm[1] > 0.0,
            "clockwise from (0, 0) about (20, 0): up first"
        );
        assert!(w[1..].iter().all(|p| p.on));
        let last = w.last().unwrap();
        assert!(distance(last.position_mm, [0.0; 3]) < 1e-12);
        let turn = std::f64::consts::TAU * 20.0 / 10.0;
        assert!(
            (last.t_s / turn - 1.0).abs() < 1e-12,
            "{} s for {turn} s",
            last.t_s
        );
    }

    /// From (10, 0) to (0, 10): R 10 is the quarter turn, R −10 the three quarters, either way
    /// round; and R's arc is the one its centre names.
    #[test]
    fn the_radius_form_takes_the_short_arc_and_a_negative_radius_the_long_one() {
        let length = |g: &str| {
            let text = format!("G1 X10 F600\n{g} X0 Y10\n");
            let w = waypoints(&text, "p.nc", &standard()).unwrap();
            (w.last().unwrap().t_s - w[1].t_s) * 10.0
        };
        let quarter = std::f64::consts::FRAC_PI_2 * 10.0;
        for (g, turns) in [
            ("G3 R10", 1.0),
            ("G3 R-10", 3.0),
            ("G2 R10", 1.0),
            ("G2 R-10", 3.0),
        ] {
            let l = length(g);
            assert!((l / (turns * quarter) - 1.0).abs() < 1e-12, "{g}: {l} mm");
        }
        let by = |g: &str| {
            waypoints(&format!("G1 X10 F600\n{g}\n"), "p.nc", &standard())
                .unwrap()
                .iter()
                .map(|w| w.position_mm)
                .collect::<Vec<_>>()
        };
        let (r, ij) = (by("G3 X0 Y10 R10"), by("G3 X0 Y10 I-10 J0"));
        assert_eq!(r.len(), ij.len());
        assert!(r.iter().zip(&ij).all(|(a, b)| distance(*a, *b) < 1e-9));
        // The centre itself (G90.1), and a helix: z runs with the angle.
        let abs = by("G90.1 G3 X0 Y10 Z5 I0 J0");
        assert!(distance(abs[abs.len() / 2 + 1], [0.0; 3]) > 9.99);
        assert_eq!(*abs.last().unwrap(), [0.0, 10.0, 5.0]);
    }

    /// Coordinates alone go on with the last motion; several G codes share a line; G20 is
    /// inches, feed included; G91 moves from the current point; F stands alone.
    #[test]
    fn modal_moves_inches_and_relative_coordinates() {
        let g = "G21 G90 G1 X10 F600\nX20\nY5\nG20 G91\nG1 X1 F60\nG90 G21\nF1200\nG0 X0 Y0\n";
        let w = waypoints(g, "p.nc", &standard()).unwrap();
        let at: Vec<[f64; 3]> = w.iter().map(|w| w.position_mm).collect();
        let want = [
            [0.0, 0.0, 0.0],
            [10.0, 0.0, 0.0],
            [20.0, 0.0, 0.0],
            [20.0, 5.0, 0.0],
        ];
        assert_eq!(at[..4], want);
        assert!(distance(at[4], [45.4, 5.0, 0.0]) < 1e-12, "{:?}", at[4]);
        assert_eq!(at[5], [0.0; 3]);
        // An inch at 60 in/min: 1 s; then 45.7 mm at 1 200 mm/min.
        assert!((w[4].t_s - w[3].t_s - 1.0).abs() < 1e-9);
        let back = 45.4f64.hypot(5.0) / 20.0;
        assert!((w[5].t_s - w[4].t_s - back).abs() < 1e-9);
    }

    /// Words packed without spaces, a printer's E among them, and a number spaced from its
    /// letter read as a controller reads them: `X10E5` is X 10 (not 1e6 mm), `X 10` is X 10.
    #[test]
    fn packed_words_and_spaced_numbers() {
        let g = "G1F600X10E5Y2\nG1X-3.5E-1.25Y+4\nG1 X 7 Y\t8 E 1\n";
        let w = waypoints(g, "p.nc", &standard()).unwrap();
        let at: Vec<[f64; 3]> = w.iter().map(|w| w.position_mm).collect();
        assert_eq!(
            at,
            [
                [0.0; 3],
                [10.0, 2.0, 0.0],
                [-3.5, 4.0, 0.0],
                [7.0, 8.0, 0.0]
            ]
        );
        assert!(
            (w[1].t_s - 104f64.sqrt() / 10.0).abs() < 1e-12,
            "{:?}",
            w[1]
        );
    }

    /// `text` with each `1eN` written out as G-code writes a number (1 and N zeros, or a point,
    /// −N − 1 zeros and 1).
    fn tens(text: &str) -> String {
        let mut out = text.to_string();
        for n in [308, 300, 9, -300] {
            let written = match n {
                n if n >= 0 => format!("1{}", "0".repeat(n as usize)),
                n => format!("0.{}1", "0".repeat((-n - 1) as usize)),
            };
            out = out.replace(&format!("1e{n}"), &written);
        }
        out
    }

    #[test]
    fn what_it_cannot_lay_is_refused_naming_the_line() {
        for (g, says) in [
            ("G1 X1 F1\nG92\n", "p.nc line 2: G92 naming no axis"),
            (
                "G1 X1 F1\nG28 X0\n",
                "line 2: G28 (a return to a home position)",
            ),
            ("G53 G0 X0\n", "line 1: G53"),
            ("X1\n", "line 1: coordinates with no motion mode"),
            (
                "G1 F600\nG2 X10 Y0 I3 J0\n",
                "line 2: an arc whose end lies 7.0000 mm",
            ),
            (
                "G1 F600\nG2 X10 Y0 R2\n",
                "expected a radius of at least half the chord",
            ),
            ("G1 F600\nG2 X0 Y0 R2\n", "a whole turn needs its centre"),
            ("G1 F600\nG2 X10 Y0\n", "neither its centre"),
            ("G1 F600\nG2 X10 Y0 I5 R5\n", "both its centre"),
            (
                "G1 F600\nG2 X0 Y0 I5 P1.5\n",
                "P1.5 turns of an arc; expected a whole",
            ),
            ("G1 F600\nG2 X0 Y0 I5 P0\n", "P0 turns"),
            ("G1 F600\nG18 G2 X10 Y0\n", "neither its centre (K, I)"),
            ("G1 X- F1\n", "line 1: X-; expected a finite number"),
            (
                "G93 G1 X1 F60\n",
                "line 1: G93 (inverse-time feed); expected feed in units a minute (G94",
            ),
            (
                "G1 X1 F60\nG1 X2 A0 C0\nG1 X3 A15 C90\n",
                "line 3: A15 (a rotary axis turned)",
            ),
            (
                "G1 X1 F60\nC90\nG1 X3\n",
                "line 2: C90 (a rotary axis turned)",
            ),
            ("G91 G1 X1e308 F1e9\nX1e308\n", "line 2: a move to [inf"),
            (
                "G1 X1e308 F1e300\nG2 X1e308 Y0 I1e308\n",
                "line 2: an arc centred at [inf",
            ),
            (
                "G1 X1e300 F1e-300\n",
                "expected a move the program's clock can time",
            ),
        ] {
            // G-code has no exponents: the powers of ten written out.
            let g = tens(g);
            let e = waypoints(&g, "p.nc", &standard()).unwrap_err();
            assert!(e.message.contains(says), "{g:?}: {}", e.message);
        }
    }
}
