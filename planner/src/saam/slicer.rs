//! The adaptive slicer of Radel et al. 2019 (§2.1, §3.2–§3.5, Fig. 8): the list of points to
//! build, starting with the branches' points on the starting plane; the next point P_c the one of
//! highest priority, then nearest the starting plane; its welding-time ratio k_w ([`super::overlap`]);
//! its tool orientation (along the branch, or offset at an intersection, §3.4); its stand-off
//! out of a collision zone (§3.3); then, once the drop is laid, the next point propagated from
//! the top of the drop as measured (closed loop, §2.4) or by the nominal increment δ (open loop).
//! At a node the propagation continues into the branches leaving it that are not yet under
//! construction.
//!
//! [`Slicer`] is a state machine: [`Slicer::next_drop`] plans a drop, [`Slicer::built`] says where its
//! top was found. It does no IO and draws no random numbers: the camera is the caller's.

use super::graph::{Branch, Priority, Skeleton};
use super::overlap::Built;
use nalgebra::{Point3, Rotation3, Unit, Vector3};

#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SlicerSettings {
    /// δ: the nominal increment, the height of one drop, mm.
    pub increment_mm: f64,
    /// γ_div (§3.4): the tool's angle from the priority branch at a divergent intersection.
    pub divergent_offset_deg: f64,
    /// γ_conv (§3.4): the tool's turn about the TCP, away from the branch built through a
    /// convergent intersection.
    pub convergent_offset_deg: f64,
    pub nozzle_radius_mm: f64,
    /// The contact tip to work distance (CTDWP) the slicer keeps, mm.
    pub standoff_mm: f64,
    /// The nozzle cylinder's length beyond the tip, mm.
    pub nozzle_length_mm: f64,
    /// The most the tool stands off out of a collision zone (δ_coll), mm.
    pub max_collision_standoff_mm: f64,
}

impl Default for SlicerSettings {
    /// The paper's setting: δ 1.3 mm (R_d 3 mm), 90° and 70°, a nozzle 24 mm across at a CTDWP
    /// of 10 mm.
    fn default() -> Self {
        SlicerSettings {
            increment_mm: 1.3,
            divergent_offset_deg: 90.0,
            convergent_offset_deg: 70.0,
            nozzle_radius_mm: 12.0,
            standoff_mm: 10.0,
            nozzle_length_mm: 60.0,
            max_collision_standoff_mm: 30.0,
        }
    }
}

/// How a drop stands at an intersection (§3.4).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Intersection {
    /// The first points of a branch leaving a node after the priority branch.
    Divergent,
    /// The last points of a branch arriving at a node another branch was built through.
    Convergent,
}

/// One planned drop.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Planned {
    pub index: usize,
    pub branch: usize,
    /// Curvilinear abscissa on the branch, from the end it is built from, mm.
    pub s_mm: f64,
    /// Where the open loop would lay it (its sphere in the virtual part), mm.
    pub nominal_s: f64,
    /// P_c: where the drop is laid (the TCP), mm.
    pub position: Point3<f64>,
    /// n_branch.
    pub direction: Vector3<f64>,
    /// From the drop to the torch.
    pub tool: Vector3<f64>,
    pub radius_mm: f64,
    /// k_w.
    pub weld_ratio: f64,
    /// The contact tip to work distance planned: CTDWP plus δ_coll.
    pub standoff_mm: f64,
    pub intersection: Option<Intersection>,
    /// The branch whose collision zone held this point back (§3.3), if any.
    pub waited_for: Option<usize>,
    /// The drop this one lies on (the branch's previous drop, or at a node the drop nearest).
    pub support: Option<usize>,
}

/// A collision zone (§3.3): while the torch builds `branch` between `s` (its nozzle cylinder
/// along the branch), metal of `other` between `t` would be inside the nozzle.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Zone {
    pub branch: usize,
    pub s: [f64; 2],
    pub other: usize,
    pub t: [f64; 2],
}

#[derive(Debug, Clone, PartialEq)]
struct State {
    started: bool,
    done: bool,
    /// The abscissa of the next point to build, while under construction.
    next: Option<f64>,
    /// Where the open loop would put it: the virtual part's point, δ after the last one's.
    nominal: f64,
    /// Built up to here (the last drop's point).
    front: f64,
    last_drop: Option<usize>,
    priority: Priority,
    /// Its first points stand at a divergent intersection up to this abscissa, the tool so.
    divergent: Option<(f64, Vector3<f64>)>,
    /// From this abscissa on it converges on a node built through: the tool turned so.
    convergent: Option<(f64, Vector3<f64>)>,
    /// The branch whose collision zone holds (or held) its next point back.
    held: Option<usize>,
}

/// k_w below this: the point lies in metal already there (a convergent branch arriving at its
/// node), and its branch is done.
const MIN_WELD_RATIO: f64 = 0.1;

#[derive(Debug, Clone)]
pub struct Slicer {
    geometry: Vec<Branch>,
    sk: Skeleton,
    set: SlicerSettings,
    state: Vec<State>,
    zones: Vec<Zone>,
    built: Built,
    drops: Vec<Planned>,
    pending: Option<usize>,
    node_drop: Vec<Option<usize>>,
    /// Points let into a zone although what they waited for never came (no other way on).
    pub forced: usize,
}

impl Slicer {
    pub fn new(sk: &Skeleton, set: SlicerSettings) -> Slicer {
        let r_max = sk.branches.iter().map(|b| b.radius_mm).fold(0.0, f64::max);
        let mut s = Slicer {
            geometry: sk.branches.clone(),
            sk: sk.clone(),
            set,
            state: sk
                .branches
                .iter()
                .map(|b| State {
                    started: false,
                    done: false,
                    next: None,
                    nominal: 0.0,
                    front: 0.0,
                    last_drop: None,
                    priority: b.priority,
                    divergent: None,
                    convergent: None,
                    held: None,
                })
                .collect(),
            zones: Vec::new(),
            built: Built::new(r_max),
            drops: Vec::new(),
            pending: None,
            node_drop: vec![None; sk.nodes.len()],
            forced: 0,
        };
        s.zones = collision_zones(sk, &s.geometry, &set);
        let starts: Vec<usize> = (0..sk.nodes.len()).filter(|&k| sk.nodes[k].start).collect();
        for k in starts {
            s.open_node(k);
        }
        s
    }

    pub fn zones(&self) -> &[Zone] {
        &self.zones
    }

    pub fn drops(&self) -> &[Planned] {
        &self.drops
    }

    /// The branch geometry as built (a level branch turned to start where it was reached).
    pub fn branch(&self, b: usize) -> &Branch {
        &self.geometry[b]
    }

    /// Start the branches leaving node k that are not under construction (§3.5), the first
    /// points of all but the priority one offset as at a divergent intersection (§3.4).
    fn open_node(&mut self, k: usize) {
        let mut leaving: Vec<usize> = self
            .sk
            .leaving(k)
            .into_iter()
            .filter(|&b| !self.state[b].started)
            .collect();
        if leaving.is_empty() {
            return;
        }
        for &b in &leaving {
            if self.geometry[b].ends[0] != k {
                self.geometry[b] = self.geometry[b].reversed();
            }
        }
        // The priority branch: highest priority, then the most upright, then the first.
        leaving.sort_by(|&a, &b| {
            let up = |x: usize| self.geometry[x].at(0.0).1.z;
            self.state[b]
                .priority
                .cmp(&self.state[a].priority)
                .then(up(b).total_cmp(&up(a)))
                .then(a.cmp(&b))
        });
        let lead = leaving[0];
        let n_lead = self.geometry[lead].at(0.0).1;
        let arriving = !self.sk.arriving(k).is_empty();
        let divergent = arriving || leaving.len() > 1;
        for (rank, &b) in leaving.iter().enumerate() {
            let g = &self.geometry[b];
            let (_, dir) = g.at(0.0);
            let first = if rank == 0 || !divergent {
                if self.sk.nodes[k].start {
                    0.0
                } else {
                    self.set.increment_mm
                }
            } else {
                // On the border of the priority branch's metal (the paper's 5.9 mm at 30°).
                let sin = n_lead.cross(&dir).norm().max(1e-3);
                (g.radius_mm / sin).min(g.length())
            };
            if rank > 0 && divergent {
                let tool = offset_from(&n_lead, &dir, self.set.divergent_offset_deg);
                self.state[b].divergent = Some((first + g.radius_mm, tool));
            }
            let st = &mut self.state[b];
            st.started = true;
            st.next = Some(first.min(g.length()));
            st.nominal = first.min(g.length());
        }
    }

    /// Whether a point of `b` at `s` waits (§3.3 (i)): it would lay metal in a collision zone,
    /// where another branch's nozzle is still to pass: until that branch has left its part of
    /// the zone (or is built). When everything waits, the lowest goes ([`Slicer::forced`]) and
    /// the nozzle stands off (δ_coll, (ii)).
    fn waits_for(&self, b: usize, s: f64) -> Option<usize> {
        self.zones.iter().find_map(|z| {
            if z.other != b || s < z.t[0] || s > z.t[1] {
                return None;
            }
            let o = &self.state[z.branch];
            let passed = o.done || o.front > z.s[1];
            (!passed).then_some(z.branch)
        })
    }

    /// Plan the next drop; None when every branch is built. Call [`Slicer::built`] before the
    /// next call.
    pub fn next_drop(&mut self) -> Option<Planned> {
        assert!(self.pending.is_none(), "next_drop() before built()");
        loop {
            let candidates: Vec<(usize, f64)> = (0..self.state.len())
                .filter_map(|b| self.state[b].next.map(|s| (b, s)))
                .collect();
            if candidates.is_empty() {
                return None;
            }
            for &(b, s) in &candidates {
                if let Some(o) = self.waits_for(b, s) {
                    self.state[b].held = Some(o);
                }
            }
            let height = |&(b, s): &(usize, f64)| self.geometry[b].at(s).0.z - self.sk.start_z;
            let order = |a: &(usize, f64), c: &(usize, f64)| {
                self.state[c.0]
                    .priority
                    .cmp(&self.state[a.0].priority)
                    .then(height(a).total_cmp(&height(c)))
                    .then(a.0.cmp(&c.0))
            };
            let free: Vec<(usize, f64)> = candidates
                .iter()
                .copied()
                .filter(|&(b, s)| self.waits_for(b, s).is_none())
                .collect();
            let chosen = match free.iter().min_by(|a, c| order(a, c)) {
                Some(&c) => c,
                None => {
                    // Everything waits: the lowest goes, and it is counted.
                    self.forced += 1;
                    *candidates.iter().min_by(|a, c| order(a, c)).unwrap()
                }
            };
            let waited = self.state[chosen.0].held.take();
            if let Some(p) = self.plan(chosen.0, chosen.1, waited) {
                self.pending = Some(self.drops.len());
                self.drops.push(p);
                return Some(p);
            }
        }
    }

    /// The drop at (b, s), or None where no metal is wanted there (the branch is then done).
    fn plan(&mut self, b: usize, s: f64, waited_for: Option<usize>) -> Option<Planned> {
        let g = &self.geometry[b];
        let (position, direction) = g.at(s);
        let radius = g.radius_mm;
        // k_w on the virtual part (§3.5): the drop where the open loop would lay it, against the
        // drops as planned. The camera moves the torch, not the metal a drop brings: with the
        // sphere at the top it read, k_w would follow each drop's error and the drops would
        // shrink away (a rod's new metal per drop is πR²·d for centres d apart, exactly what a
        // drop of that k_w lays, so nothing holds d).
        let nominal = self.state[b].nominal.min(g.length());
        let weld_ratio = self
            .built
            .weld_ratio(&g.at(nominal).0, radius, self.sk.start_z);
        let converging = self.state[b].convergent.is_some_and(|(from, _)| s >= from);
        if weld_ratio < MIN_WELD_RATIO && (converging || s >= g.length() - radius) {
            self.finish(b);
            return None;
        }
        // Converging on a node another branch was built through (§3.4): turned away from it.
        let upper = g.ends[1];
        if self.state[b].convergent.is_none()
            && let Some(through) = self.through(upper, b)
        {
            let other = &self.geometry[through];
            let n_other = other.at(other.length()).1;
            let sin = n_other.cross(&direction).norm().max(1e-3);
            let from = g.length() - (2.0 * radius / sin).min(g.length());
            // Away from the other branch's axis through the node, where its metal stands.
            let node = self.sk.nodes[upper].position;
            let off = g.at(from).0 - node;
            let away = off - n_other * off.dot(&n_other);
            let tool = turned_away(&direction, &n_other, &away, self.set.convergent_offset_deg);
            self.state[b].convergent = Some((from, tool));
        }
        let st = &self.state[b];
        let (mut tool, mut intersection) = (direction, None);
        if let Some((until, t)) = st.divergent
            && s <= until
        {
            (tool, intersection) = (t, Some(Intersection::Divergent));
        }
        if let Some((from, t)) = st.convergent
            && s >= from
        {
            (tool, intersection) = (t, Some(Intersection::Convergent));
        }
        // Conflict priority (§3.4): a branch entering a convergent node's zone first goes
        // through in priority.
        if self.sk.arriving(upper).len() > 1 && s >= g.length() - 2.0 * radius {
            let p = &mut self.state[b].priority;
            *p = (*p).max(Priority::Conflict);
        }
        let standoff = self.set.standoff_mm + self.clearance(&position, &tool, b);
        let support = self.state[b].last_drop.or_else(|| {
            let k = self.geometry[b].ends[0];
            self.node_drop[k]
        });
        Some(Planned {
            index: self.drops.len(),
            branch: b,
            s_mm: s,
            nominal_s: nominal,
            position,
            direction,
            tool: tool.normalize(),
            radius_mm: radius,
            weld_ratio,
            standoff_mm: standoff,
            intersection,
            waited_for,
            support,
        })
    }

    /// A branch other than `b` arriving at node k and built through it (done), if any.
    fn through(&self, k: usize, b: usize) -> Option<usize> {
        self.sk
            .arriving(k)
            .into_iter()
            .find(|&o| o != b && self.state[o].done)
    }

    /// δ_coll (§3.3 (ii)): how much farther than the CTDWP the torch stands so that no drop
    /// built on another branch lies in its nozzle; 0.5 mm steps, at most the settings' most.
    fn clearance(&self, p: &Point3<f64>, tool: &Vector3<f64>, b: usize) -> f64 {
        let t = tool.normalize();
        let hit = |extra: f64| {
            self.drops.iter().any(|d| {
                d.branch != b && {
                    let from = self.set.standoff_mm + extra;
                    let along = (d.position - p).dot(&t);
                    let across = ((d.position - p) - t * along).norm();
                    along + d.radius_mm >= from
                        && along - d.radius_mm <= from + self.set.nozzle_length_mm
                        && across < self.set.nozzle_radius_mm + d.radius_mm
                }
            })
        };
        let mut extra = 0.0;
        while hit(extra) && extra < self.set.max_collision_standoff_mm {
            extra += 0.5;
        }
        extra
    }

    /// The drop just planned is laid; closed loop, the camera read its top at abscissa `top_s`
    /// (§2.4) and the next point goes there; open loop (None), δ on. Either way the virtual
    /// part grows by the drop's sphere where the open loop would have it.
    pub fn built(&mut self, top_s: Option<f64>) {
        let i = self.pending.take().expect("built() after next_drop()");
        let d = self.drops[i];
        let g = &self.geometry[d.branch];
        let len = g.length();
        self.built.add(g.at(d.nominal_s).0, d.radius_mm);
        let st = &mut self.state[d.branch];
        st.front = d.s_mm;
        st.last_drop = Some(i);
        st.nominal = d.nominal_s + self.set.increment_mm;
        let next = top_s.unwrap_or(d.s_mm + self.set.increment_mm);
        // Never backwards, and the branch's end is its last point.
        let next = next.max(d.s_mm + 0.05 * self.set.increment_mm);
        if d.s_mm >= len - 1e-9 || (top_s.is_none() && d.nominal_s >= len - 1e-9) {
            self.finish(d.branch);
        } else {
            st.next = Some(next.min(len));
        }
    }

    /// Branch b is built: its upper node reached, the branches leaving it started.
    fn finish(&mut self, b: usize) {
        let st = &mut self.state[b];
        st.done = true;
        st.next = None;
        let k = self.geometry[b].ends[1];
        if self.node_drop[k].is_none() {
            self.node_drop[k] = st.last_drop;
        }
        // A node is opened once every branch arriving at it is built (or given up).
        let all_in = self
            .sk
            .arriving(k)
            .into_iter()
            .all(|a| self.state[a].done || self.through(k, a).is_some());
        if all_in {
            self.open_node(k);
        }
    }
}

/// The tool at a divergent intersection: from the priority branch's direction `lead`, turned by
/// `deg` towards the branch `dir` in their plane.
fn offset_from(lead: &Vector3<f64>, dir: &Vector3<f64>, deg: f64) -> Vector3<f64> {
    let u = (dir - lead * lead.dot(dir))
        .try_normalize(1e-9)
        .unwrap_or_else(|| lead.cross(&Vector3::x()).normalize());
    let a = deg.to_radians();
    lead * a.cos() + u * a.sin()
}

/// The tool at a convergent intersection: the branch's direction turned by `deg` about the
/// normal to the plane of the two branches (directions `dir`, `other`), to the side `away` from
/// the other branch, so that the wire reaches the drop past it.
fn turned_away(
    dir: &Vector3<f64>,
    other: &Vector3<f64>,
    away: &Vector3<f64>,
    deg: f64,
) -> Vector3<f64> {
    let Some(axis) = Unit::try_new(dir.cross(other), 1e-9) else {
        return *dir;
    };
    let turn = |sign: f64| Rotation3::from_axis_angle(&axis, sign * deg.to_radians()) * dir;
    let (a, b) = (turn(1.0), turn(-1.0));
    if a.dot(away) >= b.dot(away) { a } else { b }
}

/// §3.3's collision zones, pre-processed: along each branch (every half increment) the nozzle
/// cylinder on the branch's direction, against the metal of every other branch (every 0.5 mm,
/// a cylinder of its R_d); metal within R_d of the branch's own axis (where they meet at a
/// node) is the intersection's, not a collision. Only between branches that may grow at once:
/// one built wholly after the other (above it in the skeleton) meets its metal finished.
fn collision_zones(sk: &Skeleton, branches: &[Branch], set: &SlicerSettings) -> Vec<Zone> {
    let after = descendants(sk);
    let mut zones = Vec::new();
    let step = (set.increment_mm / 2.0).max(0.1);
    for (i, bi) in branches.iter().enumerate() {
        for (j, bj) in branches.iter().enumerate() {
            if i == j || after[i][j] || after[j][i] {
                continue;
            }
            let mut zone: Option<Zone> = None;
            let mut s = 0.0;
            while s <= bi.length() + 1e-9 {
                let (p, t) = bi.at(s);
                let mut u = 0.0;
                while u <= bj.length() + 1e-9 {
                    let (q, _) = bj.at(u);
                    let along = (q - p).dot(&t);
                    let across = ((q - p) - t * along).norm();
                    let inside = along + bj.radius_mm >= set.standoff_mm
                        && along - bj.radius_mm <= set.standoff_mm + set.nozzle_length_mm
                        && across < set.nozzle_radius_mm + bj.radius_mm;
                    if inside && distance_to(bi, &q) > bi.radius_mm + bj.radius_mm {
                        let z = zone.get_or_insert(Zone {
                            branch: i,
                            s: [s, s],
                            other: j,
                            t: [u, u],
                        });
                        z.s = [z.s[0].min(s), z.s[1].max(s)];
                        z.t = [z.t[0].min(u), z.t[1].max(u)];
                    }
                    u += 0.5;
                }
                s += step;
            }
            zones.extend(zone);
        }
    }
    zones
}

/// after[i][j]: branch j starts only once branch i is built (it leaves a node above i).
fn descendants(sk: &Skeleton) -> Vec<Vec<bool>> {
    let n = sk.branches.len();
    (0..n)
        .map(|i| {
            let mut seen = vec![false; n];
            let mut stack = vec![sk.branches[i].ends[1]];
            let mut nodes = vec![false; sk.nodes.len()];
            while let Some(k) = stack.pop() {
                if std::mem::replace(&mut nodes[k], true) {
                    continue;
                }
                // A level branch may be started from its other end: not surely after i.
                for b in sk.leaving(k) {
                    if b != i && !seen[b] && !sk.branches[b].flat {
                        seen[b] = true;
                        stack.extend(sk.branches[b].ends);
                    }
                }
            }
            seen
        })
        .collect()
}

/// Distance from q to the branch's polyline.
fn distance_to(b: &Branch, q: &Point3<f64>) -> f64 {
    b.points
        .windows(2)
        .map(|w| {
            let ab = w[1] - w[0];
            let s = ((q - w[0]).dot(&ab) / ab.norm_squared()).clamp(0.0, 1.0);
            (q - (w[0] + ab * s)).norm()
        })
        .fold(f64::INFINITY, f64::min)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::saam::graph::BranchSpec;

    fn skeleton(v: &[[f64; 3]], lines: &[Vec<u32>], priorities: &[Priority]) -> Skeleton {
        let v: Vec<Point3<f64>> = v.iter().map(|p| Point3::new(p[0], p[1], p[2])).collect();
        Skeleton::new(&v, lines, |k| BranchSpec {
            radius_mm: 3.0,
            priority: priorities.get(k).copied().unwrap_or(Priority::None),
        })
        .unwrap()
    }

    fn run(sk: &Skeleton, set: SlicerSettings) -> Slicer {
        let mut sl = Slicer::new(sk, set);
        while sl.next_drop().is_some() {
            sl.built(None);
        }
        sl
    }

    /// A vertical rod 13 mm tall, open loop: a drop every δ = 1.3 mm from the plate, the tool
    /// along the rod; the first half in the plate (k_w 0.5), the others cut by the drop beneath
    /// (the lens of two spheres 1.3 mm apart: k_w 0.32).
    #[test]
    fn a_rod_drop_by_drop() {
        let sk = skeleton(&[[0.0, 0.0, 0.0], [0.0, 0.0, 13.0]], &[vec![0, 1]], &[]);
        let sl = run(&sk, SlicerSettings::default());
        let d = sl.drops();
        assert_eq!(d.len(), 11);
        assert!((d[0].weld_ratio - 0.5).abs() < 0.01, "{}", d[0].weld_ratio);
        assert!((d[5].weld_ratio - 0.32).abs() < 0.02, "{}", d[5].weld_ratio);
        assert!(d.iter().all(|p| (p.tool - Vector3::z()).norm() < 1e-12));
        assert!(d.windows(2).all(|w| w[1].support == Some(w[0].index)));
        assert_eq!(d[10].position.z, 13.0);
    }

    /// The K of §4.2: a stem L1 and an arm L4 tilted 30° from the plate converge on node A; L5
    /// goes on up to node B, where L2 (upright) and L3 (30°, high priority) diverge. L3 is built
    /// first; L2's first point stands 3/sin 30° = 6 mm up (the paper: 5.9 mm), the tool 90° from
    /// L3 there; the arm arriving second at A turned 70° away from the stem.
    #[test]
    fn the_k_skeleton_intersections() {
        let t = 30f64.to_radians().tan();
        let v = [
            [0.0, 0.0, 0.0],
            [0.0, 0.0, 30.0],
            [30.0 * t, 0.0, 0.0],
            [0.0, 0.0, 45.0],
            [0.0, 0.0, 75.0],
            [30.0 * t, 0.0, 75.0],
        ];
        let lines = [vec![0, 1], vec![2, 1], vec![1, 3], vec![3, 4], vec![3, 5]];
        use Priority::*;
        let sk = skeleton(&v, &lines, &[None, None, None, Conflict, High]);
        let sl = run(&sk, SlicerSettings::default());
        let d = sl.drops();
        let on = |b: usize| d.iter().filter(move |p| p.branch == b);
        // L3 (branch 4) starts first at B.
        let first_l3 = on(4).map(|p| p.index).min().unwrap();
        let first_l2 = on(3).map(|p| p.index).min().unwrap();
        assert!(first_l3 < first_l2);
        let l2 = on(3).next().unwrap();
        assert!((l2.s_mm - 6.0).abs() < 0.05, "{}", l2.s_mm);
        assert_eq!(l2.intersection, Some(Intersection::Divergent));
        let l3_dir = sl.branch(4).at(0.0).1;
        assert!((l2.tool.angle(&l3_dir).to_degrees() - 90.0).abs() < 1e-6);
        // At A one of L1, L4 went through, the other converged with the tool turned 70°.
        let conv: Vec<&Planned> = d
            .iter()
            .filter(|p| p.intersection == Some(Intersection::Convergent))
            .collect();
        assert!(!conv.is_empty());
        assert!(
            conv.iter()
                .all(|p| (p.tool.angle(&p.direction).to_degrees() - 70.0).abs() < 1e-6)
        );
        // Every branch built, L5 after both arrived.
        for b in 0..5 {
            assert!(on(b).count() > 0, "branch {b}");
        }
        let first_l5 = on(2).map(|p| p.index).min().unwrap();
        assert!(on(0).chain(on(1)).all(|p| p.index < first_l5));
    }
}
