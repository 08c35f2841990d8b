//! What a replay's readings give reason to doubt in how its probes were set up: a probe whose
//! column held no reading, one that compared nothing (in the air), readings on another clock
//! than the path's (all before its first arc or all after its last deposit), and a unit that
//! reads wrong (a file in °C read as kelvin lies below ambient and is dropped; one in kelvin
//! read as °C starts the cold part near 293 °C). Said, not refused: each can be right (a
//! window that closes before the metal comes, a plate preheated to about 300 °C), and each
//! would otherwise leave an empty or shifted comparison and a run that looks whole.

use super::setup::BELOW_AMBIENT_K;
use crate::measured::probes::Series;
use crate::pipeline::resolution::Warning;
use thermal::ZERO_CELSIUS_K as C;

/// One probe as the replay met it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Met<'a> {
    pub name: &'a str,
    pub position_mm: [f64; 3],
    /// Its column in the file, 0-based.
    pub column: usize,
    /// Whether its column held any reading (not empty, not 0, not below ambient).
    pub read: bool,
    /// Whether any of those readings was compared with the model.
    pub compared: bool,
}

/// The probes whose column held no reading (`probe_empty`), and those whose readings met no
/// metal (`probe_unread`): no metal lay within a cell of them while their readings ran, or none
/// in the window judged.
pub fn probes(met: &[Met<'_>]) -> Vec<Warning> {
    let empty: Vec<String> = met
        .iter()
        .filter(|p| !p.read)
        .map(|p| format!("{} column {}", p.name, p.column))
        .collect();
    let unread: Vec<String> = met
        .iter()
        .filter(|p| p.read && !p.compared)
        .map(|p| {
            let [x, y, z] = p.position_mm;
            format!("{} at ({x:.1}, {y:.1}, {z:.1}) mm", p.name)
        })
        .collect();
    let mut out = Vec::new();
    if !empty.is_empty() {
        out.push(Warning {
            kind: "probe_empty",
            line: format!(
                "warning: {} of the probes had no reading ({}): every value in the column \
                 empty, 0 or more than {BELOW_AMBIENT_K} K below ambient; check [probes] \
                 points' column (0-based, the time's counted) and unit",
                empty.len(),
                empty.join(", ")
            ),
        });
    }
    if !unread.is_empty() {
        out.push(Warning {
            kind: "probe_unread",
            line: format!(
                "warning: {} of the probes read nothing ({}): no metal lay within a cell of \
                 them while their readings ran; check [probes] points' x_mm, y_mm, z_mm \
                 against the path (and [toolpath] z_offset_mm)",
                unread.len(),
                unread.join(", ")
            ),
        });
    }
    out
}

/// Whether `dropped` of `readings` (read in kelvin where `kelvin`) lying below `ambient_k`
/// doubt the unit (`probe_unit`): more than half of them, as a file in °C read as kelvin
/// drops all (25 °C becomes −248 °C). `follow` asks it of the readings so far.
pub fn below_ambient(
    dropped: usize,
    readings: usize,
    kelvin: bool,
    ambient_k: f64,
) -> Option<Warning> {
    (dropped * 2 > readings).then(|| Warning {
        kind: "probe_unit",
        line: format!(
            "warning: {dropped} of {readings} readings lay more than {BELOW_AMBIENT_K} K below \
             ambient ({:.1} °C) and were dropped{}; check [probes] unit (\"{}\") against the file",
            ambient_k - C,
            if kelvin {
                ", as a file in °C read as kelvin does"
            } else {
                ""
            },
            if kelvin { "K" } else { "C" },
        ),
    })
}

/// Whether the readings' times `t_s` miss the build, the first arc at `first_arc_s` to the
/// last deposit at `last_s` (`probe_clock`): all of them before it or all after it, where the
/// file and the path are on two clocks (a logger started an hour before the program, its
/// times not moved by `toolpath.time_offset_s`). A log of the cooling alone is all after, and
/// said too.
pub fn clock(t_s: &[f64], first_arc_s: f64, last_s: f64) -> Option<Warning> {
    let (&first, &last) = (t_s.first()?, t_s.last()?);
    let missed = if last < first_arc_s {
        format!("end at {last} s, before the first arc at {first_arc_s:.1} s")
    } else if first > last_s {
        format!("begin at {first} s, after the last deposit at {last_s:.1} s")
    } else {
        return None;
    };
    Some(Warning {
        kind: "probe_clock",
        line: format!(
            "warning: the readings {missed}: none was taken while metal was laid; check \
             [toolpath] time_offset_s, which puts the path on the readings' clock"
        ),
    })
}

/// Within this of ambient in kelvin, a cold part's reading taken as °C is a file in kelvin, K.
const KELVIN_LOOKALIKE_K: f64 = 15.0;

/// Whether the readings `m` (°C, read in kelvin where `kelvin`; `dropped` of them below
/// ambient and dropped) look read in the wrong unit (`probe_unit`): most of them dropped below
/// `ambient_k` (a file in °C read as K: 25 °C becomes −248 °C), or, read as °C, those before
/// the first arc (`first_arc_s`: the part stands at ambient) near ambient's kelvin and far
/// above ambient.
pub fn unit(
    m: &Series,
    dropped: usize,
    kelvin: bool,
    ambient_k: f64,
    first_arc_s: f64,
) -> Option<Warning> {
    let kept = m.values.iter().flatten().flatten().count();
    if let Some(w) = below_ambient(dropped, dropped + kept, kelvin, ambient_k) {
        return Some(w);
    }
    if kelvin {
        return None;
    }
    let cold: Vec<f64> = m
        .t_s
        .iter()
        .enumerate()
        .filter(|(_, t)| **t < first_arc_s)
        .flat_map(|(j, _)| m.values.iter().filter_map(move |v| v[j]))
        .collect();
    lookalike(cold, ambient_k, first_arc_s)
}

/// Whether readings in °C taken before the first arc (`cold`, at `first_arc_s`: the part stands
/// at ambient) read, at their median, within `KELVIN_LOOKALIKE_K` of ambient's kelvin and far
/// above ambient: a file in kelvin read as °C (`probe_unit`).
pub fn lookalike(mut cold: Vec<f64>, ambient_k: f64, first_arc_s: f64) -> Option<Warning> {
    if cold.is_empty() {
        return None;
    }
    let ambient_c = ambient_k - C;
    cold.sort_by(f64::total_cmp);
    let median = cold[cold.len() / 2];
    let lookalike = (median - ambient_k).abs() <= KELVIN_LOOKALIKE_K && median - ambient_c > 100.0;
    lookalike.then(|| Warning {
        kind: "probe_unit",
        line: format!(
            "warning: the readings before the first arc (at {first_arc_s:.1} s) read \
             {median:.1} °C, the part at ambient {ambient_c:.1} °C ({ambient_k:.1} K), as a file \
             in kelvin read as °C does; check [probes] unit (\"C\") against the file (a plate \
             preheated to about {median:.0} °C is fine)"
        ),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn series(t_s: Vec<f64>, values: Vec<Vec<Option<f64>>>) -> Series {
        Series { t_s, values }
    }

    /// A file in °C read as kelvin: all its readings dropped (the GAMMA substrate's 6 288)
    /// is said, with the unit; a few dropped (the GAMMA wall's camera: 154 of 174 579, pixels
    /// metal only partly fills) are not.
    #[test]
    fn most_readings_below_ambient_doubt_the_unit() {
        let m = series(vec![0.0, 1.0], vec![vec![None, None]]);
        let w = unit(&m, 2, true, 300.0, 0.5).unwrap();
        assert_eq!(w.kind, "probe_unit");
        assert!(
            w.line.contains("2 of 2 readings") && w.line.contains("unit (\"K\")"),
            "{}",
            w.line
        );
        let m = series(
            vec![0.0, 1.0, 2.0],
            vec![vec![Some(30.0), Some(900.0), Some(400.0)]],
        );
        assert_eq!(unit(&m, 1, true, 300.0, 0.5), None);
    }

    /// A file in kelvin read as °C: the cold part before the first arc reads 295 "°C" at an
    /// ambient of 293.15 K; at 25 °C it does not, nor after the arc, nor read as kelvin.
    #[test]
    fn a_cold_part_near_ambients_kelvin_doubts_the_unit() {
        let kelvin = series(
            vec![0.0, 1.0, 5.0],
            vec![
                vec![Some(295.0), Some(296.0), Some(1500.0)],
                vec![Some(294.0), None, Some(900.0)],
            ],
        );
        let w = unit(&kelvin, 0, false, 293.15, 2.0).unwrap();
        assert!(
            w.line.contains("read 295.0 °C") && w.line.contains("unit (\"C\")"),
            "{}",
            w.line
        );
        assert_eq!(
            unit(&kelvin, 0, false, 293.15, 0.0),
            None,
            "nothing before the arc"
        );
        let celsius = series(vec![0.0, 5.0], vec![vec![Some(25.0), Some(1200.0)]]);
        assert_eq!(unit(&celsius, 0, false, 293.15, 2.0), None);
    }

    /// Readings all before the first arc or all after the last deposit miss the build; any
    /// overlap does not.
    #[test]
    fn readings_that_miss_the_build_doubt_the_clock() {
        let w = clock(&[0.0, 5.0], 10.0, 50.0).unwrap();
        assert_eq!(w.kind, "probe_clock");
        assert!(
            w.line
                .contains("end at 5 s, before the first arc at 10.0 s"),
            "{}",
            w.line
        );
        let w = clock(&[3600.0, 3700.0], 10.0, 50.0).unwrap();
        assert!(
            w.line
                .contains("begin at 3600 s, after the last deposit at 50.0 s"),
            "{}",
            w.line
        );
        assert_eq!(clock(&[0.0, 20.0], 10.0, 50.0), None);
        assert_eq!(clock(&[40.0, 3600.0], 10.0, 50.0), None);
        assert_eq!(clock(&[], 10.0, 50.0), None);
    }

    /// A probe with no reading in its column is named with its column, one that compared none
    /// with its place; one that compared is not named.
    #[test]
    fn probes_without_readings_and_without_metal_are_named_apart() {
        let met = |name, read, compared| Met {
            name,
            position_mm: [1.0, 2.0, 50.0],
            column: 3,
            read,
            compared,
        };
        let w = probes(&[
            met("a", false, false),
            met("b", true, false),
            met("c", true, true),
        ]);
        let kinds: Vec<&str> = w.iter().map(|w| w.kind).collect();
        assert_eq!(kinds, ["probe_empty", "probe_unread"]);
        assert!(
            w[0].line
                .contains("1 of the probes had no reading (a column 3)"),
            "{}",
            w[0].line
        );
        assert!(
            w[1].line.contains("(b at (1.0, 2.0, 50.0) mm)"),
            "{}",
            w[1].line
        );
        assert!(probes(&[met("c", true, true)]).is_empty());
    }
}
