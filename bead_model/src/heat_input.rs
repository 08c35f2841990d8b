//! Heat input: the arc power (fixed, or from a synergic line of current and voltage against wire
//! feed), the share of it that enters the part (process efficiency η, about 0.85 for CMT by
//! calorimetry, Pépe et al. 2011), and the energy per length η·P/TS handed to the thermal models.

/// Current and voltage against wire feed, interpolated linearly and held flat beyond the ends.
#[derive(Debug, Clone, PartialEq)]
pub struct SynergicLine {
    /// Wire-feed speeds, m/s, increasing.
    pub wfs: Vec<f64>,
    pub current_a: Vec<f64>,
    pub voltage_v: Vec<f64>,
}

impl SynergicLine {
    /// An illustrative line for 1.0 mm G3Si with CMT in Ar/CO₂: currents and voltages of the order
    /// CMT characteristic lines give (70–180 A, 10.5–15 V over 2–10 m/min). Not a manufacturer's
    /// table: give your power source's line in the scenario for real work (docs/PHYSICS.md).
    pub fn g3si_cmt_1mm() -> SynergicLine {
        let m_min = 1.0 / 60.0;
        SynergicLine {
            wfs: [2.0, 4.0, 6.0, 8.0, 10.0]
                .iter()
                .map(|w| w * m_min)
                .collect(),
            current_a: vec![70.0, 105.0, 135.0, 160.0, 180.0],
            voltage_v: vec![10.5, 11.8, 13.0, 14.0, 15.0],
        }
    }

    /// Checks: equal lengths, at least two points, increasing wire feed, positive values.
    pub fn validate(&self) -> Result<(), String> {
        let n = self.wfs.len();
        if n < 2 || self.current_a.len() != n || self.voltage_v.len() != n {
            return Err(format!(
                "needs at least 2 points and as many currents and voltages as wire feeds (got {}, {}, {})",
                n,
                self.current_a.len(),
                self.voltage_v.len()
            ));
        }
        if self.wfs.windows(2).any(|w| w[1] <= w[0]) {
            return Err("wire feeds must increase".into());
        }
        if self
            .current_a
            .iter()
            .chain(&self.voltage_v)
            .chain(&self.wfs)
            .any(|v| !(v.is_finite() && *v > 0.0))
        {
            return Err("every value must be a positive number".into());
        }
        Ok(())
    }

    fn interpolate(&self, ys: &[f64], wfs: f64) -> f64 {
        let xs = &self.wfs;
        if wfs <= xs[0] {
            return ys[0];
        }
        let i = xs.partition_point(|&x| x < wfs);
        if i >= xs.len() {
            return ys[ys.len() - 1];
        }
        let t = (wfs - xs[i - 1]) / (xs[i] - xs[i - 1]);
        ys[i - 1] + t * (ys[i] - ys[i - 1])
    }

    /// Arc power U·I (W) at a wire feed (m/s).
    pub fn power(&self, wfs: f64) -> f64 {
        self.interpolate(&self.current_a, wfs) * self.interpolate(&self.voltage_v, wfs)
    }
}

#[derive(Debug, Clone, PartialEq)]
pub enum ArcPower {
    Fixed { watts: f64 },
    Synergic(SynergicLine),
}

impl ArcPower {
    pub fn power(&self, wfs: f64) -> f64 {
        match self {
            ArcPower::Fixed { watts } => *watts,
            ArcPower::Synergic(line) => line.power(wfs),
        }
    }
}

/// Energy entering the part per length of bead, J/m: η·P/TS.
pub fn energy_per_length(power_w: f64, efficiency: f64, travel: f64) -> f64 {
    efficiency * power_w / travel
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolation_and_energy_by_hand() {
        let line = SynergicLine::g3si_cmt_1mm();
        line.validate().unwrap();
        // 5 m/min lies halfway between 4 and 6: 120 A × 12.4 V = 1488 W.
        assert!((line.power(5.0 / 60.0) - 1488.0).abs() < 1e-9);
        // Held flat beyond the ends.
        assert_eq!(line.power(0.0), 70.0 * 10.5);
        assert_eq!(line.power(1.0), 180.0 * 15.0);
        // 2000 W, η 0.85, 10 mm/s → 170 J/mm.
        assert!((energy_per_length(2000.0, 0.85, 0.01) - 170e3).abs() < 1e-9);
        let bad = SynergicLine {
            wfs: vec![0.1, 0.05],
            current_a: vec![1.0, 2.0],
            voltage_v: vec![1.0, 2.0],
        };
        assert!(bad.validate().is_err());
    }
}
