//! Two files written side by side, the probe logger's and the machine's log
//! (`[live.machine_log] file`), fed to the twin as one stream in time order. A row goes once
//! the other file has been read to its time (the machine's first on a tie: the engine takes a
//! machine row before the probe row of the same time); a reading also once the machine's file
//! has said nothing for `stall_s` (its rows that come later than what was fed are counted and
//! dropped); everything when the run ends. So a forecast made at t uses no row of either file
//! after t, whichever file the cell wrote first.

use super::Row;
use super::tail::Mark;
use crate::pipeline::twin::asrun::MachineRow;
use std::collections::VecDeque;

/// A row that may go, with where its file is read to once it has.
pub enum Next {
    Probe(Mark, Row),
    Machine(Mark, MachineRow),
}

/// The rows read and not yet fed, and how far each file has been read.
#[derive(Default)]
pub struct Merge {
    probes: VecDeque<(Mark, Row)>,
    machine: VecDeque<(Mark, MachineRow)>,
    probes_read_s: f64,
    machine_read_s: f64,
}

impl Merge {
    pub fn new() -> Merge {
        Merge {
            probes_read_s: f64::NEG_INFINITY,
            machine_read_s: f64::NEG_INFINITY,
            ..Merge::default()
        }
    }

    pub fn probe(&mut self, mark: Mark, row: Row) {
        self.probes_read_s = self.probes_read_s.max(row.0);
        self.probes.push_back((mark, row));
    }

    pub fn holds_no_probe_row(&self) -> bool {
        self.probes.is_empty()
    }

    pub fn machine(&mut self, mark: Mark, row: MachineRow) {
        self.machine_read_s = self.machine_read_s.max(row.t_s);
        self.machine.push_back((mark, row));
    }

    /// The next row that may go. `wait_probes` / `wait_machine`: whether a row of the other
    /// file waits for that file to be read to its time (false once it stalled, at the run's
    /// end, and for the machine where it has no file of its own).
    pub fn next(&mut self, wait_probes: bool, wait_machine: bool) -> Option<Next> {
        let p = self.probes.front().map(|r| r.1.0);
        let m = self.machine.front().map(|r| r.1.t_s);
        let machine_first = match (p, m) {
            (Some(p), Some(m)) => m <= p,
            (Some(p), None) => {
                if wait_machine && self.machine_read_s < p {
                    return None;
                }
                false
            }
            (None, Some(m)) => {
                if wait_probes && self.probes_read_s < m {
                    return None;
                }
                true
            }
            (None, None) => return None,
        };
        Some(match machine_first {
            true => {
                let (mark, row) = self.machine.pop_front()?;
                Next::Machine(mark, row)
            }
            false => {
                let (mark, row) = self.probes.pop_front()?;
                Next::Probe(mark, row)
            }
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn machine(t_s: f64) -> MachineRow {
        MachineRow {
            t_s,
            arc_on: true,
            power_w: None,
        }
    }

    fn times(m: &mut Merge, wait: (bool, bool)) -> Vec<(char, f64)> {
        std::iter::from_fn(|| m.next(wait.0, wait.1))
            .map(|n| match n {
                Next::Probe(_, r) => ('p', r.0),
                Next::Machine(_, r) => ('m', r.t_s),
            })
            .collect()
    }

    /// Rows go in time order, the machine's first on a tie; a probe row waits until the
    /// machine's file has been read to its time, and goes without waiting once told not to.
    #[test]
    fn rows_go_in_time_order_once_both_files_reach_them() {
        let mut m = Merge::new();
        for t in [1.0, 2.0, 3.0, 4.0] {
            m.probe(Mark::default(), (t, vec![]));
        }
        m.machine(Mark::default(), machine(0.5));
        m.machine(Mark::default(), machine(2.0));
        assert_eq!(
            times(&mut m, (true, true)),
            [('m', 0.5), ('p', 1.0), ('m', 2.0), ('p', 2.0)]
        );
        // The machine's file read to 2 s: 3 s and 4 s wait for it.
        assert!(m.next(true, true).is_none());
        m.machine(Mark::default(), machine(3.5));
        assert_eq!(times(&mut m, (true, true)), [('p', 3.0), ('m', 3.5)]);
        assert!(m.next(true, true).is_none());
        // The machine's file stalled (or the run ends): the rest goes.
        assert_eq!(times(&mut m, (true, false)), [('p', 4.0)]);
        // A machine row past the probes waits for them in turn.
        m.machine(Mark::default(), machine(9.0));
        assert!(m.next(true, true).is_none());
        assert_eq!(times(&mut m, (false, true)), [('m', 9.0)]);
    }
}
