//! The arc's heat on the grid: Goldak's double ellipsoid in the arc's frame, cut at three
//! semi-axes, or a Gaussian on the exposed top; each scaled so that its discrete sum is the
//! segment's heat.

use super::lay::bead_frame;
use super::vec3::{cross, dot, norm, normalize, perpendicular, scale, sub};
use super::{HeatSource, VoxelModel};
use crate::run::Burn;
use crate::schedule::Deposit;
use rayon::prelude::*;

/// Goldak double-ellipsoid parameters relative to the bead: half-width a = W/2, depth b = H,
/// front c_f = a, rear c_r = 2a, f_f = 0.6, f_r = 1.4 (typical values for GMAW).
pub(super) struct Goldak {
    pub(super) a: f64,
    pub(super) b: f64,
    pub(super) cf: f64,
    pub(super) cr: f64,
}

impl Goldak {
    /// The source's rear length c_r for a bead of width `w`.
    pub(super) fn rear(w: f64) -> f64 {
        w
    }

    pub(super) fn weight(&self, along: f64, across: f64, depth: f64) -> f64 {
        let (c, f) = if along >= 0.0 {
            (self.cf, 0.6)
        } else {
            (self.cr, 1.4)
        };
        f / (self.a * self.b * c)
            * (-3.0
                * (along * along / (c * c)
                    + across * across / (self.a * self.a)
                    + depth * depth / (self.b * self.b)))
                .exp()
    }
}

impl VoxelModel {
    /// Goldak source of the burn's heat over its arc time, for deposit i, on the active voxels
    /// around the top of its settled metal, oriented along its travel across the torch
    /// ([`arc_frame`]).
    pub(super) fn source(&self, deps: &[Deposit], i: usize, burn: Burn, out: &mut Vec<(u32, f32)>) {
        out.clear();
        let d = &deps[i];
        // The pool sits on the metal, `sink` below the path point where the metal settled.
        let pool = sub(d.position, scale(d.axis, self.sink[i]));
        let heat = burn.heat;
        if burn.arc_time <= 0.0 || heat <= 0.0 {
            return;
        }
        let (tangent, across) = arc_frame(deps, i);
        let w = match self.settings.source {
            HeatSource::Gaussian { radius } => {
                let w = self.surface(pool, d.axis, d.height, radius);
                if w.is_empty() {
                    self.ellipsoid(d, pool, tangent, across)
                } else {
                    w
                }
            }
            HeatSource::DoubleEllipsoid => self.ellipsoid(d, pool, tangent, across),
        };
        let total: f64 = w.iter().map(|x| x.1).sum();
        let power = heat / burn.arc_time;
        out.extend(w.iter().map(|&(v, wt)| (v, (power * wt / total) as f32)));
    }

    /// Goldak's double-ellipsoid weights of deposit `d`'s heat on the active voxels around
    /// `pool`, cut where the exponent passes 27 along any of the ellipsoid's axes (three
    /// semi-axes: e^-27 ≈ 2e-12 of the peak; Goldak et al. 1984 put the semi-axes where the
    /// density is e^-3 ≈ 5 % of it). The cells looked at are the box around that cut, not a cube
    /// of 3·c_r about the pool, which looked up every cell of it and handed each step thousands
    /// of voxels weighed zero in f32 (docs/PERFORMANCE.md, "Two cores").
    pub(super) fn ellipsoid(
        &self,
        d: &Deposit,
        pool: [f64; 3],
        tangent: [f64; 3],
        across: [f64; 3],
    ) -> Vec<(u32, f64)> {
        let g = Goldak {
            a: d.width / 2.0,
            b: d.height.max(self.settings.size),
            cf: d.width / 2.0,
            cr: Goldak::rear(d.width),
        };
        let dx = self.settings.size;
        // The cut in the source's own axes: along the tangent, across, and along the build
        // axis (depth below the pool, and as far above, where its own metal may lie).
        let axes = [tangent, across, d.axis];
        let cut = [
            [-3.0 * g.cr, 3.0 * g.cf],
            [-3.0 * g.a, 3.0 * g.a],
            [-3.0 * g.b, 3.0 * g.b],
        ];
        let inside = |r: [f64; 3]| {
            (0..3).all(|l| {
                let x = dot(r, axes[l]);
                x >= cut[l][0] && x <= cut[l][1]
            })
        };
        let (lo, hi) = cut_box(axes, cut, pool, dx).unwrap_or_else(|| {
            let reach = 3.0 * g.cr + dx;
            (pool.map(|p| p - reach), pool.map(|p| p + reach))
        });
        let lo: [isize; 3] =
            std::array::from_fn(|k| ((lo[k] - self.origin[k]) / dx).floor() as isize);
        let hi: [isize; 3] =
            std::array::from_fn(|k| ((hi[k] - self.origin[k]) / dx).ceil() as isize);
        // The box is thousands of cells at fine voxels, once per deposit: its slices go to the
        // threads and come back in order, so the weights are the same on any number.
        let slices: Vec<Vec<(u32, f64)>> = (lo[2].max(0)..=hi[2].min(self.dims[2] as isize - 1))
            .into_par_iter()
            .map(|iz| {
                let mut w = Vec::new();
                for iy in lo[1].max(0)..=hi[1].min(self.dims[1] as isize - 1) {
                    for ix in lo[0].max(0)..=hi[0].min(self.dims[0] as isize - 1) {
                        let (ix, iy, iz) = (ix as usize, iy as usize, iz as usize);
                        let r = sub(self.centre(ix, iy, iz), pool);
                        if !inside(r) {
                            continue;
                        }
                        let Some(&v) = self.index.get(&self.flat(ix, iy, iz)) else {
                            continue;
                        };
                        let wt = g.weight(dot(r, tangent), dot(r, across), dot(r, d.axis).min(0.0));
                        if wt > 0.0 {
                            w.push((v, wt));
                        }
                    }
                }
                w
            })
            .collect();
        slices.concat()
    }

    /// Gaussian surface weights: the active voxels with their top exposed (no voxel above),
    /// within 2R of `pool` across the build direction and within a layer of it along it.
    pub(super) fn surface(
        &self,
        pool: [f64; 3],
        axis: [f64; 3],
        height: f64,
        radius: f64,
    ) -> Vec<(u32, f64)> {
        let dx = self.settings.size;
        let reach = 2.0 * radius + dx;
        let depth = height.max(dx) + dx;
        let lo: [isize; 3] = std::array::from_fn(|k| {
            ((pool[k] - reach - depth - self.origin[k]) / dx).floor() as isize
        });
        let hi: [isize; 3] =
            std::array::from_fn(|k| ((pool[k] + reach + dx - self.origin[k]) / dx).ceil() as isize);
        let mut w = Vec::new();
        for iz in lo[2].max(0)..=hi[2].min(self.dims[2] as isize - 1) {
            for iy in lo[1].max(0)..=hi[1].min(self.dims[1] as isize - 1) {
                for ix in lo[0].max(0)..=hi[0].min(self.dims[0] as isize - 1) {
                    let (ix, iy, iz) = (ix as usize, iy as usize, iz as usize);
                    let Some(&v) = self.index.get(&self.flat(ix, iy, iz)) else {
                        continue;
                    };
                    if !self.open_above(v, [ix, iy, iz]) {
                        continue;
                    }
                    let r = sub(self.centre(ix, iy, iz), pool);
                    let along = dot(r, axis);
                    let off = norm(sub(r, scale(axis, along)));
                    if along >= -depth && along <= dx && off <= 2.0 * radius {
                        w.push((v, (-2.0 * off * off / (radius * radius)).exp()));
                    }
                }
            }
        }
        w
    }
}

/// The world box around the points r = p − `pool` with `cut[l][0]` ≤ r·`axes[l]` ≤
/// `cut[l][1]` (a parallelepiped; the axes need not be orthogonal), widened by `pad`; None
/// where the axes are near parallel and it has no bounded box worth the name.
pub(super) fn cut_box(
    axes: [[f64; 3]; 3],
    cut: [[f64; 2]; 3],
    pool: [f64; 3],
    pad: f64,
) -> Option<([f64; 3], [f64; 3])> {
    // r = Σ u_l·d_l/det, the d_l the inverse's columns (the other two axes crossed).
    let [a, b, c] = axes;
    let dual = [cross(b, c), cross(c, a), cross(a, b)];
    let det = dot(a, dual[0]);
    if det.is_nan() || det.abs() < 1e-3 {
        return None;
    }
    let (mut lo, mut hi) = (pool, pool);
    for corner in 0..8 {
        let u: [f64; 3] = std::array::from_fn(|l| cut[l][(corner >> l) & 1] / det);
        for k in 0..3 {
            let r = (0..3).map(|l| u[l] * dual[l][k]).sum::<f64>();
            lo[k] = lo[k].min(pool[k] + r - pad);
            hi[k] = hi[k].max(pool[k] + r + pad);
        }
    }
    Some((lo, hi))
}

/// The arc's frame for Goldak's ellipsoid at deposit i: the travel across the torch (the bead's
/// direction less its part along the axis: a climbing helix's source lies square to its torch,
/// as Goldak's does to the work, not sheared along the climb) and across it; where the torch
/// moves along its own axis, any direction square to it.
pub(super) fn arc_frame(deps: &[Deposit], i: usize) -> ([f64; 3], [f64; 3]) {
    let axis = deps[i].axis;
    let (tangent, _, _) = bead_frame(deps, i);
    let travel = sub(tangent, scale(axis, dot(tangent, axis)));
    let travel = match norm(travel) > 1e-6 {
        true => normalize(travel),
        false => perpendicular(axis),
    };
    (travel, cross(axis, travel))
}
