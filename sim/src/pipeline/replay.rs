//! A toolpath the machine ran, replayed on a heat model, and the model held against what the
//! part measured (no IO: the readers are in [`crate::measured`]).
//!
//! Each deposited segment of the toolpath becomes deposits no longer than `deposit_m`, timed
//! along it at its constant speed; a segment after travel with the arc off starts a new track
//! ([`Deposit::start`]). What a deposit lies on is the latest earlier deposit within half a
//! bead width across and about one layer below, or the plate.

use crate::measured::toolpath::Waypoint;
use thermal::ZERO_CELSIUS_K as C;
use thermal::run::ProbeTrace;
use thermal::schedule::Deposit;
use thermal::{HeatRun, ThermalError};

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

/// One probe's measurement against the model's prediction at the same place and times.
#[derive(Debug, Clone, PartialEq)]
pub struct Agreement {
    /// Samples where both read, inside the window.
    pub samples: usize,
    pub rms_c: f64,
    /// Largest |predicted − measured|, and when.
    pub max_abs_c: f64,
    pub max_at_s: f64,
    /// Mean of predicted − measured.
    pub bias_c: f64,
}

/// One sample: time, measured and predicted, °C.
pub type Sample = (f64, f64, f64);

/// The prediction at each measured time where both read (°C; `measured_c` already in °C),
/// the model's trace interpolated linearly.
pub fn pair(t_s: &[f64], measured_c: &[Option<f64>], trace: &ProbeTrace) -> Vec<Sample> {
    t_s.iter()
        .zip(measured_c)
        .filter_map(|(&t, m)| {
            let m = (*m)?;
            let p = at(trace, t)?;
            Some((t, m, p - C))
        })
        .collect()
}

/// The trace at time t, K; None outside it or where it does not read.
fn at(trace: &ProbeTrace, t: f64) -> Option<f64> {
    let k = trace.time.partition_point(|&x| x < t);
    let v = match k {
        k if trace.time.get(k) == Some(&t) => trace.temperature[k],
        0 => return None,
        k if k == trace.time.len() => return None,
        k => {
            let (t0, t1) = (trace.time[k - 1], trace.time[k]);
            let (v0, v1) = (trace.temperature[k - 1], trace.temperature[k]);
            v0 + (t - t0) / (t1 - t0) * (v1 - v0)
        }
    };
    v.is_finite().then_some(v)
}

/// How well the samples inside `window` (s, inclusive) agree; None without a sample there.
pub fn agreement(samples: &[Sample], window: (f64, f64)) -> Option<Agreement> {
    let inside: Vec<&Sample> = samples
        .iter()
        .filter(|s| s.0 >= window.0 && s.0 <= window.1)
        .collect();
    if inside.is_empty() {
        return None;
    }
    let n = inside.len() as f64;
    let errors = inside.iter().map(|s| (s.0, s.2 - s.1));
    let (mut sq, mut sum, mut max, mut max_at) = (0.0, 0.0, 0.0f64, window.0);
    for (t, e) in errors {
        sq += e * e;
        sum += e;
        if e.abs() > max {
            (max, max_at) = (e.abs(), t);
        }
    }
    Some(Agreement {
        samples: inside.len(),
        rms_c: (sq / n).sqrt(),
        max_abs_c: max,
        max_at_s: max_at,
        bias_c: sum / n,
    })
}

/// When each pass starts: a deposit after travel (a new track) or after a pause with the arc
/// off, s.
pub fn pass_starts(deps: &[Deposit]) -> Vec<f64> {
    let mut out = Vec::new();
    for (i, d) in deps.iter().enumerate() {
        let paused = i > 0 && d.arc_start() > deps[i - 1].time + 1e-9;
        if i == 0 || d.start.is_some() || paused {
            out.push(d.arc_start());
        }
    }
    out
}

/// One pass of the torch as a probe saw it: the highest temperature from its start to the next
/// pass's, and the temperature just before the next pass (what the next one is laid on), °C,
/// measured and predicted.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pass {
    pub start_s: f64,
    pub peak: Option<(f64, f64)>,
    pub before_next: Option<(f64, f64)>,
}

/// Each pass's peaks and the temperatures before the next, from paired samples.
pub fn passes(samples: &[Sample], starts: &[f64]) -> Vec<Pass> {
    starts
        .iter()
        .enumerate()
        .map(|(i, &a)| {
            let b = starts.get(i + 1).copied().unwrap_or(f64::INFINITY);
            let inside = samples.iter().filter(|s| s.0 >= a && s.0 < b);
            let peak = inside.fold(None, |m: Option<(f64, f64)>, s| {
                Some(m.map_or((s.1, s.2), |m| (m.0.max(s.1), m.1.max(s.2))))
            });
            let before_next = (b.is_finite())
                .then(|| samples.iter().rev().find(|s| s.0 < b && s.0 >= a))
                .flatten()
                .map(|s| (s.1, s.2));
            Pass {
                start_s: a,
                peak,
                before_next,
            }
        })
        .collect()
}

/// RMS and mean of predicted − measured over pairs.
pub fn errors(pairs: impl Iterator<Item = (f64, f64)>) -> Option<(f64, f64)> {
    let (mut n, mut sq, mut sum) = (0usize, 0.0, 0.0);
    for (m, p) in pairs {
        n += 1;
        sq += (p - m) * (p - m);
        sum += p - m;
    }
    (n > 0).then(|| ((sq / n as f64).sqrt(), sum / n as f64))
}

/// Go on with `run` (started on `deps`, wherever it stands) until `until_s`: lay the deposits
/// whose arc starts before then, each after the gap the schedule leaves before it, and cool
/// to `until_s` if the last comes earlier. A run stopped at T and advanced to T' gives what
/// one advanced to T' at once does, but for how its cooling is cut into steps.
pub fn advance(run: &mut impl HeatRun, deps: &[Deposit], until_s: f64) -> Result<(), ThermalError> {
    advance_observed(run, deps, until_s, &mut |_| {})
}

/// [`advance`], showing `after` the run after each deposit (a caller's checkpoints).
pub fn advance_observed<R: HeatRun>(
    run: &mut R,
    deps: &[Deposit],
    until_s: f64,
    after: &mut dyn FnMut(&R),
) -> Result<(), ThermalError> {
    for (i, d) in deps.iter().enumerate().skip(run.laid()) {
        if d.arc_start() >= until_s {
            break;
        }
        let previous_end = match i {
            0 => d.arc_start(),
            _ => deps[i - 1].time,
        };
        // From the schedule's own times, as `thermal::run::replay` lays them, unless the run
        // was cooled past the previous end (stopped at a window's end in between).
        let from = match run.now() > previous_end + 1e-9 {
            true => run.now(),
            false => previous_end,
        };
        run.deposit(i, (d.arc_start() - from).max(0.0))?;
        after(run);
    }
    if until_s > run.now() {
        run.cool(until_s - run.now())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn laying() -> Laying {
        Laying {
            power_w: 500.0,
            efficiency: 0.5,
            width_m: 2e-3,
            height_m: 0.75e-3,
            deposit_m: 1e-3,
        }
    }

    fn waypoint(t_s: f64, x: f64, z: f64, on: bool) -> Waypoint {
        Waypoint {
            t_s,
            position_mm: [x, 0.0, z],
            on,
            power_w: None,
        }
    }

    /// Two tracks one way with a return trip between: the second starts its own bead and lies
    /// on the first; each segment's heat is η·P over its share of the time.
    #[test]
    fn two_tracks_one_way() {
        let path = [
            waypoint(0.0, -2.0, 0.75, false),
            waypoint(4.0, 2.0, 0.75, true),
            waypoint(8.0, -2.0, 1.5, false),
            waypoint(12.0, 2.0, 1.5, true),
        ];
        let d = deposits(&path, &laying());
        assert_eq!(d.len(), 8);
        assert_eq!(d[0].start, Some([-2e-3, 0.0, 0.75e-3]));
        assert!(d[1..4].iter().all(|x| x.start.is_none()));
        assert_eq!(d[4].start, Some([-2e-3, 0.0, 1.5e-3]));
        assert!((d[0].arc_time - 1.0).abs() < 1e-12 && (d[0].heat - 250.0).abs() < 1e-9);
        assert_eq!(d[3].support, None);
        assert_eq!(d[4].support, Some(0));
        assert_eq!(d[7].support, Some(3));
        thermal::schedule::validate(&d).unwrap();
    }

    /// Two tracks make two passes; each pass's peak and the reading before the next come from
    /// its own samples.
    #[test]
    fn passes_of_two_tracks() {
        let path = [
            waypoint(0.0, -2.0, 0.75, false),
            waypoint(4.0, 2.0, 0.75, true),
            waypoint(8.0, -2.0, 1.5, false),
            waypoint(12.0, 2.0, 1.5, true),
        ];
        let starts = pass_starts(&deposits(&path, &laying()));
        assert_eq!(starts, vec![0.0, 8.0]);
        let samples = [
            (1.0, 900.0, 950.0),
            (7.0, 300.0, 280.0),
            (9.0, 1000.0, 900.0),
            (11.0, 500.0, 520.0),
        ];
        let p = passes(&samples, &starts);
        assert_eq!(p[0].peak, Some((900.0, 950.0)));
        assert_eq!(p[0].before_next, Some((300.0, 280.0)));
        assert_eq!(p[1].peak, Some((1000.0, 900.0)));
        assert_eq!(p[1].before_next, None);
        let (rms, bias) = errors(p.iter().filter_map(|p| p.peak)).unwrap();
        // Errors +50 and −100 °C.
        assert!((rms - 6250.0f64.sqrt()).abs() < 1e-9, "{rms}");
        assert!((bias - (-25.0)).abs() < 1e-9);
    }

    #[test]
    fn agreement_of_known_errors() {
        let trace = ProbeTrace {
            position: [0.0; 3],
            time: vec![0.0, 1.0, 2.0],
            temperature: vec![f64::NAN, C + 110.0, C + 130.0],
        };
        let t = [0.5, 1.0, 1.5, 2.0, 3.0];
        let m = [Some(1.0), Some(100.0), None, Some(140.0), Some(1.0)];
        let s = pair(&t, &m, &trace);
        // 0.5 s: the trace does not read yet; 1.5 s: no measurement; 3 s: past the trace.
        assert_eq!(s.len(), 2);
        let a = agreement(&s, (0.0, 10.0)).unwrap();
        assert_eq!(a.samples, 2);
        assert!((a.rms_c - 10.0).abs() < 1e-9);
        assert!(a.bias_c.abs() < 1e-9);
        assert!(agreement(&s, (5.0, 6.0)).is_none());
    }
}

#[cfg(test)]
mod checkpoint_tests {
    use super::*;
    use crate::pipeline::deposition::heat_model_of;
    use crate::pipeline::params::{ThermalModel, ThermalSettings};

    /// A run stopped in a gap of the schedule (a calibration's fit window ending between two
    /// tracks) and advanced from its clone ends where a run advanced at once does: the same
    /// deposits laid, every deposit's metal within 0.1 K (the cooling is cut into steps
    /// differently), on the voxel model with a plate of its own material.
    #[test]
    fn a_run_resumed_from_its_checkpoint_ends_where_one_run_does() {
        let path: Vec<Waypoint> = (0..6)
            .flat_map(|k| {
                let (t, z) = (10.0 * k as f64, 1.5 * (k + 1) as f64);
                let at = |t_s, x, on| Waypoint {
                    t_s,
                    position_mm: [x, 0.0, z],
                    on,
                    power_w: None,
                };
                [at(t, -15.0, false), at(t + 5.0, 15.0, true)]
            })
            .collect();
        let l = Laying {
            power_w: 2000.0,
            efficiency: 0.8,
            width_m: 4e-3,
            height_m: 1.5e-3,
            deposit_m: 2e-3,
        };
        let deps = deposits(&path, &l);
        let t = ThermalSettings {
            table_contact_w_m2k: 100.0,
            plate_cell_m: 5e-3,
            node_m: 3e-3,
            deposit_k: 1823.15,
            footprint_m: 4e-3,
            hot_threshold_k: 873.15,
            temperature_dependent: true,
            voxel_m: 2e-3,
            model: ThermalModel::Voxel,
            ambient_k: 293.15,
            convection_w_m2k: 15.0,
            emissivity: 0.6,
            plate_m: [60e-3, 30e-3, 10e-3],
            plate_fit: false,
            plate_disc: false,
            lead_m: 10e-3,
        };
        let mut model = heat_model_of(
            thermal::material::Material::in718(),
            &t,
            &deps,
            vec![],
            vec![],
        );
        model.set_plate_material(Some(thermal::material::Material::g3si()));
        let (end, gap) = (62.0, 27.5);
        let mut once = model.start(&deps).unwrap();
        advance(&mut once, &deps, end).unwrap();
        let mut stopped = model.start(&deps).unwrap();
        advance(&mut stopped, &deps, gap).unwrap();
        assert!((stopped.now() - gap).abs() < 1e-9 && stopped.laid() < deps.len());
        let mut resumed = stopped.clone();
        advance(&mut resumed, &deps, end).unwrap();
        assert_eq!((once.laid(), resumed.laid()), (deps.len(), deps.len()));
        assert!((once.now() - resumed.now()).abs() < 1e-9);
        let worst = (0..deps.len())
            .map(|i| (once.temperature_of(i) - resumed.temperature_of(i)).abs())
            .fold(0.0, f64::max);
        assert!(worst < 0.1, "{worst} K");
        let hottest = (0..deps.len())
            .map(|i| once.temperature_of(i))
            .fold(0.0, f64::max);
        assert!(hottest > 400.0, "{hottest} K: the part still warm");
    }
}
