//! Bead cross-sections with the area rule of Eq.7: the wire fed in one second, π·d²·WFS/4, fills
//! the section times the travel in one second, so the section's area is A = π·d²·WFS/(4·TS).
//! Eq.7 takes the section as a rectangle W × LH; a real bead is rounder. For the same area and
//! width a parabolic cap stands 1.5 times as high and a circular cap between the two.

use std::f64::consts::PI;

#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Section {
    /// W × h (Eq.7).
    Rectangle,
    /// A parabolic cap of chord W and height h: A = (2/3)·W·h.
    Parabolic,
    /// A circular segment of chord W and height h ≤ W/2.
    Circular,
}

impl Section {
    /// Area (m²) of a bead of width `w` and height `h` (m).
    pub fn area(self, w: f64, h: f64) -> f64 {
        match self {
            Section::Rectangle => w * h,
            Section::Parabolic => 2.0 / 3.0 * w * h,
            Section::Circular => {
                // Radius from chord and sagitta, then segment area R²(θ − sin θ)/2 with θ the
                // subtended angle.
                let r = (w * w / 4.0 + h * h) / (2.0 * h);
                let theta = 2.0 * (w / (2.0 * r)).clamp(-1.0, 1.0).asin();
                let theta = if h > r { 2.0 * PI - theta } else { theta };
                0.5 * r * r * (theta - theta.sin())
            }
        }
    }

    /// Height (m) of a bead of area `a` and width `w`. A circular cap holds at most a half disc
    /// (h = W/2); a larger area gives `None`.
    pub fn height(self, a: f64, w: f64) -> Option<f64> {
        match self {
            Section::Rectangle => Some(a / w),
            Section::Parabolic => Some(1.5 * a / w),
            Section::Circular => {
                let max = Section::Circular.area(w, w / 2.0);
                (a <= max * (1.0 + 1e-12))
                    .then(|| bisect(|h| Section::Circular.area(w, h) - a, 0.0, w / 2.0))
            }
        }
    }

    /// Width (m) of a bead of area `a` and height `h`.
    pub fn width(self, a: f64, h: f64) -> Option<f64> {
        match self {
            Section::Rectangle => Some(a / h),
            Section::Parabolic => Some(1.5 * a / h),
            // Width from 2h (half disc) upwards; the area grows monotonically with the width.
            Section::Circular => {
                let min_area = Section::Circular.area(2.0 * h, h);
                if a < min_area * (1.0 - 1e-12) {
                    return None;
                }
                let mut hi = 2.0 * h;
                while Section::Circular.area(hi, h) < a {
                    hi *= 2.0;
                }
                Some(bisect(|w| Section::Circular.area(w, h) - a, 2.0 * h, hi))
            }
        }
    }

    /// Radius of curvature of the bead's top (m): the R_deposit of the skeleton-AM paper for a
    /// circular cap; for the others, the circle through the same chord and height.
    pub fn cap_radius(w: f64, h: f64) -> f64 {
        (w * w / 4.0 + h * h) / (2.0 * h)
    }
}

/// Root of an increasing function on [lo, hi] by bisection to machine precision.
fn bisect(f: impl Fn(f64) -> f64, mut lo: f64, mut hi: f64) -> f64 {
    for _ in 0..200 {
        let mid = 0.5 * (lo + hi);
        if f(mid) < 0.0 {
            lo = mid;
        } else {
            hi = mid;
        }
        if hi - lo <= 1e-15 * hi.abs().max(1e-300) {
            break;
        }
    }
    0.5 * (lo + hi)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn closed_forms() {
        let (w, h) = (5e-3, 2e-3);
        assert!((Section::Rectangle.area(w, h) - 1e-5).abs() < 1e-20);
        assert!((Section::Parabolic.area(w, h) - 2.0 / 3.0 * 1e-5).abs() < 1e-20);
        // Half disc: chord 2R, height R → πR²/2.
        assert!((Section::Circular.area(4e-3, 2e-3) - PI * 4e-6 / 2.0).abs() < 1e-18);
        // Circle of R = 5 mm, chord 8 mm → sagitta 2 mm, θ = 2·asin(0.8).
        let th = 2.0 * 0.8f64.asin();
        assert!((Section::Circular.area(8e-3, 2e-3) - 0.5 * 25e-6 * (th - th.sin())).abs() < 1e-18);
        assert!((Section::cap_radius(8e-3, 2e-3) - 5e-3).abs() < 1e-15);
    }

    #[test]
    fn every_section_conserves_area_both_ways() {
        let a = 1e-3 * 1e-3 * PI / 4.0 * 7.64 / 60.0 / 10e-3; // 1 mm wire, 7.64 m/min, 10 mm/s
        // 10 mm² does not fit a circular cap on a 5 mm chord (a half disc holds 9.8 mm²): use 6 mm.
        for s in [Section::Rectangle, Section::Parabolic, Section::Circular] {
            let w = 6e-3;
            let h = s.height(a, w).unwrap();
            assert!((s.area(w, h) / a - 1.0).abs() < 1e-12, "{s:?}");
            let w2 = s.width(a, h).unwrap();
            assert!((w2 / w - 1.0).abs() < 1e-9, "{s:?}: {w2}");
        }
        // Same area and width: parabolic is 1.5× the rectangle; circular in between.
        let (r, p, c) = (
            Section::Rectangle.height(a, 6e-3).unwrap(),
            Section::Parabolic.height(a, 6e-3).unwrap(),
            Section::Circular.height(a, 6e-3).unwrap(),
        );
        assert!((p / r - 1.5).abs() < 1e-12 && c > r && c < p, "{r} {p} {c}");
        assert!(Section::Circular.height(a, 5e-3).is_none());
    }
}
