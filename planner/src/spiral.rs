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
    /// The revolutions after the start-up: Eq.5's floor(min(L) / h_min), or the count
    /// [`place_seam`] chose.
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

/// Where the spiral starts (its seam) and how many regular revolutions follow the start-up.
///
/// After the start-up generator g has R_g left, and N revolutions step it R_g/N: Eq.6 holds on
/// the steps iff max(R)/h_max ≤ N ≤ min(R)/h_min. Eq.5 takes the upper end, floor(min(R)/h_min),
/// and never looks at the lower one. The start-up lays h more on the generator where the spiral
/// ends a revolution than where it starts one, so where the seam lies moves every R_g, and a
/// seam the lower loop did not happen to start at can keep a window Eq.5 breaks.
#[derive(Debug, Clone, PartialEq)]
pub struct Seam {
    /// The generator the spiral starts on, as the lengths were given.
    pub first: usize,
    /// Regular revolutions after the start-up.
    pub n_layers: usize,
    /// Eq.5's count with the spiral starting on generator 0.
    pub eq5_layers: usize,
    /// How far the steps R_g/N stay inside the window at the nearest bound, mm; negative: by
    /// how much the best choice misses it.
    pub margin_mm: f64,
    pub reason: SeamReason,
}

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SeamReason {
    /// Generator 0 and Eq.5's count keep every step in the window: nothing moved.
    Eq5Holds,
    /// Eq.5 at generator 0 breaks the window; this seam and count keep it.
    Moved,
    /// No seam and count keep every step in the window; this one misses it least.
    NoChoiceHolds,
}

impl SeamReason {
    pub fn key(&self) -> &'static str {
        match self {
            SeamReason::Eq5Holds => "eq5_holds",
            SeamReason::Moved => "moved_for_eq6",
            SeamReason::NoChoiceHolds => "no_choice_holds",
        }
    }
}

/// The lengths left after the start-up with the spiral starting on generator `first`.
fn remaining(lengths: &[f64], start_up: &StartUp, first: usize) -> Vec<f64> {
    let n = lengths.len();
    (0..n)
        .map(|g| lengths[g] - start_up.height(((g + n - first) % n) as f64 / n as f64))
        .collect()
}

/// The least distance of the steps R_g/N inside [h_min, h_max], mm (negative outside).
fn margin(remaining: &[f64], n_layers: usize, h_min: f64, h_max: f64) -> f64 {
    remaining
        .iter()
        .map(|r| {
            let step = r / n_layers as f64;
            (step - h_min).min(h_max - step)
        })
        .fold(f64::INFINITY, f64::min)
}

/// The count of regular revolutions for `remaining` that keeps the steps furthest inside the
/// window, with that margin: every N between max(R)/h_max and min(R)/h_min, or the two counts
/// around that gap where it is empty.
fn best_count(remaining: &[f64], h_min: f64, h_max: f64) -> Option<(usize, f64)> {
    let (lo, hi) = remaining
        .iter()
        .fold((f64::INFINITY, 0.0f64), |(a, b), &r| (a.min(r), b.max(r)));
    if lo <= 0.0 {
        return None;
    }
    let most = ((lo / h_min + 1e-9).floor() as usize).max(1);
    let least = ((hi / h_max - 1e-9).ceil() as usize).max(1);
    let (from, to) = (most.min(least), most.max(least));
    (from..=to)
        .map(|n| (n, margin(remaining, n, h_min, h_max)))
        .fold(None, |best: Option<(usize, f64)>, c| match best {
            Some(b) if b.1 >= c.1 => Some(b),
            _ => Some(c),
        })
}

/// Place the seam and count the revolutions (see [`Seam`]): Eq.5 at generator 0 where it holds
/// the window, else the seam and count that keep the steps furthest inside it, tried at every
/// generator.
pub fn place_seam(lengths: &[f64], h: f64, h_min: f64, h_max: f64) -> Result<Seam, SpiralError> {
    let start_up = StartUp::new(h, h_min, h_max)?;
    let at_zero = remaining(lengths, &start_up, 0);
    let shortest = at_zero.iter().cloned().fold(f64::INFINITY, f64::min);
    let eq5_layers = (shortest / h_min + 1e-9).floor() as usize;
    let too_short = || {
        let g = (0..lengths.len())
            .min_by(|&a, &b| at_zero[a].total_cmp(&at_zero[b]))
            .expect("generators");
        SpiralError::TooShort {
            shortest_mm: lengths[g],
            start_up_mm: lengths[g] - at_zero[g],
        }
    };
    if eq5_layers == 0 {
        return Err(too_short());
    }
    // Rounding slack: a step on the bound is in the window.
    let eq5_margin = margin(&at_zero, eq5_layers, h_min, h_max);
    if eq5_margin >= -1e-9 {
        return Ok(Seam {
            first: 0,
            n_layers: eq5_layers,
            eq5_layers,
            margin_mm: eq5_margin,
            reason: SeamReason::Eq5Holds,
        });
    }
    let (first, (n_layers, margin_mm)) = (0..lengths.len())
        .filter_map(|s| best_count(&remaining(lengths, &start_up, s), h_min, h_max).map(|c| (s, c)))
        .fold(None, |best: Option<(usize, (usize, f64))>, c| match best {
            Some(b) if b.1.1 >= c.1.1 => Some(b),
            _ => Some(c),
        })
        .ok_or_else(too_short)?;
    Ok(Seam {
        first,
        n_layers,
        eq5_layers,
        margin_mm,
        reason: match margin_mm >= -1e-9 {
            true => SeamReason::Moved,
            false => SeamReason::NoChoiceHolds,
        },
    })
}

/// Lay the spiral on generators of the given lengths (in path order), its regular revolutions
/// counted by Eq.5.
pub fn spiral(lengths: &[f64], h: f64, h_min: f64, h_max: f64) -> Result<Spiral, SpiralError> {
    spiral_of(lengths, h, h_min, h_max, None)
}

/// Lay the spiral on generators of the given lengths (in path order, the seam before the
/// first), with `n_layers` regular revolutions, or Eq.5's count where None.
pub fn spiral_of(
    lengths: &[f64],
    h: f64,
    h_min: f64,
    h_max: f64,
    n_layers: Option<usize>,
) -> Result<Spiral, SpiralError> {
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
    let n_layers = n_layers.unwrap_or((shortest / h_min + 1e-9).floor() as usize);
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

    /// Generators of a cylinder cut by a tilted plane: mean `height`, ±`height`·13/165 (the
    /// Table 2 ratio 178/152), the longest first, as the lower loop happened to start there.
    fn tilted(height: f64, n: usize) -> Vec<f64> {
        let slope = height * 13.0 / 165.0;
        (0..n)
            .map(|g| height + slope * (2.0 * std::f64::consts::PI * g as f64 / n as f64).cos())
            .collect()
    }

    /// Where Eq.5 at the longest generator breaks the window (a 60 mm tall tilted cylinder: its
    /// longest generators step 2.229 mm), the seam moves away from the longest, which then takes
    /// more of the start-up, and every step of the spiral laid from there is inside [1.8, 2.2].
    #[test]
    fn the_seam_moves_where_eq5_breaks_the_window() {
        let (h, lo, hi) = (2.0, 1.8, 2.2);
        let lengths = tilted(60.0, 120);
        let eq5 = spiral(&lengths, h, lo, hi).unwrap();
        let worst = eq5.points.iter().map(|p| p.step_mm).fold(0.0, f64::max);
        assert!(
            worst > hi + 1e-3,
            "Eq.5 at generator 0 breaks the window: {worst}"
        );
        let seam = place_seam(&lengths, h, lo, hi).unwrap();
        eprintln!("60 mm: Eq.5 at the longest steps up to {worst:.3} mm; {seam:?}");
        assert_eq!(seam.reason, SeamReason::Moved);
        assert!(seam.margin_mm >= 0.0, "{seam:?}");
        let mut rotated = lengths.clone();
        rotated.rotate_left(seam.first);
        let sp = spiral_of(&rotated, h, lo, hi, Some(seam.n_layers)).unwrap();
        let (dlo, dhi) = sp.points.iter().fold((f64::INFINITY, 0.0f64), |(a, b), p| {
            (a.min(p.step_mm), b.max(p.step_mm))
        });
        assert!(dlo >= lo - 1e-9 && dhi <= hi + 1e-9, "{dlo}..{dhi}");
        // The spiral ends a revolution on the longest generator: it lies last, or near it.
        let longest = (0..rotated.len())
            .max_by(|&a, &b| rotated[a].total_cmp(&rotated[b]))
            .unwrap();
        assert!(
            longest > rotated.len() / 2,
            "longest at {longest} of {}",
            rotated.len()
        );
    }

    /// Eq.5 at generator 0 is kept wherever it holds (the 165 mm part of Table 2), and where no
    /// seam and count can hold the window (lengths 1.5 : 1 against a 1.22 window) the least
    /// miss is reported, negative.
    #[test]
    fn eq5_is_kept_where_it_holds_and_a_miss_is_measured() {
        let (h, lo, hi) = (2.0, 1.8, 2.2);
        let seam = place_seam(&tilted(165.0, 120), h, lo, hi).unwrap();
        assert_eq!((seam.first, seam.reason), (0, SeamReason::Eq5Holds));
        assert_eq!(seam.n_layers, seam.eq5_layers);
        let wide: Vec<f64> = (0..60).map(|g| if g < 30 { 60.0 } else { 90.0 }).collect();
        let seam = place_seam(&wide, h, lo, hi).unwrap();
        assert_eq!(seam.reason, SeamReason::NoChoiceHolds);
        assert!(seam.margin_mm < -0.1, "{seam:?}");
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
