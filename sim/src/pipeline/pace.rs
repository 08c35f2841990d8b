//! Cooling with the arc kept on: a stretch of the path laid k times slower, wire feed and travel
//! speed divided by the same pace k so that Eq.7 lays the same deposit, the arc burning k times
//! longer at the power the slower wire feed gives. With a synergic line the power falls with the
//! wire feed and so does the heat put in per second; with a fixed arc power it does not, and
//! slowing down only lays the same power over a longer time (more heat per revolution). The
//! process window bounds k ([`bead_model::window::Window::slowest_pace`]).

use super::beads::Beads;
use super::deposition::{burn, segment_m};
use super::params::Process;
use bead_model::drop::Drop;
use planner::plan::Plan;
use std::ops::Range;
use thermal::Burn;
use thermal::schedule::DropPart;

/// Per path point, how it burns at any pace; no state.
#[derive(Debug, Clone)]
pub struct Pacing<'a> {
    process: &'a Process,
    beads: &'a Beads,
    /// The length of bead each point lays, m.
    segment_m: Vec<f64>,
    /// The slowest pace the window allows each point.
    slowest: Vec<f64>,
    /// The deposit each point lays, m.
    deposit_m: Vec<f64>,
}

impl<'a> Pacing<'a> {
    pub fn new(process: &'a Process, plan: &Plan, beads: &'a Beads) -> Pacing<'a> {
        let window = process.window();
        Pacing {
            process,
            beads,
            segment_m: (0..plan.points.len())
                .map(|i| segment_m(process, plan, i))
                .collect(),
            slowest: beads
                .beads
                .iter()
                .map(|b| window.slowest_pace(b.wfs_m_s, b.travel_m_s))
                .collect(),
            deposit_m: plan.points.iter().map(|q| q.deposit_mm * 1e-3).collect(),
        }
    }

    /// How point i burns at `pace`, laid as part of a drop or not: `None` when that is as
    /// scheduled (the planned pace, no drop), so that the run takes the schedule's own numbers.
    pub fn burn(&self, i: usize, pace: f64, drop: Option<DropPart>) -> Option<Burn> {
        (pace != 1.0 || drop.is_some()).then(|| Burn {
            drop,
            ..burn(self.process, &self.beads.beads[i], self.segment_m[i], pace)
        })
    }

    /// The slowest pace every point of `range` allows (1 for an empty range).
    pub fn slowest(&self, range: Range<usize>) -> f64 {
        self.slowest[range]
            .iter()
            .copied()
            .reduce(f64::min)
            .unwrap_or(1.0)
    }

    /// How much longer `range` burns at pace `to` than at pace `from`, s.
    pub fn extra_time_s(&self, range: Range<usize>, from: f64, to: f64) -> f64 {
        range
            .map(|i| {
                let arc =
                    |k| burn(self.process, &self.beads.beads[i], self.segment_m[i], k).arc_time;
                arc(to) - arc(from)
            })
            .sum()
    }

    /// The points of `range` laid as one drop: their metal (each segment's, Eq.7's rectangle of
    /// bead width by deposit) as a spherical cap on the bead's width. Its welding time, volume
    /// over the wire's feed rate, is the segments' arc time by Eq.7.
    pub fn drop_cap(&self, range: Range<usize>) -> Drop {
        let w = self.process.bead_width_m;
        let volume: f64 = range
            .map(|i| self.segment_m[i] * w * self.deposit_m[i])
            .sum();
        Drop::of_volume(volume, w)
    }

    /// The closing zone from `first` on cut into drops: each as long along the path as the bead
    /// is wide (its metal a cap about as wide as the bead), a short remainder joined to the
    /// drop before it.
    pub fn drops(&self, first: usize) -> Vec<Range<usize>> {
        let w = self.process.bead_width_m;
        let n = self.segment_m.len();
        let mut out: Vec<Range<usize>> = Vec::new();
        let (mut start, mut length) = (first, 0.0);
        for i in first..n {
            length += self.segment_m[i];
            if length >= w {
                out.push(start..i + 1);
                (start, length) = (i + 1, 0.0);
            }
        }
        if start < n {
            match out.last_mut() {
                Some(last) if length < w / 2.0 => last.end = n,
                _ => out.push(start..n),
            }
        }
        out
    }

    /// Whether laying `range` at `pace` puts less heat in per second than as planned at some point
    /// of it: the power model's power falls with the wire feed (a synergic line; a fixed power
    /// does not).
    pub fn cools(&self, range: Range<usize>, pace: f64) -> bool {
        range
            .into_iter()
            .any(|i| self.power_w(i, pace) < self.power_w(i, 1.0))
    }

    /// The power point i burns with at `pace`, W.
    pub fn power_w(&self, i: usize, pace: f64) -> f64 {
        self.beads.beads[i].paced(pace, self.process).power_w
    }
}

#[cfg(test)]
mod tests {
    use super::super::Build;
    use thermal::schedule::DropPart;

    /// A closed dome R 20 mm planned with CTPP under `process` (a `[process]` table's lines).
    fn dome(process: &str) -> Build {
        super::super::test_parts::dome(20.0, &format!("[process]\n{process}\n"))
    }

    /// At the planned pace a point burns as the schedule says (the run takes the schedule's own
    /// numbers), and a drop at the planned pace burns its segments' arc time with their heat.
    #[test]
    fn the_planned_pace_is_the_schedule() {
        let b = dome("");
        let pacing = b.pacing();
        for (i, d) in b.deposits().iter().enumerate() {
            assert_eq!(pacing.burn(i, 1.0, None), None);
            let drop = pacing.burn(i, 1.0, Some(DropPart::Continues)).unwrap();
            assert_eq!(
                (drop.arc_time, drop.heat),
                (d.arc_time, d.heat),
                "point {i}"
            );
        }
    }

    /// k times slower burns k times longer; the synergic line's power falls with the wire feed,
    /// a fixed power does not (its heat grows k-fold); the pace is bounded by the window.
    #[test]
    fn slowing_down_burns_longer_at_the_power_of_the_slower_wire_feed() {
        for (process, lower) in [("power_model = \"synergic\"", true), ("", false)] {
            let b = dome(process);
            let pacing = b.pacing();
            for (i, d) in b.deposits().iter().enumerate().skip(1).step_by(97) {
                let slow = pacing.burn(i, 2.0, None).unwrap();
                assert!((slow.arc_time - 2.0 * d.arc_time).abs() < 1e-12 * d.arc_time);
                let (p0, p1) = (d.heat / d.arc_time, slow.heat / slow.arc_time);
                match lower {
                    true => assert!(p1 < 0.8 * p0, "point {i}: {p1} W vs {p0} W"),
                    false => assert!((p1 - p0).abs() < 1e-9 * p0),
                }
                assert!((pacing.extra_time_s(i..i + 1, 1.0, 2.0) - d.arc_time).abs() < 1e-12);
            }
            // 10 mm/s over 2 mm/s, 1.5 m/min over the planned wire feed: at most 5.
            let k = pacing.slowest(0..b.deposits().len());
            assert!(k > 1.0 && k <= 5.0 + 1e-9, "{k}");
        }
    }

    /// The closing zone cut into drops: contiguous, each at least a bead width along the path,
    /// the last at least half one; each drop a cap whose radius is of the bead's half width.
    #[test]
    fn drops_are_a_bead_width_long() {
        let b = dome("");
        let pacing = b.pacing();
        let n = b.deposits().len();
        let first = n - 200;
        let drops = pacing.drops(first);
        assert_eq!(drops.first().unwrap().start, first);
        assert_eq!(drops.last().unwrap().end, n);
        assert!(drops.windows(2).all(|w| w[0].end == w[1].start));
        let w = b.params.process.bead_width_m;
        for (k, d) in drops.iter().enumerate() {
            let length: f64 = d.clone().map(|i| pacing.segment_m[i]).sum();
            let last = k + 1 == drops.len();
            assert!(
                length >= if last { w / 2.0 } else { w },
                "drop {k}: {length} m"
            );
            let cap = pacing.drop_cap(d.clone());
            assert!(
                cap.radius > 0.3 * w && cap.radius < 2.0 * w,
                "drop {k}: {cap:?}"
            );
        }
    }
}
