//! The thin wall's plate as cells: columns of `layers` cells through the thickness, on the
//! plate's cell in the plane near the metal laid on it, and merged 2 × 2 and then 4 × 4 columns
//! farther out, where the plate is a slowly varying sink for the wall's heat. Under a small part
//! the plate is most of the thin wall's nodes (7 500 of 8 079 for a dome R 25 on the 250 mm
//! stock plate), and the solves' cost follows the nodes.
//!
//! A merged column keeps its cells' mass, top and table areas exactly; conduction between two
//! columns is summed over the fine faces they share, each of the fine cell's face area over the
//! distance between the two columns' centres along the face's axis (a finite-volume
//! agglomeration, first order where a side-2 column meets two of side 1). Where no column is
//! merged (a plate within four cells of the metal everywhere), the cells, their order and
//! their edges are the uniform grid's, to the bit.

use crate::run::Plate;
use crate::schedule::Deposit;
use std::collections::HashMap;

/// Columns farther than this many cells (in x or y) from the metal laid on the plate are merged
/// 2 × 2.
const MERGE_2_BEYOND_CELLS: f64 = 4.0;
/// And farther than this, 4 × 4.
const MERGE_4_BEYOND_CELLS: f64 = 12.0;

pub(crate) struct PlateCells {
    /// The plate's corner (least x and y), m.
    origin: [f64; 2],
    /// A fine cell's x, y and thickness, m.
    pub cell: [f64; 3],
    /// Fine columns in x and y.
    n: [usize; 2],
    layers: usize,
    /// Per fine column (j·nx + i): its column of cells.
    column_of: Vec<u32>,
    /// Per column: its first fine column (i, j) and its side, in fine columns.
    columns: Vec<([usize; 2], usize)>,
}

impl PlateCells {
    /// The cells of plate `p` under the deposits `deps` (those with no support are laid on
    /// it); `merge` false: the uniform grid, nothing merged.
    pub fn new(p: &Plate, deps: &[Deposit], merge: bool) -> PlateCells {
        let (nx, ny, nz) = (
            ((p.size[0] / p.cell).round() as usize).max(1),
            ((p.size[1] / p.cell).round() as usize).max(1),
            p.layers.max(1),
        );
        let cell = [
            p.size[0] / nx as f64,
            p.size[1] / ny as f64,
            p.size[2] / nz as f64,
        ];
        let origin = [p.centre[0] - p.size[0] / 2.0, p.centre[1] - p.size[1] / 2.0];
        // The uniform grid never asks how far a column lies from the metal.
        let near = match merge {
            true => cells_to_metal([nx, ny], origin, cell, deps),
            false => Vec::new(),
        };
        // How many cells a block of columns lies from the metal: its nearest column's count.
        let away = |[i, j]: [usize; 2], side: usize| -> f64 {
            (j..j + side)
                .flat_map(|jj| near[jj * nx + i..jj * nx + i + side].iter())
                .fold(f64::INFINITY, |a, &d| a.min(d))
        };
        let side_at = |i: usize, j: usize| -> usize {
            if !merge {
                return 1;
            }
            for (side, beyond) in [(4, MERGE_4_BEYOND_CELLS), (2, MERGE_2_BEYOND_CELLS)] {
                let first = [i - i % side, j - j % side];
                let inside = first[0] + side <= nx && first[1] + side <= ny;
                if inside && away(first, side) > beyond {
                    return side;
                }
            }
            1
        };
        let mut column_of = vec![u32::MAX; nx * ny];
        let mut columns = Vec::new();
        for j in 0..ny {
            for i in 0..nx {
                if column_of[j * nx + i] != u32::MAX {
                    continue;
                }
                let side = side_at(i, j);
                let id = columns.len() as u32;
                for jj in j..j + side {
                    column_of[jj * nx + i..jj * nx + i + side].fill(id);
                }
                columns.push(([i, j], side));
            }
        }
        PlateCells {
            origin,
            cell,
            n: [nx, ny],
            layers: nz,
            column_of,
            columns,
        }
    }

    /// Cells in all: columns × layers.
    pub fn len(&self) -> usize {
        self.columns.len() * self.layers
    }

    /// The cell of column `c` in layer `k` (0 the top), numbered from 0.
    fn id(&self, c: usize, k: usize) -> usize {
        k * self.columns.len() + c
    }

    /// The top cell over point (x, y), m; none off the plate.
    pub fn top_at(&self, x: f64, y: f64) -> Option<usize> {
        let i = ((x - self.origin[0]) / self.cell[0]).floor();
        let j = ((y - self.origin[1]) / self.cell[1]).floor();
        (i >= 0.0 && j >= 0.0 && (i as usize) < self.n[0] && (j as usize) < self.n[1])
            .then(|| self.column_of[j as usize * self.n[0] + i as usize] as usize)
    }

    /// The top cells round point (x, y), m, each weighted bilinearly by its fine column's
    /// centre's distance from the point (a merged cell once per fine column it covers): the
    /// plate's top at the point, where [`Self::top_at`] gives the cell that holds it. None off
    /// the plate.
    pub fn top_around(&self, x: f64, y: f64) -> Vec<(usize, f64)> {
        let f = [
            (x - self.origin[0]) / self.cell[0] - 0.5,
            (y - self.origin[1]) / self.cell[1] - 0.5,
        ];
        let mut out = Vec::with_capacity(4);
        for (oi, oj) in [(0, 0), (1, 0), (0, 1), (1, 1)] {
            let (i, j) = (f[0].floor() + oi as f64, f[1].floor() + oj as f64);
            let w = (1.0 - (i - f[0]).abs()) * (1.0 - (j - f[1]).abs());
            if i >= 0.0
                && j >= 0.0
                && (i as usize) < self.n[0]
                && (j as usize) < self.n[1]
                && w > 0.0
            {
                out.push((
                    self.column_of[j as usize * self.n[0] + i as usize] as usize,
                    w,
                ));
            }
        }
        out
    }

    /// Each cell in order: its mass at density `rho`, its top (exposed) and table areas, its
    /// centre, and its side in fine cells.
    pub fn cells(&self, rho: f64) -> impl Iterator<Item = (f64, f64, f64, [f64; 3], u8)> + '_ {
        let [cx, cy, cz] = self.cell;
        (0..self.layers).flat_map(move |k| {
            self.columns.iter().map(move |&([i, j], side)| {
                let s = side as f64;
                let (w, d) = (s * cx, s * cy);
                let area = w * d;
                (
                    rho * w * d * cz,
                    if k == 0 { area } else { 0.0 },
                    if k == self.layers - 1 { area } else { 0.0 },
                    [
                        self.origin[0] + (i as f64 + 0.5 * s) * cx,
                        self.origin[1] + (j as f64 + 0.5 * s) * cy,
                        -(k as f64 + 0.5) * cz,
                    ],
                    side as u8,
                )
            })
        })
    }

    /// The conducting pairs (a, b, area/length), numbered as [`PlateCells::cells`] yields them,
    /// in the uniform grid's order where no column is merged.
    pub fn edges(&self) -> Vec<(usize, usize, f64)> {
        let [nx, ny] = self.n;
        let [cx, cy, cz] = self.cell;
        let mut edges: Vec<(usize, usize, f64)> = Vec::new();
        // Pairs met before (merged columns share several fine faces): where their edge is.
        let mut seen: HashMap<(usize, usize), usize> = HashMap::new();
        let mut add = |a: usize, b: usize, g: f64, merged: bool| {
            if !merged {
                edges.push((a, b, g));
                return;
            }
            match seen.get(&(a, b)) {
                Some(&e) => edges[e].2 += g,
                None => {
                    seen.insert((a, b), edges.len());
                    edges.push((a, b, g));
                }
            }
        };
        let side = |c: usize| self.columns[c].1;
        for k in 0..self.layers {
            for j in 0..ny {
                for i in 0..nx {
                    let a = self.column_of[j * nx + i] as usize;
                    let mut across = |b: usize, face: f64, step: f64| {
                        if a != b {
                            let length = 0.5 * (side(a) + side(b)) as f64 * step;
                            let merged = side(a) > 1 || side(b) > 1;
                            add(self.id(a, k), self.id(b, k), face / length, merged);
                        }
                    };
                    if i + 1 < nx {
                        across(self.column_of[j * nx + i + 1] as usize, cz * cy, cx);
                    }
                    if j + 1 < ny {
                        across(self.column_of[(j + 1) * nx + i] as usize, cz * cx, cy);
                    }
                    if k + 1 < self.layers && self.columns[a].0 == [i, j] {
                        let s = side(a) as f64;
                        add(
                            self.id(a, k),
                            self.id(a, k + 1),
                            s * cx * (s * cy) / cz,
                            false,
                        );
                    }
                }
            }
        }
        edges
    }
}

/// Per fine column (j·nx + i), how many columns lie between it and the nearest one under
/// metal laid on the plate (a bead's width about each deposit's centre), counting diagonal
/// steps as one (the Chebyshev distance, exact in two passes); 0 under metal, and 0 everywhere
/// where nothing is laid on the plate (nothing merged).
fn cells_to_metal(n: [usize; 2], origin: [f64; 2], cell: [f64; 3], deps: &[Deposit]) -> Vec<f64> {
    let [nx, ny] = n;
    let mut d = vec![f64::INFINITY; nx * ny];
    let index = |x: f64, k: usize, top: usize| {
        (((x - origin[k]) / cell[k]).floor().max(0.0) as usize).min(top - 1)
    };
    let mut any = false;
    for dep in deps.iter().filter(|d| d.support.is_none()) {
        let (p, w) = (dep.position, dep.width);
        for j in index(p[1] - w, 1, ny)..=index(p[1] + w, 1, ny) {
            d[j * nx + index(p[0] - w, 0, nx)..=j * nx + index(p[0] + w, 0, nx)].fill(0.0);
        }
        any = true;
    }
    if !any {
        return vec![0.0; nx * ny];
    }
    let at = |i: isize, j: isize| {
        (i >= 0 && j >= 0 && (i as usize) < nx && (j as usize) < ny)
            .then(|| j as usize * nx + i as usize)
    };
    let behind = [(-1, 0), (-1, -1), (0, -1), (1, -1)];
    for pass in [1isize, -1] {
        let order: Vec<usize> = match pass {
            1 => (0..nx * ny).collect(),
            _ => (0..nx * ny).rev().collect(),
        };
        for c in order {
            let (i, j) = ((c % nx) as isize, (c / nx) as isize);
            for (di, dj) in behind {
                if let Some(o) = at(i + pass * di, j + pass * dj) {
                    d[c] = d[c].min(d[o] + 1.0);
                }
            }
        }
    }
    d
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::schedule::helix;

    /// A plate within reach of the metal everywhere is the uniform grid; a large one keeps its
    /// mass and areas exactly and conducts a uniform gradient across its merged columns as the
    /// uniform grid does; and without the merge it is the uniform grid.
    #[test]
    fn merged_columns_keep_mass_areas_and_a_gradient() {
        let deps = helix(0.02, 40, 1, 2e-3, 5e-3, 10e-3, 1000.0);
        let small = PlateCells::new(&Plate::square_mm(60.0), &deps, true);
        assert!(small.columns.iter().all(|c| c.1 == 1));
        assert_eq!(small.len(), 12 * 12 * 3);

        let big = PlateCells::new(&Plate::square_mm(250.0), &deps, true);
        assert!(big.len() < 50 * 50 * 3 / 3, "{} cells", big.len());
        let cells: Vec<_> = big.cells(7800.0).collect();
        let mass: f64 = cells.iter().map(|c| c.0).sum();
        let top: f64 = cells.iter().map(|c| c.1).sum();
        let table: f64 = cells.iter().map(|c| c.2).sum();
        assert!((mass - 7800.0 * 0.25 * 0.25 * 0.01).abs() < 1e-9 * mass);
        assert!((top - 0.0625).abs() < 1e-12 && (table - 0.0625).abs() < 1e-12);
        // T = x: the heat across the line x = −5 mm (a boundary of every merged column) is
        // the plate's cross-section times the gradient, each fine face counted once, as the
        // uniform grid has it; and no pair of cells has two edges.
        let x = |c: usize| cells[c].3[0];
        let edges = big.edges();
        let across: f64 = edges
            .iter()
            .filter(|&&(a, b, _)| (x(a) + 0.005) * (x(b) + 0.005) < 0.0)
            .map(|&(a, b, g)| g * (x(b) - x(a)).abs())
            .sum();
        assert!((across - 0.25 * 0.01).abs() < 1e-12, "{across}");
        let mut pairs: Vec<_> = edges.iter().map(|e| (e.0.min(e.1), e.0.max(e.1))).collect();
        pairs.sort();
        pairs.dedup();
        assert_eq!(pairs.len(), edges.len());

        // Not merged (the reference): the uniform grid however far the plate reaches.
        let uniform = PlateCells::new(&Plate::square_mm(250.0), &deps, false);
        assert!(uniform.columns.iter().all(|c| c.1 == 1));
        assert_eq!(uniform.len(), 50 * 50 * 3);
    }
}
