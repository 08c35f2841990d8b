//! A heat network: lumped nodes (mass, enthalpy) joined by conductances, losing heat by
//! convection and radiation from their exposed area and by contact to the table. Both thermal
//! models of the wall and the substrate plate are built on it.
//!
//! Time step: backward Euler at coefficients lagged from the start of the step (conductivity,
//! apparent heat capacity, radiation linearised around the current temperature), solved by
//! conjugate gradients preconditioned by the matrix's incomplete Cholesky factor; then every
//! node's enthalpy is advanced by the fluxes of the solved temperatures. Conduction fluxes are
//! antisymmetric and losses are booked as they are applied, so the energy ledger closes to
//! round-off whatever the step (the enthalpy method carries the latent heat).
//!
//! The loops are sequential: a wall of ten thousand nodes solves in well under a millisecond per
//! iteration, where fanning out to threads costs more than it saves; the parallelism of a study
//! is across scenarios instead.

use crate::material::Material;
use crate::rates::{LocalSteps, Rates, Torch};
use std::sync::Arc;

/// Stefan–Boltzmann constant, W/(m² K⁴).
pub const SIGMA: f64 = 5.670_374_419e-8;

/// Boundary conditions of the surroundings.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Surroundings {
    pub ambient_k: f64,
    pub convection_w_m2k: f64,
    pub emissivity: f64,
    /// Contact conductance to the table under the plate, W/(m² K).
    pub table_w_m2k: f64,
}

/// Energy accounts, J.
#[derive(Debug, Clone, Copy, Default, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Ledger {
    /// Heat put in by sources.
    pub source: f64,
    /// Enthalpy (above ambient) that activated material brought in.
    pub deposited: f64,
    pub convection: f64,
    pub radiation: f64,
    pub table: f64,
    /// Heat taken out at once by [`crate::HeatRun::quench`] (a bound's "cooled to ambient").
    #[serde(default)]
    pub quenched: f64,
    /// Heat a data assimilation put in (negative: took out) by setting temperatures to what
    /// the sensors said ([`crate::voxel::VoxelModel::set_temperature`]); not a physical flux.
    #[serde(default)]
    pub assimilated: f64,
}

impl Ledger {
    pub fn energy_in(&self) -> f64 {
        self.source + self.deposited + self.assimilated
    }
    pub fn lost(&self) -> f64 {
        self.convection + self.radiation + self.table + self.quenched
    }
}

/// Cloning is a checkpoint: the state (enthalpy, temperature, activity, mass laid, exposure,
/// ledger) is copied, the structure (material, adjacency) shared.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub struct Network {
    pub material: Arc<Material>,
    pub surroundings: Surroundings,
    /// Mass of each node, kg: of a node switched on, the metal laid in it so far ([`Network::lay`]);
    /// of one not yet on, what it holds whole.
    pub mass: Vec<f64>,
    /// Exposed area for convection and radiation, m².
    pub exposed: Vec<f64>,
    /// Area in contact with the table, m².
    pub contact: Arc<Vec<f64>>,
    pub active: Vec<bool>,
    /// Specific enthalpy, J/kg, and the temperature it means, K.
    pub h: Vec<f64>,
    pub t: Vec<f64>,
    /// Symmetric adjacency (CSR): neighbour and geometric factor area/length (m).
    start: Arc<Vec<u32>>,
    adj: Arc<Vec<(u32, f64)>>,
    /// The neighbours of `adj` alone: what the solver streams.
    column: Arc<Vec<u32>>,
    pub ledger: Ledger,
    /// Solver statistics: steps and CG iterations.
    pub steps: usize,
    pub iterations: usize,
    /// Node steps taken (a node stepped once counts one): the model's work, whatever the
    /// rates.
    #[serde(default)]
    pub node_steps: u64,
    h_ambient: f64,
    scratch: Scratch,
    /// Local time stepping, where the nodes far from the arc step at their own rates.
    #[serde(default)]
    rates: Option<Rates>,
    #[serde(skip)]
    stepped: Vec<(usize, usize, f64)>,
}

/// The step's workspace, sized once: no allocation in a time step. A checkpoint copies only
/// the last step's temperatures and length (the next step starts from their trend).
#[derive(Default, serde::Serialize, serde::Deserialize)]
struct Scratch {
    /// Heat capacity over the step, m·c/dt, W/K: the secant of h(T) over the step once found.
    #[serde(skip)]
    cap: Vec<f64>,
    #[serde(skip)]
    diag: Vec<f64>,
    #[serde(skip)]
    rhs: Vec<f64>,
    #[serde(skip)]
    x: Vec<f64>,
    #[serde(skip)]
    r: Vec<f64>,
    #[serde(skip)]
    z: Vec<f64>,
    #[serde(skip)]
    p: Vec<f64>,
    #[serde(skip)]
    q: Vec<f64>,
    #[serde(skip)]
    cond: Vec<f64>,
    /// 1 / diag: the Jacobi correction, which the solve's tolerance is stated in.
    #[serde(skip)]
    inv_diag: Vec<f64>,
    /// 1 / the pivots of the incomplete Cholesky factor ([`factor`]).
    #[serde(skip)]
    pivot: Vec<f64>,
    /// Per node, its first edge to a higher node (the rows are in column order): structure,
    /// made at the first solve and shared by the copies a checkpoint makes.
    #[serde(skip)]
    mid: Arc<Vec<u32>>,
    /// Conductance of each adjacency entry this step (0 to inactive neighbours).
    #[serde(skip)]
    edge_g: Vec<f64>,
    /// Conductance of each adjacency entry to a held (coarser) node this step, else 0.
    #[serde(skip)]
    held: Vec<f64>,
    /// The active nodes as runs of consecutive indices [start, end): the loops over them are
    /// plain slices the compiler vectorises.
    #[serde(skip)]
    runs: Vec<(usize, usize)>,
    last_t: Vec<f64>,
    last_dt: f64,
}

/// The secant heat capacity of a node over a step may fall this share below the one the step
/// was solved with before its row is solved again with it.
const SECANT_TOLERANCE: f64 = 0.25;

/// Local passes of the secant correction between two solves, and rounds of passes and a solve,
/// in one step at most.
const MAX_SECANT_PASSES: usize = 4;
const MAX_SECANT_ROUNDS: usize = 3;

/// Temperature correction at which the solve after a secant correction stops, K.
const SECANT_CG_TOLERANCE_K: f64 = 1e-2;

/// Temperature correction at which conjugate gradients stop, K. The energy update is exact
/// whatever the solve's accuracy; this bounds the temperatures' error per step.
const CG_TOLERANCE_K: f64 = 1e-4;

/// The same where the nodes far from the arc step at their own rates: for the nodes near it
/// (level 0), and for a coarser level's step. A coarser node is read by its finer neighbours
/// up to a period old, up to [`crate::rates::LocalSteps::change`] (1 K in the engine) off; a
/// solve a hundredth of that off is well inside it and takes half the iterations of one to
/// 1e-4 K (the dome R 200, preconditioned by Jacobi then: 43 → 21 a solve at level 4, 29 → 26
/// at level 0; its preheats moved by 0.004 % of the rise at the median and 0.64 % at the worst
/// point, and its errors against the uncut run by 0.01 %, docs/PHYSICS.md "Local time
/// stepping").
const NEAR_CG_TOLERANCE_K: f64 = 1e-3;
const FAR_CG_TOLERANCE_K: f64 = 1e-2;

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
        // Each row in column order: its edges to lower nodes first, which the factor's sweeps
        // take without a test ([`factor`]).
        for i in 0..n {
            adj[count[i] as usize..count[i + 1] as usize].sort_by_key(|e| e.0);
        }
        let h_ambient = material.enthalpy(surroundings.ambient_k);
        Network {
            h: vec![h_ambient; n],
            t: vec![surroundings.ambient_k; n],
            active: vec![false; n],
            material: Arc::new(material),
            surroundings,
            mass,
            exposed,
            contact: Arc::new(contact),
            start: Arc::new(count),
            column: Arc::new(adj.iter().map(|e| e.0).collect()),
            adj: Arc::new(adj),
            ledger: Ledger::default(),
            steps: 0,
            iterations: 0,
            node_steps: 0,
            h_ambient,
            scratch: Scratch::default(),
            rates: None,
            stepped: Vec::new(),
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
        if let Some(r) = &mut self.rates {
            r.join(i);
        }
        if let Some(last) = self.scratch.last_t.get_mut(i) {
            *last = t;
        }
        self.ledger.deposited += self.mass[i] * (self.h[i] - self.h_ambient);
    }

    /// Lay `dm` kg of metal at temperature `t` into node i: a node not yet on is switched on
    /// holding just that; one on takes it in, their enthalpies mixed. What the metal brings
    /// above ambient is booked. A node of several deposits is laid in their shares, so that it
    /// holds the heat of only the metal laid so far (docs/PHYSICS.md "Nodes of several
    /// deposits").
    pub fn lay(&mut self, i: usize, dm: f64, t: f64) {
        if !self.active[i] {
            self.mass[i] = dm;
            self.activate(i, t);
            return;
        }
        let (m, h) = (self.mass[i], self.material.enthalpy(t));
        self.h[i] = (m * self.h[i] + dm * h) / (m + dm);
        self.mass[i] = m + dm;
        self.t[i] = self.material.temperature(self.h[i]);
        if let Some(last) = self.scratch.last_t.get_mut(i) {
            *last = self.t[i];
        }
        self.ledger.deposited += dm * (h - self.h_ambient);
    }

    /// Every active node at ambient at once, the heat taken out booked as quenched.
    pub fn quench(&mut self) {
        let ambient = self.surroundings.ambient_k;
        for i in 0..self.len() {
            if self.active[i] {
                self.ledger.quenched += self.mass[i] * (self.h[i] - self.h_ambient);
                self.h[i] = self.h_ambient;
                self.t[i] = ambient;
            }
        }
        if let Some(r) = &mut self.rates {
            self.ledger.quenched += r.acc.iter().sum::<f64>();
            r.acc.fill(0.0);
        }
    }

    /// Enthalpy stored above ambient in the active nodes, J (with the heat booked to a node
    /// far from the arc and not yet in its enthalpy).
    pub fn stored(&self) -> f64 {
        let booked = self.rates.as_ref().map_or(0.0, |r| r.acc.iter().sum());
        booked
            + (0..self.len())
                .filter(|&i| self.active[i])
                .map(|i| self.mass[i] * (self.h[i] - self.h_ambient))
                .sum::<f64>()
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

    /// Step the nodes far from the arc at their own rates from here on ([`crate::rates`]).
    pub fn local_steps(&mut self, settings: LocalSteps) {
        self.rates = Some(Rates::new(settings, &self.active));
    }

    /// The nodes the last step moved, as index runs [start, end) with the time each run
    /// advanced, s: every active node after [`Network::step`], those near the torch and the
    /// levels that fell due after [`Network::step_near`].
    pub fn stepped(&self) -> &[(usize, usize, f64)] {
        &self.stepped
    }

    /// Advance every active node by `dt` seconds with `power[i]` watts into node i (inactive
    /// nodes ignore it), after bringing every level to the same time where the nodes far from
    /// the arc step at their own rates.
    pub fn step(&mut self, dt: f64, power: &[f64]) {
        self.sync();
        let mut ws = std::mem::take(&mut self.scratch);
        ws.resize(self.len(), self.adj.len());
        // Active nodes only: switched-off ones are outside the system altogether.
        ws.runs.clear();
        for (i, &on) in self.active.iter().enumerate() {
            match ws.runs.last_mut() {
                Some(run) if on && run.1 == i => run.1 = i + 1,
                _ if on => ws.runs.push((i, i + 1)),
                _ => {}
            }
        }
        self.stepped.clear();
        self.solve(&mut ws, dt, Some(power), Scope::All);
        ws.last_dt = dt;
        self.scratch = ws;
        if let Some(r) = &mut self.rates {
            r.elapsed += dt;
            let now = r.elapsed;
            r.last.fill(now);
        }
    }

    /// As [`Network::step`], then every node sorted again by where the torch is and will be (a
    /// travel: the torch is somewhere new).
    pub fn step_whole(&mut self, dt: f64, power: &[f64], torch: &impl Torch) {
        self.step(dt, power);
        if let Some(top) = self.rates.as_ref().map(|r| r.settings.levels) {
            self.sort_levels(top, torch);
        }
    }

    /// Sort the nodes of levels 0..=top (all just stepped) again by where the torch is and
    /// will be; a node that changes level starts its trend from where it is.
    fn sort_levels(&mut self, top: u8, torch: &impl Torch) {
        let Some(rates) = &mut self.rates else {
            return;
        };
        let stable = stability(
            &self.start,
            &self.adj,
            &self.active,
            &self.mass,
            &self.t,
            &self.material,
        );
        let start = &self.start;
        let neighbours = |i: usize| start[i] as usize..start[i + 1] as usize;
        for i in rates.sort(top, torch, stable, neighbours, &self.column) {
            self.scratch.last_t[i as usize] = self.t[i as usize];
        }
    }

    /// Advance by `dt` seconds with `power[i]` watts into node i (a node near the torch): the
    /// nodes near it take the step, each coarser level steps when its period falls due
    /// ([`crate::rates`]), and the levels that stepped are sorted again by where the torch is
    /// and will be. Without local steps, as [`Network::step`].
    pub fn step_near(&mut self, dt: f64, power: &[f64], torch: &impl Torch) {
        let Some(levels) = self.rates.as_ref().map(|r| r.settings.levels) else {
            return self.step(dt, power);
        };
        let mut ws = std::mem::take(&mut self.scratch);
        ws.resize(self.len(), self.adj.len());
        self.stepped.clear();
        let rates = self.rates.as_mut().expect("local steps");
        let joint = rates.joint(dt);
        rates.runs_upto(joint, &mut ws.runs);
        self.solve(&mut ws, dt, Some(power), Scope::Levels(0, joint));
        ws.last_dt = dt;
        let rates = self.rates.as_mut().expect("local steps");
        rates.elapsed += dt;
        let now = rates.elapsed;
        rates.last[..=usize::from(joint)].fill(now);
        let mut top = joint;
        for m in joint + 1..=levels {
            let rates = self.rates.as_mut().expect("local steps");
            if !rates.due(m) {
                break;
            }
            let tau = rates.elapsed - rates.last[usize::from(m)];
            rates.last[usize::from(m)] = rates.elapsed;
            top = m;
            if !rates.members[usize::from(m)].is_empty() {
                rates.runs_of(m, &mut ws.runs);
                self.solve(&mut ws, tau, None, Scope::Levels(m, m));
            }
        }
        self.scratch = ws;
        if top > 0 {
            self.sort_levels(top, torch);
        }
    }

    /// Bring every level to the network's time (each coarser level steps over what it owes,
    /// finest first, so that each takes the heat the finer ones booked to it).
    pub fn sync(&mut self) {
        let Some(levels) = self.rates.as_ref().map(|r| r.settings.levels) else {
            return;
        };
        let mut ws = std::mem::take(&mut self.scratch);
        ws.resize(self.len(), self.adj.len());
        for m in 1..=levels {
            let rates = self.rates.as_mut().expect("local steps");
            let tau = rates.elapsed - rates.last[usize::from(m)];
            rates.last[usize::from(m)] = rates.elapsed;
            if tau > 0.0 && !rates.members[usize::from(m)].is_empty() {
                rates.runs_of(m, &mut ws.runs);
                self.solve(&mut ws, tau, None, Scope::Levels(m, m));
            }
        }
        self.scratch = ws;
    }

    /// One backward-Euler step of `dt` over the nodes of `ws.runs` (the active nodes, or one
    /// level's): the level's own edges implicit, a coarser neighbour held at its temperature and
    /// the heat across booked to it, a finer neighbour's heat taken from what it booked.
    fn solve(&mut self, ws: &mut Scratch, dt: f64, power: Option<&[f64]>, scope: Scope) {
        for &(a, b) in &ws.runs {
            self.stepped.push((a, b, dt));
            self.node_steps += (b - a) as u64;
        }
        let sur = self.surroundings;
        let (mat, t, active, mass, exposed, contact) = (
            &self.material,
            &self.t,
            &self.active,
            &self.mass,
            &self.exposed,
            &self.contact,
        );
        let (level, acc, rate): (&[u8], &mut [f64], &[f32]) = match &mut self.rates {
            Some(Rates {
                level, acc, rate, ..
            }) => (level, acc, rate),
            None => (&[], &mut [], &[]),
        };
        let class = |j: usize| -> Class {
            match scope {
                _ if !active[j] => Class::Off,
                Scope::All => Class::Implicit,
                Scope::Levels(lo, hi) => match level[j] {
                    l if l > hi => Class::Held,
                    l if l < lo => Class::Off,
                    _ => Class::Implicit,
                },
            }
        };
        let source = |i: usize, acc: &[f64]| {
            power.map_or(0.0, |p| p[i]) + acc.get(i).map_or(0.0, |a| a / dt)
        };
        // Lagged coefficients: conductivity per node, conductance per edge, loss coefficient
        // (convection, radiation, table), then the backward-Euler diagonal and right-hand side.
        for i in nodes(&ws.runs) {
            ws.cond[i] = mat.conductivity(t[i]);
        }
        for i in nodes(&ws.runs) {
            let (a, b) = (self.start[i] as usize, self.start[i + 1] as usize);
            let (mut g_sum, mut held) = (0.0, 0.0);
            for e in a..b {
                let (j, g) = self.adj[e];
                let j = j as usize;
                let (ge, gh) = match class(j) {
                    Class::Implicit => (conductance(ws.cond[i], ws.cond[j], g), 0.0),
                    Class::Held => (0.0, conductance(ws.cond[i], mat.conductivity(t[j]), g)),
                    Class::Off => (0.0, 0.0),
                };
                ws.edge_g[e] = ge;
                ws.held[e] = gh;
                g_sum += ge + gh;
                held += gh * t[j];
            }
            let loss = loss_coefficient(&sur, t[i]) * exposed[i] + sur.table_w_m2k * contact[i];
            let cap = mass[i] * mat.apparent_heat(t[i]) / dt;
            ws.cap[i] = cap;
            ws.diag[i] = cap + g_sum + loss;
            ws.rhs[i] = cap * t[i] + loss * sur.ambient_k + source(i, acc) + held;
        }
        // Start from the last step's trend, which halves level 0's iterations; a coarser
        // level's node (its step far longer, carried along with level 0 or not) from its own
        // rate over its last step, which saves it little (43.9 → 43.4 iterations a solve at
        // level 4 on the dome R 200): what its solve costs is set by the tolerance.
        let trend = match scope {
            Scope::Levels(m, _) if m > 0 => 0.0,
            _ if ws.last_dt > 0.0 => dt / ws.last_dt,
            _ => 0.0,
        };
        for i in nodes(&ws.runs) {
            ws.x[i] = match level.get(i) {
                Some(&l) if l > 0 => {
                    let r = rate.get(i).map_or(0.0, |&r| f64::from(r));
                    t[i] + if r.is_finite() { dt * r } else { 0.0 }
                }
                _ => t[i] + trend * (t[i] - ws.last_t[i]),
            };
        }
        let tol = match scope {
            Scope::All => CG_TOLERANCE_K,
            Scope::Levels(0, _) => NEAR_CG_TOLERANCE_K,
            Scope::Levels(..) => FAR_CG_TOLERANCE_K,
        };
        self.iterations += cg(&self.start, &self.column, ws, tol);
        // The capacity above is h(T)'s slope at the step's start. Where h(T) bends over the
        // step (leaving the mushy range, the magnetic peak) that slope can be many times the
        // secant, and a capacity above the secant books more heat than the temperature change
        // holds: a 0.3 g node leaving the mushy range in a 2 s cooling step took the latent
        // slope (6 kJ/(kg K)) over a 180 K drop, booked 1.1 MJ/kg where the drop holds
        // ~0.2 MJ/kg, and read below ambient, down to 0 K. Such a node's row is solved again
        // with its secant capacity, (h(x) − h(t))/(x − t), its neighbours held, until the two
        // agree (local Picard), then the step is solved again; a capacity below the secant only
        // lags, and the next step catches up. The energy update below stays exact either way.
        for _ in 0..MAX_SECANT_ROUNDS {
            let mut corrected = false;
            for _ in 0..MAX_SECANT_PASSES {
                let mut again = false;
                for i in nodes(&ws.runs) {
                    let dx = ws.x[i] - t[i];
                    if dx.abs() < 1e-6 {
                        continue;
                    }
                    let secant = mass[i] * (mat.enthalpy(ws.x[i]) - mat.enthalpy(t[i])) / dx / dt;
                    if secant < (1.0 - SECANT_TOLERANCE) * ws.cap[i] {
                        ws.diag[i] += secant - ws.cap[i];
                        ws.rhs[i] += (secant - ws.cap[i]) * t[i];
                        ws.cap[i] = secant;
                        let (a, b) = (self.start[i] as usize, self.start[i + 1] as usize);
                        let mut sum = ws.rhs[i];
                        for e in a..b {
                            sum += ws.edge_g[e] * ws.x[self.column[e] as usize];
                        }
                        ws.x[i] = sum / ws.diag[i];
                        again = true;
                    }
                }
                corrected |= again;
                if !again {
                    break;
                }
            }
            if !corrected {
                break;
            }
            // The corrected rows moved their neighbours' balance: solve the step again with
            // the secant capacities, from the corrected temperatures, to a looser tolerance
            // (the energy update is exact whatever the solve's accuracy).
            self.iterations += cg(&self.start, &self.column, ws, SECANT_CG_TOLERANCE_K);
        }
        // Conservative update from the solved temperatures: what crosses to a held node is
        // booked to it, so that it gains what this level loses.
        let keeps_trend = !matches!(scope, Scope::Levels(m, _) if m > 0);
        let mut sums = [0.0; 4];
        for i in nodes(&ws.runs) {
            let (a, b) = (self.start[i] as usize, self.start[i + 1] as usize);
            let mut flux = source(i, acc);
            for e in a..b {
                let j = self.column[e] as usize;
                flux += ws.edge_g[e] * (ws.x[j] - ws.x[i]);
                if ws.held[e] != 0.0 {
                    let across = ws.held[e] * (t[j] - ws.x[i]);
                    flux += across;
                    acc[j] -= across * dt;
                }
            }
            if let Some(a) = acc.get_mut(i) {
                *a = 0.0;
            }
            let dta = ws.x[i] - sur.ambient_k;
            let conv = sur.convection_w_m2k * exposed[i] * dta;
            let rad = radiation_coefficient(&sur, t[i]) * exposed[i] * dta;
            let table = sur.table_w_m2k * contact[i] * dta;
            if keeps_trend {
                ws.last_t[i] = t[i];
            }
            self.h[i] += dt * (flux - conv - rad - table) / mass[i];
            sums[0] += power.map_or(0.0, |p| p[i]);
            sums[1] += conv;
            sums[2] += rad;
            sums[3] += table;
        }
        // Each node's rate over this step: how fast it moves sets how long its next may be,
        // and where that step's solve starts.
        let mut rate = self.rates.as_mut().map(|r| &mut r.rate[..]);
        for i in nodes(&ws.runs) {
            let t = self.material.temperature(self.h[i]);
            if let Some(r) = rate.as_mut().and_then(|r| r.get_mut(i)) {
                *r = ((t - self.t[i]) / dt) as f32;
            }
            self.t[i] = t;
        }
        self.ledger.source += dt * sums[0];
        self.ledger.convection += dt * sums[1];
        self.ledger.radiation += dt * sums[2];
        self.ledger.table += dt * sums[3];
        if keeps_trend {
            self.steps += 1;
        }
    }
}

/// What one solve covers: every active node, or the levels lo..=hi.
#[derive(Clone, Copy)]
enum Scope {
    All,
    Levels(u8, u8),
}

/// An edge in a solve: both ends in it, the far end held (a coarser level), or left out (off,
/// or a finer level whose heat came booked).
enum Class {
    Implicit,
    Held,
    Off,
}

/// Whether node i may step at period `p` given its neighbours' levels (`level`, i's own at
/// `m`): held neighbours' heat is booked to it explicitly, which keeps stable while the
/// conductance to finer neighbours is at most 2C/p plus the conductance to the neighbours it
/// steps with or is held by (the booked step's amplification |g_f·p/C − 1| against
/// 1 + g_c·p/C).
fn stability<'a>(
    start: &'a [u32],
    adj: &'a [(u32, f64)],
    active: &'a [bool],
    mass: &'a [f64],
    t: &'a [f64],
    material: &'a Material,
) -> impl Fn(usize, u8, f64, &[u8]) -> bool + 'a {
    move |i, m, p, level| {
        let (mut finer, mut coarser) = (0.0, 0.0);
        for &(j, g) in &adj[start[i] as usize..start[i + 1] as usize] {
            let j = j as usize;
            if !active[j] {
                continue;
            }
            let k = material.conductivity(t[i]).min(material.conductivity(t[j]));
            if level[j] < m {
                finer += k * g;
            } else {
                coarser += k * g;
            }
        }
        finer <= 2.0 * mass[i] * material.apparent_heat(t[i]) / p + coarser
    }
}

impl Clone for Scratch {
    fn clone(&self) -> Scratch {
        Scratch {
            last_t: self.last_t.clone(),
            last_dt: self.last_dt,
            mid: Arc::clone(&self.mid),
            ..Scratch::default()
        }
    }
}

impl Scratch {
    fn resize(&mut self, n: usize, n_adj: usize) {
        for v in [
            &mut self.cap,
            &mut self.diag,
            &mut self.rhs,
            &mut self.x,
            &mut self.r,
            &mut self.z,
            &mut self.p,
            &mut self.q,
            &mut self.cond,
            &mut self.inv_diag,
            &mut self.pivot,
            &mut self.last_t,
        ] {
            v.resize(n, 0.0);
        }
        self.edge_g.resize(n_adj, 0.0);
        self.held.resize(n_adj, 0.0);
    }
}

/// The active node indices, run by run.
fn nodes(runs: &[(usize, usize)]) -> impl DoubleEndedIterator<Item = usize> + '_ {
    runs.iter().flat_map(|&(a, b)| a..b)
}

/// Σ a_i·b_i over the runs in four interleaved partial sums: no chain of dependent additions,
/// and the same order whatever the thread (deterministic).
fn dot(runs: &[(usize, usize)], a: &[f64], b: &[f64]) -> f64 {
    let mut acc = [0.0; 4];
    for &(s, e) in runs {
        let (a, b) = (&a[s..e], &b[s..e]);
        let (mut ca, mut cb) = (a.chunks_exact(4), b.chunks_exact(4));
        for (x, y) in (&mut ca).zip(&mut cb) {
            for k in 0..4 {
                acc[k] += x[k] * y[k];
            }
        }
        for (x, y) in ca.remainder().iter().zip(cb.remainder()) {
            acc[0] += x * y;
        }
    }
    (acc[0] + acc[1]) + (acc[2] + acc[3])
}

/// y = A p on the active nodes: diagonal minus the edge conductances.
fn apply(start: &[u32], column: &[u32], ws: &mut Scratch) {
    let (edge_g, diag, p, q) = (&ws.edge_g, &ws.diag, &ws.p, &mut ws.q);
    for i in nodes(&ws.runs) {
        let mut v = diag[i] * p[i];
        for e in start[i] as usize..start[i + 1] as usize {
            v -= edge_g[e] * p[column[e] as usize];
        }
        q[i] = v;
    }
}

/// Conjugate gradients on the active nodes from the workspace's x, preconditioned by the
/// incomplete Cholesky factor of [`factor`]. Stops when the Jacobi correction r_i/d_i, a
/// temperature, is below `tolerance` everywhere: scale-free whatever the node masses, and the
/// same measure whatever the preconditioner.
fn cg(start: &[u32], column: &[u32], ws: &mut Scratch, tolerance: f64) -> usize {
    std::mem::swap(&mut ws.p, &mut ws.x);
    apply(start, column, ws);
    std::mem::swap(&mut ws.p, &mut ws.x);
    for &(a, b) in &ws.runs {
        ws.inv_diag[a..b]
            .iter_mut()
            .zip(&ws.diag[a..b])
            .for_each(|(v, d)| *v = 1.0 / d);
        for ((r, rhs), q) in ws.r[a..b].iter_mut().zip(&ws.rhs[a..b]).zip(&ws.q[a..b]) {
            *r = rhs - q;
        }
    }
    factor(start, column, ws);
    solve_factor(start, column, ws);
    for &(a, b) in &ws.runs {
        ws.p[a..b].copy_from_slice(&ws.z[a..b]);
    }
    let mut rz = dot(&ws.runs, &ws.r, &ws.z);
    let mut worst = largest_scaled(&ws.runs, &ws.r, &ws.inv_diag);
    let mut it = 0;
    while it < 1000 && worst > tolerance {
        apply(start, column, ws);
        let alpha = rz / dot(&ws.runs, &ws.p, &ws.q);
        for &(a, b) in &ws.runs {
            let (x, r) = (&mut ws.x[a..b], &mut ws.r[a..b]);
            let (p, q) = (&ws.p[a..b], &ws.q[a..b]);
            for ((x, r), (p, q)) in x.iter_mut().zip(r).zip(p.iter().zip(q)) {
                *x += alpha * p;
                *r -= alpha * q;
            }
        }
        solve_factor(start, column, ws);
        let rz_new = dot(&ws.runs, &ws.r, &ws.z);
        worst = largest_scaled(&ws.runs, &ws.r, &ws.inv_diag);
        let beta = rz_new / rz;
        rz = rz_new;
        for &(a, b) in &ws.runs {
            for (p, z) in ws.p[a..b].iter_mut().zip(&ws.z[a..b]) {
                *p = z + beta * *p;
            }
        }
        it += 1;
    }
    it
}

/// The pivots of the incomplete Cholesky factor of the step's matrix with no fill (IC(0)):
/// A ≈ (D + L) D⁻¹ (D + Lᵀ), L the strictly lower part of A, D_i = A_ii − Σ_{j<i} A_ij² / D_j.
/// On the wall's and the plate's graphs (a chain along the bead with the layer beneath, a
/// grid) no two neighbours of a node are neighbours of each other but for a few contacts, so
/// this is the exact IC(0) factor up to those. The pivots stay positive: A is a diagonally
/// dominant M-matrix (Meijerink & van der Vorst 1977).
fn factor(start: &[u32], column: &[u32], ws: &mut Scratch) {
    if ws.mid.len() + 1 != start.len() {
        ws.mid = Arc::new(
            (0..start.len() - 1)
                .map(|i| {
                    let row = &column[start[i] as usize..start[i + 1] as usize];
                    start[i] + row.partition_point(|&j| (j as usize) < i) as u32
                })
                .collect(),
        );
    }
    // The sweeps read a lower neighbour's value as already made: the runs must ascend (every
    // caller's do: the active nodes in order, the levels' members kept sorted).
    debug_assert!(ws.runs.windows(2).all(|w| w[0].1 <= w[1].0));
    let (edge_g, diag, pivot, mid) = (&ws.edge_g, &ws.diag, &mut ws.pivot, &ws.mid);
    for i in nodes(&ws.runs) {
        let mut d = diag[i];
        // A node outside this solve has no conductance here (edge_g 0).
        for e in start[i] as usize..mid[i] as usize {
            d -= edge_g[e] * edge_g[e] * pivot[column[e] as usize];
        }
        pivot[i] = 1.0 / d;
    }
}

/// z = M⁻¹ r for the factor of [`factor`]: forward through (D + L), back through
/// D⁻¹(D + Lᵀ), in the nodes' order (the wall's along the bead, revolution after revolution).
fn solve_factor(start: &[u32], column: &[u32], ws: &mut Scratch) {
    let (edge_g, pivot, mid, r, z) = (&ws.edge_g, &ws.pivot, &ws.mid, &ws.r, &mut ws.z);
    for i in nodes(&ws.runs) {
        let mut s = r[i];
        for e in start[i] as usize..mid[i] as usize {
            s += edge_g[e] * z[column[e] as usize];
        }
        z[i] = s * pivot[i];
    }
    for i in nodes(&ws.runs).rev() {
        let mut s = 0.0;
        for e in mid[i] as usize..start[i + 1] as usize {
            s += edge_g[e] * z[column[e] as usize];
        }
        z[i] += s * pivot[i];
    }
}

/// max |a_i·b_i| over the runs.
fn largest_scaled(runs: &[(usize, usize)], a: &[f64], b: &[f64]) -> f64 {
    let mut m = [0.0f64; 4];
    for &(s, e) in runs {
        let (a, b) = (&a[s..e], &b[s..e]);
        let (mut ca, mut cb) = (a.chunks_exact(4), b.chunks_exact(4));
        for (x, y) in (&mut ca).zip(&mut cb) {
            for k in 0..4 {
                m[k] = m[k].max((x[k] * y[k]).abs());
            }
        }
        for (x, y) in ca.remainder().iter().zip(cb.remainder()) {
            m[0] = m[0].max((x * y).abs());
        }
    }
    m[0].max(m[1]).max(m[2].max(m[3]))
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

#[cfg(test)]
mod tests {
    use super::*;

    /// On a graph with no cycles (a bar) IC(0) drops no fill: it is the exact Cholesky factor,
    /// and the preconditioned solve ends after one iteration however stiff the step. A factor
    /// that drops or mis-weights a term takes more (61 with the pivots' correction halved).
    #[test]
    fn on_a_bar_the_factor_is_exact() {
        let (n, dx, area) = (200, 1e-3, 1e-5);
        let sur = Surroundings {
            ambient_k: 300.0,
            convection_w_m2k: 10.0,
            emissivity: 0.5,
            table_w_m2k: 0.0,
        };
        let edges: Vec<(usize, usize, f64)> = (0..n - 1).map(|i| (i, i + 1, area / dx)).collect();
        let mut net = Network::new(
            Material::constant(7800.0, 600.0, 40.0, 1800.0, 0.0),
            sur,
            vec![7800.0 * area * dx; n],
            vec![4e-3 * dx; n],
            vec![0.0; n],
            &edges,
        );
        for i in 0..n {
            net.activate(i, 300.0 + 1000.0 * (i as f64 / n as f64));
        }
        let mut power = vec![0.0; n];
        power[n / 2] = 50.0;
        // dt·α/dx² ≈ 850: diffusion reaches across 30 nodes in the step.
        net.step(100.0, &power);
        assert_eq!(net.iterations, 1);
        assert!(net.balance_error().abs() < 1e-12, "{}", net.balance_error());
    }
}
