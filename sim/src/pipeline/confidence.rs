//! Plans at a confidence (issue 29, item 2): dwells sized so that every point meets the
//! criteria at the q-quantile of the calibrated parameters' uncertainty, not only at their mean.
//!
//! The method is the first-order reliability method's design point (Hasofer and Lind 1974;
//! Ditlevsen and Madsen, *Structural Reliability Methods*, 1996, §5): a point's preheat T(θ) is
//! near-linear in the parameters over their spread, T ≈ T(θ̄) + gᵀ(θ − θ̄), so its q-quantile
//! under θ ~ N(θ̄, Σ) is T(θ̄) + z_q·√(gᵀΣg), which is T at the one parameter set
//! θ* = θ̄ + z_q·Σg/√(gᵀΣg). Every point's preheat grows the same way with the heat put in and
//! falls with each loss, so one θ* serves all of them: the plan is searched once, at θ*, instead
//! of over an ensemble. g is the gradient of the mean preheat over the points, by one run per
//! parameter a standard deviation from the mean. That this gives the quantile is checked on the
//! plan itself: [`check`] runs it under fresh draws from N(θ̄, Σ) and compares each point's
//! empirical q-quantile with its preheat at θ* (dwell.json's `quantile_check`).

use super::deposition::Cooling;
use super::params::Params;
use super::replay::Parameter;
use super::{Build, Simulation};
use rand::SeedableRng;
use rayon::prelude::*;
use statrs::distribution::{ContinuousCDF, Normal};
use thermal::ThermalError;

/// What a plan at a confidence needs: the quantile, the parameters' distribution, the check.
#[derive(Debug, Clone, PartialEq)]
pub struct Settings {
    /// q, in (0.5, 1).
    pub confidence: f64,
    /// Fresh draws the final plan is checked under.
    pub check_draws: usize,
    pub seed: u64,
    pub uncertainty: Uncertainty,
}

/// Calibrated parameters as a normal distribution, cut at their search ranges.
#[derive(Debug, Clone, PartialEq)]
pub struct Uncertainty {
    pub parameters: Vec<Parameter>,
    pub mean: Vec<f64>,
    /// In the parameters' order and units.
    pub covariance: Vec<Vec<f64>>,
    pub bounds: Vec<[f64; 2]>,
}

impl Uncertainty {
    pub fn sd(&self) -> Vec<f64> {
        (0..self.mean.len())
            .map(|i| self.covariance[i][i].max(0.0).sqrt())
            .collect()
    }

    fn clamp(&self, x: &mut [f64]) {
        for (v, [lo, hi]) in x.iter_mut().zip(&self.bounds) {
            *v = v.clamp(*lo, *hi);
        }
    }
}

/// `p` with `parameters` at `x`.
pub fn params_at(p: &Params, parameters: &[Parameter], x: &[f64]) -> Params {
    let mut p = p.clone();
    for (&k, &v) in parameters.iter().zip(x) {
        match k {
            Parameter::Efficiency => p.process.efficiency = v,
            Parameter::Convection => p.thermal.convection_w_m2k = v,
            Parameter::Emissivity => p.thermal.emissivity = v,
            Parameter::TableContact => p.thermal.table_contact_w_m2k = v,
        }
    }
    p
}

/// The build `b` (its plan, its fitted plate) at the parameters `x`.
pub fn build_at(b: &Build, u: &Uncertainty, x: &[f64]) -> Build {
    Build::new(b.plan.clone(), params_at(&b.params, &u.parameters, x))
}

/// z_q, the standard normal's q-quantile.
pub fn z_of(q: f64) -> f64 {
    Normal::standard().inverse_cdf(q)
}

/// The design point of a plan's cooling.
#[derive(Debug, Clone, PartialEq)]
pub struct DesignPoint {
    /// θ*, in the parameters' order.
    pub x: Vec<f64>,
    /// ∂(mean preheat)/∂θ, K per unit of each parameter.
    pub gradient_k: Vec<f64>,
    /// √(gᵀΣg): the mean preheat's standard deviation, K.
    pub preheat_sd_k: f64,
    pub z: f64,
}

/// The mean preheat over the points, K: the response whose gradient sets θ*.
fn mean_preheat(s: &Simulation) -> f64 {
    let p = &s.result.points;
    p.iter().map(|r| r.preheat).sum::<f64>() / p.len().max(1) as f64
}

/// θ* for `cooling` on `b` at confidence `q`: 1 + n runs (the mean, and each parameter a
/// standard deviation toward the inside of its range).
pub fn design_point(
    b: &Build,
    u: &Uncertainty,
    q: f64,
    cooling: &Cooling,
) -> Result<DesignPoint, ThermalError> {
    let (n, sd) = (u.mean.len(), u.sd());
    let steps: Vec<Vec<f64>> = (0..=n)
        .map(|k| {
            let mut x = u.mean.clone();
            if k > 0 {
                let [lo, hi] = u.bounds[k - 1];
                let up = x[k - 1] + sd[k - 1];
                x[k - 1] = if up <= hi {
                    up
                } else {
                    (x[k - 1] - sd[k - 1]).max(lo)
                };
            }
            x
        })
        .collect();
    let responses = steps
        .par_iter()
        .map(|x| {
            Ok(mean_preheat(&build_at(b, u, x).simulate_cooled(
                cooling,
                0,
                Vec::new(),
            )?))
        })
        .collect::<Result<Vec<f64>, ThermalError>>()?;
    let gradient_k: Vec<f64> = (0..n)
        .map(|k| {
            let dx = steps[k + 1][k] - u.mean[k];
            if dx == 0.0 {
                0.0
            } else {
                (responses[k + 1] - responses[0]) / dx
            }
        })
        .collect();
    let sigma_g: Vec<f64> = (0..n)
        .map(|i| (0..n).map(|j| u.covariance[i][j] * gradient_k[j]).sum())
        .collect();
    let var: f64 = (0..n).map(|i| gradient_k[i] * sigma_g[i]).sum();
    let (z, sd_k) = (z_of(q), var.max(0.0).sqrt());
    let mut x = u.mean.clone();
    if sd_k > 0.0 {
        for i in 0..n {
            x[i] += z * sigma_g[i] / sd_k;
        }
    }
    u.clamp(&mut x);
    Ok(DesignPoint {
        x,
        gradient_k,
        preheat_sd_k: sd_k,
        z,
    })
}

/// `count` parameter sets drawn from N(θ̄, Σ) (its Cholesky factor times ChaCha's normals:
/// the same on every platform and thread count), each cut at the ranges.
pub fn draws(u: &Uncertainty, count: usize, seed: u64) -> Vec<Vec<f64>> {
    let n = u.mean.len();
    let cov = nalgebra::DMatrix::from_fn(n, n, |i, j| u.covariance[i][j]);
    // A covariance the data leave near-singular (convection against emissivity at −0.96 on
    // the GAMMA wall) may lose definiteness to rounding: a jitter of 1e-12 of its trace.
    let jitter = 1e-12 * cov.trace().max(f64::MIN_POSITIVE);
    let l = (cov.clone() + nalgebra::DMatrix::identity(n, n) * jitter)
        .cholesky()
        .map(|c| c.l())
        .unwrap_or_else(|| {
            nalgebra::DMatrix::from_diagonal(&cov.diagonal().map(|v| v.max(0.0).sqrt()))
        });
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(seed);
    (0..count)
        .map(|_| {
            let z = nalgebra::DVector::from_vec(super::twin::normals(&mut rng, n));
            let dx = &l * z;
            let mut x: Vec<f64> = (0..n).map(|i| u.mean[i] + dx[i]).collect();
            u.clamp(&mut x);
            x
        })
        .collect()
}

/// How a plan fares under fresh draws.
#[derive(Debug, Clone, PartialEq)]
pub struct Check {
    /// Draws under which some point the plan kept safe breaks a criterion.
    pub violated: usize,
    pub draws: usize,
    /// Per point, the q-quantile of its preheat over the draws, K.
    pub preheat_quantile_k: Vec<f64>,
}

impl Check {
    pub fn violation_probability(&self) -> f64 {
        self.violated as f64 / self.draws.max(1) as f64
    }
}

/// Run `cooling` on `b` under each of `draws`, judged by `b`'s criteria. `safe[i]`: point i
/// met them in the plan's own run; a point the plan could not keep safe (a closing zone no
/// remedy reaches) is reported by the plan itself and not counted again here.
pub fn check(
    b: &Build,
    u: &Uncertainty,
    cooling: &Cooling,
    safe: &[bool],
    draws: &[Vec<f64>],
    q: f64,
) -> Result<Check, ThermalError> {
    let runs = draws
        .par_iter()
        .map(|x| {
            let s = build_at(b, u, x).simulate_cooled(cooling, 0, Vec::new())?;
            let broke = s
                .risks(&b.criteria)
                .iter()
                .zip(safe)
                .any(|(r, &ok)| ok && r.is_some());
            let preheat: Vec<f64> = s.result.points.iter().map(|p| p.preheat).collect();
            Ok((broke, preheat))
        })
        .collect::<Result<Vec<(bool, Vec<f64>)>, ThermalError>>()?;
    let points = runs.first().map_or(0, |r| r.1.len());
    let preheat_quantile_k = (0..points)
        .map(|i| {
            let v: Vec<f64> = runs.iter().map(|r| r.1[i]).collect();
            super::twin::quantile(&v, q)
        })
        .collect();
    Ok(Check {
        violated: runs.iter().filter(|r| r.0).count(),
        draws: runs.len(),
        preheat_quantile_k,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn two() -> Uncertainty {
        Uncertainty {
            parameters: vec![Parameter::Efficiency, Parameter::Convection],
            mean: vec![0.6, 40.0],
            covariance: vec![vec![0.0004, -0.09], vec![-0.09, 25.0]],
            bounds: vec![[0.2, 0.95], [5.0, 150.0]],
        }
    }

    /// The draws keep the covariance they were drawn from (4000 draws: the sample moments'
    /// standard errors are about 1.6 % of a standard deviation and 0.016 in the correlation).
    #[test]
    fn draws_keep_their_correlation() {
        let u = two();
        let d = draws(&u, 4000, 7);
        let n = d.len() as f64;
        let m: Vec<f64> = (0..2)
            .map(|k| d.iter().map(|x| x[k]).sum::<f64>() / n)
            .collect();
        let c = |a: usize, b: usize| {
            d.iter().map(|x| (x[a] - m[a]) * (x[b] - m[b])).sum::<f64>() / (n - 1.0)
        };
        let sd = u.sd();
        assert!(((m[0] - 0.6) / sd[0]).abs() < 0.07, "{m:?}");
        assert!(((c(0, 0).sqrt() / sd[0]) - 1.0).abs() < 0.05);
        assert!(((c(1, 1).sqrt() / sd[1]) - 1.0).abs() < 0.05);
        let r = c(0, 1) / (c(0, 0) * c(1, 1)).sqrt();
        assert!((r - (-0.9)).abs() < 0.03, "correlation {r}");
        assert_eq!(draws(&u, 5, 7), draws(&u, 5, 7));
    }

    #[test]
    fn the_normal_quantiles() {
        assert!((z_of(0.95) - 1.644_853_6).abs() < 1e-6);
        assert!(z_of(0.5).abs() < 1e-9);
    }
}
