//! The laid metal, read from the grid: the voxel at a point, what a deposit lies on (its
//! preheat, read at its support's point), the melt pool behind the torch, the peaks, snapshots
//! and the top surface.

use super::lay::bead_frame;
use super::vec3::{dot, norm, normalize, scale, sub};
use super::{OBSERVED_PER_TASK, VoxelModel};
use crate::run::{PointResult, Snapshot};
use crate::schedule::{Deposit, segment_start};
use rayon::prelude::*;
use rustc_hash::FxHashSet as HashSet;

impl VoxelModel {
    /// The active voxel whose cell holds point `p` (m), if any.
    pub fn voxel_at(&self, p: [f64; 3]) -> Option<u32> {
        let cell: [f64; 3] =
            std::array::from_fn(|k| ((p[k] - self.origin[k]) / self.settings.size).floor());
        if (0..3).any(|k| cell[k] < 0.0 || cell[k] >= self.dims[k] as f64) {
            return None;
        }
        let f = self.flat(cell[0] as usize, cell[1] as usize, cell[2] as usize);
        self.index.get(&f).copied()
    }

    /// The active voxel whose centre is nearest to `p` (m), if one lies within a cell's edge of
    /// it: a point on the part's surface reads the cell beneath the surface.
    pub fn voxel_near(&self, p: [f64; 3]) -> Option<u32> {
        let dx = self.settings.size;
        let cell: [isize; 3] =
            std::array::from_fn(|k| ((p[k] - self.origin[k]) / dx).floor() as isize);
        let mut best: Option<(f64, u32)> = None;
        for oz in -1..=1 {
            for oy in -1..=1 {
                for ox in -1..=1 {
                    let c = [cell[0] + ox, cell[1] + oy, cell[2] + oz];
                    if (0..3).any(|k| c[k] < 0 || c[k] >= self.dims[k] as isize) {
                        continue;
                    }
                    let (ix, iy, iz) = (c[0] as usize, c[1] as usize, c[2] as usize);
                    if let Some(&v) = self.index.get(&self.flat(ix, iy, iz)) {
                        let d = norm(sub(self.centre(ix, iy, iz), p));
                        if d <= dx && best.is_none_or(|b| d < b.0) {
                            best = Some((d, v));
                        }
                    }
                }
            }
        }
        best.map(|b| b.1)
    }

    /// Temperature of voxel v, K.
    pub fn temperature(&self, v: u32) -> f64 {
        self.t[v as usize] as f64
    }

    /// The temperature of what deposit i is laid on (its preheat, read as the torch comes):
    /// its support's metal at the support's point ([`VoxelModel::under_point`]), or the
    /// plate's top at its point ([`VoxelModel::plate_at`]), K.
    pub(super) fn temperature_under(&self, deps: &[Deposit], i: usize) -> f64 {
        let (mut sum, mut weight) = (0.0, 0.0);
        for (v, w) in self.beneath(deps, i) {
            sum += w * self.t[v as usize] as f64;
            weight += w;
        }
        match weight > 0.0 {
            true => sum / weight,
            false => self.settings.surroundings.ambient_k,
        }
    }

    /// The voxels deposit i is laid on, each with its weight: its support's metal at the
    /// support's point, or the plate's top at its point.
    pub(super) fn beneath(&self, deps: &[Deposit], i: usize) -> Vec<(u32, f64)> {
        match deps[i].support {
            Some(s) if !self.laid[s].is_empty() => self.under_point(deps, s),
            // A support that switched on no cell of its own (its segment over cells already
            // laid) lies in the metal of the bead beside it or of the cell there: read as a
            // support with cells is. Its own support, a revolution further down (on a flat
            // crown, also further out and a revolution older), only where no cell lies within a
            // cell of its point (docs/PHYSICS.md "The metal at the support's point").
            Some(s) => match self.under_point(deps, s) {
                along if along.is_empty() => self.beneath(deps, s),
                along => along,
            },
            // On the plate: its top at the point; under the bead's width only where no column
            // lies round the point (at the plate's edge).
            None => match self.plate_at(deps[i].position) {
                at if !at.is_empty() => at,
                _ => self.plate_under(deps, i),
            },
        }
    }

    /// The plate's top under deposit i's bead: the columns within its half width of its point
    /// each alike (a coarse cell once per column it covers).
    fn plate_under(&self, deps: &[Deposit], i: usize) -> Vec<(u32, f64)> {
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
                    out.push((v, 1.0));
                }
            }
        }
        out
    }

    /// The plate's top at `p` (m): the four columns round it, each weighted bilinearly by its
    /// centre's distance from `p` across the plate (a coarse cell once per column it covers).
    pub(super) fn plate_at(&self, p: [f64; 3]) -> Vec<(u32, f64)> {
        let dx = self.settings.size;
        let f = [0, 1].map(|k| (p[k] - self.origin[k]) / dx - 0.5);
        let mut out = Vec::new();
        for oy in 0..2 {
            for ox in 0..2 {
                let c = [f[0].floor() + ox as f64, f[1].floor() + oy as f64];
                if c.iter().any(|&x| x < 0.0) {
                    continue;
                }
                let w = (1.0 - (c[0] - f[0]).abs()) * (1.0 - (c[1] - f[1]).abs());
                match self.plate_top.get(&(c[0] as usize, c[1] as usize)) {
                    Some(&v) if w > 0.0 => out.push((v, w)),
                    _ => {}
                }
            }
        }
        out
    }

    /// The middle of deposit k's settled bead beneath `p`, a point of its path (m): half its
    /// height under its metal's top, which lies `sink` below the path along its build direction.
    pub(super) fn bead_middle(&self, deps: &[Deposit], k: usize, p: [f64; 3]) -> [f64; 3] {
        let d = &deps[k];
        sub(p, scale(d.axis, self.sink[k] + 0.5 * d.height))
    }

    /// The metal at deposit s's point: the voxels of the bead laid along the path within a cell
    /// of the point, on either side (s's own segment behind it, the next ones ahead), each
    /// weighted by 1 − d/dx at its distance d from the point along the path (between two
    /// columns of cells, their temperatures interpolated), and likewise by its distance across
    /// the bead from its centre line and along the build direction from the middle of the bead
    /// that laid it: the bead's core, not its edges. A tilted bead's outer cells stand a layer
    /// up, beside the bead being laid, and read its heat (a head's knuckle: single points 20-27
    /// K over their neighbours; a drop is read along the path alone). Else the cell nearest the bead's
    /// middle at the point (not for a drop), else all of s's own alike (an empty list where s
    /// laid none and no cell lies there). The thin wall reads the node at the point. A
    /// deposit's voxels run its whole segment back towards the torch, which reads preheat
    /// `lead_mm` upstream: where a deposit is half the lead long (the R 100 cylinder's 5.2 mm
    /// chords against 10 mm) its nearest voxels lie some 5 mm from the arc and read the arc's
    /// front, and the mean of a deposit's voxels made the points' preheats alternate by up to
    /// 140 K as their segments took a column of cells more or less (docs/PHYSICS.md "The metal
    /// at the support's point").
    pub(super) fn under_point(&self, deps: &[Deposit], s: usize) -> Vec<(u32, f64)> {
        let p = deps[s].position;
        let dx = self.settings.size;
        let along = normalize(sub(p, segment_start(deps, s)));
        let own = || self.laid[s].iter().map(|&v| (v, 1.0)).collect();
        if !along.iter().all(|x| x.is_finite()) {
            return own();
        }
        // The deposits whose segments reach within a cell of the point along the path: s and
        // those before it while the path back is shorter, those after it likewise; a travel
        // ends the bead (and the walk: at most `WALK` deposits either way, which a path cut
        // into thousandths of a millimetre reaches).
        const WALK: usize = 1024;
        let distance = |a, b| norm(sub(a, b));
        let joined = |k: usize| distance(segment_start(deps, k), deps[k - 1].position) < 1e-9;
        let mut near = vec![s];
        let mut back = 0.0;
        for k in (s.saturating_sub(WALK)..s).rev() {
            back += distance(deps[k + 1].position, segment_start(deps, k + 1));
            if back > dx || !joined(k + 1) {
                break;
            }
            near.push(k);
        }
        let mut ahead = 0.0;
        for k in s + 1..deps.len().min(s + 1 + WALK) {
            if ahead > dx || !joined(k) {
                break;
            }
            near.push(k);
            ahead += distance(deps[k].position, segment_start(deps, k));
        }
        let (_, across, _) = bead_frame(deps, s);
        let drop = deps[s].drop.is_some();
        let out: Vec<(u32, f64)> = near
            .iter()
            .flat_map(|&k| {
                let middle = self.bead_middle(deps, k, p);
                self.laid[k].iter().map(move |&v| (k, middle, v))
            })
            .map(|(k, middle, v)| {
                let c = self.centre_of(v);
                let off = |from: [f64; 3], dir: [f64; 3]| dot(sub(c, from), dir).abs() / dx;
                let w = 1.0 - off(p, along);
                match drop {
                    true => (v, w),
                    false => {
                        let core = (1.0 - off(p, across)).max(0.0)
                            * (1.0 - off(middle, deps[k].axis)).max(0.0);
                        (v, w.max(0.0) * core)
                    }
                }
            })
            .filter(|&(_, w)| w > 0.0)
            .collect();
        if !out.is_empty() {
            return out;
        }
        // No cell of the bead within a cell of the point along the path (s's cells lie back
        // towards the torch, the next deposit laid none): the cell at the bead's middle there,
        // whoever laid it, rather than s's own cells, which read the arc's front as the mean
        // once did (a head's flange read 26-30 K over its neighbours at single points). A
        // skeleton's drop has no bead along a path: its own cells, the drop, as before.
        match self.voxel_near(self.bead_middle(deps, s, p)) {
            Some(v) if deps[s].drop.is_none() => vec![(v, 1.0)],
            _ => own(),
        }
    }

    /// The temperature of deposit i's metal: the mean of its voxels, or of the nearest earlier
    /// deposit's where it switched on none (as the snapshots take it).
    pub(super) fn metal_t(&self, i: usize) -> f64 {
        match self.filled.partition_point(|&j| j as usize <= i) {
            0 => self.settings.surroundings.ambient_k,
            k => self.mean_t(&self.laid[self.filled[k - 1] as usize]),
        }
    }

    /// Active voxels whose centres lie within `radius` of `p` (m), with their distances: the
    /// field a data assimilation corrects around a sensor.
    pub fn voxels_within(&self, p: [f64; 3], radius: f64) -> Vec<(u32, f64)> {
        let dx = self.settings.size;
        let lo: [isize; 3] =
            std::array::from_fn(|k| ((p[k] - radius - self.origin[k]) / dx).floor() as isize);
        let hi: [isize; 3] =
            std::array::from_fn(|k| ((p[k] + radius - self.origin[k]) / dx).ceil() as isize);
        let clamp = |k: usize, x: isize| x.clamp(0, self.dims[k] as isize - 1) as usize;
        let mut out = Vec::new();
        let mut coarse_seen = HashSet::default();
        for iz in clamp(2, lo[2])..=clamp(2, hi[2]) {
            for iy in clamp(1, lo[1])..=clamp(1, hi[1]) {
                for ix in clamp(0, lo[0])..=clamp(0, hi[0]) {
                    let Some(&v) = self.index.get(&self.flat(ix, iy, iz)) else {
                        continue;
                    };
                    // A coarse cell once, at its own centre.
                    let coarse = (v as usize) < self.coarse;
                    if coarse && !coarse_seen.insert(v) {
                        continue;
                    }
                    let c = match coarse {
                        true => self.centre_of(v),
                        false => self.centre(ix, iy, iz),
                    };
                    let d = ((c[0] - p[0]).powi(2) + (c[1] - p[1]).powi(2) + (c[2] - p[2]).powi(2))
                        .sqrt();
                    if d <= radius {
                        out.push((v, d));
                    }
                }
            }
        }
        out
    }

    pub(super) fn mean_t(&self, v: &[u32]) -> f64 {
        if v.is_empty() {
            return self.settings.surroundings.ambient_k;
        }
        v.iter().map(|&i| self.t[i as usize] as f64).sum::<f64>() / v.len() as f64
    }

    /// The active voxels open to the top (no active voxel above), with their centres (m): the
    /// part as seen from above, what a view of its temperature shows.
    pub fn top_surface(&self) -> Vec<(u32, [f64; 3])> {
        (0..self.cell.len() as u32)
            .filter(|&v| {
                let [ix, iy, iz] = self.cell_of(v);
                // A coarse cell's top cells are one up from its corner.
                let iz = iz + usize::from((v as usize) < self.coarse);
                self.open_above(v, [ix, iy, iz])
            })
            .map(|v| (v, self.centre_of(v)))
            .collect()
    }

    /// The centre of voxel v, m.
    pub(super) fn centre_of(&self, v: u32) -> [f64; 3] {
        let [ix, iy, iz] = self.cell_of(v);
        let c = self.centre(ix, iy, iz);
        match (v as usize) < self.coarse {
            // A coarse cell's first cell is its corner.
            true => c.map(|x| x + self.settings.size / 2.0),
            false => c,
        }
    }

    /// Grid indices of voxel v's cell (a coarse cell's corner).
    pub(super) fn cell_of(&self, v: u32) -> [usize; 3] {
        let f = self.cell[v as usize];
        let (nx, ny) = (self.dims[0], self.dims[1]);
        [f % nx, (f / nx) % ny, f / (nx * ny)]
    }

    /// Whether nothing active lies on top of grid cell (ix, iy, iz), which voxel v holds: for a
    /// voxel of edge dx its +z face has no neighbour; a coarse cell is open where the cell
    /// above is inactive (the kernel's neighbour lists do not see seams).
    pub(super) fn open_above(&self, v: u32, [ix, iy, iz]: [usize; 3]) -> bool {
        match (v as usize) < self.coarse {
            true => iz + 1 >= self.dims[2] || !self.index.contains_key(&self.flat(ix, iy, iz + 1)),
            false => self.neighbours[5][v as usize] == v,
        }
    }

    /// Peak and time above the threshold of the metal of deposits 0..laid, after a step of dt.
    /// Returns the hottest laid metal's temperature (NaN before any is laid).
    pub(super) fn observe(&self, laid: usize, dt: f64, points: &mut [PointResult]) -> f64 {
        let hot = self.settings.hot_threshold;
        points[..laid]
            .par_iter_mut()
            .zip(&self.laid[..laid])
            .with_min_len(OBSERVED_PER_TASK)
            .map(|(p, voxels)| {
                if voxels.is_empty() {
                    return f64::NAN;
                }
                let t = self.mean_t(voxels);
                p.peak = p.peak.max(t);
                if t > hot {
                    p.time_above += dt;
                }
                t
            })
            .reduce(|| f64::NAN, f64::max)
    }

    /// Keep the field at the snapshot times reached by `now`, deposits 0..laid laid: per
    /// deposit the mean temperature of its metal (its predecessor's where it has none).
    pub(super) fn keep(&self, laid: usize, now: f64, snapshots: &mut Vec<Snapshot>) {
        let times = &self.settings.snapshot_times;
        while snapshots.len() < times.len() && times[snapshots.len()] <= now + 1e-9 {
            let ambient = self.settings.surroundings.ambient_k;
            let mut temperature = vec![ambient; self.laid.len()];
            for i in 0..laid {
                temperature[i] = match (self.laid[i].is_empty(), i) {
                    (false, _) => self.mean_t(&self.laid[i]),
                    (true, 0) => ambient,
                    (true, _) => temperature[i - 1],
                };
            }
            snapshots.push(Snapshot {
                time: times[snapshots.len()],
                temperature,
            });
        }
    }

    /// The molten bead behind the torch as deposit i is finished: the deposits back from i
    /// whose metal is above the solidus, the tail placed where the solidus falls between the
    /// last molten one and the first solid one ([`crate::pool`]); its length along the path (m),
    /// and the radius of the half sphere of its volume (m). `along`: each deposit's distance
    /// along the path from the first ([`path_lengths`]).
    pub(super) fn pool(&self, deps: &[Deposit], along: &[f64], i: usize) -> (f64, f64) {
        let cell = self.settings.size.powi(3);
        let step = |j: usize| match j {
            0 => 0.0,
            _ => norm(sub(deps[j].position, deps[j - 1].position)),
        };
        // A deposit that added no voxel has no cells of its own: its bead lies in cells that
        // other deposits laid (a layer under a cell's height lays none for a stretch, the
        // cells under it those of the revolution before, which its arc heats). A run of such
        // deposits is read a cell's length of path at a time (found in `along`, so that a path
        // cut into deposits far finer than the voxels, 0.002 mm on 2 mm, does not walk a
        // thousand deposits a cell), each piece at the cell nearest the middle of its beads.
        // Read as a gap between the samples around it, a run of five 5.2 mm deposits on a
        // cylinder of 1.9 mm layers on 2 mm cells made an 88 mm pool (docs/PHYSICS.md "A pool
        // across deposits that laid no cell").
        let dx = self.settings.size;
        // Deposits j down to 0 are still to walk; filled[..k] are the ones at or before j.
        let (mut j, mut k) = (
            i as isize,
            self.filled.partition_point(|&f| f as usize <= i),
        );
        let samples = std::iter::from_fn(|| {
            let at = usize::try_from(j).ok()?;
            if k > 0 && self.filled[k - 1] as usize == at {
                (j, k) = (j - 1, k - 1);
                let laid = &self.laid[at];
                return Some(crate::pool::Sample {
                    t: Some(self.mean_t(laid)),
                    length: step(at),
                    volume: laid.len() as f64 * cell,
                });
            }
            // The run of empty deposits from `at` down to `from`; this piece from `q` to `at`,
            // a cell's length of path (or one deposit, where that is longer).
            let from = k.checked_sub(1).map_or(0, |k| self.filled[k] as usize + 1);
            let q = (from + along[from..=at].partition_point(|&x| x < along[at] - dx)).min(at);
            let before = q.checked_sub(1).map_or(0.0, |b| along[b]);
            j = q as isize - 1;
            let m = (q + at) / 2;
            let (a, b) = (segment_start(deps, m), deps[m].position);
            let middle: [f64; 3] = std::array::from_fn(|c| 0.5 * (a[c] + b[c]));
            let bead = self.bead_middle(deps, m, middle);
            Some(crate::pool::Sample {
                t: self.voxel_near(bead).map(|v| self.temperature(v)),
                length: along[at] - before,
                volume: 0.0,
            })
        });
        let (length, volume) = crate::pool::behind(samples, self.settings.material.solidus);
        (length, (3.0 * volume / (2.0 * std::f64::consts::PI)).cbrt())
    }
}

/// Each deposit's distance along the path from the first, m: the sum of the straight
/// segments between their points (the first at 0), a travel with the arc off included, as the
/// pool's walk measures its steps (`schedule::arc_lengths` leaves travel out).
pub(super) fn path_lengths(deps: &[Deposit]) -> Vec<f64> {
    let mut along = 0.0;
    (0..deps.len())
        .map(|j| {
            if j > 0 {
                along += norm(sub(deps[j].position, deps[j - 1].position));
            }
            along
        })
        .collect()
}
