//! # bead_model
//!
//! The bead the arc lays, in SI units: what the machine must do to lay a planned deposit (Eq.7 of
//! the CTPP paper, both ways), which deposits its limits allow (the process window), how much heat
//! that puts in, whether surface tension holds the pool (the Bond number), the cap a drop laid
//! standing makes, and what comes out when the metal underneath is hot. Pure functions of plain
//! numbers; no geometry, no files.

pub mod as_built;
pub mod bond;
pub mod drop;
pub mod eq7;
pub mod heat_input;
pub mod section;
pub mod window;
