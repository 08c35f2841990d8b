//! The thin-wall model. The wall is a few millimetres thick and its Biot number is tiny (h·W/k ≈
//! 15·0.005/40 ≈ 0.002), so its temperature is uniform through the thickness away from the pool:
//! the wall is a shell laid out on the path's own grid. Each node is a stretch of bead (width ×
//! height × length, at least `min_node_mm` long, so that the shrinking revolutions near a closing
//! point do not make the model stiff), joined to its neighbours along the bead and to the deposit
//! it lies on. The substrate plate is a grid of cells uniform through its thickness, losing heat
//! from its top and through the table beneath. Nodes switch on as the torch lays them, arriving
//! molten; the rest of the arc's heat goes into the active nodes within the torch footprint.

use crate::material::Material;
use crate::network::{Ledger, Network, Surroundings};
use crate::schedule::{Deposit, validate};
use std::collections::HashMap;

#[derive(Debug, Clone, PartialEq)]
pub struct Plate {
    /// Size x, y and thickness, m.
    pub size: [f64; 3],
    /// Centre of the plate's top face in x and y, m (the top face is at z = 0).
    pub centre: [f64; 2],
    pub cell: f64,
    /// Cell layers through the thickness: the wall heats the plate's top skin first.
    pub layers: usize,
}

#[derive(Debug, Clone, PartialEq)]
pub struct WallSettings {
    pub material: Material,
    pub surroundings: Surroundings,
    pub plate: Plate,
    /// Shortest node along the bead, m.
    pub min_node: f64,
    /// Temperature of the metal as it arrives, K.
    pub deposit_temperature: f64,
    /// Radius of the torch footprint over which the arc heats the part, m.
    pub footprint: f64,
    /// How far ahead of the torch the preheat is read, m.
    pub lead: f64,
    /// Temperature for the time-above-threshold count, K.
    pub hot_threshold: f64,
    /// Longest time step during dwells and cooling, s.
    pub max_step: f64,
    /// Times at which to keep the whole field, s.
    pub snapshot_times: Vec<f64>,
}

/// Per deposit.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct PointResult {
    /// Temperature of the metal this deposit is laid on, read when the torch is `lead` upstream.
    pub preheat: f64,
    /// Highest temperature its node reached, K.
    pub peak: f64,
    /// Length of molten bead behind the torch when it was laid, m.
    pub pool_length: f64,
    /// Radius of the half sphere of the molten volume, m.
    pub pool_radius: f64,
    /// Time its node spent above the threshold, s.
    pub time_above: f64,
}

#[derive(Debug, Clone)]
pub struct Snapshot {
    pub time: f64,
    pub temperature: Vec<f64>,
}

#[derive(Debug, Clone)]
pub struct WallResult {
    pub points: Vec<PointResult>,
    pub ledger: Ledger,
    pub stored: f64,
    /// (in − stored − lost)/in.
    pub balance_error: f64,
    /// Node positions (wall then plate cells), m, and which node each deposit belongs to.
    pub node_positions: Vec<[f64; 3]>,
    pub node_of_deposit: Vec<usize>,
    pub n_wall_nodes: usize,
    pub snapshots: Vec<Snapshot>,
    pub final_temperature: Vec<f64>,
    pub steps: usize,
    pub cg_iterations: usize,
    /// Deposits whose heat did not cover melting their own metal (source clamped at zero).
    pub underpowered: usize,
}

struct Layout {
    node_of: Vec<usize>,
    /// Per wall node: first deposit, length, width, height, centre.
    first: Vec<usize>,
    length: Vec<f64>,
    width: Vec<f64>,
    height: Vec<f64>,
    centre: Vec<[f64; 3]>,
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Group consecutive deposits into nodes at least `min_node` long.
fn layout(deps: &[Deposit], min_node: f64) -> Layout {
    let mut l = Layout {
        node_of: Vec::with_capacity(deps.len()),
        first: vec![],
        length: vec![],
        width: vec![],
        height: vec![],
        centre: vec![],
    };
    let mut acc: Vec<(usize, f64)> = Vec::new(); // (deposit, segment length)
    let flush = |l: &mut Layout, acc: &mut Vec<(usize, f64)>| {
        if acc.is_empty() {
            return;
        }
        let len: f64 = acc.iter().map(|a| a.1).sum::<f64>().max(1e-6);
        let w = acc.iter().map(|a| deps[a.0].width * a.1).sum::<f64>() / len;
        let h = acc.iter().map(|a| deps[a.0].height * a.1).sum::<f64>() / len;
        let c: [f64; 3] = std::array::from_fn(|k| {
            acc.iter().map(|&(d, _)| deps[d].position[k]).sum::<f64>() / acc.len() as f64
        });
        l.first.push(acc[0].0);
        l.length.push(len);
        l.width.push(w);
        l.height.push(h);
        l.centre.push(c);
        acc.clear();
    };
    let mut run = 0.0;
    for (i, d) in deps.iter().enumerate() {
        // The segment ending at deposit i: from the previous point (the first has its width).
        let seg = if i == 0 {
            d.width
        } else {
            dist(d.position, deps[i - 1].position).max(1e-6)
        };
        if !acc.is_empty() && run >= min_node {
            flush(&mut l, &mut acc);
            run = 0.0;
        }
        acc.push((i, seg));
        run += seg;
        l.node_of.push(l.first.len());
    }
    flush(&mut l, &mut acc);
    l
}

pub struct WallModel {
    pub network: Network,
    layout_first: Vec<usize>,
    node_of: Vec<usize>,
    n_wall: usize,
    positions: Vec<[f64; 3]>,
    /// Bead top area of each wall node, covered when a deposit is laid on it.
    top: Vec<f64>,
    /// Per deposit: the node it is laid on (a wall node or a plate cell).
    below: Vec<usize>,
    length: Vec<f64>,
    volume: Vec<f64>,
}

impl WallModel {
    pub fn build(deps: &[Deposit], s: &WallSettings) -> Result<WallModel, String> {
        validate(deps)?;
        let l = layout(deps, s.min_node);
        let nw = l.first.len();
        let rho = s.material.density;
        // Plate cells: nx × ny columns of `layers` cells through the thickness, top layer first.
        let p = &s.plate;
        let (nx, ny, nz) = (
            ((p.size[0] / p.cell).round() as usize).max(1),
            ((p.size[1] / p.cell).round() as usize).max(1),
            p.layers.max(1),
        );
        let (cx, cy, cz) = (
            p.size[0] / nx as f64,
            p.size[1] / ny as f64,
            p.size[2] / nz as f64,
        );
        let origin = [p.centre[0] - p.size[0] / 2.0, p.centre[1] - p.size[1] / 2.0];
        let plate_id = |i: usize, j: usize, k: usize| nw + (k * ny + j) * nx + i;
        let cell_id = |x: f64, y: f64| -> Option<usize> {
            let i = ((x - origin[0]) / cx).floor();
            let j = ((y - origin[1]) / cy).floor();
            (i >= 0.0 && j >= 0.0 && (i as usize) < nx && (j as usize) < ny)
                .then(|| plate_id(i as usize, j as usize, 0))
        };
        let n = nw + nx * ny * nz;
        let mut mass = Vec::with_capacity(n);
        let mut exposed = Vec::with_capacity(n);
        let mut contact = vec![0.0; n];
        let mut positions = l.centre.clone();
        let mut top = Vec::with_capacity(nw);
        let mut volume = Vec::with_capacity(nw);
        for k in 0..nw {
            let v = l.width[k] * l.height[k] * l.length[k];
            volume.push(v);
            mass.push(rho * v);
            // Both faces of the wall, and the top until something is laid on it.
            exposed.push(2.0 * l.height[k] * l.length[k] + l.width[k] * l.length[k]);
            top.push(l.width[k] * l.length[k]);
        }
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    mass.push(rho * cx * cy * cz);
                    exposed.push(if k == 0 { cx * cy } else { 0.0 });
                    if k == nz - 1 {
                        contact[plate_id(i, j, k)] = cx * cy;
                    }
                    positions.push([
                        origin[0] + (i as f64 + 0.5) * cx,
                        origin[1] + (j as f64 + 0.5) * cy,
                        -(k as f64 + 0.5) * cz,
                    ]);
                }
            }
        }
        let mut edges: Vec<(usize, usize, f64)> = Vec::new();
        for k in 0..nz {
            for j in 0..ny {
                for i in 0..nx {
                    let a = plate_id(i, j, k);
                    if i + 1 < nx {
                        edges.push((a, plate_id(i + 1, j, k), cz * cy / cx));
                    }
                    if j + 1 < ny {
                        edges.push((a, plate_id(i, j + 1, k), cz * cx / cy));
                    }
                    if k + 1 < nz {
                        edges.push((a, plate_id(i, j, k + 1), cx * cy / cz));
                    }
                }
            }
        }
        // Along the bead.
        for k in 0..nw.saturating_sub(1) {
            let area = 0.5 * (l.width[k] * l.height[k] + l.width[k + 1] * l.height[k + 1]);
            edges.push((
                k,
                k + 1,
                area / dist(l.centre[k], l.centre[k + 1]).max(1e-6),
            ));
        }
        // To what each deposit is laid on: one edge per pair of nodes, the contact area summed.
        let mut below = Vec::with_capacity(deps.len());
        let mut contact_edges: HashMap<(usize, usize), (f64, f64)> = HashMap::new(); // area, length
        for (i, d) in deps.iter().enumerate() {
            let me = l.node_of[i];
            let seg = if i == 0 {
                d.width
            } else {
                dist(d.position, deps[i - 1].position)
            };
            let (under, gap) = match d.support {
                Some(sp) => (l.node_of[sp], dist(l.centre[me], l.centre[l.node_of[sp]])),
                None => match cell_id(d.position[0], d.position[1]) {
                    Some(c) => (c, 0.5 * (l.height[me] + cz)),
                    None => {
                        return Err(format!(
                            "deposit {i} at ({:.1}, {:.1}) mm lies outside the plate",
                            d.position[0] * 1e3,
                            d.position[1] * 1e3
                        ));
                    }
                },
            };
            below.push(under);
            if under != me {
                let e = contact_edges.entry((me, under)).or_insert((0.0, 0.0));
                e.0 += d.width * seg;
                e.1 = gap.max(1e-4);
            }
        }
        let mut pairs: Vec<_> = contact_edges.into_iter().collect();
        pairs.sort_by_key(|(k, _)| *k);
        for ((a, b), (area, gap)) in pairs {
            edges.push((a, b, area / gap));
        }
        let mut network = Network::new(
            s.material.clone(),
            s.surroundings,
            mass,
            exposed,
            contact,
            &edges,
        );
        for c in nw..n {
            network.activate(c, s.surroundings.ambient_k);
        }
        // The plate starts at ambient: its enthalpy is not energy put in.
        network.ledger.deposited = 0.0;
        Ok(WallModel {
            network,
            layout_first: l.first,
            node_of: l.node_of,
            n_wall: nw,
            positions,
            top,
            below,
            length: l.length,
            volume,
        })
    }

    /// Run the schedule to its end and `cool_after` seconds beyond.
    pub fn run(mut self, deps: &[Deposit], s: &WallSettings, cool_after: f64) -> WallResult {
        let n = self.network.len();
        let h_amb = s.material.enthalpy(s.surroundings.ambient_k);
        let h_dep = s.material.enthalpy(s.deposit_temperature);
        let mut points = vec![PointResult::default(); deps.len()];
        let read_at = read_times(deps, s.lead);
        let mut probes: Vec<usize> = (0..deps.len()).collect();
        probes.sort_by(|&a, &b| read_at[a].total_cmp(&read_at[b]));
        let mut next_probe = 0;
        let mut time_above = vec![0.0; n];
        let mut peak = vec![s.surroundings.ambient_k; n];
        let mut snapshots = Vec::new();
        let mut snap_times = s.snapshot_times.clone();
        snap_times.sort_by(f64::total_cmp);
        let mut next_snap = 0;
        let grid = NodeGrid::new(&self.positions[..self.n_wall], s.footprint);
        let mut power = vec![0.0; n];
        let mut now = deps.first().map_or(0.0, |d| d.arc_start());
        let mut underpowered = 0;
        let below = std::mem::take(&mut self.below);
        let mut observe =
            |net: &Network, now: f64, dt: f64, points: &mut Vec<PointResult>, below: &[usize]| {
                while next_probe < probes.len() && read_at[probes[next_probe]] <= now + 1e-9 {
                    let i = probes[next_probe];
                    points[i].preheat = net.t[below[i]];
                    next_probe += 1;
                }
                for k in 0..n {
                    if net.active[k] {
                        if net.t[k] > s.hot_threshold {
                            time_above[k] += dt;
                        }
                        peak[k] = peak[k].max(net.t[k]);
                    }
                }
                while next_snap < snap_times.len() && snap_times[next_snap] <= now + 1e-9 {
                    snapshots.push(Snapshot {
                        time: snap_times[next_snap],
                        temperature: net.t.clone(),
                    });
                    next_snap += 1;
                }
            };
        for (i, d) in deps.iter().enumerate() {
            // Dwell (arc off) until this segment's arc starts.
            cool(
                &mut self.network,
                d.arc_start() - now,
                s.max_step,
                &mut power,
                &mut now,
                &mut |net, t, dt| observe(net, t, dt, &mut points, &below),
            );
            let node = self.node_of[i];
            if self.layout_first[node] == i {
                self.network.activate(node, s.deposit_temperature);
                if below[i] < self.n_wall {
                    let b = below[i];
                    let covered = self.top[b].min(self.network.exposed[b]);
                    self.network.exposed[b] -= covered.min(self.top[b]);
                    self.top[b] = 0.0;
                }
            }
            // The arc's heat less what melting this segment's wire took, over the footprint.
            let seg_mass =
                self.network.mass[node] * segment_share(deps, i, &self.length, &self.node_of);
            let mut q = d.heat - seg_mass * (h_dep - h_amb);
            if q < 0.0 {
                q = 0.0;
                underpowered += 1;
            }
            power.iter_mut().for_each(|p| *p = 0.0);
            let near = grid.within(d.position, s.footprint, &self.positions);
            let weights: Vec<(usize, f64)> = near
                .into_iter()
                .filter(|&k| self.network.active[k])
                .map(|k| {
                    (
                        k,
                        (-3.0 * (dist(self.positions[k], d.position) / s.footprint).powi(2)).exp(),
                    )
                })
                .collect();
            let total: f64 = weights.iter().map(|w| w.1).sum();
            if d.arc_time > 0.0 {
                if total > 0.0 {
                    for (k, w) in &weights {
                        power[*k] += q / d.arc_time * w / total;
                    }
                } else {
                    power[node] += q / d.arc_time;
                }
                let dt = d.arc_time;
                self.network.step(dt, &power);
                now += dt;
                observe(&self.network, now, dt, &mut points, &below);
            }
            // The melt pool behind the torch.
            let (mut len, mut vol, mut k) = (0.0, 0.0, node as isize);
            while k >= 0 && self.network.t[k as usize] > s.material.solidus {
                len += self.length[k as usize];
                vol += self.volume[k as usize];
                k -= 1;
            }
            points[i].pool_length = len;
            points[i].pool_radius = (3.0 * vol / (2.0 * std::f64::consts::PI)).cbrt();
        }
        power.iter_mut().for_each(|p| *p = 0.0);
        cool(
            &mut self.network,
            cool_after,
            s.max_step,
            &mut power,
            &mut now,
            &mut |net, t, dt| observe(net, t, dt, &mut points, &below),
        );
        for (i, p) in points.iter_mut().enumerate() {
            let node = self.node_of[i];
            p.peak = peak[node];
            p.time_above = time_above[node];
        }
        let net = &self.network;
        WallResult {
            points,
            ledger: net.ledger,
            stored: net.stored(),
            balance_error: net.balance_error(),
            node_positions: self.positions.clone(),
            node_of_deposit: self.node_of.clone(),
            n_wall_nodes: self.n_wall,
            snapshots,
            final_temperature: net.t.clone(),
            steps: net.steps,
            cg_iterations: net.iterations,
            underpowered,
        }
    }
}

/// Let the part cool (no source) for `duration`, in steps growing from half a second to
/// `max_step`.
fn cool(
    net: &mut Network,
    duration: f64,
    max_step: f64,
    power: &mut [f64],
    now: &mut f64,
    observe: &mut impl FnMut(&Network, f64, f64),
) {
    if duration <= 1e-9 {
        return;
    }
    power.iter_mut().for_each(|p| *p = 0.0);
    let end = *now + duration;
    let mut dt = 0.5f64.min(duration);
    while *now < end - 1e-9 {
        let step = dt.min(end - *now);
        net.step(step, power);
        *now += step;
        observe(net, *now, step);
        dt = (dt * 1.5).min(max_step);
    }
}

/// The share of its node's mass that deposit i lays.
fn segment_share(deps: &[Deposit], i: usize, length: &[f64], node_of: &[usize]) -> f64 {
    let seg = if i == 0 {
        deps[0].width
    } else {
        dist(deps[i].position, deps[i - 1].position).max(1e-6)
    };
    (seg / length[node_of[i]]).min(1.0)
}

/// When the torch is `lead` upstream of each deposit (along the path), s.
pub(crate) fn read_times(deps: &[Deposit], lead: f64) -> Vec<f64> {
    let mut s = vec![0.0; deps.len()];
    for i in 1..deps.len() {
        s[i] = s[i - 1] + dist(deps[i].position, deps[i - 1].position);
    }
    (0..deps.len())
        .map(|i| {
            let target = s[i] - lead;
            if target <= 0.0 {
                return deps[0].arc_start();
            }
            // The torch passes arc length `target` during the arc of the segment ending at j.
            let j = s
                .partition_point(|&x| x < target)
                .min(deps.len() - 1)
                .max(1);
            let f = (target - s[j - 1]) / (s[j] - s[j - 1]).max(1e-12);
            deps[j].arc_start() + f * deps[j].arc_time
        })
        .collect()
}

/// Spatial hash of wall nodes for footprint queries.
struct NodeGrid {
    cell: f64,
    map: HashMap<[i64; 3], Vec<u32>>,
}

impl NodeGrid {
    fn new(pos: &[[f64; 3]], cell: f64) -> NodeGrid {
        let mut map: HashMap<[i64; 3], Vec<u32>> = HashMap::new();
        for (i, p) in pos.iter().enumerate() {
            map.entry(key(p, cell)).or_default().push(i as u32);
        }
        NodeGrid { cell, map }
    }

    fn within(&self, p: [f64; 3], r: f64, pos: &[[f64; 3]]) -> Vec<usize> {
        let c = key(&p, self.cell);
        let mut out = Vec::new();
        for dx in -1..=1 {
            for dy in -1..=1 {
                for dz in -1..=1 {
                    for &k in self
                        .map
                        .get(&[c[0] + dx, c[1] + dy, c[2] + dz])
                        .into_iter()
                        .flatten()
                    {
                        if dist(pos[k as usize], p) <= r {
                            out.push(k as usize);
                        }
                    }
                }
            }
        }
        out.sort_unstable();
        out
    }
}

fn key(p: &[f64; 3], cell: f64) -> [i64; 3] {
    std::array::from_fn(|k| (p[k] / cell).floor() as i64)
}
