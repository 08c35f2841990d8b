//! The deposition schedule of a toolpath the machine ran: each deposited segment becomes
//! deposits no longer than `deposit_m`, timed along it at its constant speed; a segment after
//! travel with the arc off starts a new track ([`Deposit::start`]). What a deposit lies on is
//! the latest earlier deposit within half a bead width across and about one layer below, or the
//! plate.

use crate::measured::toolpath::Waypoint;
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
        let length = dist(from, to);
        let n = ((length / l.deposit_m).ceil() as usize).max(1);
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
fn supports(deps: &[Deposit], width: f64, height: f64) -> Vec<Option<usize>> {
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
