//! A drop: metal laid with the torch standing still, as skeleton arc AM lays its nodes (Radel et
//! al. 2019, §2). The drop settles as a spherical cap on the bead beneath, its base the bead's
//! width; its radius R is what the Bond number judges, and its welding time is its volume over
//! the wire's feed rate.

use std::f64::consts::PI;

/// A spherical cap of volume `volume` (m³) on a base of diameter `width` (m).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Drop {
    /// Height of the cap, m.
    pub height: f64,
    /// Radius of the sphere it is cut from (R of the Bond number), m.
    pub radius: f64,
}

impl Drop {
    /// The cap of that volume on that base: V = πh(3a² + h²)/6 with a = width/2, increasing in h,
    /// solved by bisection; R = (a² + h²)/(2h). A drop too small to wet the whole width (less
    /// than the half sphere of radius a) stands as a half sphere of its own volume instead: the
    /// 90° contact angle assumed for liquid steel on its own solid (docs/PHYSICS.md).
    pub fn of_volume(volume: f64, width: f64) -> Drop {
        let a = width / 2.0;
        if volume < 2.0 * PI * a.powi(3) / 3.0 {
            let r = (3.0 * volume / (2.0 * PI)).cbrt();
            return Drop {
                height: r,
                radius: r,
            };
        }
        let v = |h: f64| PI * h * (3.0 * a * a + h * h) / 6.0;
        let (mut lo, mut hi) = (0.0, a.max(1e-9));
        while v(hi) < volume {
            hi *= 2.0;
        }
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if v(mid) < volume {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        let height = 0.5 * (lo + hi);
        Drop {
            height,
            radius: (a * a + height * height) / (2.0 * height.max(1e-300)),
        }
    }
}

/// How long the arc burns to melt `volume` of wire of diameter `wire_diameter` fed at `wfs`, s.
pub fn welding_time(volume: f64, wire_diameter: f64, wfs: f64) -> f64 {
    volume / (PI * wire_diameter * wire_diameter / 4.0 * wfs)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A half sphere of radius 2.5 mm on a 5 mm bead: V = 2πr³/3, h = R = 2.5 mm.
    #[test]
    fn a_half_sphere_by_hand() {
        let r: f64 = 2.5e-3;
        let d = Drop::of_volume(2.0 * PI * r.powi(3) / 3.0, 5e-3);
        assert!(
            (d.height - r).abs() < 1e-12 && (d.radius - r).abs() < 1e-12,
            "{d:?}"
        );
        // More metal: a taller cap; less: a smaller half sphere (1 mm³: R = 0.782 mm).
        let tall = Drop::of_volume(50e-9, 5e-3);
        assert!(tall.height > r && tall.radius > r, "{tall:?}");
        let small = Drop::of_volume(1e-9, 5e-3);
        assert!((small.radius - 0.781_593e-3).abs() < 1e-9, "{small:?}");
    }

    /// 1 mm wire at 6 m/min melts 78.5 mm³/s: a 39.3 mm³ drop takes 0.5 s.
    #[test]
    fn welding_time_by_hand() {
        let t = welding_time(PI / 4.0 * 50.0 * 1e-9, 1e-3, 0.1);
        assert!((t - 0.5).abs() < 1e-12, "{t}");
    }
}
