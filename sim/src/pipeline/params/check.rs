//! The engine's parameters checked against the ranges the interface documents
//! (scenarios/README.md): a caller who fills the types in Rust meets the same limits, worded the
//! same way, as a scenario file does. The checks compare in SI against the documented bounds
//! converted as the scenario reader converts a value (so a value on a bound stays inside it);
//! a message shows the value and the bounds in the interface's units and names the key.

use super::{BeadSettings, DwellSettings, Material, Params, Process, ThermalSettings};
use std::fmt;
use thermal::ZERO_CELSIUS_K as KELVIN;

/// A parameter outside what the engine can take: its section and key in the interface, its
/// value in the interface's units, and what was expected.
#[derive(Debug, Clone, PartialEq)]
pub struct Invalid {
    pub section: &'static str,
    pub key: &'static str,
    pub value: String,
    pub expected: String,
}

impl fmt::Display for Invalid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "{}.{} = {}; expected {}",
            self.section, self.key, self.value, self.expected
        )
    }
}

impl std::error::Error for Invalid {}

/// How a key's interface unit maps to SI.
#[derive(Debug, Clone, Copy)]
enum Unit {
    /// The same number (W, s, W/(m² K), 1).
    Same,
    /// mm, mm/s.
    Milli,
    /// m/min.
    PerMinute,
    /// °C.
    Celsius,
}

impl Unit {
    fn si(self, v: f64) -> f64 {
        match self {
            Unit::Same => v,
            Unit::Milli => v * 1e-3,
            // As the reader converts (× 1/60, not ÷ 60: the last bit differs for some values).
            Unit::PerMinute => v * (1.0 / 60.0),
            Unit::Celsius => v + KELVIN,
        }
    }

    /// An SI value in the interface's unit, as a person reads it: the conversion's last-bit
    /// noise rounded away.
    fn shown(self, si: f64) -> Shown {
        Shown(self.in_unit(si))
    }

    fn in_unit(self, si: f64) -> f64 {
        let v = match self {
            Unit::Same => si,
            Unit::Milli => si / 1e-3,
            Unit::PerMinute => si * 60.0,
            Unit::Celsius => si - KELVIN,
        };
        let r = (v * 1e9).round() / 1e9;
        if (r - v).abs() <= 1e-12 * v.abs().max(1.0) {
            r
        } else {
            v
        }
    }
}

/// A value in a message: as written where it is of a size a person types, in exponent form
/// where its digits would run on (`1e300`, not three hundred digits; `1e-12`).
#[derive(Clone, Copy, PartialEq)]
struct Shown(f64);

impl fmt::Display for Shown {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        match v != 0.0 && v.is_finite() && !(1e-9..1e15).contains(&v.abs()) {
            true => write!(f, "{v:e}"),
            false => write!(f, "{v}"),
        }
    }
}

impl fmt::Debug for Shown {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        fmt::Display::fmt(self, f)
    }
}

/// The checks of one section.
struct Rules(&'static str);

impl Rules {
    fn fail(&self, key: &'static str, value: impl fmt::Display, expected: String) -> Invalid {
        Invalid {
            section: self.0,
            key,
            value: value.to_string(),
            expected,
        }
    }

    /// In (0, max], max in the interface's unit.
    fn positive(&self, key: &'static str, si: f64, max: f64, u: Unit) -> Result<(), Invalid> {
        match si.is_finite() && si > u.si(0.0) && si <= u.si(max) {
            true => Ok(()),
            false => Err(self.fail(key, u.shown(si), format!("a number in (0, {max}]"))),
        }
    }

    /// In [lo, hi], in the interface's unit.
    fn range(
        &self,
        key: &'static str,
        si: f64,
        (lo, hi): (f64, f64),
        expected: &str,
        u: Unit,
    ) -> Result<(), Invalid> {
        match si.is_finite() && (u.si(lo)..=u.si(hi)).contains(&si) {
            true => Ok(()),
            false => Err(self.fail(key, u.shown(si), expected.into())),
        }
    }

    /// At least (`at_least`) or at most another key of the section.
    fn ordered(
        &self,
        (key, si): (&'static str, f64),
        (other, bound_si): (&'static str, f64),
        at_least: bool,
        u: Unit,
    ) -> Result<(), Invalid> {
        let (ok, word) = match at_least {
            true => (si >= bound_si, "least"),
            false => (si <= bound_si, "most"),
        };
        match ok {
            true => Ok(()),
            false => Err(self.fail(
                key,
                u.shown(si),
                format!("at {word} {other} ({})", u.shown(bound_si)),
            )),
        }
    }
}

impl Process {
    /// The process's numbers within the machine's and the model's ranges.
    pub fn check(&self) -> Result<(), Invalid> {
        use Unit::{Milli, PerMinute, Same};
        let r = Rules("process");
        r.positive("wire_diameter_mm", self.wire_diameter_m, 5.0, Milli)?;
        r.positive("bead_width_mm", self.bead_width_m, 50.0, Milli)?;
        r.positive("travel_speed_mm_s", self.travel_speed_m_s, 1000.0, Milli)?;
        r.positive("deposit_mm", self.deposit_m, 20.0, Milli)?;
        r.positive("deposit_min_mm", self.deposit_min_m, 20.0, Milli)?;
        r.positive("deposit_max_mm", self.deposit_max_m, 20.0, Milli)?;
        let deposit = ("deposit_mm", self.deposit_m);
        r.ordered(
            ("deposit_min_mm", self.deposit_min_m),
            deposit,
            false,
            Milli,
        )?;
        r.ordered(("deposit_max_mm", self.deposit_max_m), deposit, true, Milli)?;
        r.positive("wfs_min_m_min", self.wfs_min_m_s, 50.0, PerMinute)?;
        r.positive("wfs_max_m_min", self.wfs_max_m_s, 50.0, PerMinute)?;
        let wfs_min = ("wfs_min_m_min", self.wfs_min_m_s);
        r.ordered(
            ("wfs_max_m_min", self.wfs_max_m_s),
            wfs_min,
            true,
            PerMinute,
        )?;
        r.positive("travel_min_mm_s", self.travel_min_m_s, 1000.0, Milli)?;
        r.positive("travel_max_mm_s", self.travel_max_m_s, 1000.0, Milli)?;
        let travel_min = ("travel_min_mm_s", self.travel_min_m_s);
        r.ordered(
            ("travel_max_mm_s", self.travel_max_m_s),
            travel_min,
            true,
            Milli,
        )?;
        r.positive("arc_power_w", self.arc_power_w, 50_000.0, Same)?;
        r.positive("efficiency", self.efficiency, 1.0, Same)
            .map_err(|e| Invalid {
                expected: "in (0, 1]".into(),
                ..e
            })?;
        if let bead_model::window::Modulation::TravelSpeed { wfs } = self.modulation {
            r.positive("wfs_m_min", wfs, 50.0, PerMinute)?;
        }
        Ok(())
    }
}

impl Material {
    /// The metal's constants within physical ranges.
    pub fn check(&self) -> Result<(), Invalid> {
        use Unit::{Celsius, Same};
        let r = Rules("material");
        r.positive("density_kg_m3", self.density_kg_m3, 30_000.0, Same)?;
        r.positive(
            "specific_heat_j_kgk",
            self.specific_heat_j_kgk,
            10_000.0,
            Same,
        )?;
        r.positive("conductivity_w_mk", self.conductivity_w_mk, 1_000.0, Same)?;
        r.positive("surface_tension_n_m", self.surface_tension_n_m, 10.0, Same)?;
        let melting = (100.0, 4000.0);
        r.range(
            "melting_c",
            self.melting_k,
            melting,
            "between 100 and 4000",
            Celsius,
        )
    }
}

impl ThermalSettings {
    /// The boundary conditions and the models' sizes within their documented ranges.
    pub fn check(&self) -> Result<(), Invalid> {
        use Unit::{Celsius, Milli, Same};
        let r = Rules("thermal");
        r.range(
            "ambient_c",
            self.ambient_k,
            (-50.0, 100.0),
            "between -50 and 100",
            Celsius,
        )?;
        let convection = (0.0, 10_000.0);
        r.range(
            "convection_w_m2k",
            self.convection_w_m2k,
            convection,
            "between 0 and 10000",
            Same,
        )?;
        r.range(
            "emissivity",
            self.emissivity,
            (0.0, 1.0),
            "between 0 and 1",
            Same,
        )?;
        for (k, v) in self.plate_m.iter().enumerate() {
            if !(v.is_finite() && *v > 0.0 && *v <= Milli.si(10_000.0)) {
                let mm = self.plate_m.map(|v| Milli.shown(v));
                return Err(r.fail(
                    "plate_mm",
                    format!("{mm:?}"),
                    format!("three sizes in (0, 10000] mm (entry {k} is {})", mm[k]),
                ));
            }
        }
        r.range(
            "lead_mm",
            self.lead_m,
            (0.0, 1000.0),
            "between 0 and 1000",
            Milli,
        )?;
        let contact = (0.0, 1e5);
        let table = self.table_contact_w_m2k;
        r.range(
            "table_contact_w_m2k",
            table,
            contact,
            "between 0 and 100000",
            Same,
        )?;
        // The reader holds a plate cell the user gives to at least 0.5 mm; the default follows
        // the bead's width, which may be narrower.
        r.positive("plate_cell_mm", self.plate_cell_m, 100.0, Milli)?;
        r.range(
            "node_mm",
            self.node_m,
            (0.1, 50.0),
            "between 0.1 and 50",
            Milli,
        )?;
        let deposit = (500.0, 3000.0);
        r.range(
            "deposit_c",
            self.deposit_k,
            deposit,
            "between 500 and 3000",
            Celsius,
        )?;
        let hot = (0.0, 3000.0);
        r.range(
            "hot_threshold_c",
            self.hot_threshold_k,
            hot,
            "between 0 and 3000",
            Celsius,
        )?;
        r.range(
            "voxel_mm",
            self.voxel_m,
            (0.25, 20.0),
            "between 0.25 and 20",
            Milli,
        )?;
        r.positive("footprint_mm", self.footprint_m, 100.0, Milli)
    }
}

impl DwellSettings {
    /// The limits and the search's bounds within their documented ranges.
    pub fn check(&self) -> Result<(), Invalid> {
        use Unit::{Celsius, Same};
        let r = Rules("dwell");
        let interpass = (20.0, 1500.0);
        r.range(
            "interpass_max_c",
            self.interpass_max_k,
            interpass,
            "between 20 and 1500",
            Celsius,
        )?;
        if let Some(k) = self.strength_loss_k {
            r.range(
                "strength_loss_c",
                k,
                (100.0, 1500.0),
                "between 100 and 1500",
                Celsius,
            )?;
        }
        r.positive("max_dwell_s", self.max_dwell_s, 86_400.0, Same)?;
        let min = (0.0, self.max_dwell_s);
        r.range(
            "min_dwell_s",
            self.min_dwell_s,
            min,
            "between 0 and dwell.max_dwell_s",
            Same,
        )?;
        r.range(
            "margin_c",
            self.margin_k,
            (0.0, 100.0),
            "between 0 and 100",
            Same,
        )?;
        let weight = (0.0, 86_400.0);
        r.range(
            "count_weight_s",
            self.count_weight_s,
            weight,
            "between 0 and 86400",
            Same,
        )?;
        r.positive("closing_zone_mm", self.closing_zone_mm, 10_000.0, Same)
    }
}

impl BeadSettings {
    /// The risk threshold and the hot-metal law within their documented ranges.
    pub fn check(&self) -> Result<(), Invalid> {
        use Unit::{Celsius, Milli, Same};
        let r = Rules("bead");
        r.positive("bond_max", self.bond_max, 100.0, Same)?;
        let law = &self.hot_metal;
        let loss = (0.0, 0.01);
        let loss_text = "between 0 and 0.01 per K";
        r.range(
            "hot_height_loss_per_k",
            law.height_loss_per_k,
            loss,
            loss_text,
            Same,
        )?;
        let reference = (-50.0, 1500.0);
        r.range(
            "hot_reference_c",
            law.reference_k,
            reference,
            "between -50 and 1500",
            Celsius,
        )?;
        r.positive("stickout_mm", self.stickout_m, 100.0, Milli)
    }
}

/// The CTPP planner's settings (`[planner]`, and the deposit window the process gives it)
/// within their documented ranges.
pub fn planning(p: &planner::plan::PlanParams) -> Result<(), Invalid> {
    use Unit::Same;
    let r = Rules("planner");
    if !(8..=100_000).contains(&p.n_points) {
        return Err(r.fail("n_points", p.n_points, "between 8 and 100000".into()));
    }
    r.positive("gap_max_mm", p.gap_max_mm, 100.0, Same)?;
    r.range(
        "deposit_tolerance_mm",
        p.tolerance_mm,
        (0.0, 1.0),
        "between 0 and 1",
        Same,
    )?;
    let n = &p.nozzle;
    r.positive("nozzle_radius_mm", n.radius_mm, 500.0, Same)?;
    r.range(
        "nozzle_standoff_mm",
        n.standoff_mm,
        (0.0, 500.0),
        "between 0 and 500",
        Same,
    )?;
    r.positive("nozzle_length_mm", n.length_mm, 5000.0, Same)?;
    let rotation = (0.0, 90.0);
    r.range(
        "nozzle_max_rotation_deg",
        n.max_rotation_deg,
        rotation,
        "between 0 and 90",
        Same,
    )?;
    r.positive(
        "nozzle_rotation_rate_deg_mm",
        n.rotation_rate_deg_mm,
        360.0,
        Same,
    )?;
    let tube = (0.0, 50.0);
    r.range(
        "deposit_tube_radius_mm",
        n.tube_radius_mm,
        tube,
        "between 0 and 50",
        Same,
    )?;
    if let Some(a) = &n.arm {
        let radius = (0.0, 1000.0);
        r.range(
            "arm_radius_mm",
            a.radius_mm,
            radius,
            "between 0 (no arm) and 1000",
            Same,
        )?;
        r.range(
            "arm_from_mm",
            a.from_mm,
            (0.0, 5000.0),
            "between 0 and 5000",
            Same,
        )?;
        r.positive("arm_length_mm", a.length_mm, 5000.0, Same)?;
    }
    let t = &p.torch;
    for (key, v) in [
        ("torch_lead_deg", t.lead_deg),
        ("torch_side_deg", t.side_deg),
    ] {
        r.range(key, v, (-60.0, 60.0), "between -60 and 60", Same)?;
    }
    r.positive("tool_rate_max_deg_mm", t.max_rate_deg_mm, 360.0, Same)
}

impl crate::pipeline::skeleton::SkeletonSettings {
    /// Skeleton arc AM's settings within their documented ranges.
    pub fn check(&self) -> Result<(), Invalid> {
        use Unit::Same;
        let r = Rules("skeleton");
        r.positive("radius_mm", self.radius_mm, 50.0, Same)?;
        for (i, v) in self.radii_mm.iter().enumerate() {
            if !(v.is_finite() && *v > 0.0 && *v <= 50.0) {
                let expected = format!("a radius in (0, 50] mm for polyline {}", i + 1);
                return Err(r.fail("radii_mm", v, expected));
            }
        }
        let sl = &self.slicer;
        r.positive("increment_mm", sl.increment_mm, 50.0, Same)?;
        for (key, v) in [
            ("divergent_offset_deg", sl.divergent_offset_deg),
            ("convergent_offset_deg", sl.convergent_offset_deg),
        ] {
            r.range(key, v, (0.0, 120.0), "between 0 and 120", Same)?;
        }
        r.positive("standoff_mm", sl.standoff_mm, 100.0, Same)?;
        r.positive("nozzle_radius_mm", sl.nozzle_radius_mm, 100.0, Same)?;
        r.positive("nozzle_length_mm", sl.nozzle_length_mm, 1000.0, Same)?;
        let collision = sl.max_collision_standoff_mm;
        r.range(
            "max_collision_standoff_mm",
            collision,
            (0.0, 200.0),
            "between 0 and 200",
            Same,
        )?;
        r.positive("wfs_m_min", self.wfs_m_min, 50.0, Same)?;
        r.range(
            "camera_noise_mm",
            self.camera_noise_mm,
            (0.0, 10.0),
            "between 0 and 10",
            Same,
        )?;
        let noise = self.drop_height_noise;
        r.range(
            "drop_height_noise",
            noise,
            (0.0, 0.5),
            "between 0 and 0.5",
            Same,
        )?;
        let bad = self.bad_drop_probability;
        r.range(
            "bad_drop_probability",
            bad,
            (0.0, 1.0),
            "between 0 and 1",
            Same,
        )?;
        r.range(
            "bad_drop_height",
            self.bad_drop_height,
            (0.0, 1.0),
            "between 0 and 1",
            Same,
        )?;
        r.range(
            "min_wait_s",
            self.min_wait_s,
            (0.0, 3600.0),
            "between 0 and 3600",
            Same,
        )?;
        let waits = (self.min_wait_s, 36000.0);
        let text = "at least min_wait_s and at most 36000";
        r.range("max_wait_s", self.max_wait_s, waits, text, Same)?;
        if !(1..=1_000_000).contains(&self.max_drops) {
            return Err(r.fail("max_drops", self.max_drops, "between 1 and 1000000".into()));
        }
        Ok(())
    }
}

impl crate::pipeline::replay::Laying {
    /// A replayed toolpath's process and deposit within their documented ranges.
    pub fn check(&self) -> Result<(), Invalid> {
        use Unit::{Milli, Same};
        let r = Rules("process");
        r.positive("power_w", self.power_w, 1e5, Same)?;
        r.positive("efficiency", self.efficiency, 1.0, Same)?;
        r.positive("bead_width_mm", self.width_m, 100.0, Milli)?;
        r.positive("layer_height_mm", self.height_m, 50.0, Milli)?;
        Rules("toolpath").positive("deposit_mm", self.deposit_m, 100.0, Milli)
    }
}

impl crate::pipeline::twin::Settings {
    /// The twin's filter and forecasts within their documented ranges (`[live]`).
    pub fn check(&self) -> Result<(), Invalid> {
        use Unit::{Celsius, Milli, Same};
        let r = Rules("live");
        if !(2..=256).contains(&self.ensemble) {
            return Err(r.fail("ensemble", self.ensemble, "2 to 256 members".into()));
        }
        r.positive("reading_sd_c", self.reading_sd_k, 1000.0, Same)?;
        r.positive("localisation_mm", self.localisation_m, 10_000.0, Milli)?;
        r.range(
            "relaxation",
            self.relaxation,
            (0.0, 1.0),
            "a share in [0, 1]",
            Same,
        )?;
        r.positive("assimilate_every_s", self.assimilate_every_s, 1e5, Same)?;
        r.positive("forecast_every_s", self.forecast_every_s, 1e6, Same)?;
        r.positive("parameters_every_s", self.parameters_every_s, 1e6, Same)?;
        let h = &self.horizons_s;
        let good = !h.is_empty()
            && h.len() <= 16
            && h.iter().all(|h| h.is_finite() && *h > 0.0 && *h <= 1e5);
        if !good {
            let expected = "1 to 16 horizons, each in (0, 1e5] s".into();
            return Err(r.fail("forecast_horizons_s", format!("{h:?}"), expected));
        }
        for (key, limit) in [
            ("interpass_max_c", self.interpass_max_k),
            ("strength_loss_c", self.strength_loss_k),
        ] {
            if let Some(k) = limit {
                r.range(key, k, (-200.0, 3000.0), "a temperature in °C", Celsius)?;
            }
        }
        match self.humping_pool_m {
            Some(m) => r.positive("humping_pool_mm", m, 1000.0, Milli),
            None => Ok(()),
        }
    }
}

impl Params {
    /// Every section checked ([`Process::check`] and the others): the process, the thermal,
    /// dwell and bead settings, the material.
    pub fn check(&self) -> Result<(), Invalid> {
        self.process.check()?;
        self.thermal.check()?;
        self.dwell.check()?;
        self.bead.check()?;
        self.material.check()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_defaults_pass_and_a_bad_value_is_named_in_the_interfaces_units() {
        let mut p = Params::default();
        assert_eq!(p.check(), Ok(()));
        p.process.deposit_min_m = 3.0e-3;
        let e = p.check().unwrap_err();
        assert_eq!(
            e.to_string(),
            "process.deposit_min_mm = 3; expected at most deposit_mm (2)"
        );
        let mut t = ThermalSettings {
            deposit_k: thermal::kelvin(3000.0),
            ..Default::default()
        };
        assert_eq!(t.check(), Ok(()), "a value on its bound is inside it");
        t.deposit_k = thermal::kelvin(3000.5);
        assert_eq!(
            t.check().unwrap_err().to_string(),
            "thermal.deposit_c = 3000.5; expected between 500 and 3000"
        );
    }

    /// A value far out of range is shown as a person would write it, not as the three hundred
    /// digits of its decimal expansion; one of ordinary size as typed.
    #[test]
    fn a_huge_or_tiny_value_is_shown_in_exponent_form() {
        let t = ThermalSettings {
            lead_m: 1e300,
            ..Default::default()
        };
        assert_eq!(
            t.check().unwrap_err().to_string(),
            "thermal.lead_mm = 1e303; expected between 0 and 1000"
        );
        let t = ThermalSettings {
            plate_m: [0.25, 1e13, 0.01],
            ..Default::default()
        };
        assert_eq!(
            t.check().unwrap_err().to_string(),
            "thermal.plate_mm = [250, 1e16, 10]; expected three sizes in (0, 10000] mm (entry 1 is 1e16)"
        );
        assert_eq!(super::Shown(-2.5e-3).to_string(), "-0.0025");
    }
}
