//! The program as the cell ran it: where the machine log says what the program did not (a
//! stop, a later restart, a dwell cut short or drawn out, another power), the log wins and the
//! twin lays what actually happened.
//!
//! The torch is taken to move as programmed whenever the arc burns: the program's deposits are
//! laid in order, each once the arc has burnt, since the one before, as long as the program
//! gives it (its `arc_time`), with the heat of the logged power (η·P_log·t, η the program's;
//! the members scale it by theirs). Arc seconds the log has and the program does not run on
//! into the next deposits (a pause programmed with the arc off that the cell bridged with it
//! on); a pass the log ends short of its programmed end by at most [`SNAP_S`] (or a twentieth
//! of it) is taken as ended (its last deposits laid at the arc's stop), a longer shortfall as a
//! stop mid-pass that the next arc goes on from. What the log has not reached yet runs as
//! programmed from where the build stands: the rest of a burning pass at once, the next pass
//! after what is left of its programmed pause (none, where the cell has already waited longer),
//! at the power the arc burns at now (the program's while it is off). So what a row teaches is
//! what the cell did from that row on: the schedule before a row's time is fixed by the rows
//! before it, and a forecast made between two rows uses nothing the later one says.

use serde::{Deserialize, Serialize};
use thermal::schedule::Deposit;

/// A pass the arc leaves with at most this much of it unburnt is done, s.
pub const SNAP_S: f64 = 2.0;

/// Times closer than this are one, s.
const EPS_S: f64 = 1e-9;

/// One row of the machine log.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MachineRow {
    pub t_s: f64,
    pub arc_on: bool,
    /// V·I, where the log has them.
    pub power_w: Option<f64>,
}

/// The program, the schedule as run so far and as it will go on, and where the log has taken
/// it.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct AsRun {
    program: Vec<Deposit>,
    /// The program's power, W, that its deposits' heat was made with.
    program_power_w: f64,
    /// Per deposit, the pass it belongs to (a run of deposits without a pause).
    pass_of: Vec<usize>,
    /// The schedule the twin runs: deposits `..next` as they were laid, the rest as they will.
    pub deps: Vec<Deposit>,
    /// The first deposit not yet laid, and the arc seconds burnt toward it.
    next: usize,
    burnt_s: f64,
    /// The last row: its time, arc and power.
    last: Option<MachineRow>,
    /// When the arc last stopped, s.
    off_since: Option<f64>,
    pub stops: usize,
    pub stops_mid_pass: usize,
    pub rows: usize,
    /// Σ P_log·t over the arc seconds logged, J, and those seconds.
    energy_j: f64,
    arc_s: f64,
}

impl AsRun {
    /// `program` as the cell was told to run it, made at `power_w`.
    pub fn new(program: Vec<Deposit>, power_w: f64) -> AsRun {
        let mut pass_of = Vec::with_capacity(program.len());
        for (i, d) in program.iter().enumerate() {
            let paused = i > 0 && d.arc_start() > program[i - 1].time + 1e-9;
            let p = pass_of.last().copied().unwrap_or(0) + usize::from(paused);
            pass_of.push(p);
        }
        AsRun {
            deps: program.clone(),
            program,
            program_power_w: power_w,
            pass_of,
            next: 0,
            burnt_s: 0.0,
            last: None,
            off_since: None,
            stops: 0,
            stops_mid_pass: 0,
            rows: 0,
            energy_j: 0.0,
            arc_s: 0.0,
        }
    }

    /// How many deposits the log has laid.
    pub fn laid(&self) -> usize {
        self.next
    }

    /// The mean logged power over the arc's seconds, W.
    pub fn mean_power_w(&self) -> Option<f64> {
        (self.arc_s > 0.0).then(|| self.energy_j / self.arc_s)
    }

    /// How late the rest of the program runs against its own clock, s (negative: early).
    pub fn late_s(&self) -> f64 {
        match self.program.get(self.next) {
            Some(p) => self.deps[self.next].time - p.time,
            None => {
                self.deps.last().map_or(0.0, |d| d.time)
                    - self.program.last().map_or(0.0, |d| d.time)
            }
        }
    }

    /// Take a row: the state of the last row held until it, so the arc seconds between them
    /// lay what they lay. Rows at or before the last are ignored. Returns whether the
    /// schedule changed.
    pub fn feed(&mut self, row: MachineRow) -> bool {
        let Some(last) = self.last else {
            self.last = Some(row);
            self.off_since = (!row.arc_on).then_some(row.t_s);
            self.rows += 1;
            return self.plan_rest(row.t_s);
        };
        if row.t_s <= last.t_s {
            return false;
        }
        self.rows += 1;
        if last.arc_on {
            let power = last.power_w.unwrap_or(self.program_power_w);
            self.burn(last.t_s, row.t_s, power);
        }
        match (last.arc_on, row.arc_on) {
            (true, false) => {
                self.stops += 1;
                self.off_since = Some(row.t_s);
                self.snap(row.t_s);
            }
            (false, true) => self.off_since = None,
            _ => {}
        }
        self.last = Some(row);
        self.plan_rest(row.t_s)
    }

    /// The arc burns from `t0` to `t1` at `power_w`: lay what it reaches.
    fn burn(&mut self, t0: f64, t1: f64, power_w: f64) {
        self.energy_j += power_w * (t1 - t0);
        self.arc_s += t1 - t0;
        let mut t = t0;
        while let Some(p) = self.program.get(self.next) {
            let need = p.arc_time - self.burnt_s;
            // Within a nanosecond is reached: rows' times and arc times sum with round-off.
            if t + need > t1 + EPS_S {
                self.burnt_s += t1 - t;
                return;
            }
            t += need;
            self.lay(t, power_w);
        }
    }

    /// Lay deposit `next`, ending at `t_s`, at `power_w`.
    fn lay(&mut self, t_s: f64, power_w: f64) {
        let p = &self.program[self.next];
        self.deps[self.next] = Deposit {
            time: t_s,
            heat: p.heat * power_w / self.program_power_w,
            ..*p
        };
        self.next += 1;
        self.burnt_s = 0.0;
    }

    /// The arc stopped at `t_s`: a pass with little left is done (its rest laid now), one with
    /// more is stopped mid-pass.
    fn snap(&mut self, t_s: f64) {
        let Some(&pass) = self.pass_of.get(self.next) else {
            return;
        };
        let starts_pass = self.next == 0 || self.pass_of[self.next - 1] != pass;
        if self.burnt_s < EPS_S && starts_pass {
            // The pass before ended with this stop, to the second.
            return;
        }
        let rest: Vec<usize> = (self.next..self.program.len())
            .take_while(|&i| self.pass_of[i] == pass)
            .collect();
        let left: f64 = rest.iter().map(|&i| self.program[i].arc_time).sum::<f64>() - self.burnt_s;
        let whole: f64 = (0..self.program.len())
            .filter(|&i| self.pass_of[i] == pass)
            .map(|i| self.program[i].arc_time)
            .sum();
        if left > SNAP_S.max(whole / 20.0) {
            self.stops_mid_pass += 1;
            return;
        }
        let power = self
            .last
            .and_then(|l| l.power_w)
            .unwrap_or(self.program_power_w);
        for _ in rest {
            // Squeezed into the stop's instant: at most SNAP_S of arc, its heat all the same.
            let arc = self.program[self.next].arc_time;
            self.lay(t_s, power);
            self.deps[self.next - 1].arc_time = arc.min(1e-3);
        }
    }

    /// The deposits not yet laid, on from `now_s` as programmed. Returns whether any moved.
    fn plan_rest(&mut self, now_s: f64) -> bool {
        let Some(p) = self.program.get(self.next) else {
            return false;
        };
        let burning = self.last.is_some_and(|l| l.arc_on);
        // Where the rest starts: the next deposit's end, on from now.
        let end = match (burning, self.off_since) {
            (true, _) | (false, None) => now_s + p.arc_time - self.burnt_s,
            (false, Some(off)) => {
                let mid_pass = self.burnt_s > EPS_S
                    || (self.next > 0 && self.pass_of[self.next] == self.pass_of[self.next - 1]);
                let start = match (mid_pass, self.next) {
                    // Not begun: as programmed, or as late as the cell is.
                    (false, 0) => p.arc_start(),
                    (true, _) => off,
                    (false, n) => off + p.arc_start() - self.program[n - 1].time,
                }
                .max(now_s);
                start + p.arc_time - self.burnt_s
            }
        };
        let shift = end - p.time;
        // At the power the arc burns at now (the rows to come are laid at the row's own), or
        // the program's.
        let power = self
            .last
            .filter(|l| l.arc_on)
            .and_then(|l| l.power_w)
            .unwrap_or(self.program_power_w);
        let mut moved = false;
        for i in self.next..self.program.len() {
            let p = &self.program[i];
            let d = Deposit {
                time: p.time + shift,
                heat: p.heat * power / self.program_power_w,
                ..*p
            };
            moved |= (self.deps[i].time - d.time).abs() > 1e-9 || self.deps[i].heat != d.heat;
            self.deps[i] = d;
        }
        moved
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two passes of ten 1 s deposits, 10 s apart (0–10 s, 20–30 s), at 1000 W.
    fn program() -> Vec<Deposit> {
        (0..20)
            .map(|i| {
                let start = if i < 10 { i as f64 } else { 10.0 + i as f64 };
                Deposit {
                    position: [i as f64 * 1e-3, 0.0, 0.0],
                    time: start + 1.0,
                    arc_time: 1.0,
                    heat: 800.0,
                    width: 4e-3,
                    height: 2e-3,
                    axis: [0.0, 0.0, 1.0],
                    support: None,
                    start: None,
                    drop: None,
                }
            })
            .collect()
    }

    fn feed(a: &mut AsRun, rows: &[(f64, bool, f64)]) {
        for &(t, on, p) in rows {
            a.feed(MachineRow {
                t_s: t,
                arc_on: on,
                power_w: Some(p),
            });
        }
    }

    /// A log that says what the program says changes nothing.
    #[test]
    fn the_program_as_logged_is_the_program() {
        let mut a = AsRun::new(program(), 1000.0);
        let rows: Vec<(f64, bool, f64)> = (0..=40)
            .map(|t| {
                let t = t as f64;
                (t, t < 10.0 || (20.0..30.0).contains(&t), 1000.0)
            })
            .collect();
        feed(&mut a, &rows);
        assert_eq!(a.laid(), 20);
        for (d, p) in a.deps.iter().zip(program()) {
            assert!(
                (d.time - p.time).abs() < 1e-9,
                "{} against {}",
                d.time,
                p.time
            );
            assert_eq!(d.heat, p.heat);
        }
        assert_eq!((a.stops, a.stops_mid_pass), (2, 0));
        assert_eq!(a.mean_power_w(), Some(1000.0));
    }

    /// The arc stops 4 s into the first pass for 6 s, then runs on: the pass's last six
    /// deposits come 6 s late, the second pass starts its programmed 10 s after the first
    /// pass's end, and the rest of the program, not yet logged, moves with it.
    #[test]
    fn a_stop_mid_pass_and_a_restart_move_the_rest() {
        let mut a = AsRun::new(program(), 1000.0);
        let on = |t: f64| t < 4.0 || (10.0..16.0).contains(&t);
        let rows: Vec<(f64, bool, f64)> =
            (0..=17).map(|t| (t as f64, on(t as f64), 1000.0)).collect();
        feed(&mut a, &rows);
        assert_eq!(a.stops_mid_pass, 1);
        assert_eq!(a.laid(), 10);
        assert!((a.deps[3].time - 4.0).abs() < 1e-9);
        assert!((a.deps[4].time - 11.0).abs() < 1e-9, "{}", a.deps[4].time);
        assert!((a.deps[9].time - 16.0).abs() < 1e-9);
        // The second pass, unlogged: 10 s after the stop at 16 s.
        assert!(
            (a.deps[10].arc_start() - 26.0).abs() < 1e-9,
            "{}",
            a.deps[10].arc_start()
        );
        assert!((a.late_s() - 6.0).abs() < 1e-9);
    }

    /// The operator cuts the pause short (the second pass starts at 14 s, not 20 s) and at
    /// twice the power: its deposits come 6 s early with twice the heat.
    #[test]
    fn an_early_start_at_another_power() {
        let mut a = AsRun::new(program(), 1000.0);
        let rows: Vec<(f64, bool, f64)> = (0..=30)
            .map(|t| {
                let t = t as f64;
                match t {
                    t if t < 10.0 => (t, true, 1000.0),
                    t if t < 14.0 => (t, false, 0.0),
                    t => (t, t < 24.0, 2000.0),
                }
            })
            .collect();
        feed(&mut a, &rows);
        assert_eq!(a.laid(), 20);
        assert!((a.deps[10].time - 15.0).abs() < 1e-9, "{}", a.deps[10].time);
        assert_eq!(a.deps[10].heat, 1600.0);
        assert!((a.late_s() + 6.0).abs() < 1e-9);
    }

    /// The log ends a pass 1 s short (within SNAP_S): the pass is done, its last deposit laid
    /// at the stop, and the next arc starts the next pass.
    #[test]
    fn a_pass_ended_a_little_short_is_done() {
        let mut a = AsRun::new(program(), 1000.0);
        let rows: Vec<(f64, bool, f64)> = (0..=25)
            .map(|t| {
                let t = t as f64;
                (t, t < 9.0 || (20.0..30.0).contains(&t), 1000.0)
            })
            .collect();
        feed(&mut a, &rows);
        assert_eq!(a.stops_mid_pass, 0);
        assert!(a.laid() >= 15);
        assert!((a.deps[9].time - 9.0).abs() < 1e-9);
        assert!((a.deps[10].time - 21.0).abs() < 1e-9);
    }
}
