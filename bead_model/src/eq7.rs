//! Eq.7 of the CTPP paper (Diourté et al. 2020, after Hascoët et al.): the wire fed per second
//! fills the bead's cross-section times the travel per second,
//!
//! LH = π·d_wire²·WFS / (4·W·TS),
//!
//! with LH the layer height, d_wire the wire diameter, WFS the wire-feed speed, W the bead width
//! and TS the travel speed (a rectangular bead section). All SI: m and m/s.

use std::f64::consts::PI;

/// Layer height (m) from wire diameter (m), wire-feed speed (m/s), bead width (m) and travel speed
/// (m/s).
pub fn layer_height(d_wire: f64, wfs: f64, width: f64, travel: f64) -> f64 {
    PI * d_wire * d_wire * wfs / (4.0 * width * travel)
}

/// Wire-feed speed (m/s) that lays `height` at a constant travel speed (the CTPP choice).
pub fn wire_feed(height: f64, d_wire: f64, width: f64, travel: f64) -> f64 {
    4.0 * width * travel * height / (PI * d_wire * d_wire)
}

/// Travel speed (m/s) that lays `height` at a constant wire feed (adaptive travel speed, Chalvin
/// et al. 2019).
pub fn travel_speed(height: f64, d_wire: f64, wfs: f64, width: f64) -> f64 {
    PI * d_wire * d_wire * wfs / (4.0 * width * height)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Hand computation: d = 1 mm, W = 5 mm, TS = 10 mm/s, LH = 2 mm →
    /// WFS = 4·5·10·2 / (π·1²) mm/s = 400/π = 127.324 mm/s = 7.639 m/min.
    #[test]
    fn by_hand() {
        let wfs = wire_feed(2e-3, 1e-3, 5e-3, 10e-3);
        assert!((wfs - 0.4 / PI).abs() < 1e-15);
        assert!((wfs * 60.0 - 7.639_437).abs() < 1e-6);
        assert!((layer_height(1e-3, wfs, 5e-3, 10e-3) - 2e-3).abs() < 1e-15);
        // Constant wire feed of 6 m/min: TS = π·1²·100 / (4·5·2) mm/s = 7.854 mm/s.
        let ts = travel_speed(2e-3, 1e-3, 0.1, 5e-3);
        assert!((ts - 7.853_981_6e-3).abs() < 1e-10);
    }

    #[test]
    fn the_three_forms_agree() {
        for (d, w, ts, lh) in [(1.2e-3, 6e-3, 8e-3, 1.8e-3), (0.8e-3, 4e-3, 12e-3, 2.2e-3)] {
            let wfs = wire_feed(lh, d, w, ts);
            assert!((layer_height(d, wfs, w, ts) / lh - 1.0).abs() < 1e-12);
            assert!((travel_speed(lh, d, wfs, w) / ts - 1.0).abs() < 1e-12);
        }
    }
}
