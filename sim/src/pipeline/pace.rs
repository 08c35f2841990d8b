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

    /// The power point i burns with at `pace`, W.
    pub fn power_w(&self, i: usize, pace: f64) -> f64 {
        self.beads.beads[i].paced(pace, self.process).power_w
    }
}
