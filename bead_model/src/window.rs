//! The process window: the wire-feed range of the power source and the travel-speed range of the
//! robot bound the deposit heights Eq.7 can give for a bead width.

use crate::eq7;

/// Machine limits, SI (m, m/s).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Window {
    pub wire_diameter: f64,
    pub width: f64,
    pub wfs_min: f64,
    pub wfs_max: f64,
    pub travel_min: f64,
    pub travel_max: f64,
}

/// How the deposit height is modulated along the path.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Modulation {
    /// Constant travel speed, wire feed per point (the CTPP choice).
    WireFeed { travel: f64 },
    /// Constant wire feed, travel speed per point (Chalvin et al. 2019).
    TravelSpeed { wfs: f64 },
}

impl Window {
    /// The achievable [h_min, h_max] (m) under a modulation.
    pub fn heights(&self, m: Modulation) -> (f64, f64) {
        let (d, w) = (self.wire_diameter, self.width);
        match m {
            Modulation::WireFeed { travel } => (
                eq7::layer_height(d, self.wfs_min, w, travel),
                eq7::layer_height(d, self.wfs_max, w, travel),
            ),
            Modulation::TravelSpeed { wfs } => (
                eq7::layer_height(d, wfs, w, self.travel_max),
                eq7::layer_height(d, wfs, w, self.travel_min),
            ),
        }
    }

    /// The machine settings that lay `height`: (wire feed, travel speed), m/s.
    pub fn settings(&self, height: f64, m: Modulation) -> (f64, f64) {
        match m {
            Modulation::WireFeed { travel } => (
                eq7::wire_feed(height, self.wire_diameter, self.width, travel),
                travel,
            ),
            Modulation::TravelSpeed { wfs } => (
                wfs,
                eq7::travel_speed(height, self.wire_diameter, wfs, self.width),
            ),
        }
    }

    /// How much slower a point laid at (`wfs`, `travel`) can be laid with both divided by the
    /// same pace k ≥ 1 and still inside the window: Eq.7's height depends on WFS/TS alone, so the
    /// deposit stays as planned while the arc runs k times longer on a slower wire feed (whose
    /// power the synergic line gives). 1 when either is already at its lower limit (or below).
    pub fn slowest_pace(&self, wfs: f64, travel: f64) -> f64 {
        (wfs / self.wfs_min).min(travel / self.travel_min).max(1.0)
    }

    /// Indices of the heights the window cannot lay.
    pub fn outside(&self, heights: &[f64], m: Modulation) -> Vec<usize> {
        let (lo, hi) = self.heights(m);
        let eps = 1e-12 * hi;
        heights
            .iter()
            .enumerate()
            .filter(|&(_, &h)| h < lo - eps || h > hi + eps)
            .map(|(i, _)| i)
            .collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn window() -> Window {
        Window {
            wire_diameter: 1e-3,
            width: 5e-3,
            wfs_min: 1.5 / 60.0,
            wfs_max: 10.0 / 60.0,
            travel_min: 2e-3,
            travel_max: 25e-3,
        }
    }

    /// By hand at 10 mm/s: LH = π·1·WFS/(4·5·10) mm with WFS in mm/s: 1.5 m/min (25 mm/s) →
    /// π/8 = 0.3927 mm, 10 m/min → 2.618 mm.
    #[test]
    fn heights_by_hand() {
        let (lo, hi) = window().heights(Modulation::WireFeed { travel: 10e-3 });
        assert!(
            (lo * 1e3 - std::f64::consts::FRAC_PI_8).abs() < 1e-12
                && (hi * 1e3 - 2.617_994).abs() < 1e-6,
            "{lo} {hi}"
        );
        // Constant 6 m/min: TS from 25 to 2 mm/s → LH from 0.6283 to 7.854 mm.
        let (lo, hi) = window().heights(Modulation::TravelSpeed { wfs: 0.1 });
        assert!((lo * 1e3 - 0.628_319).abs() < 1e-6 && (hi * 1e3 - 7.853_982).abs() < 1e-6);
    }

    /// 6 m/min at 10 mm/s: the travel limit (2 mm/s) allows 5 ×, the wire's (1.5 m/min) 4 ×;
    /// at the slowest pace the height is Eq.7's at the planned settings.
    #[test]
    fn the_slowest_pace_keeps_the_deposit_inside_the_window() {
        let (wfs, ts) = (0.1, 10e-3);
        let k = window().slowest_pace(wfs, ts);
        assert!((k - 4.0).abs() < 1e-12, "{k}");
        let h = |w, t| crate::eq7::layer_height(1e-3, w, 5e-3, t);
        assert!((h(wfs / k, ts / k) - h(wfs, ts)).abs() < 1e-15);
        assert!((window().slowest_pace(0.5, 4e-3) - 2.0).abs() < 1e-12);
        assert_eq!(window().slowest_pace(0.01, 10e-3), 1.0);
    }

    #[test]
    fn a_narrow_window_names_the_points() {
        let mut w = window();
        w.wfs_max = 8.0 / 60.0; // h_max = 2.094 mm at 10 mm/s
        let hs = [1.8e-3, 2.0e-3, 2.1e-3, 2.2e-3];
        assert_eq!(
            w.outside(&hs, Modulation::WireFeed { travel: 10e-3 }),
            vec![2, 3]
        );
        let (wfs, ts) = w.settings(2e-3, Modulation::WireFeed { travel: 10e-3 });
        assert_eq!(ts, 10e-3);
        assert!((crate::eq7::layer_height(1e-3, wfs, 5e-3, ts) - 2e-3).abs() < 1e-15);
    }
}
