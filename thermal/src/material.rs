//! Thermal properties of the deposited metal, SI with temperatures in K.
//!
//! The state of a node is its specific enthalpy h (J/kg); temperature follows from h through the
//! tabulated h(T) = ∫ c_p dT + L·f_liquid(T), with the latent heat released linearly between
//! solidus and liquidus (an enthalpy method: energy is conserved exactly whatever the step).

/// Temperature range of the tables, K.
const T_MAX: f64 = 4000.0;
const TABLE_STEP: f64 = 1.0;

/// The named constants of a filler metal: the one definition every crate of the workbench
/// reads (the temperature-dependent tables below, the bead model's Bond number, the
/// constant-property mode). Sources in docs/PHYSICS.md.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Preset {
    pub name: &'static str,
    pub density_kg_m3: f64,
    pub solidus_k: f64,
    pub liquidus_k: f64,
    pub latent_j_kg: f64,
    pub surface_tension_n_m: f64,
    /// Room-temperature values, for the constant-property mode.
    pub specific_heat_j_kgk: f64,
    pub diffusivity_m2_s: f64,
}

/// G3Si (ER70S-6 class): density, surface tension and diffusivity from the skeleton-AM paper's
/// Table 1 (Radel et al. 2019); solidus, liquidus and latent heat of low-carbon steel; c_p =
/// 480 J/(kg K) at room temperature.
pub const G3SI: Preset = Preset {
    name: "G3Si",
    density_kg_m3: 7800.0,
    solidus_k: 1740.0,
    liquidus_k: 1790.0,
    latent_j_kg: 2.7e5,
    surface_tension_n_m: 1.6,
    specific_heat_j_kgk: 480.0,
    diffusivity_m2_s: 14e-6,
};

/// IN718 (Inconel 718): c_p (J/(kg K)) and k (W/(m K)) against T (K), as the GAMMA authors
/// tabulated them for their DED calibration (AMPL-NU/DED_Simulation_Cupy, commit 1b1b511,
/// `projects/calibration/inputs/IN718_cp.txt` and `IN718_cond.txt`, there in J/(g K) and
/// W/(mm K); copied in `../shared/validation-data/gamma_in718_ded_thinwall/`), with their
/// density 8 190 kg/m³, solidus 1 533.15 K, liquidus 1 609.15 K and latent heat 270 kJ/kg (from
/// their model deck, the data set's setup.json). Sources and caveats in docs/PHYSICS.md.
pub const IN718_CP: [(f64, f64); 17] = [
    (298.0, 435.0),
    (373.0, 455.0),
    (473.0, 479.0),
    (573.0, 497.0),
    (673.0, 515.0),
    (773.0, 527.0),
    (873.0, 558.0),
    (973.0, 568.0),
    (1073.0, 680.0),
    (1173.0, 640.0),
    (1273.0, 620.0),
    (1373.0, 640.0),
    (1443.0, 650.0),
    (1609.0, 720.0),
    (1673.0, 720.0),
    (1773.0, 720.0),
    (1873.0, 720.0),
];

/// IN718 conductivity, W/(m K), against T (K); the source of [`IN718_CP`].
pub const IN718_K: [(f64, f64); 17] = [
    (298.0, 8.9),
    (373.0, 10.8),
    (473.0, 12.9),
    (573.0, 15.2),
    (673.0, 17.4),
    (773.0, 18.7),
    (873.0, 20.8),
    (973.0, 21.9),
    (1073.0, 26.9),
    (1173.0, 25.8),
    (1273.0, 26.7),
    (1373.0, 28.3),
    (1443.0, 29.3),
    (1609.0, 29.6),
    (1673.0, 29.6),
    (1773.0, 29.6),
    (1873.0, 29.6),
];

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Material {
    pub density: f64,
    /// Specific heat c_p(T), J/(kg K), at `TABLE_STEP` intervals from 0 K.
    cp: Vec<f64>,
    /// Conductivity k(T), W/(m K), at the same temperatures.
    k: Vec<f64>,
    /// h(T) from 0 K, J/kg, including latent heat.
    h: Vec<f64>,
    pub solidus: f64,
    pub liquidus: f64,
    pub latent: f64,
    /// Where `temperature` starts its search: for each `bucket` of enthalpy from h[0], the first
    /// table index whose h is not below the bucket's start. Buckets are narrower than any table
    /// step (unless that would take more than 65 536 of them), so the search moves a step or two (a binary search over the 4 000 entries was a
    /// twelfth of the thin wall's time: 19.3 → 17.8 s on the bench).
    start: Vec<u32>,
    bucket: f64,
}

impl Material {
    /// Constant properties (verification mode); latent heat 0 unless given.
    pub fn constant(density: f64, cp: f64, k: f64, melt: f64, latent: f64) -> Material {
        Material::tabulate(density, |_| cp, |_| k, melt, melt + 1.0, latent)
    }

    /// Low-carbon steel (G3Si, ER70S-6 class), temperature-dependent: c_p and k of carbon steel
    /// from Eurocode 3 (EN 1993-1-2 §3.4.1, valid 20–1200 °C, held constant above), solidus
    /// 1740 K and liquidus 1790 K, latent heat 270 kJ/kg, density 7800 kg/m³ (Radel et al.
    /// 2019). Sources and caveats in docs/PHYSICS.md.
    pub fn g3si() -> Material {
        let p = G3SI;
        Material::tabulate(
            p.density_kg_m3,
            eurocode_cp,
            eurocode_k,
            p.solidus_k,
            p.liquidus_k,
            p.latent_j_kg,
        )
    }

    /// IN718 from [`IN718_CP`] and [`IN718_K`].
    pub fn in718() -> Material {
        Material::from_tables(8190.0, &IN718_CP, &IN718_K, 1533.15, 1609.15, 2.7e5)
            .expect("the IN718 tables are ascending and positive (tested)")
    }

    /// Properties from measured tables: c_p(T) in J/(kg K) and k(T) in W/(m K), each as
    /// (T in K, value) rows in ascending temperature, interpolated linearly and held at the end
    /// values outside them; latent heat released linearly between solidus and liquidus.
    /// Fails with what is wrong with a table.
    pub fn from_tables(
        density: f64,
        cp: &[(f64, f64)],
        k: &[(f64, f64)],
        solidus: f64,
        liquidus: f64,
        latent: f64,
    ) -> Result<Material, String> {
        for (name, table) in [("specific heat", cp), ("conductivity", k)] {
            check_table(name, table)?;
        }
        if !(density > 0.0 && solidus > 0.0 && liquidus > solidus && latent >= 0.0) {
            return Err(format!(
                "density {density} kg/m³, solidus {solidus} K, liquidus {liquidus} K, latent \
                 {latent} J/kg; expected positive, liquidus above solidus"
            ));
        }
        Ok(Material::tabulate(
            density,
            |t| interpolate(cp, t),
            |t| interpolate(k, t),
            solidus,
            liquidus,
            latent,
        ))
    }

    fn tabulate(
        density: f64,
        cp: impl Fn(f64) -> f64,
        k: impl Fn(f64) -> f64,
        solidus: f64,
        liquidus: f64,
        latent: f64,
    ) -> Material {
        let n = (T_MAX / TABLE_STEP) as usize + 1;
        let temps: Vec<f64> = (0..n).map(|i| i as f64 * TABLE_STEP).collect();
        let cp: Vec<f64> = temps.iter().map(|&t| cp(t)).collect();
        let k: Vec<f64> = temps.iter().map(|&t| k(t)).collect();
        let liquid = |t: f64| ((t - solidus) / (liquidus - solidus)).clamp(0.0, 1.0);
        let mut h = vec![0.0; n];
        for i in 1..n {
            // Trapezoid in c_p, exact in the linear latent release.
            h[i] = h[i - 1]
                + 0.5 * (cp[i] + cp[i - 1]) * TABLE_STEP
                + latent * (liquid(temps[i]) - liquid(temps[i - 1]));
        }
        let span = h[n - 1] - h[0];
        let bucket = h
            .windows(2)
            .map(|w| w[1] - w[0])
            .fold(f64::INFINITY, f64::min)
            .max(span / 65536.0);
        let buckets = (span / bucket).ceil() as usize + 1;
        let start = (0..buckets)
            .map(|b| h.partition_point(|&x| x < h[0] + b as f64 * bucket) as u32)
            .collect();
        Material {
            density,
            cp,
            k,
            h,
            solidus,
            liquidus,
            latent,
            start,
            bucket,
        }
    }

    fn at(table: &[f64], t: f64) -> f64 {
        let x = (t / TABLE_STEP).clamp(0.0, (table.len() - 1) as f64);
        let i = (x as usize).min(table.len() - 2);
        let f = x - i as f64;
        table[i] + f * (table[i + 1] - table[i])
    }

    /// h(T); above the tables' top it runs on at their last c_p, the inverse of
    /// [`Material::temperature`] there. Clamped there, it gave a node above 4 000 K no heat
    /// capacity: the thin wall's implicit step then took it for its neighbours' temperature, its
    /// heat never left, and it read 3 740–4 140 °C for the rest of the run (docs/PHYSICS.md
    /// "Above the tables' top").
    pub fn enthalpy(&self, t: f64) -> f64 {
        let last = self.h.len() - 1;
        let top = last as f64 * TABLE_STEP;
        match t > top {
            true => self.h[last] + (t - top) * self.cp[last],
            false => Material::at(&self.h, t),
        }
    }

    pub fn conductivity(&self, t: f64) -> f64 {
        Material::at(&self.k, t)
    }

    pub fn specific_heat(&self, t: f64) -> f64 {
        Material::at(&self.cp, t)
    }

    /// Apparent heat capacity dh/dT over [t, t + 1 K]: c_p plus latent heat in the mushy range.
    pub fn apparent_heat(&self, t: f64) -> f64 {
        (self.enthalpy(t + TABLE_STEP) - self.enthalpy(t)) / TABLE_STEP
    }

    /// Temperature of specific enthalpy `h` (inverse of the monotone table).
    pub fn temperature(&self, h: f64) -> f64 {
        let i = self.first_not_below(h);
        if i == 0 {
            return 0.0;
        }
        if i >= self.h.len() {
            let last = self.h.len() - 1;
            return last as f64 * TABLE_STEP + (h - self.h[last]) / self.cp[last];
        }
        let (a, b) = (self.h[i - 1], self.h[i]);
        ((i - 1) as f64 + (h - a) / (b - a)) * TABLE_STEP
    }

    /// The first table index whose h is not below `h` (`partition_point(|x| x < h)`), from the
    /// bucket's start.
    fn first_not_below(&self, h: f64) -> usize {
        if h.is_nan() || h <= self.h[0] {
            return 0;
        }
        let b = (((h - self.h[0]) / self.bucket) as usize).min(self.start.len() - 1);
        let mut i = self.start[b] as usize;
        while i > 0 && self.h[i - 1] >= h {
            i -= 1;
        }
        while i < self.h.len() && self.h[i] < h {
            i += 1;
        }
        i
    }

    pub fn diffusivity(&self, t: f64) -> f64 {
        self.conductivity(t) / (self.density * self.specific_heat(t))
    }

    /// The largest diffusivity anywhere from 250 to 3 500 K, m²/s: the largest k/(ρ·dh/dT) over
    /// each kelvin of the tables (k the larger at its two ends, dh/dT the secant, latent heat
    /// included). What bounds an explicit step on Kirchhoff's potential: there the update of h
    /// reads Φ(h), whose slope dΦ/dh = k/(dh/dT) is this times ρ, so the stencil is stable
    /// while dt ≤ dx²/(6·this) (forward Euler on the 7-point Laplacian, whose largest
    /// eigenvalue is 12/dx²). Largest at the same temperature for k and c: for carbon steel
    /// that is room temperature (k falls and c rises with T), where k_max/c_min already was;
    /// for IN718, whose k rises about as fast as c, 1.5 times below k_max/(ρ·c_min).
    pub fn fastest_diffusivity(&self) -> f64 {
        (250..3500)
            .map(|t| {
                let t = f64::from(t);
                let k = self.conductivity(t).max(self.conductivity(t + TABLE_STEP));
                k / (self.density * self.apparent_heat(t))
            })
            .fold(0.0, f64::max)
    }
}

/// EN 1993-1-2 §3.4.1.2: specific heat of carbon steel, J/(kg K), T in K (formula in °C).
fn eurocode_cp(t: f64) -> f64 {
    let c = crate::celsius(t).clamp(20.0, 1200.0);
    if c < 600.0 {
        425.0 + 7.73e-1 * c - 1.69e-3 * c * c + 2.22e-6 * c * c * c
    } else if c < 735.0 {
        666.0 + 13002.0 / (738.0 - c)
    } else if c < 900.0 {
        545.0 + 17820.0 / (c - 731.0)
    } else {
        650.0
    }
}

/// EN 1993-1-2 §3.4.1.3: thermal conductivity of carbon steel, W/(m K).
fn eurocode_k(t: f64) -> f64 {
    let c = crate::celsius(t).clamp(20.0, 1200.0);
    if c < 800.0 { 54.0 - 3.33e-2 * c } else { 27.3 }
}

/// A property table is usable: rows in ascending temperature, finite positive values.
fn check_table(name: &str, table: &[(f64, f64)]) -> Result<(), String> {
    if table.is_empty() {
        return Err(format!("the {name} table is empty"));
    }
    if let Some(row) = table
        .iter()
        .position(|&(t, v)| !(t.is_finite() && t >= 0.0 && v.is_finite() && v > 0.0))
    {
        return Err(format!(
            "the {name} table's row {} reads T = {} K, {}; expected a temperature ≥ 0 K and a \
             positive value",
            row + 1,
            table[row].0,
            table[row].1
        ));
    }
    for (row, w) in table.windows(2).enumerate() {
        if w[1].0 <= w[0].0 {
            return Err(format!(
                "the {name} table's row {} has T = {} K after {} K; expected ascending temperatures",
                row + 2,
                w[1].0,
                w[0].0
            ));
        }
    }
    Ok(())
}

/// Linear between rows, the end values outside.
fn interpolate(table: &[(f64, f64)], t: f64) -> f64 {
    let j = table.partition_point(|r| r.0 < t);
    match j {
        0 => table[0].1,
        j if j == table.len() => table[j - 1].1,
        j => {
            let (a, b) = (table[j - 1], table[j]);
            a.1 + (t - a.0) / (b.0 - a.0) * (b.1 - a.1)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Above the tables' top h(T) goes on at the last c_p, so that T(h(T)) = T and the
    /// apparent heat stays c_p: a node there keeps a heat capacity and cools.
    #[test]
    fn above_the_tables_h_and_t_are_inverse_and_the_capacity_stays() {
        let m = Material::g3si();
        for t in [3990.5, 4000.0, 4174.0, 6000.0] {
            let back = m.temperature(m.enthalpy(t));
            assert!((back - t).abs() < 1e-6, "{t} K → {back} K");
            let c = m.apparent_heat(t);
            assert!((c - m.cp[m.cp.len() - 1]).abs() < 1e-6 * c, "{t} K: {c}");
        }
    }

    #[test]
    fn eurocode_values() {
        // EN 1993-1-2 at 20 °C: c = 439.8 J/kgK, λ = 53.3 W/mK; peak near 735 °C: 5000 J/kgK.
        assert!((eurocode_cp(293.15) - 439.8).abs() < 0.1);
        assert!((eurocode_k(293.15) - 53.334).abs() < 1e-9);
        assert!((eurocode_cp(crate::kelvin(735.0)) - 5000.0).abs() < 10.0);
        assert_eq!(eurocode_k(crate::kelvin(1000.0)), 27.3);
    }

    #[test]
    fn bucketed_search_equals_the_binary_search() {
        let m = Material::g3si();
        let (lo, hi) = (m.h[0] - 1e4, m.h[m.h.len() - 1] + 1e4);
        for j in 0..200_000 {
            let h = lo + (hi - lo) * j as f64 / 199_999.0;
            assert_eq!(m.first_not_below(h), m.h.partition_point(|&x| x < h), "{h}");
        }
        for &h in &m.h {
            assert_eq!(m.first_not_below(h), m.h.partition_point(|&x| x < h));
        }
    }

    #[test]
    fn enthalpy_round_trip_and_latent_heat() {
        let m = Material::g3si();
        for t in [300.0, 800.0, 1000.0, 1745.0, 1785.0, 2000.0, 3500.0] {
            assert!((m.temperature(m.enthalpy(t)) - t).abs() < 1e-6, "{t}");
        }
        let jump = m.enthalpy(1790.0) - m.enthalpy(1740.0);
        assert!((jump - 2.7e5 - 650.0 * 50.0).abs() < 1.0, "{jump}");
        let c = Material::constant(7800.0, 480.0, 52.416, 1700.0, 0.0);
        assert!((c.enthalpy(1000.0) - c.enthalpy(500.0) - 480.0 * 500.0).abs() < 1e-6);
        assert!((c.diffusivity(500.0) - 14e-6).abs() < 1e-12);
    }

    #[test]
    fn tables_interpolate_and_hold_their_ends() {
        let cp = [(300.0, 400.0), (500.0, 600.0)];
        let k = [(300.0, 10.0)];
        let m = super::Material::from_tables(8000.0, &cp, &k, 1500.0, 1600.0, 2e5).unwrap();
        assert!((m.specific_heat(400.0) - 500.0).abs() < 1e-9);
        assert!((m.specific_heat(100.0) - 400.0).abs() < 1e-9);
        assert!((m.specific_heat(1000.0) - 600.0).abs() < 1e-9);
        assert!((m.conductivity(900.0) - 10.0).abs() < 1e-9);
        let unsorted = [(500.0, 1.0), (300.0, 1.0)];
        let e = super::Material::from_tables(8000.0, &unsorted, &k, 1500.0, 1600.0, 0.0);
        assert!(e.unwrap_err().contains("row 2 has T = 300 K"));
        let negative = [(300.0, -1.0)];
        let e = super::Material::from_tables(8000.0, &cp, &negative, 1500.0, 1600.0, 0.0);
        assert!(e.unwrap_err().contains("conductivity table's row 1"));
    }

    /// The IN718 preset is the GAMMA tables in SI: c_p 0.455 J/(g K) at 373 K, k 0.0269 W/(mm K)
    /// at 1073 K, held beyond the last row.
    #[test]
    fn in718_is_the_gamma_tables_in_si() {
        let m = super::Material::in718();
        assert!((m.specific_heat(373.0) - 455.0).abs() < 1e-9);
        assert!((m.conductivity(1073.0) - 26.9).abs() < 1e-9);
        assert!((m.conductivity(3000.0) - 29.6).abs() < 1e-9);
        assert_eq!(m.density, 8190.0);
    }
}
