//! Skeleton arc additive manufacturing (SAAM; Radel, Diourté, Soulié, Company, Bordreuil,
//! Additive Manufacturing 2019): truss parts built point by point along the polylines of a
//! skeleton, each point a drop (a spherical cap of radius R_deposit) struck with the torch
//! standing still.
//!
//! One module per step of the paper: [`graph`] (§3.1: polylines, nodes, priorities, what the
//! propagation can reach), [`overlap`] (§3.5: the welding-time ratio k_w from the drop's sphere
//! less the union of the drops already built), [`slicer`] (§2.1, §3.2–§3.5: the adaptive slicer
//! with its list of points to build, intersections and collision zones, corrected by what a
//! camera measured of each drop).

pub mod graph;
pub mod overlap;
pub mod slicer;

pub use graph::{Branch, Priority, Skeleton, SkeletonError};
pub use slicer::{Planned, Slicer, SlicerSettings};
