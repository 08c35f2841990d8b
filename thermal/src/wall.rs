//! The thin-wall model. The wall is a few millimetres thick and its Biot number is tiny (h·W/k ≈
//! 15·0.005/40 ≈ 0.002), so its temperature is uniform through the thickness away from the pool:
//! the wall is a shell laid out on the path's own grid. Each node is a stretch of bead (width ×
//! height × length, at least `min_node_mm` long, so that the shrinking revolutions near a closing
//! point do not make the model stiff), joined to its neighbours along the bead and to the deposit
//! it lies on. The substrate plate is a grid of cells uniform through its thickness (its columns
//! merged away from the part, [`crate::plate_cells`]), losing heat from its top and through the
//! table beneath. Nodes switch on as the torch lays them, arriving
//! molten; the rest of the arc's heat goes into the nodes of the torch footprint behind it.

use crate::error::ThermalError;
use crate::material::Material;
use crate::network::{Network, Surroundings};
use crate::plate_cells::PlateCells;
use crate::pool;
use crate::rates::{LocalSteps, Reach, Torch, Window};
use crate::run::{
    Burn, Cells, CoolingSteps, Drops, HeatRun, Hottest, Plate, PointResult, ProbeTrace, RunResult,
    Snapshot, Support, Trace, replay,
};
use crate::schedule::{Deposit, just_laid, read_fractions, segment_start, validate};
use std::collections::{BTreeMap, HashMap};
use std::sync::Arc;

#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct WallSettings {
    pub material: Material,
    pub surroundings: Surroundings,
    pub plate: Plate,
    /// Shortest node along the bead, m.
    pub min_node: f64,
    /// Temperature of the metal as it arrives, K.
    pub deposit_temperature: f64,
    /// Length of bead behind the torch, along the path, over which the arc heats the part, m.
    pub footprint: f64,
    /// How far ahead of the torch the preheat is read, m.
    pub lead: f64,
    /// Temperature for the time-above-threshold count, K.
    pub hot_threshold: f64,
    /// Longest time step during dwells and cooling, s.
    pub max_step: f64,
    /// Times at which to keep the whole field, s.
    pub snapshot_times: Vec<f64>,
    /// Deposits whose metal's temperature is kept at every step from when it is laid: a
    /// history finer than the snapshots, which shows every pass of the torch.
    pub traces: Vec<usize>,
    /// Watch the laid metal at every step: each deposit's peak and time above `hot_threshold`
    /// (`PointResult::peak`, `time_above`) and the hottest of it ([`crate::run::Hottest`]),
    /// what `simulate` writes. Off where nothing reads them (the dwell search, replays,
    /// calibration, the live twin): the peaks and times above are then NaN, not read. (The voxel
    /// model's watch is the costly one; the thin wall's reads its nodes alone.)
    pub watch_metal: bool,
    /// Points whose temperature is kept ([`crate::run::ProbeTrace`]), m: each reads the
    /// nearest node (a bead node or a plate cell) whose centre lies within the larger of
    /// `min_node` and the plate's cell of it, once that node is there.
    pub probes: Vec<[f64; 3]>,
    /// Least time between two kept probe samples, s (0: every step).
    pub probe_every: f64,
    /// The nodes far from the arc stepped at their own rates ([`crate::rates`]); none: every
    /// node at every step (the reference).
    #[serde(default)]
    pub local_steps: Option<LocalSteps>,
    /// The plate's columns merged 2 × 2 and 4 × 4 away from the metal laid on it
    /// ([`crate::plate_cells`]); false: the uniform grid of `plate.cell` (the reference).
    #[serde(default = "merged")]
    pub merge_plate: bool,
}

/// `merge_plate` where a serialized setting lacks it: the default, merged.
fn merged() -> bool {
    true
}

struct Layout {
    node_of: Vec<usize>,
    /// Per wall node: first deposit, length, width, height, centre (its stretch of bead's
    /// middle, where its one temperature stands: not its deposits' points, which end their
    /// segments).
    first: Vec<usize>,
    length: Vec<f64>,
    width: Vec<f64>,
    height: Vec<f64>,
    centre: Vec<[f64; 3]>,
}

fn dist(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// Length of deposit i's bead segment: from where it begins (the previous deposit, or its own
/// start after travel) to its point; the first deposit of a path is as long as it is wide.
fn seg_len(deps: &[Deposit], i: usize) -> f64 {
    match (i, deps[i].start) {
        (0, None) => deps[0].width,
        _ => dist(deps[i].position, segment_start(deps, i)).max(1e-6),
    }
}

/// Group consecutive deposits into nodes at least `min_node` long, a node never reaching across
/// the travel between two tracks, nor past 1.5 `min_node` by taking a deposit in (a node is
/// closed short instead, or is one deposit longer than that). Grown until at least `min_node`
/// long, deposits a little shorter (2.8 mm on a 3 mm `min_node`) made nodes of two, twice
/// `min_node`, whose one temperature, laid whole at their first deposit, made neighbouring
/// points' preheats alternate by 15 K and their pools by 6 mm, and read a false humping risk on
/// a canister's third revolution (docs/PHYSICS.md "Nodes of two deposits").
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
            acc.iter()
                .map(|&(d, seg)| 0.5 * (deps[d].position[k] + segment_start(deps, d)[k]) * seg)
                .sum::<f64>()
                / len
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
        let seg = seg_len(deps, i);
        if !acc.is_empty() && (run >= min_node || run + seg > 1.5 * min_node || d.start.is_some()) {
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

/// How many cells the thin wall lays plate `p` out in under `deps` (its columns merged away
/// from the metal laid on it where `merge`), without building the model.
pub fn plate_cells(p: &Plate, deps: &[Deposit], merge: bool) -> usize {
    PlateCells::new(p, deps, merge).len()
}

#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub struct WallModel {
    pub network: Network,
    layout_first: Arc<Vec<usize>>,
    /// Per wall node: it begins a track (the arc's footprint does not reach behind it).
    track_start: Arc<Vec<bool>>,
    node_of: Arc<Vec<usize>>,
    n_wall: usize,
    positions: Arc<Vec<[f64; 3]>>,
    /// Per plate cell: its side in the plate's cells (merged columns are 2 or 4).
    plate_side: Arc<Vec<u8>>,
    /// Bead top area of each wall node, covered when a deposit is laid on it.
    top: Vec<f64>,
    /// Per deposit: the node it is laid on (a wall node or a plate cell).
    below: Vec<usize>,
    /// What a deposit's preheat reads where more than the node under it: laid on the plate,
    /// the plate's top at its point, the cells round it each with its weight
    /// ([`PlateCells::top_around`]); laid on the wall, the node under it and its neighbour along
    /// the bead, linear between their centres ([`along_below`]).
    #[serde(default, alias = "plate_at")]
    read_at: BTreeMap<usize, Vec<(usize, f64)>>,
    length: Arc<Vec<f64>>,
    volume: Arc<Vec<f64>>,
}

impl WallModel {
    pub fn build(deps: &[Deposit], s: &WallSettings) -> Result<WallModel, ThermalError> {
        validate(deps)?;
        if s.plate.disc {
            return Err(ThermalError::Plate {
                reason: "a disc; the thin wall's plate is a grid of cells (a box): use the \
                         voxel model"
                    .into(),
            });
        }
        if s.plate.material.is_some() {
            return Err(ThermalError::Plate {
                reason: "of its own material; the thin wall is one material throughout: use \
                         the voxel model"
                    .into(),
            });
        }
        let l = layout(deps, s.min_node);
        let nw = l.first.len();
        let rho = s.material.density;
        // Plate cells: columns of `layers` cells through the thickness, top layer first, merged
        // in the plane away from the metal laid on it ([`PlateCells`]).
        let plate = PlateCells::new(&s.plate, deps, s.merge_plate);
        let cz = plate.cell[2];
        let cell_id = |x: f64, y: f64| plate.top_at(x, y).map(|c| nw + c);
        let n = nw + plate.len();
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
        let mut plate_side = Vec::with_capacity(plate.len());
        for (c, (m, top, table, centre, side)) in plate.cells(rho).enumerate() {
            mass.push(m);
            exposed.push(top);
            contact[nw + c] = table;
            positions.push(centre);
            plate_side.push(side);
        }
        let mut edges: Vec<(usize, usize, f64)> = plate
            .edges()
            .into_iter()
            .map(|(a, b, g)| (nw + a, nw + b, g))
            .collect();
        // Along the bead, but not across the travel between two tracks.
        for k in 0..nw.saturating_sub(1) {
            if deps[l.first[k + 1]].start.is_some() {
                continue;
            }
            let area = 0.5 * (l.width[k] * l.height[k] + l.width[k + 1] * l.height[k + 1]);
            edges.push((
                k,
                k + 1,
                area / dist(l.centre[k], l.centre[k + 1]).max(1e-6),
            ));
        }
        // To what each deposit is laid on: one edge per pair of nodes, the contact area summed.
        let mut below = Vec::with_capacity(deps.len());
        let mut read_at = BTreeMap::new();
        let mut contact_edges: HashMap<(usize, usize), (f64, f64)> = HashMap::new(); // area, length
        for (i, d) in deps.iter().enumerate() {
            let me = l.node_of[i];
            let seg = seg_len(deps, i);
            let under = match d.support {
                Some(sp) => l.node_of[sp],
                None => {
                    cell_id(d.position[0], d.position[1]).ok_or(ThermalError::OutsidePlate {
                        deposit: i,
                        x_mm: d.position[0] * 1e3,
                        y_mm: d.position[1] * 1e3,
                    })?
                }
            };
            // What the bead lies on: its support, or the plate cells under its width (the
            // bead's whole bottom in contact, however fine the cells: through the one cell under
            // its centre line a fine plate would take the wall's heat through a strip).
            let contacts: Vec<(usize, f64)> = match d.support {
                Some(_) => vec![(under, 1.0)],
                None => {
                    let across = bead_across(deps, i);
                    (0..ACROSS)
                        .map(|j| {
                            let o = d.width * ((j as f64 + 0.5) / ACROSS as f64 - 0.5);
                            let p = [d.position[0] + o * across[0], d.position[1] + o * across[1]];
                            (cell_id(p[0], p[1]).unwrap_or(under), 1.0 / ACROSS as f64)
                        })
                        .collect()
                }
            };
            below.push(under);
            if d.support.is_none() {
                let around = plate.top_around(d.position[0], d.position[1]);
                read_at.insert(i, around.into_iter().map(|(c, w)| (nw + c, w)).collect());
            }
            for (c, share) in contacts {
                if c != me {
                    let gap = match d.support {
                        Some(_) => dist(l.centre[me], l.centre[c]),
                        None => 0.5 * (l.height[me] + cz),
                    };
                    let e = contact_edges.entry((me, c)).or_insert((0.0, 0.0));
                    e.0 += share * d.width * seg;
                    e.1 = gap.max(1e-4);
                }
            }
        }
        for (k, around) in along_below(deps, &l, &below, s.lead) {
            read_at.insert(k, around);
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
            track_start: Arc::new(l.first.iter().map(|&d| deps[d].start.is_some()).collect()),
            layout_first: Arc::new(l.first),
            node_of: Arc::new(l.node_of),
            n_wall: nw,
            positions: Arc::new(positions),
            plate_side: Arc::new(plate_side),
            top,
            below,
            read_at,
            length: Arc::new(l.length),
            volume: Arc::new(volume),
        })
    }

    /// Run the schedule as its times say (dwells are the gaps between arcs) and `cool_after`
    /// seconds beyond.
    pub fn run(
        self,
        deps: &[Deposit],
        s: &WallSettings,
        cool_after: f64,
    ) -> Result<RunResult, ThermalError> {
        let mut run = WallRun::new(self, deps, s);
        replay(&mut run, deps)?;
        run.cool(cool_after)?;
        Ok(run.finish())
    }
}

/// A thin-wall run in progress, one deposit at a time. Cloning it is a checkpoint: the dwell
/// planner restarts from one with a trial dwell instead of simulating the build again.
#[derive(Clone, serde::Serialize, serde::Deserialize)]
pub struct WallRun {
    model: WallModel,
    settings: Arc<WallSettings>,
    deps: Arc<Vec<Deposit>>,
    /// Per deposit, the deposit during whose arc its preheat is read (dwell-independent: the
    /// torch is `lead` upstream along the path).
    probes_at: Arc<Vec<Vec<(usize, f64)>>>,
    /// Per deposit, whether it lies on metal just laid when its preheat is read
    /// ([`crate::schedule::just_laid`], within the footprint).
    just_laid: Arc<Vec<bool>>,
    points: Vec<PointResult>,
    time_above: Vec<f64>,
    peak: Vec<f64>,
    snapshots: Vec<Snapshot>,
    next_snapshot: usize,
    traces: Vec<Trace>,
    hottest: Hottest,
    probes: Vec<ProbeTrace>,
    /// Per probe, its node once one lies within reach.
    probe_nodes: Vec<Option<usize>>,
    /// Deposits laid when the nodes were last searched: none is switched on between deposits.
    probes_searched_at: Option<usize>,
    power: Vec<f64>,
    /// The nodes `power` heats this arc (the rest stay 0).
    powered: Vec<usize>,
    /// Where the torch will be, where the nodes far from the arc step at their own rates.
    reach: Option<Arc<Reach>>,
    below: Arc<Vec<usize>>,
    /// What a deposit's preheat reads where more than the node under it ([`WallModel::read_at`]).
    #[serde(default, alias = "plate_at")]
    read_at: Arc<BTreeMap<usize, Vec<(usize, f64)>>>,
    /// Time now, s; deposits laid so far.
    now: f64,
    laid: usize,
    /// The next cooling step, s: it doubles from 1 s while the part cools with the arc off, and
    /// starts again at 1 s once a deposit is laid, so that cooling continued in several calls
    /// (a dwell search trying longer and longer dwells) takes the steps one call would.
    cooling_step: f64,
    underpowered: usize,
    drops: Drops,
    h_deposit: f64,
    h_ambient: f64,
}

impl WallRun {
    pub fn new(mut model: WallModel, deps: &[Deposit], s: &WallSettings) -> WallRun {
        let n = model.network.len();
        let mut probes_at = vec![Vec::new(); deps.len()];
        let mut points = vec![PointResult::default(); deps.len()];
        let reads = read_fractions(deps, s.lead);
        let just_laid = just_laid(deps, &reads, |_| s.footprint);
        for (k, &r) in reads.iter().enumerate() {
            match r {
                Some((j, f)) => probes_at[j].push((k, f)),
                // Read before the path starts: the plate as it is, at ambient.
                None => points[k].preheat = s.surroundings.ambient_k,
            }
        }
        let below = std::mem::take(&mut model.below);
        let read_at = std::mem::take(&mut model.read_at);
        let reach = s.local_steps.map(|local| {
            model.network.local_steps(local);
            let from: Vec<[f64; 3]> = (0..deps.len()).map(|i| segment_start(deps, i)).collect();
            let to: Vec<[f64; 3]> = deps.iter().map(|d| d.position).collect();
            let arc: Vec<f64> = deps.iter().map(|d| d.arc_time).collect();
            Arc::new(Reach::new(&from, &to, &arc))
        });
        let mut snap = s.snapshot_times.clone();
        snap.sort_by(f64::total_cmp);
        let mut settings = s.clone();
        settings.snapshot_times = snap;
        WallRun {
            deps: Arc::new(deps.to_vec()),
            probes_at: Arc::new(probes_at),
            just_laid: Arc::new(just_laid),
            points,
            time_above: vec![0.0; n],
            peak: vec![s.surroundings.ambient_k; n],
            snapshots: Vec::new(),
            next_snapshot: 0,
            traces: s.traces.iter().map(|&d| Trace::new(d)).collect(),
            hottest: Hottest::default(),
            probes: s.probes.iter().map(|&p| ProbeTrace::new(p)).collect(),
            probe_nodes: vec![None; s.probes.len()],
            probes_searched_at: None,
            cooling_step: 1.0,
            power: vec![0.0; n],
            powered: Vec::new(),
            reach,
            below: Arc::new(below),
            read_at: Arc::new(read_at),
            now: deps.first().map_or(0.0, |d| d.arc_start()),
            laid: 0,
            underpowered: 0,
            drops: Drops::default(),
            h_deposit: s.material.enthalpy(s.deposit_temperature),
            h_ambient: s.material.enthalpy(s.surroundings.ambient_k),
            settings: Arc::new(settings),
            model,
        }
    }

    /// Node steps taken so far ([`Network::node_steps`]).
    pub fn node_steps(&self) -> u64 {
        self.model.network.node_steps
    }

    /// The temperatures of the nodes, K (wall nodes first, then the plate).
    pub fn temperatures(&self) -> &[f64] {
        &self.model.network.t
    }

    /// A numerical failure shows as a non-finite temperature or loss: checked at `node` (the
    /// deposit just laid, where the heat went in) and in the ledger after every deposit, and at
    /// every node after a cooling.
    fn check(&self, node: Option<usize>) -> Result<(), ThermalError> {
        let net = &self.model.network;
        let bad = match node {
            Some(k) => !(net.t[k].is_finite() && net.ledger.lost().is_finite()),
            None => true,
        };
        if !bad {
            return Ok(());
        }
        match net.t.iter().position(|t| !t.is_finite()) {
            Some(k) => Err(ThermalError::NonFinite {
                time_s: self.now,
                position_mm: self.model.positions[k].map(|x| x * 1e3),
                what: "temperature (K)",
                value: net.t[k],
            }),
            None if !net.ledger.lost().is_finite() => Err(ThermalError::NonFinite {
                time_s: self.now,
                position_mm: node
                    .map_or([f64::NAN; 3], |k| self.model.positions[k].map(|x| x * 1e3)),
                what: "heat lost (J)",
                value: net.ledger.lost(),
            }),
            None => Ok(()),
        }
    }

    /// Keep each probe's temperature, at most every `every` seconds (the settings'
    /// `probe_every` as the run goes; 0 at its end, so that a trace holds the run's last
    /// moment: a reading there is compared, not left past the trace).
    fn sample_probes(&mut self, every: f64) {
        let (min_node, cell) = (self.settings.min_node, self.settings.plate.cell);
        let (net, positions, nw) = (
            &self.model.network,
            &self.model.positions,
            self.model.n_wall,
        );
        // A merged plate cell reaches as far as its side.
        let side = |k: usize| k.checked_sub(nw).map_or(1, |c| self.model.plate_side[c]);
        let reach = |k: usize| min_node.max(cell * f64::from(side(k)));
        // Nodes switch on only when a deposit is laid: search again only then.
        let search = self.probes_searched_at != Some(self.laid);
        self.probes_searched_at = Some(self.laid);
        for (trace, node) in self.probes.iter_mut().zip(&mut self.probe_nodes) {
            if node.is_none() && search {
                *node = (0..net.len())
                    .filter(|&k| net.active[k])
                    .map(|k| (dist(positions[k], trace.position), k))
                    .filter(|&(d, k)| d <= reach(k))
                    .min_by(|a, b| a.0.total_cmp(&b.0))
                    .map(|(_, k)| k);
            }
            if trace
                .time
                .last()
                .is_some_and(|&t| self.now - t < (every - 1e-12).max(1e-9))
            {
                continue;
            }
            trace.time.push(self.now);
            trace.temperature.push(node.map_or(f64::NAN, |k| net.t[k]));
        }
    }

    fn observe(&mut self) {
        let net = &self.model.network;
        let thr = self.settings.hot_threshold;
        // The nodes the step moved, each by its own time (all of them but where the nodes far
        // from the arc step at their own rates).
        let watched = match self.settings.watch_metal {
            true => net.stepped(),
            false => &[],
        };
        for &(a, b, tau) in watched {
            for k in a..b {
                if net.t[k] > thr {
                    self.time_above[k] += tau;
                }
                self.peak[k] = self.peak[k].max(net.t[k]);
            }
        }
        for tr in &mut self.traces {
            if tr.deposit < self.laid {
                tr.time.push(self.now);
                tr.temperature.push(net.t[self.model.node_of[tr.deposit]]);
            }
        }
        if self.settings.watch_metal && self.laid > 0 {
            let node_of = &self.model.node_of[..self.laid];
            let hottest = node_of.iter().map(|&k| net.t[k]).fold(f64::NAN, f64::max);
            self.hottest.push(true, self.now, hottest);
        }
        let times = &self.settings.snapshot_times;
        while self.next_snapshot < times.len() && times[self.next_snapshot] <= self.now + 1e-9 {
            self.snapshots.push(Snapshot {
                time: times[self.next_snapshot],
                temperature: self.model.node_of.iter().map(|&k| net.t[k]).collect(),
            });
            self.next_snapshot += 1;
        }
        self.sample_probes(self.settings.probe_every);
    }
}

impl HeatRun for WallRun {
    fn deposit_burning(
        &mut self,
        i: usize,
        dwell: f64,
        burn: Option<Burn>,
    ) -> Result<(), ThermalError> {
        let burn = Burn::or_scheduled(burn, &self.deps[i], i)?;
        self.cool(dwell)?;
        let (t, below, read_at) = (&self.model.network.t, &self.below, &self.read_at);
        self.drops
            .before(&self.deps, i, burn.drop, |k| beneath(t, below, read_at, k));
        // Laid from here on: the arc's step below observes it.
        self.laid = i + 1;
        let deps = Arc::clone(&self.deps);
        let deps = &deps[..];
        let (t_deposit, footprint) = (self.settings.deposit_temperature, self.settings.footprint);
        let d = &deps[i];
        let m = &mut self.model;
        let node = m.node_of[i];
        if m.layout_first[node] == i {
            let b = self.below[i];
            if b < m.n_wall {
                let covered = m.top[b].min(m.network.exposed[b]);
                m.network.exposed[b] -= covered;
                m.top[b] = 0.0;
            }
        }
        let seg_mass = m.lay(
            node,
            segment_share(deps, i, &m.length, &m.node_of),
            t_deposit,
        );
        let mut q = burn.heat - seg_mass * (self.h_deposit - self.h_ambient);
        if q < 0.0 {
            q = 0.0;
            self.underpowered += 1;
        }
        for k in self.powered.drain(..) {
            self.power[k] = 0.0;
        }
        let weights = footprint_weights(m, node, d.position, footprint);
        let total: f64 = weights.iter().map(|w| w.1).sum();
        // Preheats read during this arc: interpolated between its start and its end.
        let before: Vec<f64> = self.probes_at[i]
            .iter()
            .map(|&(k, _)| beneath(&m.network.t, &self.below, &self.read_at, k))
            .collect();
        let arc = burn.arc_time;
        if arc > 0.0 {
            if total > 0.0 {
                for (k, w) in &weights {
                    self.power[*k] += q / arc * w / total;
                    self.powered.push(*k);
                }
            } else {
                self.power[node] += q / arc;
                self.powered.push(node);
            }
            // Where the nodes far from the arc step at their own rates, the levels were sorted
            // by where the scheduled path brings the torch at its fastest: a travel between
            // tracks, or an arc run faster than scheduled, is stepped whole.
            let whole = d.start.is_some() || arc < d.arc_time * (1.0 - 1e-9);
            let torch = TorchOnPath {
                reach: self.reach.as_deref(),
                positions: &m.positions,
                at: i,
                position: d.position,
            };
            if whole {
                m.network.step_whole(arc, &self.power, &torch);
            } else {
                m.network.step_near(arc, &self.power, &torch);
            }
            self.now += arc;
            self.observe();
        }
        for (&(k, f), t0) in self.probes_at[i].iter().zip(before) {
            // The step lays its share of its node at its start: a point of that node (its segment
            // longer than the lead) is read before the step, as the torch, still upstream,
            // has not laid metal over it; interpolated, the reading took a share of that
            // metal's heat (docs/PHYSICS.md "The preheat of a long deposit").
            let f = if self.model.node_of[k] == node {
                0.0
            } else {
                f
            };
            let t1 = beneath(&self.model.network.t, &self.below, &self.read_at, k);
            self.points[k].preheat = t0 + f * (t1 - t0);
        }
        if let Some(t) = self.drops.after(i, burn.drop) {
            self.points[i].preheat = t;
        }
        // The melt pool behind the torch: the wall's nodes from the torch's back along the bead,
        // the torch's own node as far as it has laid it. Counted whole, a node of two deposits
        // read the pool at its first a deposit longer than at its second (docs/PHYSICS.md
        // "Nodes of two deposits").
        let m = &self.model;
        let laid = (m.layout_first[node]..=i)
            .map(|j| segment_share(deps, j, &m.length, &m.node_of))
            .sum::<f64>()
            .min(1.0);
        let samples = (0..=node).rev().map(|k| {
            let share = if k == node { laid } else { 1.0 };
            pool::Sample {
                t: Some(m.network.t[k]),
                length: share * m.length[k],
                volume: share * m.volume[k],
            }
        });
        let (len, vol) = pool::behind(samples, self.settings.material.solidus);
        self.points[i].pool_length = len;
        self.points[i].pool_radius = (3.0 * vol / (2.0 * std::f64::consts::PI)).cbrt();
        self.cooling_step = 1.0;
        self.check(Some(node))
    }

    /// Let the part cool (no source) for `duration`, in steps doubling from one second to the
    /// settings' longest step (backward Euler is stable at any step; cooling slows as it goes),
    /// carried on from where an earlier cooling since the last deposit stopped.
    fn cool(&mut self, duration: f64) -> Result<(), ThermalError> {
        if duration <= 1e-9 {
            return Ok(());
        }
        for k in self.powered.drain(..) {
            self.power[k] = 0.0;
        }
        let end = self.now + duration;
        let mut dt = self.cooling_step.min(duration);
        while self.now < end - 1e-9 {
            let step = dt.min(end - self.now);
            // The torch waits where it stopped: far from it, and in metal long cooled, the
            // levels step at their own rates through the dwell as through the arc.
            let m = &mut self.model;
            match self.laid.checked_sub(1) {
                Some(last) if self.reach.is_some() => {
                    let torch = TorchOnPath {
                        reach: self.reach.as_deref(),
                        positions: &m.positions,
                        at: self.laid.min(self.deps.len() - 1),
                        position: self.deps[last].position,
                    };
                    m.network.step_near(step, &self.power, &torch);
                }
                _ => m.network.step(step, &self.power),
            }
            self.now += step;
            self.observe();
            dt = (dt * 2.0).min(self.settings.max_step);
        }
        self.cooling_step = dt;
        self.check(None)
    }

    fn quench(&mut self) {
        self.model.network.quench();
    }

    fn set_losses(&mut self, convection_w_m2k: f64, emissivity: f64, table_w_m2k: f64) {
        let s = &mut self.model.network.surroundings;
        (s.convection_w_m2k, s.emissivity, s.table_w_m2k) =
            (convection_w_m2k, emissivity, table_w_m2k);
    }

    fn points(&self) -> &[PointResult] {
        &self.points
    }

    fn support(&self, i: usize) -> Support {
        let (b, own) = (self.below[i], self.model.node_of[i]);
        // A drop's reading is taken as its own arc strikes, after the wait before it: the metal
        // beneath is no longer the arc's.
        let read_after_support = !self.drops.contains(i) && self.just_laid[i];
        if b >= self.model.n_wall {
            Support::Plate
        } else if b >= own || read_after_support {
            Support::JustLaid
        } else {
            Support::Deposit
        }
    }

    fn laid(&self) -> usize {
        self.laid
    }

    fn now(&self) -> f64 {
        self.now
    }

    fn temperature_beneath(&self, i: usize) -> f64 {
        beneath(&self.model.network.t, &self.below, &self.read_at, i)
    }

    fn temperature_of(&self, i: usize) -> f64 {
        self.model.network.t[self.model.node_of[i]]
    }

    fn cooling_steps(&self) -> CoolingSteps {
        CoolingSteps::Doubling {
            max: self.settings.max_step,
        }
    }

    fn finish(mut self) -> RunResult {
        self.sample_probes(0.0);
        let support = (0..self.points.len()).map(|i| self.support(i)).collect();
        for (i, p) in self.points.iter_mut().enumerate() {
            let node = self.model.node_of[i];
            (p.peak, p.time_above) = match self.settings.watch_metal {
                true => (self.peak[node], self.time_above[node]),
                false => (f64::NAN, f64::NAN),
            };
        }
        let net = &self.model.network;
        RunResult {
            points: self.points,
            support,
            snapshots: self.snapshots,
            traces: self.traces,
            hottest: self.hottest,
            probes: self.probes,
            ledger: net.ledger,
            stored: net.stored(),
            balance_error: net.balance_error(),
            underpowered: self.underpowered,
            steps: net.steps,
            cells: Cells::ThinWall {
                wall_nodes: self.model.n_wall,
                plate_cells: net.len() - self.model.n_wall,
                cg_iterations: net.iterations,
                node_steps: net.node_steps,
            },
        }
    }
}

/// The torch on deposit `at` of the path, for sorting the nodes into levels.
struct TorchOnPath<'a> {
    reach: Option<&'a Reach>,
    positions: &'a [[f64; 3]],
    at: usize,
    position: [f64; 3],
}

impl Torch for TorchOnPath<'_> {
    type Ahead = Option<Window>;

    fn near(&self, i: usize, d: f64) -> bool {
        dist(self.positions[i], self.position) <= d
    }

    fn ahead(&self, horizon: f64) -> Option<Window> {
        self.reach.map(|r| r.window(self.at, horizon))
    }

    fn clear_of(&self, i: usize, d: f64, ahead: &Option<Window>) -> bool {
        match (self.reach, ahead) {
            (Some(r), Some(w)) => !r.window_within(self.positions[i], d, w),
            _ => false,
        }
    }
}

/// The temperature of what deposit k lies on: its support's node, read along the bead between
/// it and its neighbour where both are whole, or the plate's top at its point (`read_at`: the
/// cells round it interpolated; the one cell that holds the point made a first revolution's
/// preheats alternate by 12 K as the points crossed the cells).
fn beneath(
    t: &[f64],
    below: &[usize],
    read_at: &BTreeMap<usize, Vec<(usize, f64)>>,
    k: usize,
) -> f64 {
    match read_at.get(&k) {
        Some(around) if !around.is_empty() => {
            let w: f64 = around.iter().map(|a| a.1).sum();
            around.iter().map(|&(c, a)| a * t[c]).sum::<f64>() / w
        }
        _ => t[below[k]],
    }
}

/// What a deposit laid on the wall reads: its support's node and that node's neighbour along
/// the bead on the point's side, the temperature linear between their centres (as the pool
/// reads it), where both are whole when the point is read (`lead` upstream). Read from its
/// node alone, a node of several deposits gave each of them one temperature, and the next
/// node's points another: a staircase along the revolution (docs/PHYSICS.md "Nodes of several
/// deposits").
fn along_below(
    deps: &[Deposit],
    l: &Layout,
    below: &[usize],
    lead: f64,
) -> Vec<(usize, Vec<(usize, f64)>)> {
    let nw = l.first.len();
    let reads = read_fractions(deps, lead);
    // Node n is whole once the deposit after its last is laid.
    let whole_by = |n: usize| l.first.get(n + 1).copied().unwrap_or(deps.len());
    let joined = |a: usize, b: usize| deps[l.first[a.max(b)]].start.is_none();
    let mut out = Vec::new();
    for (k, d) in deps.iter().enumerate() {
        let (Some(_), Some((j, _))) = (d.support, reads[k]) else {
            continue;
        };
        let u = below[k];
        if u >= nw || whole_by(u) > j {
            continue;
        }
        let c = l.centre[u];
        let side = [u.checked_sub(1), (u + 1 < nw).then_some(u + 1)]
            .into_iter()
            .flatten()
            .filter(|&n| joined(u, n) && whole_by(n) <= j)
            .map(|n| {
                let e: [f64; 3] = std::array::from_fn(|q| l.centre[n][q] - c[q]);
                let r: [f64; 3] = std::array::from_fn(|q| d.position[q] - c[q]);
                let ee = e.iter().map(|x| x * x).sum::<f64>().max(1e-18);
                (
                    n,
                    (e.iter().zip(r).map(|(a, b)| a * b).sum::<f64>() / ee).clamp(0.0, 1.0),
                )
            })
            .max_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((n, f)) = side.filter(|s| s.1 > 0.0) {
            out.push((k, vec![(u, 1.0 - f), (n, f)]));
        }
    }
    out
}

impl WallModel {
    /// Lay `share` of wall node `node` at temperature `t`: its mass and its faces grow with the
    /// metal laid, so that a node of several deposits holds, and loses heat from, only what the
    /// torch has laid of it (docs/PHYSICS.md "Nodes of several deposits"). The mass laid, kg.
    fn lay(&mut self, node: usize, share: f64, t: f64) -> f64 {
        let net = &mut self.network;
        let whole = net.material.density * self.volume[node];
        let laid = if net.active[node] {
            net.mass[node] / whole
        } else {
            0.0
        };
        let share = share.min(1.0 - laid).max(0.0);
        // Its faces as built are the whole node's; the layer above covers its top only once
        // the node is whole (the path comes back to it a revolution later).
        let faces = if laid > 0.0 {
            net.exposed[node] / laid
        } else {
            net.exposed[node]
        };
        net.exposed[node] = faces * (laid + share);
        net.lay(node, share * whole, t);
        share * whole
    }
}

/// The share of its node's mass that deposit i lays.
fn segment_share(deps: &[Deposit], i: usize, length: &[f64], node_of: &[usize]) -> f64 {
    (seg_len(deps, i) / length[node_of[i]]).min(1.0)
}

/// The arc's heat over the footprint: the nodes behind the torch along the path (its own node
/// first) whose centres lie within `footprint` of arc length from it, weighted by the Gaussian
/// exp(−3 s²/footprint²). Along the path, as the Goldak ellipsoid of the voxel model lies along
/// the bead: a sphere round the torch put more than half of it into the revolutions below (57 %
/// on the comparison cylinder), which made the thin wall read 5 % of the rise above the voxel
/// model (docs/PHYSICS.md).
fn footprint_weights(
    m: &WallModel,
    node: usize,
    torch: [f64; 3],
    footprint: f64,
) -> Vec<(usize, f64)> {
    let mut weights = Vec::new();
    let (mut k, mut s) = (node, dist(m.positions[node], torch));
    while s <= footprint && m.network.active[k] {
        weights.push((k, (-3.0 * (s / footprint).powi(2)).exp()));
        if k == 0 || m.track_start[k] {
            break;
        }
        s += dist(m.positions[k], m.positions[k - 1]);
        k -= 1;
    }
    weights
}

/// Points across a plate-supported bead's width, each joined to the plate cell beneath it.
const ACROSS: usize = 5;

/// Horizontal unit vector across deposit i's bead (perpendicular to its travel).
fn bead_across(deps: &[Deposit], i: usize) -> [f64; 2] {
    let (a, b) = match i {
        0 if deps.len() > 1 => (deps[0].position, deps[1].position),
        0 => return [1.0, 0.0],
        _ => (segment_start(deps, i), deps[i].position),
    };
    let (tx, ty) = (b[0] - a[0], b[1] - a[1]);
    let n = tx.hypot(ty);
    if n < 1e-12 {
        [1.0, 0.0]
    } else {
        [-ty / n, tx / n]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A straight bead along x of deposits `step` apart, the first at x = 0.
    fn line(n: usize, step: f64) -> Vec<Deposit> {
        (0..n)
            .map(|i| Deposit {
                position: [i as f64 * step, 0.0, 2e-3],
                time: (i + 1) as f64,
                arc_time: 1.0,
                heat: 100.0,
                width: 5e-3,
                height: 2e-3,
                axis: [0.0, 0.0, 1.0],
                support: None,
                start: None,
                drop: None,
            })
            .collect()
    }

    /// A node's one temperature is its stretch of bead's mean, so it stands at the stretch's
    /// middle. At the mean of its deposits' points (their segments' ends) a node of one 4.2 mm
    /// deposit stood 2.1 mm nearer the arc than its metal, and the preheat read at a point
    /// took metal nearer the arc: an upright R 80 wall of 4.2 mm deposits read 10.5 K over
    /// the voxel model on revolution 1, 6.5 K since (docs/PHYSICS.md "A node at its stretch's
    /// middle").
    #[test]
    fn a_node_stands_at_the_middle_of_its_stretch() {
        // One deposit a node: deposit k's segment runs from x = 4(k - 1) to 4k mm.
        let l = layout(&line(5, 4e-3), 3e-3);
        for k in 1..5 {
            assert_eq!(l.node_of[k], k);
            let x = l.centre[k][0] * 1e3;
            assert!(
                (x - (4.0 * k as f64 - 2.0)).abs() < 1e-9,
                "node {k} at {x} mm"
            );
        }
        // Nodes of three 1 mm deposits: deposits 1-3 make the node from x = 0 to 3 mm.
        let l = layout(&line(10, 1e-3), 3e-3);
        assert_eq!(&l.node_of[1..4], &[1, 1, 1]);
        let x = l.centre[1][0] * 1e3;
        assert!((x - 1.5).abs() < 1e-9, "node 1 at {x} mm");
    }
}
