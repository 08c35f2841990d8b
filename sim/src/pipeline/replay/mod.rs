//! A toolpath the machine ran, replayed on a heat model, and the model held against what the
//! part measured (no IO: the readers are in [`crate::measured`], the commands read the files).
//!
//! [`schedule`] cuts the toolpath into deposits; [`Replay`] is a replay set up once (schedule,
//! materials, probes) and run at any parameters; [`advance`] goes on with a run to a time;
//! [`compare`] pairs the model's probes with the measurements; [`doubts`] says what the
//! readings give reason to doubt in how the probes were set up.

pub mod compare;
pub mod doubts;
pub mod schedule;
mod setup;

pub use compare::*;
pub use schedule::{Laying, count, deposits};
pub use setup::*;

use thermal::schedule::Deposit;
use thermal::{HeatRun, ThermalError};

/// Go on with `run` (started on `deps`, wherever it stands) until `until_s`: lay the deposits
/// whose arc starts before then, each after the gap the schedule leaves before it, and cool
/// to `until_s` if the last comes earlier. A run stopped at T and advanced to T' gives what
/// one advanced to T' at once does, but for how its cooling is cut into steps.
pub fn advance(run: &mut impl HeatRun, deps: &[Deposit], until_s: f64) -> Result<(), ThermalError> {
    advance_observed(run, deps, until_s, &mut |_| {})
}

/// [`advance`], showing `after` the run after each deposit (a caller's checkpoints).
pub fn advance_observed<R: HeatRun>(
    run: &mut R,
    deps: &[Deposit],
    until_s: f64,
    after: &mut dyn FnMut(&R),
) -> Result<(), ThermalError> {
    advance_scaled(run, deps, until_s, 1.0, after)
}

/// [`advance_observed`] with every deposit's heat times `scale` (a twin's member whose
/// efficiency is not the schedule's: η·P·t is linear in η).
pub fn advance_scaled<R: HeatRun>(
    run: &mut R,
    deps: &[Deposit],
    until_s: f64,
    scale: f64,
    after: &mut dyn FnMut(&R),
) -> Result<(), ThermalError> {
    for (i, d) in deps.iter().enumerate().skip(run.laid()) {
        if d.arc_start() >= until_s {
            break;
        }
        let previous_end = match i {
            0 => d.arc_start(),
            _ => deps[i - 1].time,
        };
        // From the schedule's own times, as `thermal::run::replay` lays them, unless the run
        // was cooled past the previous end (stopped at a window's end in between).
        let from = match run.now() > previous_end + 1e-9 {
            true => run.now(),
            false => previous_end,
        };
        let dwell = (d.arc_start() - from).max(0.0);
        // As `deps` says, not as the run was started on: a twin's schedule moves with the
        // machine log (heat and arc time; the same at scale 1 where nothing moved).
        let burn = thermal::run::Burn {
            heat: d.heat * scale,
            ..thermal::run::Burn::of(d)
        };
        run.deposit_burning(i, dwell, Some(burn))?;
        after(run);
    }
    if until_s > run.now() {
        run.cool(until_s - run.now())?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measured::toolpath::Waypoint;
    use thermal::ZERO_CELSIUS_K as C;
    use thermal::run::ProbeTrace;

    fn laying() -> Laying {
        Laying {
            power_w: 500.0,
            efficiency: 0.5,
            width_m: 2e-3,
            height_m: 0.75e-3,
            deposit_m: 1e-3,
        }
    }

    fn waypoint(t_s: f64, x: f64, z: f64, on: bool) -> Waypoint {
        Waypoint {
            t_s,
            position_mm: [x, 0.0, z],
            on,
            power_w: None,
        }
    }

    /// Two tracks one way with a return trip between: the second starts its own bead and lies
    /// on the first; each segment's heat is η·P over its share of the time.
    #[test]
    fn two_tracks_one_way() {
        let path = [
            waypoint(0.0, -2.0, 0.75, false),
            waypoint(4.0, 2.0, 0.75, true),
            waypoint(8.0, -2.0, 1.5, false),
            waypoint(12.0, 2.0, 1.5, true),
        ];
        let d = deposits(&path, &laying());
        assert_eq!(d.len(), 8);
        assert_eq!(d[0].start, Some([-2e-3, 0.0, 0.75e-3]));
        assert!(d[1..4].iter().all(|x| x.start.is_none()));
        assert_eq!(d[4].start, Some([-2e-3, 0.0, 1.5e-3]));
        assert!((d[0].arc_time - 1.0).abs() < 1e-12 && (d[0].heat - 250.0).abs() < 1e-9);
        assert_eq!(d[3].support, None);
        assert_eq!(d[4].support, Some(0));
        assert_eq!(d[7].support, Some(3));
        thermal::schedule::validate(&d).unwrap();
    }

    /// Two tracks make two passes; each pass's peak and the reading before the next come from
    /// its own samples.
    #[test]
    fn passes_of_two_tracks() {
        let path = [
            waypoint(0.0, -2.0, 0.75, false),
            waypoint(4.0, 2.0, 0.75, true),
            waypoint(8.0, -2.0, 1.5, false),
            waypoint(12.0, 2.0, 1.5, true),
        ];
        let starts = pass_starts(&deposits(&path, &laying()));
        assert_eq!(starts, vec![0.0, 8.0]);
        let samples = [
            (1.0, 900.0, 950.0),
            (7.0, 300.0, 280.0),
            (9.0, 1000.0, 900.0),
            (11.0, 500.0, 520.0),
        ];
        let p = passes(&samples, &starts);
        assert_eq!(p[0].peak, Some((900.0, 950.0)));
        assert_eq!(p[0].before_next, Some((300.0, 280.0)));
        assert_eq!(p[1].peak, Some((1000.0, 900.0)));
        assert_eq!(p[1].before_next, None);
        let (rms, bias) = errors(p.iter().filter_map(|p| p.peak)).unwrap();
        // Errors +50 and −100 °C.
        assert!((rms - 6250.0f64.sqrt()).abs() < 1e-9, "{rms}");
        assert!((bias - (-25.0)).abs() < 1e-9);
    }

    #[test]
    fn agreement_of_known_errors() {
        let trace = ProbeTrace {
            position: [0.0; 3],
            time: vec![0.0, 1.0, 2.0],
            temperature: vec![f64::NAN, C + 110.0, C + 130.0],
        };
        let t = [0.5, 1.0, 1.5, 2.0, 3.0];
        let m = [Some(1.0), Some(100.0), None, Some(140.0), Some(1.0)];
        let s = pair(&t, &m, &trace);
        // 0.5 s: the trace does not read yet; 1.5 s: no measurement; 3 s: past the trace.
        assert_eq!(s.len(), 2);
        let a = agreement(&s, (0.0, 10.0)).unwrap();
        assert_eq!(a.samples, 2);
        assert!((a.rms_c - 10.0).abs() < 1e-9);
        assert!(a.bias_c.abs() < 1e-9);
        assert!(agreement(&s, (5.0, 6.0)).is_none());
    }
}

/// What the engine's tests lay: tracks one way, voxel settings.
#[cfg(test)]
pub(crate) mod fixtures {
    use crate::measured::toolpath::Waypoint;
    use crate::pipeline::params::{ThermalModel, ThermalSettings};

    /// `n` tracks along x from −`half_mm` to +`half_mm`, 1.5 mm apart in z, one every
    /// `period_s`, each laid in `arc_s` after travel back.
    pub fn tracks(n: usize, period_s: f64, arc_s: f64, half_mm: f64) -> Vec<Waypoint> {
        (0..n)
            .flat_map(|k| {
                let (t, z) = (period_s * k as f64, 1.5 * (k + 1) as f64);
                let at = |t_s, x, on| Waypoint {
                    t_s,
                    position_mm: [x, 0.0, z],
                    on,
                    power_w: None,
                };
                [at(t, -half_mm, false), at(t + arc_s, half_mm, true)]
            })
            .collect()
    }

    /// The voxel model at 2 mm on a plate of `plate_m`, G3Si's usual losses.
    pub fn voxel_settings(plate_m: [f64; 3]) -> ThermalSettings {
        ThermalSettings {
            table_contact_w_m2k: 100.0,
            plate_cell_m: 5e-3,
            node_m: 3e-3,
            deposit_k: 1823.15,
            footprint_m: 4e-3,
            hot_threshold_k: 873.15,
            temperature_dependent: true,
            voxel_m: 2e-3,
            model: ThermalModel::Voxel,
            ambient_k: 293.15,
            convection_w_m2k: 15.0,
            emissivity: 0.6,
            plate_m,
            plate_fit: false,
            plate_disc: false,
            lead_m: 10e-3,
            coarse_plate: false,
            local_steps: true,
            merge_plate: true,
            device: Default::default(),
        }
    }
}

#[cfg(test)]
mod checkpoint_tests {
    use super::*;
    use crate::pipeline::deposition::heat_model_of;

    /// A run stopped in a gap of the schedule (a calibration's fit window ending between two
    /// tracks) and advanced from its clone ends where a run advanced at once does: the same
    /// deposits laid, every deposit's metal within 0.1 K (the cooling is cut into steps
    /// differently), on the voxel model with a plate of its own material.
    #[test]
    fn a_run_resumed_from_its_checkpoint_ends_where_one_run_does() {
        let path = fixtures::tracks(6, 10.0, 5.0, 15.0);
        let l = Laying {
            power_w: 2000.0,
            efficiency: 0.8,
            width_m: 4e-3,
            height_m: 1.5e-3,
            deposit_m: 2e-3,
        };
        let deps = deposits(&path, &l);
        let t = fixtures::voxel_settings([60e-3, 30e-3, 10e-3]);
        let mut model = heat_model_of(
            thermal::material::Material::in718(),
            &t,
            &deps,
            vec![],
            vec![],
        );
        model.set_plate_material(Some(thermal::material::Material::g3si()));
        let (end, gap) = (62.0, 27.5);
        let mut once = model.start(&deps).unwrap();
        advance(&mut once, &deps, end).unwrap();
        let mut stopped = model.start(&deps).unwrap();
        advance(&mut stopped, &deps, gap).unwrap();
        assert!((stopped.now() - gap).abs() < 1e-9 && stopped.laid() < deps.len());
        let mut resumed = stopped.clone();
        advance(&mut resumed, &deps, end).unwrap();
        assert_eq!((once.laid(), resumed.laid()), (deps.len(), deps.len()));
        assert!((once.now() - resumed.now()).abs() < 1e-9);
        let worst = (0..deps.len())
            .map(|i| (once.temperature_of(i) - resumed.temperature_of(i)).abs())
            .fold(0.0, f64::max);
        assert!(worst < 0.1, "{worst} K");
        let hottest = (0..deps.len())
            .map(|i| once.temperature_of(i))
            .fold(0.0, f64::max);
        assert!(hottest > 400.0, "{hottest} K: the part still warm");
    }
}
