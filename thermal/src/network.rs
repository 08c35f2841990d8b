//! A heat network: lumped nodes (mass, enthalpy) joined by conductances, losing heat by
//! convection and radiation from their exposed area and by contact to the table. Both thermal
//! models of the wall and the substrate plate are built on it.
//!
//! Time step: backward Euler at coefficients lagged from the start of the step (conductivity,
//! apparent heat capacity, radiation linearised around the current temperature), solved by
//! Jacobi-preconditioned conjugate gradients; then every node's enthalpy is advanced by the fluxes
//! of the solved temperatures. Conduction fluxes are antisymmetric and losses are booked as they
//! are applied, so the energy ledger closes to round-off whatever the step (the enthalpy method
//! carries the latent heat).

use crate::material::Material;
use rayon::prelude::*;

/// Stefan–Boltzmann constant, W/(m² K⁴).
pub const SIGMA: f64 = 5.670_374_419e-8;

/// Boundary conditions of the surroundings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Surroundings {
    pub ambient_k: f64,
    pub convection_w_m2k: f64,
    pub emissivity: f64,
    /// Contact conductance to the table under the plate, W/(m² K).
    pub table_w_m2k: f64,
}

/// Energy accounts, J.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Ledger {
    /// Heat put in by sources.
    pub source: f64,
    /// Enthalpy (above ambient) that activated material brought in.
    pub deposited: f64,
    pub convection: f64,
    pub radiation: f64,
    pub table: f64,
}

impl Ledger {
    pub fn energy_in(&self) -> f64 {
        self.source + self.deposited
    }
    pub fn lost(&self) -> f64 {
        self.convection + self.radiation + self.table
    }
}

pub struct Network {
    pub material: Material,
    pub surroundings: Surroundings,
    pub mass: Vec<f64>,
    /// Exposed area for convection and radiation, m².
    pub exposed: Vec<f64>,
    /// Area in contact with the table, m².
    pub contact: Vec<f64>,
    pub active: Vec<bool>,
    /// Specific enthalpy, J/kg, and the temperature it means, K.
    pub h: Vec<f64>,
    pub t: Vec<f64>,
    /// Symmetric adjacency (CSR): neighbour and geometric factor area/length (m).
    start: Vec<u32>,
    adj: Vec<(u32, f64)>,
    pub ledger: Ledger,
    /// Solver statistics: steps and CG iterations.
    pub steps: usize,
    pub iterations: usize,
    h_ambient: f64,
    scratch: Scratch,
}

#[derive(Default)]
struct Scratch {
    diag: Vec<f64>,
    rhs: Vec<f64>,
    x: Vec<f64>,
    r: Vec<f64>,
    z: Vec<f64>,
    p: Vec<f64>,
    q: Vec<f64>,
    cond: Vec<f64>,
    loss_coef: Vec<f64>,
}

/// Elements per block of a deterministic parallel sum: the partial sums are combined in a fixed
/// order, so the result does not depend on the number of threads.
const BLOCK: usize = 2048;

/// Temperature correction at which conjugate gradients stop, K.
const CG_TOLERANCE_K: f64 = 1e-9;

fn max_abs(a: &[f64]) -> f64 {
    a.par_chunks(BLOCK)
        .map(|x| x.iter().fold(0.0f64, |m, v| m.max(v.abs())))
        .reduce(|| 0.0, f64::max)
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    let partial: Vec<f64> = a
        .par_chunks(BLOCK)
        .zip(b.par_chunks(BLOCK))
        .map(|(x, y)| x.iter().zip(y).map(|(u, v)| u * v).sum())
        .collect();
    partial.iter().sum()
}

impl Network {
    /// `edges`: (i, j, area/length) for each conducting pair.
    pub fn new(
        material: Material,
        surroundings: Surroundings,
        mass: Vec<f64>,
        exposed: Vec<f64>,
        contact: Vec<f64>,
        edges: &[(usize, usize, f64)],
    ) -> Network {
        let n = mass.len();
        let mut count = vec![0u32; n + 1];
        for &(i, j, _) in edges {
            count[i + 1] += 1;
            count[j + 1] += 1;
        }
        for i in 0..n {
            count[i + 1] += count[i];
        }
        let mut fill = count.clone();
        let mut adj = vec![(0u32, 0.0); count[n] as usize];
        for &(i, j, g) in edges {
            adj[fill[i] as usize] = (j as u32, g);
            fill[i] += 1;
            adj[fill[j] as usize] = (i as u32, g);
            fill[j] += 1;
        }
        let h_ambient = material.enthalpy(surroundings.ambient_k);
        Network {
            h: vec![h_ambient; n],
            t: vec![surroundings.ambient_k; n],
            active: vec![false; n],
            material,
            surroundings,
            mass,
            exposed,
            contact,
            start: count,
            adj,
            ledger: Ledger::default(),
            steps: 0,
            iterations: 0,
            h_ambient,
            scratch: Scratch::default(),
        }
    }

    pub fn len(&self) -> usize {
        self.mass.len()
    }

    pub fn is_empty(&self) -> bool {
        self.mass.is_empty()
    }

    pub fn neighbours(&self, i: usize) -> &[(u32, f64)] {
        &self.adj[self.start[i] as usize..self.start[i + 1] as usize]
    }

    /// Switch node i on at temperature `t`; the enthalpy it brings (above ambient) is booked.
    pub fn activate(&mut self, i: usize, t: f64) {
        if self.active[i] {
            return;
        }
        self.active[i] = true;
        self.h[i] = self.material.enthalpy(t);
        self.t[i] = t;
        self.ledger.deposited += self.mass[i] * (self.h[i] - self.h_ambient);
    }

    /// Enthalpy stored above ambient in the active nodes, J.
    pub fn stored(&self) -> f64 {
        (0..self.len())
            .filter(|&i| self.active[i])
            .map(|i| self.mass[i] * (self.h[i] - self.h_ambient))
            .sum()
    }

    /// (energy in − stored − lost) / energy in.
    pub fn balance_error(&self) -> f64 {
        let e = self.ledger.energy_in();
        if e == 0.0 {
            0.0
        } else {
            (e - self.stored() - self.ledger.lost()) / e
        }
    }

    /// Advance by `dt` seconds with `power[i]` watts into node i (inactive nodes ignore it).
    pub fn step(&mut self, dt: f64, power: &[f64]) {
        let n = self.len();
        let mut ws = std::mem::take(&mut self.scratch);
        ws.resize(n);
        let sur = self.surroundings;
        let (mat, t, active, mass, exposed, contact) = (
            &self.material,
            &self.t,
            &self.active,
            &self.mass,
            &self.exposed,
            &self.contact,
        );
        // Lagged coefficients: node conductivity and linear loss coefficient (convection,
        // radiation, table), then the backward-Euler diagonal and right-hand side.
        ws.cond
            .par_iter_mut()
            .enumerate()
            .for_each(|(i, c)| *c = mat.conductivity(t[i]));
        ws.loss_coef.par_iter_mut().enumerate().for_each(|(i, l)| {
            *l = if active[i] {
                loss_coefficient(&sur, t[i]) * exposed[i] + sur.table_w_m2k * contact[i]
            } else {
                0.0
            };
        });

        {
            let sys = System {
                start: &self.start,
                adj: &self.adj,
                active,
                cond: &ws.cond,
            };
            let loss = &ws.loss_coef;
            ws.diag
                .par_iter_mut()
                .zip(ws.rhs.par_iter_mut())
                .enumerate()
                .for_each(|(i, (d, r))| {
                    if !active[i] {
                        *d = 1.0;
                        *r = t[i];
                        return;
                    }
                    let cap = mass[i] * mat.apparent_heat(t[i]) / dt;
                    *d = cap + sys.conductance_sum(i) + loss[i];
                    *r = cap * t[i] + loss[i] * sur.ambient_k + power[i];
                });
        }
        ws.x.copy_from_slice(t);
        let cond = std::mem::take(&mut ws.cond);
        self.iterations += cg(
            &System {
                start: &self.start,
                adj: &self.adj,
                active,
                cond: &cond,
            },
            &mut ws,
        );
        ws.cond = cond;
        // Conservative update from the solved temperatures.
        let sys = System {
            start: &self.start,
            adj: &self.adj,
            active,
            cond: &ws.cond,
        };
        let x = &ws.x;
        let results: Vec<[f64; 4]> = (0..n)
            .into_par_iter()
            .map(|i| {
                if !active[i] {
                    return [0.0; 4];
                }
                let flux = power[i] + sys.inflow(i, x);
                let dta = x[i] - sur.ambient_k;
                let conv = sur.convection_w_m2k * exposed[i] * dta;
                let rad = radiation_coefficient(&sur, t[i]) * exposed[i] * dta;
                let table = sur.table_w_m2k * contact[i] * dta;
                [flux - conv - rad - table, conv, rad, table]
            })
            .collect();
        let mut sums = [0.0; 4];
        for (i, r) in results.iter().enumerate() {
            if self.active[i] {
                self.h[i] += dt * r[0] / self.mass[i];
                self.t[i] = self.material.temperature(self.h[i]);
                sums[0] += power[i];
                sums[1] += r[1];
                sums[2] += r[2];
                sums[3] += r[3];
            }
        }
        self.ledger.source += dt * sums[0];
        self.ledger.convection += dt * sums[1];
        self.ledger.radiation += dt * sums[2];
        self.ledger.table += dt * sums[3];
        self.steps += 1;
        self.scratch = ws;
    }
}

impl Scratch {
    fn resize(&mut self, n: usize) {
        for v in [
            &mut self.diag,
            &mut self.rhs,
            &mut self.x,
            &mut self.r,
            &mut self.z,
            &mut self.p,
            &mut self.q,
            &mut self.cond,
            &mut self.loss_coef,
        ] {
            v.resize(n, 0.0);
        }
    }
}

/// The assembled backward-Euler operator, matrix-free: diagonal from the workspace, off-diagonal
/// −G_ij between active neighbours.
struct System<'a> {
    start: &'a [u32],
    adj: &'a [(u32, f64)],
    active: &'a [bool],
    cond: &'a [f64],
}

impl System<'_> {
    fn pairs(&self, i: usize) -> impl Iterator<Item = (usize, f64)> + '_ {
        self.adj[self.start[i] as usize..self.start[i + 1] as usize]
            .iter()
            .filter(|(j, _)| self.active[*j as usize])
            .map(move |&(j, g)| {
                (
                    j as usize,
                    conductance(self.cond[i], self.cond[j as usize], g),
                )
            })
    }

    fn conductance_sum(&self, i: usize) -> f64 {
        self.pairs(i).map(|(_, g)| g).sum()
    }

    /// Σ_j G_ij (x_j − x_i).
    fn inflow(&self, i: usize, x: &[f64]) -> f64 {
        self.pairs(i).map(|(j, g)| g * (x[j] - x[i])).sum()
    }

    fn apply(&self, diag: &[f64], x: &[f64], y: &mut [f64]) {
        y.par_iter_mut().enumerate().for_each(|(i, yi)| {
            let mut v = diag[i] * x[i];
            if self.active[i] {
                v -= self.pairs(i).map(|(j, g)| g * x[j]).sum::<f64>();
            }
            *yi = v;
        });
    }
}

/// Jacobi-preconditioned conjugate gradients on `sys` with the workspace's diagonal and
/// right-hand side, from the workspace's x. Returns the iterations used.
fn cg(sys: &System, ws: &mut Scratch) -> usize {
    let n = ws.x.len();
    sys.apply(&ws.diag, &ws.x, &mut ws.q);
    for i in 0..n {
        ws.r[i] = ws.rhs[i] - ws.q[i];
        ws.z[i] = ws.r[i] / ws.diag[i];
        ws.p[i] = ws.z[i];
    }
    // Stop when the Jacobi correction r_i/d_i, a temperature, is below CG_TOLERANCE_K everywhere:
    // scale-free, whatever the node masses.
    let mut rz = dot(&ws.r, &ws.z);
    let mut it = 0;
    while it < 1000 && max_abs(&ws.z) > CG_TOLERANCE_K {
        sys.apply(&ws.diag, &ws.p, &mut ws.q);
        let alpha = rz / dot(&ws.p, &ws.q);
        for i in 0..n {
            ws.x[i] += alpha * ws.p[i];
            ws.r[i] -= alpha * ws.q[i];
            ws.z[i] = ws.r[i] / ws.diag[i];
        }
        let rz_new = dot(&ws.r, &ws.z);
        let beta = rz_new / rz;
        rz = rz_new;
        for i in 0..n {
            ws.p[i] = ws.z[i] + beta * ws.p[i];
        }
        it += 1;
    }
    it
}

/// Conductance of a pair: harmonic mean of the two conductivities times area/length.
fn conductance(ki: f64, kj: f64, g: f64) -> f64 {
    2.0 * ki * kj / (ki + kj) * g
}

/// Radiation linearised around t: εσ(t² + t_a²)(t + t_a), so that h_r·(t − t_a) = εσ(t⁴ − t_a⁴).
fn radiation_coefficient(s: &Surroundings, t: f64) -> f64 {
    let a = s.ambient_k;
    s.emissivity * SIGMA * (t * t + a * a) * (t + a)
}

fn loss_coefficient(s: &Surroundings, t: f64) -> f64 {
    s.convection_w_m2k + radiation_coefficient(s, t)
}
