//! What can go wrong in a heat model, with the evidence: a schedule that is not a build (the
//! caller's input) or a numerical failure of the model (ours).

use std::fmt;

#[derive(Debug, Clone, PartialEq)]
pub enum ThermalError {
    /// The schedule breaks one of its rules ([`crate::schedule::validate`]).
    Schedule { deposit: usize, reason: String },
    /// The plate cannot be modelled as given.
    Plate { reason: String },
    /// A deposit laid on the plate lies outside it.
    OutsidePlate {
        deposit: usize,
        x_mm: f64,
        y_mm: f64,
    },
    /// A temperature or an energy sum left the finite numbers: a step that was not stable, or
    /// heat no material can take.
    NonFinite {
        time_s: f64,
        position_mm: [f64; 3],
        what: &'static str,
        value: f64,
    },
    /// The voxel model was asked to run on a GPU (`VoxelSettings::device`) and cannot: no
    /// adapter, a build without the `gpu` feature, or a setting the device does not run.
    Device { reason: String },
    /// The GPU failed during a run (a device lost, results that did not come back): not the
    /// input's failure.
    DeviceLost { time_s: f64, reason: String },
    /// The caller asked every run to stop ([`crate::run::request_stop`]): not a failure of the
    /// model, and not the input's.
    Stopped { time_s: f64 },
}

impl ThermalError {
    /// Whether the caller's input caused it (a schedule or plate the model cannot take), as
    /// opposed to a failure of the model.
    pub fn is_input(&self) -> bool {
        !matches!(
            self,
            ThermalError::NonFinite { .. }
                | ThermalError::Stopped { .. }
                | ThermalError::DeviceLost { .. }
        )
    }
}

impl fmt::Display for ThermalError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ThermalError::Schedule { deposit, reason } => write!(f, "deposit {deposit}: {reason}"),
            ThermalError::Plate { reason } => write!(f, "plate: {reason}"),
            ThermalError::DeviceLost { time_s, reason } => {
                write!(f, "the GPU failed at t = {time_s:.3} s: {reason}")
            }
            ThermalError::Device { reason } => {
                write!(f, "[thermal] device = \"gpu\": {reason}")
            }
            ThermalError::OutsidePlate {
                deposit,
                x_mm,
                y_mm,
            } => write!(
                f,
                "deposit {deposit} at ({x_mm:.1}, {y_mm:.1}) mm lies outside the plate"
            ),
            ThermalError::NonFinite {
                time_s,
                position_mm: p,
                what,
                value,
            } => write!(
                f,
                "numerical failure at t = {time_s:.3} s, ({:.1}, {:.1}, {:.1}) mm: {what} = {value}",
                p[0], p[1], p[2]
            ),
            ThermalError::Stopped { time_s } => {
                write!(f, "stopped on request at t = {time_s:.3} s")
            }
        }
    }
}

impl std::error::Error for ThermalError {}
