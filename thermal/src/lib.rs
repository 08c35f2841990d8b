//! # thermal
//!
//! The heat the deposition puts into the growing part. Takes a deposition schedule (where,
//! when, how much metal and heat: [`schedule::Deposit`]) and returns temperatures; knows nothing
//! of generators, layers or files. SI units, temperatures in K.
//!
//! - [`material`]: properties and the enthalpy–temperature relation (latent heat included).
//! - [`network`]: lumped nodes and conductances stepped by backward Euler, energy booked exactly.
//! - [`rates`]: local time stepping, the nodes far from the arc stepped at their own rates.
//! - [`run`]: the contract both heat models serve ([`HeatRun`], [`HeatModel`]) and the types
//!   they share: per-point results, what a point lies on, field snapshots, the plate.
//! - [`pool`]: the melt pool behind the torch, its tail interpolated between samples.
//! - [`wall`]: the thin-wall model on the path's grid, with the substrate plate
//!   (`plate_cells`: its cells, merged away from the part).
//! - [`voxel`]: the 3-D voxel model, the reference for local detail.
//! - [`error`]: what can go wrong, with the evidence.

pub mod error;
pub mod material;
pub mod network;
pub(crate) mod plate_cells;
pub(crate) mod pool;
pub mod rates;
pub mod run;
pub mod schedule;
pub mod voxel;
pub mod wall;

pub use error::ThermalError;
pub use run::{
    Burn, Cells, CoolingSteps, HeatModel, HeatRun, ModelRun, Plate, PointResult, RunResult,
    Snapshot, Support, Trace,
};

/// 0 °C in kelvin: the one place the interface's °C and the models' K meet.
pub const ZERO_CELSIUS_K: f64 = 273.15;

/// Kelvin from degrees Celsius.
pub fn kelvin(celsius: f64) -> f64 {
    celsius + ZERO_CELSIUS_K
}

/// Degrees Celsius from kelvin.
pub fn celsius(kelvin: f64) -> f64 {
    kelvin - ZERO_CELSIUS_K
}
