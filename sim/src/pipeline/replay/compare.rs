//! The model held against what the part measured: samples paired in time, agreement over a
//! window, each pass of the torch as a probe saw it.

use thermal::ZERO_CELSIUS_K as C;
use thermal::run::ProbeTrace;
use thermal::schedule::Deposit;

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

/// How far past a trace's last time a reading still reads it, s: the run ends at the last
/// reading, its clock there summed step by step (a microsecond is far below any logger's).
const END_SLACK_S: f64 = 1e-6;

/// The trace at time t, K; None outside it or where it does not read.
fn at(trace: &ProbeTrace, t: f64) -> Option<f64> {
    let k = trace.time.partition_point(|&x| x < t);
    let v = match k {
        k if trace.time.get(k) == Some(&t) => trace.temperature[k],
        0 => return None,
        k if k == trace.time.len() && t - trace.time[k - 1] <= END_SLACK_S => {
            trace.temperature[k - 1]
        }
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

#[cfg(test)]
mod tests {
    use super::*;

    /// A reading at the trace's end reads it (within the run's clock's slack past it), one
    /// inside reads the line between its neighbours, one before the trace or well past it
    /// reads nothing.
    #[test]
    fn a_reading_pairs_inside_the_trace_and_at_its_end() {
        let mut trace = ProbeTrace::new([0.0; 3]);
        (trace.time, trace.temperature) = (vec![1.0, 3.0, 4.0], vec![400.0, 600.0, 500.0]);
        let c = |k: f64| k - C;
        let times = [0.5, 1.0, 2.0, 4.0, 4.0 + 5e-7, 4.01];
        let measured = vec![Some(0.0); times.len()];
        let got: Vec<(f64, f64)> = pair(&times, &measured, &trace)
            .into_iter()
            .map(|s| (s.0, s.2))
            .collect();
        let want = [
            (1.0, c(400.0)),
            (2.0, c(500.0)),
            (4.0, c(500.0)),
            (4.0 + 5e-7, c(500.0)),
        ];
        assert_eq!(got.len(), want.len(), "{got:?}");
        for (g, w) in got.iter().zip(want) {
            assert!(g.0 == w.0 && (g.1 - w.1).abs() < 1e-9, "{got:?}");
        }
    }
}
