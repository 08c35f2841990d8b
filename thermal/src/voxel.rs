//! The voxel model: 3-D finite differences on a uniform grid, the reference for local detail and
//! for checking the thin-wall model. Only active voxels (deposited metal and the plate) are
//! stored, each with its six neighbours; a step visits the active set alone. Explicit in time at
//! the stability limit, f32 state, enthalpy update (latent heat included), rayon over fixed chunks
//! of the active set (the same arithmetic on one thread or two). The arc's heat is a Goldak double
//! ellipsoid (Goldak, Chakravarti, Bibby 1984) scaled so that its discrete sum is exactly the
//! heat of the segment.

use crate::material::Material;
use crate::network::{Ledger, SIGMA, Surroundings};
use crate::schedule::{Deposit, validate};
use crate::wall::Plate;
use rayon::prelude::*;
use std::collections::HashMap;

const NONE: u32 = u32::MAX;
/// Active voxels per parallel chunk.
const CHUNK: usize = 4096;

#[derive(Debug, Clone, PartialEq)]
pub struct VoxelSettings {
    pub material: Material,
    pub surroundings: Surroundings,
    pub plate: Plate,
    /// Voxel edge, m.
    pub size: f64,
    pub deposit_temperature: f64,
    pub lead: f64,
    /// Stability margin on the explicit step (≤ 1).
    pub courant: f64,
}

#[derive(Debug, Clone)]
pub struct VoxelResult {
    /// Per deposit: mean temperature of the voxels it is laid on, read `lead` upstream.
    pub preheat: Vec<f64>,
    pub ledger: Ledger,
    pub stored: f64,
    pub balance_error: f64,
    pub voxels: usize,
    pub steps: usize,
    /// Voxel updates performed (steps × active voxels).
    pub updates: u64,
}

/// Goldak double-ellipsoid parameters relative to the bead: half-width a = W/2, depth b = H,
/// front c_f = a, rear c_r = 2a, f_f = 0.6, f_r = 1.4 (typical values for GMAW).
struct Goldak {
    a: f64,
    b: f64,
    cf: f64,
    cr: f64,
}

impl Goldak {
    fn weight(&self, along: f64, across: f64, depth: f64) -> f64 {
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

/// f32 lookup tables for the kernel: T(h) on a uniform enthalpy grid (the exact inverse is a
/// binary search) and k(T) at 1 K steps. Interpolation error below 0.01 K.
struct Tables {
    h0: f32,
    inv_dh: f32,
    t_of_h: Vec<f32>,
    k_of_t: Vec<f32>,
}

impl Tables {
    fn new(m: &Material) -> Tables {
        let (h0, h1) = (m.enthalpy(0.0), m.enthalpy(3999.0));
        let n = 1 << 16;
        let dh = (h1 - h0) / (n - 1) as f64;
        Tables {
            h0: h0 as f32,
            inv_dh: (1.0 / dh) as f32,
            t_of_h: (0..n)
                .map(|j| m.temperature(h0 + j as f64 * dh) as f32)
                .collect(),
            k_of_t: (0..4000).map(|t| m.conductivity(t as f64) as f32).collect(),
        }
    }

    #[inline]
    fn lerp(table: &[f32], x: f32) -> f32 {
        let x = x.clamp(0.0, (table.len() - 2) as f32);
        let i = x as usize;
        let f = x - i as f32;
        table[i] + f * (table[i + 1] - table[i])
    }

    #[inline]
    fn temperature(&self, h: f32) -> f32 {
        Tables::lerp(&self.t_of_h, (h - self.h0) * self.inv_dh)
    }

    #[inline]
    fn conductivity(&self, t: f32) -> f32 {
        Tables::lerp(&self.k_of_t, t)
    }
}

pub struct VoxelModel {
    settings: VoxelSettings,
    tables: Tables,
    /// Conductivity of each voxel at its temperature, W/(m K).
    k: Vec<f32>,
    origin: [f64; 3],
    dims: [usize; 3],
    /// Grid cell → active index.
    index: HashMap<usize, u32>,
    cell: Vec<usize>,
    neighbours: Vec<[u32; 6]>,
    t: Vec<f32>,
    h: Vec<f32>,
    /// Bottom face of the plate on the table.
    on_table: Vec<bool>,
    /// Exposed-area weight of each of the six faces, |n_face·n_wall| + |n_face·axis| for bead
    /// voxels (1 for the plate): a voxelised wall at angle θ has a staircase surface of
    /// (|cos θ| + |sin θ|) times the wall's area; weighted faces add up to the wall's own area.
    face_weight: Vec<[f32; 6]>,
    ledger: Ledger,
    h_ambient: f64,
    /// Per deposit: the voxels it switched on.
    laid: Vec<Vec<u32>>,
    plate_top: HashMap<(usize, usize), u32>,
    updates: u64,
    steps: usize,
}

impl VoxelModel {
    pub fn new(deps: &[Deposit], s: &VoxelSettings) -> Result<VoxelModel, String> {
        validate(deps)?;
        let dx = s.size;
        let p = &s.plate;
        let mut lo = [
            p.centre[0] - p.size[0] / 2.0,
            p.centre[1] - p.size[1] / 2.0,
            -p.size[2],
        ];
        let mut hi = [
            p.centre[0] + p.size[0] / 2.0,
            p.centre[1] + p.size[1] / 2.0,
            0.0,
        ];
        for d in deps {
            for k in 0..3 {
                lo[k] = lo[k].min(d.position[k] - 2.0 * d.width);
                hi[k] = hi[k].max(d.position[k] + 2.0 * d.width);
            }
        }
        // Align the grid so that z = 0 (the plate's top) is a cell boundary.
        lo[2] = (lo[2] / dx).floor() * dx;
        let dims: [usize; 3] = std::array::from_fn(|k| ((hi[k] - lo[k]) / dx).ceil() as usize + 1);
        let mut m = VoxelModel {
            settings: s.clone(),
            tables: Tables::new(&s.material),
            k: vec![],
            origin: lo,
            dims,
            index: HashMap::new(),
            cell: vec![],
            neighbours: vec![],
            t: vec![],
            h: vec![],
            on_table: vec![],
            face_weight: vec![],
            ledger: Ledger::default(),
            h_ambient: s.material.enthalpy(s.surroundings.ambient_k),
            laid: vec![Vec::new(); deps.len()],
            plate_top: HashMap::new(),
            updates: 0,
            steps: 0,
        };
        // The plate: every cell whose centre lies inside it.
        let k_plate = (p.size[2] / dx).round() as usize;
        let z0 = ((0.0 - lo[2]) / dx).round() as usize; // first cell above the plate
        for iz in z0.saturating_sub(k_plate)..z0 {
            for iy in 0..dims[1] {
                for ix in 0..dims[0] {
                    let c = m.centre(ix, iy, iz);
                    if (c[0] - p.centre[0]).abs() <= p.size[0] / 2.0
                        && (c[1] - p.centre[1]).abs() <= p.size[1] / 2.0
                    {
                        let v = m.add(ix, iy, iz, s.surroundings.ambient_k);
                        m.on_table[v as usize] = iz == z0 - k_plate;
                        if iz == z0 - 1 {
                            m.plate_top.insert((ix, iy), v);
                        }
                    }
                }
            }
        }
        m.ledger.deposited = 0.0;
        Ok(m)
    }

    fn centre(&self, ix: usize, iy: usize, iz: usize) -> [f64; 3] {
        let dx = self.settings.size;
        [
            self.origin[0] + (ix as f64 + 0.5) * dx,
            self.origin[1] + (iy as f64 + 0.5) * dx,
            self.origin[2] + (iz as f64 + 0.5) * dx,
        ]
    }

    fn flat(&self, ix: usize, iy: usize, iz: usize) -> usize {
        (iz * self.dims[1] + iy) * self.dims[0] + ix
    }

    fn add(&mut self, ix: usize, iy: usize, iz: usize, temp: f64) -> u32 {
        let f = self.flat(ix, iy, iz);
        if let Some(&v) = self.index.get(&f) {
            return v;
        }
        let v = self.cell.len() as u32;
        self.index.insert(f, v);
        self.cell.push(f);
        let mut nb = [NONE; 6];
        let steps: [(isize, isize, isize); 6] = [
            (-1, 0, 0),
            (1, 0, 0),
            (0, -1, 0),
            (0, 1, 0),
            (0, 0, -1),
            (0, 0, 1),
        ];
        for (k, (dx, dy, dz)) in steps.iter().enumerate() {
            let (x, y, z) = (ix as isize + dx, iy as isize + dy, iz as isize + dz);
            if x < 0
                || y < 0
                || z < 0
                || x >= self.dims[0] as isize
                || y >= self.dims[1] as isize
                || z >= self.dims[2] as isize
            {
                continue;
            }
            if let Some(&u) = self
                .index
                .get(&self.flat(x as usize, y as usize, z as usize))
            {
                nb[k] = u;
                self.neighbours[u as usize][k ^ 1] = v;
            }
        }
        self.neighbours.push(nb);
        let h = self.settings.material.enthalpy(temp);
        self.t.push(temp as f32);
        self.k
            .push(self.settings.material.conductivity(temp) as f32);
        self.h.push(h as f32);
        self.on_table.push(false);
        self.face_weight.push([1.0; 6]);
        self.ledger.deposited += self.mass() * (h - self.h_ambient);
        v
    }

    fn mass(&self) -> f64 {
        self.settings.material.density * self.settings.size.powi(3)
    }

    /// Switch on the voxels of deposit i's bead: within W/2 across, H along the build direction
    /// below the path point, and along the segment from the previous point.
    fn lay(&mut self, deps: &[Deposit], i: usize) {
        let d = &deps[i];
        let prev = if i > 0 {
            deps[i - 1].position
        } else {
            d.position
        };
        let dx = self.settings.size;
        let axis = d.axis;
        let seg = sub(d.position, prev);
        let len = norm(seg);
        let tangent = if len > 1e-12 {
            scale(seg, 1.0 / len)
        } else {
            cross(axis, [0.0, 0.0, 1.0])
        };
        let across = normalize(cross(axis, tangent));
        let reach = d.width.max(d.height) + len + dx;
        let (lo, hi): ([usize; 3], [usize; 3]) = (
            std::array::from_fn(|k| {
                (((d.position[k] - reach - self.origin[k]) / dx)
                    .floor()
                    .max(0.0)) as usize
            }),
            std::array::from_fn(|k| {
                (((d.position[k] + reach - self.origin[k]) / dx).ceil() as usize)
                    .min(self.dims[k] - 1)
            }),
        );
        for iz in lo[2]..=hi[2] {
            for iy in lo[1]..=hi[1] {
                for ix in lo[0]..=hi[0] {
                    let c = self.centre(ix, iy, iz);
                    if c[2] < 0.0 {
                        continue;
                    }
                    let r = sub(c, prev);
                    let (s_along, s_up, s_across) = (
                        dot(r, tangent),
                        dot(sub(c, d.position), axis),
                        dot(r, across),
                    );
                    let inside_len = s_along >= -dx / 2.0 && s_along <= len + dx / 2.0;
                    if inside_len
                        && s_up <= dx / 2.0
                        && s_up > -d.height - dx / 2.0
                        && s_across.abs() <= d.width / 2.0
                    {
                        let before = self.cell.len();
                        let v = self.add(ix, iy, iz, self.settings.deposit_temperature);
                        if self.cell.len() > before {
                            self.laid[i].push(v);
                            let normals = [
                                [1.0, 0.0, 0.0],
                                [1.0, 0.0, 0.0],
                                [0.0, 1.0, 0.0],
                                [0.0, 1.0, 0.0],
                                [0.0, 0.0, 1.0],
                                [0.0, 0.0, 1.0],
                            ];
                            self.face_weight[v as usize] = normals.map(|n| {
                                (dot(n, across).abs() + dot(n, axis).abs()).min(1.0) as f32
                            });
                        }
                    }
                }
            }
        }
    }

    /// Lay every deposit at once (no heat): the finished part, for timing the kernel.
    pub fn lay_all(&mut self, deps: &[Deposit]) {
        for i in 0..deps.len() {
            self.lay(deps, i);
        }
    }

    pub fn active(&self) -> usize {
        self.t.len()
    }

    /// The voxels deposit i is laid on: its support's, or the plate's top under it.
    fn beneath(&self, deps: &[Deposit], i: usize) -> Vec<u32> {
        match deps[i].support {
            Some(s) if !self.laid[s].is_empty() => self.laid[s].clone(),
            Some(s) => self.beneath(deps, s),
            None => {
                let p = deps[i].position;
                let dx = self.settings.size;
                let r = (deps[i].width / 2.0 / dx).ceil() as isize;
                let (cx, cy) = (
                    ((p[0] - self.origin[0]) / dx) as isize,
                    ((p[1] - self.origin[1]) / dx) as isize,
                );
                let mut out = Vec::new();
                for oy in -r..=r {
                    for ox in -r..=r {
                        if let Some(&v) = self
                            .plate_top
                            .get(&((cx + ox) as usize, (cy + oy) as usize))
                        {
                            out.push(v);
                        }
                    }
                }
                out
            }
        }
    }

    fn mean_t(&self, v: &[u32]) -> f64 {
        if v.is_empty() {
            return self.settings.surroundings.ambient_k;
        }
        v.iter().map(|&i| self.t[i as usize] as f64).sum::<f64>() / v.len() as f64
    }

    /// The stable explicit step: ρ·c_min·dx²/(6·k_max), times the margin.
    pub fn stable_step(&self) -> f64 {
        let m = &self.settings.material;
        let (mut cmin, mut kmax) = (f64::INFINITY, 0.0f64);
        for t in (250..3500).step_by(10) {
            cmin = cmin.min(m.apparent_heat(t as f64));
            kmax = kmax.max(m.conductivity(t as f64));
        }
        self.settings.courant * m.density * cmin * self.settings.size.powi(2) / (6.0 * kmax)
    }

    /// One explicit step of length dt with `source[v]` watts into voxel v: the 7-point update
    /// over the active set, then temperature and conductivity from the new enthalpy.
    pub fn step(&mut self, dt: f64, source: &[f32]) {
        let s = &self.settings;
        let sur = s.surroundings;
        let dx = s.size as f32;
        let area = dx * dx;
        let inv_cap = (dt / self.mass()) as f32;
        let (t, k, nb, table, fw) = (
            &self.t,
            &self.k,
            &self.neighbours,
            &self.on_table,
            &self.face_weight,
        );
        let n = t.len();
        let (ta, h_conv, eps_sigma, h_table) = (
            sur.ambient_k as f32,
            sur.convection_w_m2k as f32,
            (sur.emissivity * SIGMA) as f32,
            sur.table_w_m2k as f32,
        );
        let ta4 = ta * ta * ta * ta;
        let partial: Vec<[f64; 4]> = self
            .h
            .par_chunks_mut(CHUNK)
            .enumerate()
            .map(|(c, chunk)| {
                let mut sums = [0.0f64; 4];
                for (o, h) in chunk.iter_mut().enumerate() {
                    let v = c * CHUNK + o;
                    let (ti, ki) = (t[v], k[v]);
                    let q = source.get(v).copied().unwrap_or(0.0);
                    let mut flux = q;
                    let mut exposed = 0.0f32;
                    for (f, &u) in nb[v].iter().enumerate() {
                        if u != NONE {
                            let kj = k[u as usize];
                            // Harmonic mean conductivity, area dx², length dx.
                            flux += 2.0 * ki * kj / (ki + kj) * dx * (t[u as usize] - ti);
                        } else if !(f == 4 && table[v]) {
                            exposed += area * fw[v][f];
                        }
                    }
                    let (conv, rad) = if exposed > 0.0 {
                        (
                            h_conv * exposed * (ti - ta),
                            eps_sigma * exposed * (ti * ti * ti * ti - ta4),
                        )
                    } else {
                        (0.0, 0.0)
                    };
                    let tab = if table[v] {
                        h_table * area * (ti - ta)
                    } else {
                        0.0
                    };
                    *h += inv_cap * (flux - conv - rad - tab);
                    sums[0] += q as f64;
                    sums[1] += conv as f64;
                    sums[2] += rad as f64;
                    sums[3] += tab as f64;
                }
                sums
            })
            .collect();
        let tables = &self.tables;
        self.t
            .par_chunks_mut(CHUNK)
            .zip(self.k.par_chunks_mut(CHUNK))
            .zip(self.h.par_chunks(CHUNK))
            .for_each(|((tc, kc), hc)| {
                for ((ti, ki), hi) in tc.iter_mut().zip(kc.iter_mut()).zip(hc) {
                    *ti = tables.temperature(*hi);
                    *ki = tables.conductivity(*ti);
                }
            });
        let mut sums = [0.0; 4];
        for p in &partial {
            for (acc, x) in sums.iter_mut().zip(p) {
                *acc += x;
            }
        }
        self.ledger.source += dt * sums[0];
        self.ledger.convection += dt * sums[1];
        self.ledger.radiation += dt * sums[2];
        self.ledger.table += dt * sums[3];
        self.updates += n as u64;
        self.steps += 1;
    }

    /// Goldak source of `heat` joules over the arc time of deposit `d` (which follows the point
    /// `prev`), on the active voxels around it.
    fn source(&self, d: &Deposit, prev: [f64; 3], heat: f64, out: &mut Vec<f32>) {
        out.clear();
        out.resize(self.t.len(), 0.0);
        if d.arc_time <= 0.0 || heat <= 0.0 {
            return;
        }
        let seg = sub(d.position, prev);
        let tangent = if norm(seg) > 1e-12 {
            normalize(seg)
        } else {
            cross(d.axis, [0.0, 0.0, 1.0])
        };
        let across = normalize(cross(d.axis, tangent));
        let g = Goldak {
            a: d.width / 2.0,
            b: d.height.max(self.settings.size),
            cf: d.width / 2.0,
            cr: d.width,
        };
        let dx = self.settings.size;
        let reach = 3.0 * g.cr + dx;
        let mut w = Vec::new();
        let lo: [isize; 3] = std::array::from_fn(|k| {
            ((d.position[k] - reach - self.origin[k]) / dx).floor() as isize
        });
        let hi: [isize; 3] = std::array::from_fn(|k| {
            ((d.position[k] + reach - self.origin[k]) / dx).ceil() as isize
        });
        for iz in lo[2].max(0)..=hi[2].min(self.dims[2] as isize - 1) {
            for iy in lo[1].max(0)..=hi[1].min(self.dims[1] as isize - 1) {
                for ix in lo[0].max(0)..=hi[0].min(self.dims[0] as isize - 1) {
                    if let Some(&v) =
                        self.index
                            .get(&self.flat(ix as usize, iy as usize, iz as usize))
                    {
                        let r = sub(
                            self.centre(ix as usize, iy as usize, iz as usize),
                            d.position,
                        );
                        let wt = g.weight(dot(r, tangent), dot(r, across), dot(r, d.axis).min(0.0));
                        if wt > 0.0 {
                            w.push((v, wt));
                        }
                    }
                }
            }
        }
        let total: f64 = w.iter().map(|x| x.1).sum();
        let power = heat / d.arc_time;
        for (v, wt) in w {
            out[v as usize] += (power * wt / total) as f32;
        }
    }

    /// Run the schedule. Each deposit's metal arrives at the deposit temperature and the rest of
    /// its heat goes in through the Goldak source over its arc time.
    pub fn run(mut self, deps: &[Deposit]) -> VoxelResult {
        let s = self.settings.clone();
        let dt_max = self.stable_step();
        let read_at = crate::wall::read_times(deps, s.lead);
        let mut order: Vec<usize> = (0..deps.len()).collect();
        order.sort_by(|&a, &b| read_at[a].total_cmp(&read_at[b]));
        let mut next = 0;
        let mut preheat = vec![0.0; deps.len()];
        let mut src = Vec::new();
        let mut now = deps.first().map_or(0.0, |d| d.arc_start());
        let zero: Vec<f32> = Vec::new();
        self.probe(deps, &read_at, &order, &mut next, now, &mut preheat);
        for i in 0..deps.len() {
            let d = &deps[i];
            // Dwell.
            while now < d.arc_start() - 1e-9 {
                let dt = dt_max.min(d.arc_start() - now);
                self.step(dt, &zero);
                now += dt;
                self.probe(deps, &read_at, &order, &mut next, now, &mut preheat);
            }
            let before = self.ledger.deposited;
            self.lay(deps, i);
            // The arc's heat less what the new metal took.
            let rest = (d.heat - (self.ledger.deposited - before)).max(0.0);
            let prev = if i > 0 {
                deps[i - 1].position
            } else {
                d.position
            };
            self.source(d, prev, rest, &mut src);
            let mut left = d.arc_time;
            while left > 1e-12 {
                let dt = dt_max.min(left);
                if src.len() < self.t.len() {
                    src.resize(self.t.len(), 0.0);
                }
                self.step(dt, &src);
                now += dt;
                left -= dt;
                self.probe(deps, &read_at, &order, &mut next, now, &mut preheat);
            }
        }
        let stored: f64 = self
            .h
            .iter()
            .map(|&h| self.mass() * (h as f64 - self.h_ambient))
            .sum();
        let e = self.ledger.energy_in();
        VoxelResult {
            preheat,
            ledger: self.ledger,
            stored,
            balance_error: if e > 0.0 {
                (e - stored - self.ledger.lost()) / e
            } else {
                0.0
            },
            voxels: self.t.len(),
            steps: self.steps,
            updates: self.updates,
        }
    }

    fn probe(
        &self,
        deps: &[Deposit],
        read_at: &[f64],
        order: &[usize],
        next: &mut usize,
        now: f64,
        preheat: &mut [f64],
    ) {
        while *next < order.len() && read_at[order[*next]] <= now + 1e-9 {
            let i = order[*next];
            preheat[i] = self.mean_t(&self.beneath(deps, i));
            *next += 1;
        }
    }
}

fn sub(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}
fn dot(a: [f64; 3], b: [f64; 3]) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}
fn cross(a: [f64; 3], b: [f64; 3]) -> [f64; 3] {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}
fn norm(a: [f64; 3]) -> f64 {
    dot(a, a).sqrt()
}
fn scale(a: [f64; 3], s: f64) -> [f64; 3] {
    [a[0] * s, a[1] * s, a[2] * s]
}
fn normalize(a: [f64; 3]) -> [f64; 3] {
    let n = norm(a);
    if n > 0.0 {
        scale(a, 1.0 / n)
    } else {
        [1.0, 0.0, 0.0]
    }
}
