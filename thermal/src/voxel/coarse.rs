//! The coarsened plate (`VoxelSettings::coarse_plate`): away from the metal laid on it, blocks
//! of 2 × 2 × 2 cells step as cells of edge 2·dx at their own rate (`coarse_due`), and meet the
//! cells of edge dx across seams, conducted before the kernel runs (docs/PHYSICS.md "A
//! coarsened plate", "The coarse cells at their own rate").

use super::{FACES, VoxelModel};
use crate::schedule::{Deposit, segment_start};
use rustc_hash::FxHashSet as HashSet;

impl VoxelModel {
    /// Switch on the coarse plate cell of the 2 × 2 × 2 cells from `corner` on (its eight cells
    /// all map to it), at temperature `temp`; `bottom` puts it on the table, `top` makes it what
    /// its four columns' metal is laid on. Coarse cells are switched on before any other, so
    /// what it meets is coarse or nothing.
    pub(super) fn add_coarse(
        &mut self,
        corner: [usize; 3],
        temp: f64,
        bottom: bool,
        top: bool,
    ) -> u32 {
        let v = self.cell.len() as u32;
        let dx = self.settings.size;
        let area = (4.0 * dx * dx) as f32;
        for o in 0..8 {
            let f = self.flat(
                corner[0] + (o & 1),
                corner[1] + ((o >> 1) & 1),
                corner[2] + (o >> 2),
            );
            self.index.insert(f, v);
        }
        if top {
            for o in 0..4 {
                self.plate_top
                    .insert((corner[0] + (o & 1), corner[1] + (o >> 1)), v);
            }
        }
        self.cell.push(self.flat(corner[0], corner[1], corner[2]));
        self.coarse_g.push(0.0);
        let (mut exposed, mut touched, mut g) = (0.0, [v; 6], 0.0);
        for face in 0..6 {
            // The cell across the face next to the corner: in the next block, if any.
            let (ox, oy, oz) = FACES[face];
            let across = [ox, oy, oz].map(|o| match o {
                1 => 2,
                o => o,
            });
            let cell = corner.map(|c| c as isize);
            let c: [isize; 3] = std::array::from_fn(|k| cell[k] + across[k]);
            let u = match (0..3).all(|k| c[k] >= 0 && c[k] < self.dims[k] as isize) {
                true => {
                    let f = self.flat(c[0] as usize, c[1] as usize, c[2] as usize);
                    self.index.get(&f).copied()
                }
                false => None,
            };
            match u {
                Some(u) => {
                    debug_assert!((u as usize) < self.coarse, "a coarse cell after a fine one");
                    touched[face] = u;
                    g += 2.0 * dx;
                    self.conduct_coarse(u, 2.0 * dx);
                    self.neighbours[face].push(u);
                    self.neighbours[face ^ 1][u as usize] = v;
                    self.exposed[u as usize] -= area;
                }
                None if face == 4 && bottom => self.neighbours[face].push(v),
                None => {
                    self.neighbours[face].push(v);
                    exposed += area;
                }
            }
        }
        self.face_weight.push([1.0; 6]);
        self.exposed.push(exposed);
        self.on_table.push(if bottom { area } else { 0.0 });
        self.conduct_coarse(v, g);
        self.switch_on(v, temp, touched);
        v
    }

    /// The coarse cells' own stable step, s: courant·V/(α_max·G) for the cell of the largest
    /// conductance G (m) and volume V = 8·dx³, the stencil's limit on its own neighbours (12·dx
    /// with coarse ones alone: 4× the limit of cells of edge dx; seams add dx/1.5 each, a
    /// mixed one at most dx; G taken at least one face's 2·dx, so that a lone block still steps
    /// for its losses). Infinite without coarse cells.
    pub(super) fn coarse_period(&self) -> f64 {
        if self.coarse == 0 {
            return f64::INFINITY;
        }
        let dx = self.settings.size;
        let g = (self.coarse_g_max as f64).max(2.0 * dx);
        self.settings.courant * 8.0 * dx.powi(3) / (self.coarse_alpha * g)
    }

    /// Whether this step of dt steps the coarse cells, and if so over how long: the time since
    /// they last were, this step's included. Far from the metal the plate's field varies
    /// slowly and its coarse cells' stable step is 3–4 times the cells of edge dx, so they
    /// step once in as many steps (a multirate step: Gear and Wells 1984), never past their
    /// period even if the next step is a whole `fine_step`. Between their steps the seams and
    /// the source still add to their h every step (no heat lost or made); the cells of edge dx
    /// read their Φ as it was at their last step (docs/PHYSICS.md "The coarse cells at their
    /// own rate").
    pub(super) fn coarse_due(&mut self, dt: f64) -> Option<f64> {
        let behind = self.coarse_behind + dt;
        let due = self.coarse == 0
            || !self.coarse_own_rate
            || behind + self.fine_step > self.coarse_period();
        self.coarse_behind = if due { 0.0 } else { behind };
        due.then_some(behind)
    }

    /// Add `g` (m) to coarse cell `u`'s conductance.
    pub(super) fn conduct_coarse(&mut self, u: u32, g: f64) {
        let c = &mut self.coarse_g[u as usize];
        *c += g as f32;
        self.coarse_g_max = self.coarse_g_max.max(*c);
    }

    /// The seams between coarse plate cells and cells of edge dx, added to h before the kernel
    /// as the source is (the kernel reads T and Φ from the h they leave): one face dx² of the
    /// smaller cell, its centre dx/2 from the face and the coarse cell's dx, so a conductance
    /// dx²/(1.5·dx) on Φ where both are of one material (the kernel's own form on a longer
    /// path), and the two half paths in series, dx/(1/(2·k_fine) + 1/k_coarse), on T where the
    /// fine side is deposit on a plate of its own material (Patankar 1980 §4.2-4); both on the
    /// state as the step starts. The same heat leaves one side as enters the other.
    /// `inv_cap`: dt/mass of a coarse cell, a plate cell of edge dx, a deposit cell.
    pub(super) fn seams(&mut self, [coarse, plate, deposit]: [f32; 3]) {
        let dx = self.settings.size;
        let g = (dx / 1.5) as f32;
        // Without a plate material a deposit cell's dt/mass is the plate's.
        for &(i, j) in &self.seams {
            let (i, j) = (i as usize, j as usize);
            let q = g * (self.phi[i] - self.phi[j]);
            self.h[j] += plate * q;
            self.h[i] -= coarse * q;
        }
        if let Some(s) = self.substrate.as_deref() {
            for &(i, j) in &self.mixed_seams {
                let (i, j) = (i as usize, j as usize);
                let kc = s.material.conductivity(self.t[i] as f64);
                let kf = self.settings.material.conductivity(self.t[j] as f64);
                let q = dx / (1.0 / (2.0 * kf) + 1.0 / kc) * (self.t[i] - self.t[j]) as f64;
                self.h[j] += deposit * q as f32;
                self.h[i] -= coarse * q as f32;
            }
        }
    }
}

/// The plate's block columns (bx, by) that stay cells of edge dx when the plate is coarsened:
/// those whose centre lies, across the plate, within 1.5·W + 3·dx of the segment of a deposit
/// whose metal's bottom is within two cells of the plate's top (the first layers, which lie on
/// the plate and pour their heat into it). That keeps the footprint, a bead's width either side
/// of it, and a block's half diagonal fine: the steep gradients under the arc.
pub(super) fn fine_columns(deps: &[Deposit], m: &VoxelModel) -> HashSet<(usize, usize)> {
    let dx = m.settings.size;
    let block = 2.0 * dx;
    let mut out = HashSet::default();
    for (i, d) in deps.iter().enumerate() {
        let bottom = d.position[2] - m.below[i] * d.axis[2];
        if d.support.is_some() && bottom > 2.0 * dx + d.width / 2.0 {
            continue;
        }
        let (a, b) = (segment_start(deps, i), d.position);
        let margin = 1.5 * d.width + 3.0 * dx;
        let lo = |k: usize| {
            ((a[k].min(b[k]) - margin - m.origin[k]) / block)
                .floor()
                .max(0.0) as usize
        };
        let hi = |k: usize| {
            (((a[k].max(b[k]) + margin - m.origin[k]) / block).ceil() as usize).min(m.dims[k] / 2)
        };
        for by in lo(1)..hi(1) {
            for bx in lo(0)..hi(0) {
                let c = [
                    m.origin[0] + (bx as f64 + 0.5) * block,
                    m.origin[1] + (by as f64 + 0.5) * block,
                ];
                if distance_to_segment(c, [a[0], a[1]], [b[0], b[1]]) <= margin {
                    out.insert((bx, by));
                }
            }
        }
    }
    out
}

/// Distance from point p to the segment ab, in the plane.
pub(super) fn distance_to_segment(p: [f64; 2], a: [f64; 2], b: [f64; 2]) -> f64 {
    let (ab, ap) = ([b[0] - a[0], b[1] - a[1]], [p[0] - a[0], p[1] - a[1]]);
    let len2 = ab[0] * ab[0] + ab[1] * ab[1];
    let t = match len2 > 0.0 {
        true => ((ap[0] * ab[0] + ap[1] * ab[1]) / len2).clamp(0.0, 1.0),
        false => 0.0,
    };
    (ap[0] - t * ab[0]).hypot(ap[1] - t * ab[1])
}
