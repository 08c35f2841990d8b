//! # planner
//!
//! Continuous Three-dimensional Path Planning (CTPP; Diourté, Bugarin, Bordreuil, Segonds,
//! Additive Manufacturing 2020) for thin parts built with one continuous WAAM bead.
//!
//! Data first, then algorithms: [`mesh`] (connectivity and validation), [`io`] (one module per
//! file format, bytes in and out), [`shapes`] (the part library). Lengths are in millimetres
//! throughout the planner: it is geometry, and the paper's numbers are in mm.

pub use nalgebra;

pub mod closing_point;
pub mod collision;
pub mod deviation;
pub mod frame;
pub mod generators;
pub mod geodesic;
pub mod geometry;
pub mod interlayer;
pub mod io;
pub mod mesh;
pub mod orientation;
pub mod plan;
pub mod planar;
pub mod saam;
pub mod shapes;
pub mod skeleton;
pub mod spiral;
pub mod table;
pub mod tube;
