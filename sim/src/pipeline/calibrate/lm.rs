//! Least squares for a few model parameters against measurements (no IO): a bounded
//! Levenberg–Marquardt (Marquardt 1963, scaled damping) with forward-difference Jacobians,
//! where every evaluation of the residuals is a heat-model run, so the count of evaluations is
//! what the method is built around: each iteration costs n + 1 runs (n parameters), a rejected
//! step one more, and the whole fit stays under `max_runs`.
//!
//! Parameters are searched in units of their bounds (0 at `low`, 1 at `high`), and every step
//! is projected into them. The confidence intervals come from the Jacobian at the optimum,
//! cov = s²·(JᵀJ)⁻¹ with s² the residual variance over `independent` samples (a series sampled
//! faster than it decorrelates would otherwise claim intervals far too narrow).

use nalgebra::{DMatrix, DVector};

/// One parameter's search range, in its own unit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Range {
    pub low: f64,
    pub high: f64,
}

impl Range {
    fn unit(&self, v: f64) -> f64 {
        (v - self.low) / (self.high - self.low)
    }
    fn value(&self, u: f64) -> f64 {
        self.low + u.clamp(0.0, 1.0) * (self.high - self.low)
    }
}

/// What a fit found.
#[derive(Debug, Clone, PartialEq)]
pub struct Fit {
    pub values: Vec<f64>,
    /// RMS of the residuals at the start and at the end.
    pub rms_start: f64,
    pub rms: f64,
    /// Residual evaluations (model runs) spent.
    pub runs: usize,
    pub iterations: usize,
    /// Per parameter: RMS over the samples of ∂residual/∂parameter, residual units per
    /// parameter unit (how strongly the data see it).
    pub sensitivity: Vec<f64>,
    /// Per parameter: 95 % confidence interval, cut at the parameter's bounds; None where JᵀJ
    /// is singular (the data do not constrain that combination).
    pub ci95: Vec<Option<[f64; 2]>>,
    /// The values' covariance in the parameters' own units, s²·(JᵀJ)⁻¹ (the intervals'
    /// before their cut at the bounds), row-major in the parameters' order: what a later draw
    /// of parameter sets needs to keep their correlation. None where JᵀJ is singular.
    pub covariance: Option<Vec<Vec<f64>>>,
}

/// The settings of a fit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Settings {
    pub max_runs: usize,
    /// Step of the forward differences, in units of the bounds.
    pub step: f64,
    /// Stop once an accepted step lowers the sum of squares by less than this share.
    pub tolerance: f64,
    /// Independent samples among the residuals, for the intervals.
    pub independent: usize,
}

impl Default for Settings {
    fn default() -> Settings {
        Settings {
            max_runs: 24,
            step: 0.02,
            tolerance: 1e-3,
            independent: usize::MAX,
        }
    }
}

fn ssr(r: &[f64]) -> f64 {
    r.iter().map(|x| x * x).sum()
}

fn rms(r: &[f64]) -> f64 {
    (ssr(r) / r.len().max(1) as f64).sqrt()
}

/// Minimise the sum of squares of `residuals(values)` from `start` within `ranges`.
/// `residuals` must return the same number of residuals every time.
pub fn fit<E>(
    start: &[f64],
    ranges: &[Range],
    s: Settings,
    mut residuals: impl FnMut(&[f64]) -> Result<Vec<f64>, E>,
) -> Result<Fit, E> {
    fit_batched(start, ranges, s, |points| {
        points.iter().map(|p| residuals(p)).collect()
    })
}

/// [`fit`], handed the points it needs together: `residuals` takes several (a Jacobian's n,
/// else one) and returns theirs in the same order, so that a caller may evaluate them side by
/// side. The same points asked in the same order, and the same fit, as [`fit`].
pub fn fit_batched<E>(
    start: &[f64],
    ranges: &[Range],
    s: Settings,
    mut residuals: impl FnMut(&[Vec<f64>]) -> Result<Vec<Vec<f64>>, E>,
) -> Result<Fit, E> {
    let n = start.len();
    let values = |u: &[f64]| -> Vec<f64> { (0..n).map(|i| ranges[i].value(u[i])).collect() };
    let mut u: Vec<f64> = (0..n)
        .map(|i| ranges[i].unit(start[i]).clamp(0.0, 1.0))
        .collect();
    let mut r = one(&mut residuals, values(&u))?;
    let mut runs = 1;
    let rms_start = rms(&r);
    let mut lambda = 1e-2;
    let mut iterations = 0;
    let mut jac = None;
    while runs + n < s.max_runs {
        let j = jacobian(&u, &r, s.step, &mut runs, |us| {
            residuals(&us.iter().map(|u| values(u)).collect::<Vec<_>>())
        })?;
        let (a, g) = normal(&j, &r);
        jac = Some(j);
        iterations += 1;
        let mut accepted = false;
        // A rejected step costs a run: try at most two dampings per Jacobian.
        for _ in 0..2 {
            if runs >= s.max_runs {
                break;
            }
            let Some(delta) = damped_step(&a, &g, lambda) else {
                lambda *= 10.0;
                continue;
            };
            let trial: Vec<f64> = (0..n).map(|i| (u[i] + delta[i]).clamp(0.0, 1.0)).collect();
            if trial.iter().zip(&u).all(|(a, b)| (a - b).abs() < 1e-6) {
                break;
            }
            let rt = one(&mut residuals, values(&trial))?;
            runs += 1;
            if ssr(&rt) < ssr(&r) {
                let gain = (ssr(&r) - ssr(&rt)) / ssr(&r).max(f64::MIN_POSITIVE);
                (u, r) = (trial, rt);
                lambda = (lambda / 3.0).max(1e-7);
                accepted = gain >= s.tolerance;
                // The Jacobian now lies at the previous point; the intervals need it here.
                jac = None;
                break;
            }
            lambda *= 4.0;
        }
        if !accepted {
            break;
        }
    }
    // The Jacobian at the optimum, for the sensitivities and the intervals.
    let j = match jac {
        Some(j) => j,
        None => jacobian(&u, &r, s.step, &mut runs, |us| {
            residuals(&us.iter().map(|u| values(u)).collect::<Vec<_>>())
        })?,
    };
    let found = values(&u);
    let (sensitivity, ci95, covariance) = statistics(&j, &r, ranges, &found, s.independent);
    Ok(Fit {
        values: found,
        rms_start,
        rms: rms(&r),
        runs,
        iterations,
        sensitivity,
        ci95,
        covariance,
    })
}

/// The residuals of one point.
fn one<E>(
    residuals: &mut impl FnMut(&[Vec<f64>]) -> Result<Vec<Vec<f64>>, E>,
    point: Vec<f64>,
) -> Result<Vec<f64>, E> {
    residuals(&[point]).map(|mut r| r.pop().expect("one residual vector a point"))
}

/// Forward differences in units of the bounds, stepping inwards at an upper bound: the n
/// points asked together.
fn jacobian<E>(
    u: &[f64],
    r: &[f64],
    step: f64,
    runs: &mut usize,
    residuals: impl FnOnce(&[Vec<f64>]) -> Result<Vec<Vec<f64>>, E>,
) -> Result<DMatrix<f64>, E> {
    let steps: Vec<f64> = u
        .iter()
        .map(|&ui| if ui + step <= 1.0 { step } else { -step })
        .collect();
    let points: Vec<Vec<f64>> = (0..u.len())
        .map(|i| {
            let mut v = u.to_vec();
            v[i] += steps[i];
            v
        })
        .collect();
    let rs = residuals(&points)?;
    *runs += u.len();
    let mut j = DMatrix::zeros(r.len(), u.len());
    for (i, (ri, h)) in rs.iter().zip(&steps).enumerate() {
        for k in 0..r.len() {
            j[(k, i)] = (ri[k] - r[k]) / h;
        }
    }
    Ok(j)
}

fn normal(j: &DMatrix<f64>, r: &[f64]) -> (DMatrix<f64>, DVector<f64>) {
    let r = DVector::from_column_slice(r);
    (j.transpose() * j, j.transpose() * r)
}

/// (A + λ·diag A) δ = −g.
fn damped_step(a: &DMatrix<f64>, g: &DVector<f64>, lambda: f64) -> Option<DVector<f64>> {
    let mut m = a.clone();
    for i in 0..m.nrows() {
        m[(i, i)] += lambda * a[(i, i)].max(1e-12);
    }
    m.cholesky().map(|c| -c.solve(g))
}

/// Sensitivities, 95 % intervals and the covariance, in the parameters' own units.
type Statistics = (Vec<f64>, Vec<Option<[f64; 2]>>, Option<Vec<Vec<f64>>>);

/// [`Statistics`] of a fit whose Jacobian (in units of the bounds) is `j`.
fn statistics(
    j: &DMatrix<f64>,
    r: &[f64],
    ranges: &[Range],
    values: &[f64],
    independent: usize,
) -> Statistics {
    let (m, n) = (r.len(), ranges.len());
    let width = |i: usize| ranges[i].high - ranges[i].low;
    let sensitivity = (0..n)
        .map(|i| (j.column(i).norm_squared() / m.max(1) as f64).sqrt() / width(i))
        .collect();
    // Per-sample variance; the information in JᵀJ counted once per independent sample.
    let s2 = ssr(r) / m.saturating_sub(n).max(1) as f64;
    let inflate = m as f64 / independent.clamp(1, m.max(1)) as f64;
    let inverse = (j.transpose() * j).try_inverse();
    // In units of the bounds u = (p − low)/width, so p's covariance is W·cov_u·W.
    let covariance = inverse.as_ref().map(|c| {
        (0..n)
            .map(|i| {
                (0..n)
                    // Symmetric to the bit (an LU inverse need not be).
                    .map(|k| 0.5 * (c[(i, k)] + c[(k, i)]) * s2 * inflate * (width(i) * width(k)))
                    .collect()
            })
            .collect()
    });
    let ci = (0..n)
        .map(|i| {
            let var = inverse.as_ref()?[(i, i)] * s2 * inflate;
            // Cut at the bounds: a convection coefficient below zero is no answer, and an
            // interval cut there says the data do not hold the parameter on that side.
            (var.is_finite() && var >= 0.0).then(|| {
                let half = 1.96 * var.sqrt() * width(i);
                [
                    (values[i] - half).max(ranges[i].low),
                    (values[i] + half).min(ranges[i].high),
                ]
            })
        })
        .collect();
    (sensitivity, ci, covariance)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A line y = a·x + b with known a, b and noise: the fit finds them within their
    /// intervals, in a handful of evaluations.
    #[test]
    fn recovers_a_line_within_its_interval() {
        let xs: Vec<f64> = (0..200).map(|k| k as f64 / 20.0).collect();
        // Deterministic noise of RMS ~0.1.
        let noise = |k: usize| 0.1 * ((k as f64 * 12.9898).sin() * 43758.5453).fract().signum();
        let ys: Vec<f64> = xs
            .iter()
            .enumerate()
            .map(|(k, x)| 2.5 * x - 1.0 + noise(k))
            .collect();
        let ranges = [
            Range {
                low: 0.0,
                high: 10.0,
            },
            Range {
                low: -5.0,
                high: 5.0,
            },
        ];
        let f = fit(&[5.0, 0.0], &ranges, Settings::default(), |p| {
            Ok::<_, ()>(
                xs.iter()
                    .zip(&ys)
                    .map(|(x, y)| p[0] * x + p[1] - y)
                    .collect(),
            )
        })
        .unwrap();
        assert!((f.values[0] - 2.5).abs() < 0.02, "{:?}", f.values);
        assert!((f.values[1] + 1.0).abs() < 0.05, "{:?}", f.values);
        assert!(
            f.rms < 0.11 && f.rms_start > 1.0,
            "{} {}",
            f.rms_start,
            f.rms
        );
        let [lo, hi] = f.ci95[0].unwrap();
        assert!(lo < 2.5 && hi > 2.5 && hi - lo < 0.1, "{lo}..{hi}");
        assert!(f.runs <= 24);
        // Seen by the data: a unit of slope moves the residuals by the RMS of x (~5.8).
        assert!((f.sensitivity[0] - 5.77).abs() < 0.1, "{:?}", f.sensitivity);
        // The covariance is ordinary least squares' own, s²·(XᵀX)⁻¹ with X = [x 1] (the
        // forward differences are exact on a line): slope and intercept anticorrelated on
        // x ≥ 0, the intervals its diagonal's.
        let m = xs.len() as f64;
        let (sx, sxx) = (
            xs.iter().sum::<f64>(),
            xs.iter().map(|x| x * x).sum::<f64>(),
        );
        let r: Vec<f64> = xs
            .iter()
            .zip(&ys)
            .map(|(x, y)| f.values[0] * x + f.values[1] - y)
            .collect();
        let s2 = r.iter().map(|r| r * r).sum::<f64>() / (m - 2.0);
        let det = m * sxx - sx * sx;
        let expected =
            [[m / det, -sx / det], [-sx / det, sxx / det]].map(|row| row.map(|v| v * s2));
        let c = f.covariance.as_ref().expect("a covariance");
        for (i, row) in expected.iter().enumerate() {
            for (k, v) in row.iter().enumerate() {
                assert!(
                    (c[i][k] - v).abs() < 1e-6 * v.abs(),
                    "{c:?} against {expected:?}"
                );
            }
        }
        assert!(c[0][1] < 0.0 && c[0][1] == c[1][0]);
        assert!((hi - lo - 2.0 * 1.96 * c[0][0].sqrt()).abs() < 1e-9);
    }

    /// A bound holds: a slope that wants 2.5 inside [0, 2] stops at 2.
    #[test]
    fn stays_within_its_bounds() {
        let xs: Vec<f64> = (0..50).map(|k| k as f64).collect();
        let ranges = [Range {
            low: 0.0,
            high: 2.0,
        }];
        let f = fit(&[1.0], &ranges, Settings::default(), |p| {
            Ok::<_, ()>(xs.iter().map(|x| p[0] * x - 2.5 * x).collect())
        })
        .unwrap();
        assert!((f.values[0] - 2.0).abs() < 1e-9, "{:?}", f.values);
        let [lo, hi] = f.ci95[0].expect("an interval");
        assert!(lo < 2.0 && hi == 2.0, "{lo}..{hi}: cut at the upper bound");
    }
}
