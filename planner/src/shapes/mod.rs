//! The part library: exact shapes meshed as mid-surfaces at a requested edge length.
//!
//! Every shape stands on z = 0 with its lower boundary there (the substrate), except where its
//! doc says otherwise. Lengths in mm.

mod params;
mod rings;

pub use params::{SIGNATURES, ShapeError, Signature};

use crate::mesh::TriMesh;
use nalgebra::Point3;
use rings::RingSurface;
use std::f64::consts::{FRAC_PI_2, PI, TAU};

/// A shape's mid-surface S(θ, t) as rings around its axis, the map boxed: one type for all.
type Surface = RingSurface<Box<dyn Fn(f64, f64) -> Point3<f64>>>;

#[derive(Debug, Clone, PartialEq)]
pub enum Shape {
    /// Open cylinder of radius R and height H.
    Cylinder { radius_mm: f64, height_mm: f64 },
    /// Open cone frustum from `radius_mm` at z = 0 to `top_radius_mm` at z = H, its upper
    /// boundary cut by the tilted plane z_top(θ) = H + slope·cos θ (flat at slope 0).
    ConeFrustum {
        radius_mm: f64,
        top_radius_mm: f64,
        height_mm: f64,
        top_slope_mm: f64,
    },
    /// Open vase: r(z) = R + bulge·sin(π z / H), upper boundary
    /// z_top(θ) = H + slope·cos θ + wave·sin(waves·θ) (sloped and sinusoidal, non-planar).
    Vase {
        radius_mm: f64,
        height_mm: f64,
        bulge_mm: f64,
        top_slope_mm: f64,
        top_wave_mm: f64,
        top_waves: u32,
    },
    /// Closed hemisphere of radius R on z = 0.
    Hemisphere { radius_mm: f64 },
    /// Closed dome symmetric about the xz plane only: a half ellipsoid of base semi-axes R (x) and
    /// R_y (y) and height H whose upper part leans towards −x by `lean_mm`·(z/H)², which changes
    /// the curvature on one side (the CTPP paper's closed part, Fig. 23, is of this kind).
    AsymmetricDome {
        radius_mm: f64,
        radius_y_mm: f64,
        height_mm: f64,
        lean_mm: f64,
    },
    /// Open bottle of height H: a cylinder of radius R, a shoulder narrowing to the neck's radius
    /// r_n over a height R − r_n (a cosine blend, tangent to both), and a neck of height h_n.
    Bottle {
        radius_mm: f64,
        height_mm: f64,
        neck_radius_mm: f64,
        neck_height_mm: f64,
    },
    /// Quarter torus tube: x = (R + r cos v) cos u − R, y = r sin v, z = (R + r cos v) sin u,
    /// u ∈ [0, π/2]. Lower boundary the circle of radius r at z = 0, upper one at x = −R.
    QuarterTorus {
        bend_radius_mm: f64,
        tube_radius_mm: f64,
    },
    /// Flat closed disk of radius R at z = 0 (a test surface: one boundary loop, no curvature).
    Disk { radius_mm: f64 },
}

impl Shape {
    pub fn name(&self) -> &'static str {
        match self {
            Shape::Cylinder { .. } => "cylinder",
            Shape::ConeFrustum { .. } => "cone_frustum",
            Shape::Vase { .. } => "vase",
            Shape::Hemisphere { .. } => "hemisphere",
            Shape::AsymmetricDome { .. } => "asymmetric_dome",
            Shape::Bottle { .. } => "bottle",
            Shape::QuarterTorus { .. } => "quarter_torus",
            Shape::Disk { .. } => "disk",
        }
    }

    /// Mesh the mid-surface with edges of about `edge_mm`.
    pub fn mesh(&self, edge_mm: f64) -> TriMesh {
        self.surface().mesh(edge_mm)
    }

    /// The vertices [`Shape::mesh`] makes at `edge_mm`, counted without making them: what a
    /// command that plans the part asks of memory is known before the part is meshed.
    pub fn vertices(&self, edge_mm: f64) -> usize {
        self.surface().vertices(edge_mm)
    }

    /// The mid-surface as rings around its axis.
    fn surface(&self) -> Surface {
        match *self {
            Shape::Cylinder {
                radius_mm: r,
                height_mm: h,
            } => ring(
                move |th, t| Point3::new(r * th.cos(), r * th.sin(), h * t),
                false,
            ),
            Shape::ConeFrustum {
                radius_mm: r0,
                top_radius_mm: r1,
                height_mm: h,
                top_slope_mm: slope,
            } => ring(
                move |th, t| {
                    let z = t * (h + slope * th.cos());
                    let r = r0 + (r1 - r0) * z / h;
                    Point3::new(r * th.cos(), r * th.sin(), z)
                },
                false,
            ),
            Shape::Vase {
                radius_mm,
                height_mm,
                bulge_mm,
                top_slope_mm,
                top_wave_mm,
                top_waves,
            } => {
                let top = move |th: f64| {
                    height_mm
                        + top_slope_mm * th.cos()
                        + top_wave_mm * (top_waves as f64 * th).sin()
                };
                ring(
                    move |th, t| {
                        let z = t * top(th);
                        let r = radius_mm + bulge_mm * (PI * z / height_mm).sin();
                        Point3::new(r * th.cos(), r * th.sin(), z)
                    },
                    false,
                )
            }
            Shape::Hemisphere { radius_mm: r } => ring(
                move |th, t| {
                    let phi = FRAC_PI_2 * (1.0 - t);
                    Point3::new(
                        r * phi.sin() * th.cos(),
                        r * phi.sin() * th.sin(),
                        r * phi.cos(),
                    )
                },
                true,
            ),
            Shape::AsymmetricDome {
                radius_mm: r,
                radius_y_mm: ry,
                height_mm: h,
                lean_mm,
            } => ring(
                move |th, t| {
                    let phi = FRAC_PI_2 * (1.0 - t);
                    let z = h * phi.cos();
                    let x = r * phi.sin() * th.cos() - lean_mm * (z / h).powi(2);
                    Point3::new(x, ry * phi.sin() * th.sin(), z)
                },
                true,
            ),
            Shape::Bottle {
                radius_mm: r,
                height_mm: h,
                neck_radius_mm: rn,
                neck_height_mm: hn,
            } => ring(
                move |th, t| {
                    let z = h * t;
                    let rho = bottle_radius(r, h, rn, hn, z);
                    Point3::new(rho * th.cos(), rho * th.sin(), z)
                },
                false,
            ),
            Shape::QuarterTorus {
                bend_radius_mm: big,
                tube_radius_mm: small,
            } => ring(
                move |v, t| {
                    let u = FRAC_PI_2 * t;
                    let rho = big + small * v.cos();
                    Point3::new(rho * u.cos() - big, small * v.sin(), rho * u.sin())
                },
                false,
            ),
            Shape::Disk { radius_mm: r } => ring(
                move |th, t| Point3::new(r * (1.0 - t) * th.cos(), r * (1.0 - t) * th.sin(), 0.0),
                true,
            ),
        }
    }
}

/// A bottle's radius at height z: the body, the shoulder's cosine blend, the neck.
fn bottle_radius(r: f64, h: f64, rn: f64, hn: f64, z: f64) -> f64 {
    let shoulder_top = h - hn;
    let shoulder_bottom = shoulder_top - (r - rn);
    if z <= shoulder_bottom {
        r
    } else if z >= shoulder_top {
        rn
    } else {
        let s = (z - shoulder_bottom) / (r - rn);
        rn + (r - rn) * 0.5 * (1.0 + (PI * s).cos())
    }
}

fn ring(map: impl Fn(f64, f64) -> Point3<f64> + 'static, closed_top: bool) -> Surface {
    RingSurface {
        map: Box::new(map),
        closed_top,
    }
}

/// A structured grid on an open tube: `around` × `up` vertices (the geodesic benchmark mesh).
pub fn tube_grid(radius_mm: f64, height_mm: f64, around: usize, up: usize) -> TriMesh {
    let mut positions = Vec::with_capacity(around * up);
    for j in 0..up {
        let z = height_mm * j as f64 / (up - 1) as f64;
        for i in 0..around {
            let th = TAU * i as f64 / around as f64;
            positions.push(Point3::new(radius_mm * th.cos(), radius_mm * th.sin(), z));
        }
    }
    let id = |i: usize, j: usize| (j * around + i % around) as u32;
    let mut faces = Vec::with_capacity(2 * around * (up - 1));
    for j in 0..up - 1 {
        for i in 0..around {
            faces.push([id(i, j), id(i + 1, j), id(i + 1, j + 1)]);
            faces.push([id(i, j), id(i + 1, j + 1), id(i, j + 1)]);
        }
    }
    TriMesh::new(positions, faces)
}
