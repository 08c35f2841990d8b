//! # thermal
//!
//! The heat the deposition puts into the growing part. Takes a deposition schedule (where,
//! when, how much metal and heat: [`schedule::Deposit`]) and returns temperatures; knows nothing
//! of generators, layers or files. SI units, temperatures in K.
//!
//! - [`material`]: properties and the enthalpy–temperature relation (latent heat included).
//! - [`network`]: lumped nodes and conductances stepped by backward Euler, energy booked exactly.
//! - [`wall`]: the thin-wall model on the path's grid, with the substrate plate.

pub mod material;
pub mod network;
pub mod schedule;
pub mod voxel;
pub mod wall;
