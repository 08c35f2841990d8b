//! The deposition schedule of a toolpath the machine ran: each deposited segment becomes
//! deposits no longer than `deposit_m`, timed along it at its constant speed; a segment after
//! travel with the arc off starts a new track ([`Deposit::start`]). What a deposit lies on is
//! the latest earlier deposit within half a bead width across and about one layer below, or the
//! plate.

use crate::measured::toolpath::Waypoint;
use std::collections::HashMap;
use thermal::schedule::Deposit;

/// How the toolpath's metal is laid, SI.
#[derive(Debug, Clone, PartialEq)]
pub struct Laying {
    /// Power on a deposited segment where the toolpath gives none, W.
    pub power_w: f64,
    /// Share of the power that enters the part (arc efficiency, laser absorptivity).
    pub efficiency: f64,
    pub width_m: f64,
    pub height_m: f64,
    /// Longest deposit, m.
    pub deposit_m: f64,
}

/// How many deposits [`deposits`] cuts the path into, counted without making them (a path
/// whose segments or `deposit_m` ask for more than the machine holds is refused before).
pub fn count(path: &[Waypoint], l: &Laying) -> f64 {
    path.windows(2)
        .filter(|w| w[1].on)
        .map(|w| pieces(&w[0], &w[1], l))
        .sum()
}

/// The deposits a deposited segment from `a` to `b` is cut into: at least one, none longer
/// than `deposit_m`.
fn pieces(a: &Waypoint, b: &Waypoint, l: &Laying) -> f64 {
    let length = dist(
        a.position_mm.map(|x| x * 1e-3),
        b.position_mm.map(|x| x * 1e-3),
    );
    (length / l.deposit_m).ceil().max(1.0)
}

/// The deposition schedule of a toolpath.
pub fn deposits(path: &[Waypoint], l: &Laying) -> Vec<Deposit> {
    let mut out: Vec<Deposit> = Vec::new();
    for w in path.windows(2) {
        let (a, b) = (&w[0], &w[1]);
        if !b.on {
            continue;
        }
        let from = a.position_mm.map(|x| x * 1e-3);
        let to = b.position_mm.map(|x| x * 1e-3);
        let n = pieces(a, b, l) as usize;
        let dt = (b.t_s - a.t_s) / n as f64;
        let power = b.power_w.unwrap_or(l.power_w);
        // A new track where the previous deposit did not end at this segment's start.
        let continues = out.last().is_some_and(|d| dist(d.position, from) < 1e-9);
        for k in 1..=n {
            let f = k as f64 / n as f64;
            let position = std::array::from_fn(|i| from[i] + f * (to[i] - from[i]));
            out.push(Deposit {
                position,
                time: a.t_s + k as f64 * dt,
                arc_time: dt,
                heat: l.efficiency * power * dt,
                width: l.width_m,
                height: l.height_m,
                axis: [0.0, 0.0, 1.0],
                support: None,
                start: (k == 1 && !continues).then_some(from),
                drop: None,
            });
        }
    }
    let supports = supports(&out, l.width_m, l.height_m);
    for (d, s) in out.iter_mut().zip(supports) {
        d.support = s;
    }
    out
}

/// Per deposit, the nearest earlier one (across; the latest of equals) within half a width
/// across and 0.3–1.7 layers below.
///
/// The earlier deposits are binned as they come on a grid of half a width across and a layer
/// high, and a deposit looks in the 3 × 3 columns round it over the (at most three) layers its
/// window spans: linear in the deposits where comparing each with every earlier one was
/// quadratic (a logged build of 86 400 deposits took 9.5 s to set up, one of a metre-class
/// part's 550 000 would have taken minutes before its cost was shown).
fn supports(deps: &[Deposit], width: f64, height: f64) -> Vec<Option<usize>> {
    let (across_m, up_m) = (width / 2.0, height);
    let cell = |p: [f64; 3]| -> [i64; 3] {
        [
            (p[0] / across_m).floor() as i64,
            (p[1] / across_m).floor() as i64,
            (p[2] / up_m).floor() as i64,
        ]
    };
    let mut bins: HashMap<[i64; 3], Vec<usize>> = HashMap::new();
    let mut out = Vec::with_capacity(deps.len());
    for (i, d) in deps.iter().enumerate() {
        let p = d.position;
        let [cx, cy, _] = cell(p);
        let (lowest, highest) = (
            cell([p[0], p[1], p[2] - 1.7 * height])[2],
            cell([p[0], p[1], p[2] - 0.3 * height])[2],
        );
        // The nearest across, the latest of equals: the largest (−across, index).
        let mut best: Option<(f64, usize)> = None;
        for cz in lowest..=highest {
            for cx in cx - 1..=cx + 1 {
                for cy in cy - 1..=cy + 1 {
                    for &j in bins.get(&[cx, cy, cz]).into_iter().flatten() {
                        let q = deps[j].position;
                        let across = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
                        let down = p[2] - q[2];
                        let below =
                            across <= across_m && down > 0.3 * height && down < 1.7 * height;
                        let better = best.is_none_or(|(b, k)| across < b || (across == b && j > k));
                        if below && better {
                            best = Some((across, j));
                        }
                    }
                }
            }
        }
        out.push(best.map(|b| b.1));
        bins.entry(cell(p)).or_default().push(i);
    }
    out
}

/// What [`supports`] finds, by comparing each deposit with every earlier one: the reference
/// the binned search is tested against.
#[cfg(test)]
fn supports_by_every_pair(deps: &[Deposit], width: f64, height: f64) -> Vec<Option<usize>> {
    (0..deps.len())
        .map(|i| {
            let p = deps[i].position;
            let mut best: Option<(f64, usize)> = None;
            for j in (0..i).rev() {
                let q = deps[j].position;
                let across = ((p[0] - q[0]).powi(2) + (p[1] - q[1]).powi(2)).sqrt();
                let down = p[2] - q[2];
                let below = across <= width / 2.0 && down > 0.3 * height && down < 1.7 * height;
                if below && best.is_none_or(|b| across < b.0) {
                    best = Some((across, j));
                }
            }
            best.map(|b| b.1)
        })
        .collect()
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

#[cfg(test)]
mod tests {
    use super::{supports, supports_by_every_pair};
    use thermal::schedule::Deposit;

    fn at(position: [f64; 3]) -> Deposit {
        Deposit {
            position,
            time: 0.0,
            arc_time: 0.1,
            heat: 1.0,
            width: 4e-3,
            height: 1.5e-3,
            axis: [0.0, 0.0, 1.0],
            support: None,
            start: None,
            drop: None,
        }
    }

    /// The binned search finds what comparing every pair finds, deposit for deposit: on a
    /// spiral wall of 12 layers (each deposit's support the one a revolution below), on
    /// deposits scattered by a fixed sequence over a block round the origin (negative
    /// coordinates, windows across the bins' edges), and on deposits laid again exactly
    /// where others lie (ties across: the latest wins) and on the bins' edges themselves.
    #[test]
    fn the_binned_supports_are_every_pairs() {
        let (w, h) = (4e-3, 1.5e-3);
        let spiral: Vec<Deposit> = (0..12 * 90)
            .map(|k| {
                let a = k as f64 * std::f64::consts::TAU / 90.0;
                at([0.03 * a.cos(), 0.03 * a.sin(), h * (1.0 + k as f64 / 90.0)])
            })
            .collect();
        let found = supports(&spiral, w, h);
        assert_eq!(found, supports_by_every_pair(&spiral, w, h));
        assert_eq!(found[90 * 5 + 7], Some(90 * 4 + 7));
        assert_eq!(found[..90].iter().flatten().count(), 0);

        let mut x: u64 = 0x9e37_79b9_7f4a_7c15;
        let mut next = || {
            x = x.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
            (x >> 11) as f64 / (1u64 << 53) as f64
        };
        let scattered: Vec<Deposit> = (0..3000)
            .map(|_| {
                at([
                    0.02 * (next() - 0.5),
                    0.02 * (next() - 0.5),
                    0.008 * next() - 0.002,
                ])
            })
            .collect();
        let found = supports(&scattered, w, h);
        assert_eq!(found, supports_by_every_pair(&scattered, w, h));
        assert!(found.iter().flatten().count() > 1000, "few supports found");

        let stacked: Vec<Deposit> = [
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 0.0],
            [2e-3, 0.0, 0.0],
            [-2e-3, 0.0, 0.0],
            [0.0, 0.0, 1.5e-3],
            [2e-3, 0.0, 1.5e-3],
            [0.0, -2e-3, 3e-3],
            [4e-3, 0.0, 3e-3],
        ]
        .map(at)
        .to_vec();
        let found = supports(&stacked, w, h);
        assert_eq!(found, supports_by_every_pair(&stacked, w, h));
        assert_eq!(found[4], Some(1), "the latest of two at the same place");
        assert_eq!(
            found[5],
            Some(2),
            "the one right below, not the nearest bin's"
        );
    }
}
