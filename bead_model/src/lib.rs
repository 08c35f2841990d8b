//! # bead_model
//!
//! The bead the arc lays: how the machine's settings make a deposit of a given height (Eq.7 of
//! the CTPP paper), in SI units. Pure functions of plain numbers; no geometry, no files.

pub mod eq7;
