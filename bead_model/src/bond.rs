//! The Bond number (Radel et al. 2019, Eq.1): Bo = Δρ·g·R²/σ, the weight of the melt against its
//! surface tension, with R the deposit radius and Δρ the density difference between the liquid
//! and the gas (the gas's is negligible). Bo < 1: surface tension holds the pool. For G3Si
//! (ρ = 7800 kg/m³, σ = 1.6 N/m) the paper finds R ≤ 3 mm (Bo ≈ 0.43) safe in any orientation.

/// Standard gravity, m/s².
pub const G: f64 = 9.806_65;

pub fn bond_number(delta_rho: f64, radius: f64, sigma: f64) -> f64 {
    delta_rho * G * radius * radius / sigma
}

/// The capillary length √(σ/(Δρ·g)): the radius at which Bo = 1.
pub fn capillary_length(sigma: f64, delta_rho: f64) -> f64 {
    (sigma / (delta_rho * G)).sqrt()
}

/// Angle (rad) between the build direction and the vertical: 0 when the torch points straight
/// down onto an upright wall, π/2 for a horizontal build direction (the pool hangs sideways).
pub fn tilt_from_vertical(build_direction: [f64; 3]) -> f64 {
    let [x, y, z] = build_direction;
    let n = (x * x + y * y + z * z).sqrt();
    (z / n).clamp(-1.0, 1.0).acos()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn g3si_numbers_of_the_skeleton_paper() {
        let bo = bond_number(7800.0, 3e-3, 1.6);
        assert!((bo - 0.43).abs() <= 0.01, "{bo}");
        let lc = capillary_length(1.6, 7800.0);
        assert!((lc * 1e3 - 4.6).abs() < 0.05, "{lc}");
        assert!((bond_number(7800.0, lc, 1.6) - 1.0).abs() < 1e-12);
        assert!((tilt_from_vertical([0.0, 0.0, 1.0])).abs() < 1e-15);
        assert!((tilt_from_vertical([1.0, 0.0, 0.0]) - std::f64::consts::FRAC_PI_2).abs() < 1e-15);
    }
}
