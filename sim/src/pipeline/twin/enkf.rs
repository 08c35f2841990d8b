//! The ensemble square-root filter, serial form (Whitaker & Hamill 2002, Mon. Wea. Rev. 130,
//! 1913–1924, Eqs. 2–13): one scalar reading at a time, no perturbed readings, each variable's
//! gain tapered by its distance to the sensor (Gaspari & Cohn 1999, Q. J. R. Meteorol. Soc.
//! 125, 723–757, Eq. 4.10), and the spread relaxed toward its prior after each analysis (RTPS,
//! Whitaker & Hamill 2012, Mon. Wea. Rev. 140, 3078–3089, Eq. 1): the inflation.
//!
//! An ensemble here is one `Vec<f64>` of member values per variable: the twin's variables are
//! its parameters and the temperatures of the cells around a sensor, the same cells in every
//! member (every member lays the same program, so the active cells agree).

/// Gaspari–Cohn's compactly supported fifth-order taper at distance `d` for half-width `c`:
/// 1 at the sensor, 0 from 2c on.
pub fn gaspari_cohn(d: f64, c: f64) -> f64 {
    let r = d.abs() / c;
    if r <= 1.0 {
        (((-0.25 * r + 0.5) * r + 0.625) * r - 5.0 / 3.0) * r * r + 1.0
    } else if r < 2.0 {
        ((((r / 12.0 - 0.5) * r + 0.625) * r + 5.0 / 3.0) * r - 5.0) * r + 4.0 - 2.0 / (3.0 * r)
    } else {
        0.0
    }
}

pub fn mean(v: &[f64]) -> f64 {
    v.iter().sum::<f64>() / v.len() as f64
}

/// Sample standard deviation (n − 1).
pub fn spread(v: &[f64]) -> f64 {
    let m = mean(v);
    (v.iter().map(|x| (x - m) * (x - m)).sum::<f64>() / (v.len() - 1).max(1) as f64).sqrt()
}

/// Assimilate one reading `y` of error variance `r` whose predicted values are `hx` (one per
/// member) into `vars` (per variable, one value per member), each variable's gain multiplied by
/// its taper in `rho`. Returns the innovation y − mean(hx); nothing changes (None) where the
/// members agree exactly on the reading (no covariance to spread it by).
pub fn assimilate(vars: &mut [Vec<f64>], rho: &[f64], hx: &[f64], y: f64, r: f64) -> Option<f64> {
    let n = hx.len();
    let hbar = mean(hx);
    let hp: Vec<f64> = hx.iter().map(|h| h - hbar).collect();
    let var = hp.iter().map(|p| p * p).sum::<f64>() / (n - 1) as f64;
    if var <= 0.0 || !var.is_finite() {
        return None;
    }
    let d = y - hbar;
    // The square root's factor for the anomalies (Eq. 13): the mean takes the full gain, the
    // anomalies a reduced one, so that the posterior spread is the Kalman filter's exactly.
    let alpha = 1.0 / (1.0 + (r / (var + r)).sqrt());
    for (x, &taper) in vars.iter_mut().zip(rho) {
        if taper == 0.0 {
            continue;
        }
        let xbar = mean(x);
        let cov = x
            .iter()
            .zip(&hp)
            .map(|(xi, p)| (xi - xbar) * p)
            .sum::<f64>()
            / (n - 1) as f64;
        let k = taper * cov / (var + r);
        for (xi, p) in x.iter_mut().zip(&hp) {
            let anomaly = *xi - xbar - alpha * k * p;
            *xi = xbar + k * d + anomaly;
        }
    }
    Some(d)
}

/// Relax each variable's posterior spread toward its prior spread `before` by `alpha` (RTPS):
/// the anomalies scaled by 1 + α(σ_b − σ_a)/σ_a.
pub fn relax(vars: &mut [Vec<f64>], before: &[f64], alpha: f64) {
    for (x, &sb) in vars.iter_mut().zip(before) {
        let sa = spread(x);
        if sa <= 0.0 || !sa.is_finite() {
            continue;
        }
        let scale = 1.0 + alpha * (sb - sa) / sa;
        let xbar = mean(x);
        for xi in x.iter_mut() {
            *xi = xbar + scale * (*xi - xbar);
        }
    }
}

/// Widen each variable whose spread is below `floor` to it, its mean kept.
pub fn at_least(vars: &mut [Vec<f64>], floor: &[f64]) {
    for (x, &f) in vars.iter_mut().zip(floor) {
        let sa = spread(x);
        if sa < f && sa > 0.0 {
            let xbar = mean(x);
            for xi in x.iter_mut() {
                *xi = xbar + f / sa * (*xi - xbar);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Two correlated variables, the first one read: the mean moves by the Kalman gain
    /// computed from the ensemble's own covariance, the read variable's variance becomes
    /// (1 − K)·σ² exactly (the square root's property), and the unread one moves by its
    /// regression on the read one.
    #[test]
    fn one_reading_gives_the_kalman_update_exactly() {
        let a = vec![1.0, 2.0, 4.0, 5.0, 3.0, 6.0];
        let b: Vec<f64> = a
            .iter()
            .enumerate()
            .map(|(i, x)| 2.0 * x + (i % 2) as f64)
            .collect();
        let mut vars = vec![a.clone(), b.clone()];
        let (y, r) = (6.0, 1.5);
        let var_a = spread(&a).powi(2);
        let cov_ab = {
            let (ma, mb) = (mean(&a), mean(&b));
            a.iter()
                .zip(&b)
                .map(|(x, z)| (x - ma) * (z - mb))
                .sum::<f64>()
                / 5.0
        };
        let d = assimilate(&mut vars, &[1.0, 1.0], &a, y, r).unwrap();
        assert!((d - (y - mean(&a))).abs() < 1e-12);
        let k = var_a / (var_a + r);
        assert!((mean(&vars[0]) - (mean(&a) + k * d)).abs() < 1e-12);
        assert!((spread(&vars[0]).powi(2) - (1.0 - k) * var_a).abs() < 1e-12);
        let kb = cov_ab / (var_a + r);
        assert!((mean(&vars[1]) - (mean(&b) + kb * d)).abs() < 1e-12);
    }

    /// A taper of 0 leaves a variable alone; Gaspari–Cohn is 1 at the sensor, ~0.208 at c
    /// (5/24 exactly), and 0 from 2c on.
    #[test]
    fn the_taper_cuts_the_update_off() {
        assert_eq!(gaspari_cohn(0.0, 1.0), 1.0);
        assert!((gaspari_cohn(1.0, 1.0) - 5.0 / 24.0).abs() < 1e-12);
        assert!(gaspari_cohn(1.999, 1.0) < 1e-6 && gaspari_cohn(2.0, 1.0) == 0.0);
        let far = vec![10.0, 11.0, 12.0];
        let mut vars = vec![vec![1.0, 2.0, 3.0], far.clone()];
        let hx = vars[0].clone();
        assimilate(&mut vars, &[1.0, 0.0], &hx, 5.0, 1.0).unwrap();
        assert_eq!(vars[1], far);
    }

    /// RTPS with α = 1 gives the prior spread back; the mean is kept.
    #[test]
    fn relaxation_restores_the_spread() {
        let mut vars = vec![vec![1.0, 1.5, 2.0]];
        relax(&mut vars, &[2.0], 1.0);
        assert!((spread(&vars[0]) - 2.0).abs() < 1e-12);
        assert!((mean(&vars[0]) - 1.5).abs() < 1e-12);
    }
}
