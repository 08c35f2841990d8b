//! Discretisation of the generators into one continuous spiral (CTPP §2.3).
//!
//! Revolution after revolution the path visits the generators in order. The first revolutions
//! remove the start-up height discontinuity (§2.3.1, Table 1); the rest split each generator's
//! remaining length evenly (§2.3.2, Eq.5), so the last revolution ends exactly on the upper
//! boundary or at the closing point.

use std::fmt;

/// Deposits along the generators in one start-up revolution: linear in the generator's position
/// x = g/N around the revolution, from `first` (x = 0) to `last` (x = 1).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RampLayer {
    pub first: f64,
    pub last: f64,
}

impl RampLayer {
    pub fn at(&self, x: f64) -> f64 {
        self.first + (self.last - self.first) * x
    }
}

/// The start-up of §2.3.1. With Δh_j = j·(h_max − h_min) after j revolutions: while Δh_j < h the
/// revolution ramps linearly from h_min to h_max; the first revolution j* with Δh_j ≥ h ramps
/// from h_min to h_min + (h − Δh_{j*−1}), which puts its first and last points h apart (its
/// points lie between h_min and h_min + h above the previous revolution's first point). The next
/// revolution is regular: the discontinuity is gone.
#[derive(Debug, Clone, PartialEq)]
pub struct StartUp {
    pub layers: Vec<RampLayer>,
}

impl StartUp {
    pub fn new(h: f64, h_min: f64, h_max: f64) -> Result<StartUp, SpiralError> {
        let range = h_max - h_min;
        if range <= 0.0 {
            return Err(SpiralError::NoModulation { h_min, h_max });
        }
        let mut layers = Vec::new();
        // Relative slack so that 5 × 0.2h counts as h despite rounding.
        let eps = 1e-9 * h;
        for j in 1.. {
            let spread_before = (j - 1) as f64 * range;
            if j as f64 * range >= h - eps {
                layers.push(RampLayer {
                    first: h_min,
                    last: h_min + (h - spread_before),
                });
                break;
            }
            layers.push(RampLayer {
                first: h_min,
                last: h_max,
            });
        }
        Ok(StartUp { layers })
    }

    /// n_stepLayers of Table 1: the ramp revolutions plus the first regular one, on which the
    /// discontinuity has been eliminated (±10 % → 6).
    pub fn n_step_layers(&self) -> usize {
        self.layers.len() + 1
    }

    /// Height reached on the generator at position x after the start-up.
    pub fn height(&self, x: f64) -> f64 {
        self.layers.iter().map(|l| l.at(x)).sum()
    }
}

/// One point of the spiral: where on which generator, and the step d along the generator from the
/// point beneath it (the deposit before projection on the build direction).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpiralPoint {
    pub generator: usize,
    /// Revolution, counted from 0.
    pub layer: usize,
    /// Arc length along the generator, mm.
    pub s_mm: f64,
    pub step_mm: f64,
}

#[derive(Debug, Clone, PartialEq)]
pub struct Spiral {
    pub points: Vec<SpiralPoint>,
    pub start_up: StartUp,
    /// Eq.5: floor(min(L) / h_min), the revolutions after the start-up.
    pub n_layers: usize,
}

impl Spiral {
    pub fn n_revolutions(&self) -> usize {
        self.start_up.layers.len() + self.n_layers
    }
}

#[derive(Debug, Clone, PartialEq)]
pub enum SpiralError {
    NoModulation { h_min: f64, h_max: f64 },
    TooShort { shortest_mm: f64, start_up_mm: f64 },
}

impl fmt::Display for SpiralError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            SpiralError::NoModulation { h_min, h_max } => write!(
                f,
                "deposit window [{h_min}, {h_max}] mm has no modulation range; CTPP needs deposit_max_mm > deposit_min_mm"
            ),
            SpiralError::TooShort {
                shortest_mm,
                start_up_mm,
            } => write!(
                f,
                "the shortest generator ({shortest_mm:.2} mm) leaves less than one layer after the start-up ({start_up_mm:.2} mm)"
            ),
        }
    }
}

impl std::error::Error for SpiralError {}

/// Lay the spiral on generators of the given lengths (in path order).
pub fn spiral(lengths: &[f64], h: f64, h_min: f64, h_max: f64) -> Result<Spiral, SpiralError> {
    let start_up = StartUp::new(h, h_min, h_max)?;
    let n = lengths.len();
    let x = |g: usize| g as f64 / n as f64;
    let mut points =
        Vec::with_capacity(n * (start_up.layers.len() + (lengths[0] / h_min) as usize + 1));
    let mut reached = vec![0.0; n];
    for (j, layer) in start_up.layers.iter().enumerate() {
        for (g, r) in reached.iter_mut().enumerate() {
            let d = layer.at(x(g));
            *r += d;
            points.push(SpiralPoint {
                generator: g,
                layer: j,
                s_mm: *r,
                step_mm: d,
            });
        }
    }
    // Eq.5 on the remaining lengths.
    let remaining: Vec<f64> = (0..n).map(|g| lengths[g] - reached[g]).collect();
    let shortest = remaining.iter().cloned().fold(f64::INFINITY, f64::min);
    let n_layers = (shortest / h_min + 1e-9).floor() as usize;
    if n_layers == 0 {
        let g = (0..n)
            .min_by(|&a, &b| remaining[a].total_cmp(&remaining[b]))
            .expect("generators");
        return Err(SpiralError::TooShort {
            shortest_mm: lengths[g],
            start_up_mm: reached[g],
        });
    }
    let steps: Vec<f64> = remaining.iter().map(|l| l / n_layers as f64).collect();
    let first = start_up.layers.len();
    for k in 1..=n_layers {
        for g in 0..n {
            let s = if k == n_layers {
                lengths[g]
            } else {
                reached[g] + k as f64 * steps[g]
            };
            points.push(SpiralPoint {
                generator: g,
                layer: first + k - 1,
                s_mm: s,
                step_mm: steps[g],
            });
        }
    }
    Ok(Spiral {
        points,
        start_up,
        n_layers,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Table 1 of the CTPP paper: ±10 % needs 6 layers; Δh_j = 0.2 h per layer.
    #[test]
    fn table_1_ten_percent_needs_six_layers() {
        let h = 2.0;
        let s = StartUp::new(h, 0.9 * h, 1.1 * h).unwrap();
        assert_eq!(s.n_step_layers(), 6);
        assert_eq!(s.layers.len(), 5);
        for l in &s.layers[..4] {
            assert_eq!((l.first, l.last), (0.9 * h, 1.1 * h));
        }
        // After the start-up the first and last generators are h apart.
        assert!((s.height(1.0) - s.height(0.0) - h).abs() < 1e-12);
        // Other windows: ±20 % → Δh_j = 0.4 h, j* = 3, 4 layers; ±5 % → 11.
        assert_eq!(
            StartUp::new(h, 0.8 * h, 1.2 * h).unwrap().n_step_layers(),
            4
        );
        assert_eq!(
            StartUp::new(h, 0.95 * h, 1.05 * h).unwrap().n_step_layers(),
            11
        );
        // Every start-up deposit is inside the window.
        for w in [0.05, 0.1, 0.15, 0.3] {
            let s = StartUp::new(h, (1.0 - w) * h, (1.0 + w) * h).unwrap();
            for l in &s.layers {
                assert!(
                    l.first >= (1.0 - w) * h - 1e-12 && l.last <= (1.0 + w) * h + 1e-12,
                    "{w}: {l:?}"
                );
            }
        }
    }

    #[test]
    fn eq5_layer_count_and_exact_end() {
        let (h, lo, hi) = (2.0, 1.8, 2.2);
        let lengths = vec![160.0; 90];
        let sp = spiral(&lengths, h, lo, hi).unwrap();
        let startup_max = sp.start_up.height(89.0 / 90.0);
        assert_eq!(sp.n_layers, ((160.0 - startup_max) / lo).floor() as usize);
        for p in sp
            .points
            .iter()
            .filter(|p| p.layer == sp.n_revolutions() - 1)
        {
            assert_eq!(p.s_mm, 160.0);
        }
        assert!(
            sp.points
                .iter()
                .all(|p| p.step_mm >= lo - 1e-12 && p.step_mm <= hi + 1e-12)
        );
    }

    #[test]
    fn no_modulation_and_too_short_are_errors() {
        assert!(matches!(
            spiral(&[100.0; 10], 2.0, 2.0, 2.0),
            Err(SpiralError::NoModulation { .. })
        ));
        assert!(matches!(
            spiral(&[5.0; 10], 2.0, 1.8, 2.2),
            Err(SpiralError::TooShort { .. })
        ));
    }
}
