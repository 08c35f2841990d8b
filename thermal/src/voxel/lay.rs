//! The bead's cells: where each deposit settles on what it lies on (`settle`), and which cells
//! of the grid its bead switches on (a segment of the path, a spot, or a column where the torch
//! climbs along its own axis).

use super::vec3::{cross, dot, norm, normalize, perpendicular, scale, sub};
use super::{FACE_NORMALS, VoxelModel};
use crate::schedule::{Deposit, segment_start};

impl VoxelModel {
    /// Switch on the voxels of deposit i's bead: centres within W/2 across, between what it lies
    /// on and its top (`settle`) along the build direction, and along the segment from the
    /// previous point.
    pub(super) fn lay(&mut self, deps: &[Deposit], i: usize) {
        self.lay_scanning(deps, i, true);
    }

    /// [`Self::lay`], looking through the whole cube round the deposit unless `cut` (the
    /// reference its scan range is tested against).
    pub(super) fn lay_scanning(&mut self, deps: &[Deposit], i: usize, cut: bool) {
        self.runs.forget_from(i);
        let d = &deps[i];
        let prev = segment_start(deps, i);
        let dx = self.settings.size;
        let axis = d.axis;
        let len = norm(sub(d.position, prev));
        let (tangent, across, spot) = bead_frame(deps, i);
        let (below, sink) = (self.below[i], self.sink[i]);
        // A face's share of the bead's surface where the cell beyond it is neither off the
        // bead's side nor above its top (an end along the path; a column's or a spot's faces).
        let weights =
            FACE_NORMALS.map(|n| (dot(n, across).abs() + dot(n, axis).abs()).min(1.0) as f32);
        // The bead's thickness along its normal (across both the travel and `across`): the
        // height window's reach there where the travel is square to the axis, a column W wide
        // where the torch climbs along its own axis and the window bounds only the travel.
        let normal = cross(tangent, across);
        let sin = dot(axis, normal).abs();
        let thick = d.width + 2.0 * below.abs().max(sink.abs()) * sin;
        // A column (`column_growth`) stands under the path point, W wide across the axis both
        // ways, its height window alone bounding it along the axis.
        let column = column_growth(deps, i).map(|_| cross(axis, across));
        let (lo, hi) = match column {
            Some(side) if cut => self.column_range(d, (across, side), (below, sink)),
            _ => self.scan_range(d, (prev, len), (tangent, across), (below, sink), cut),
        };
        for iz in lo[2]..=hi[2] {
            for iy in lo[1]..=hi[1] {
                for ix in lo[0]..=hi[0] {
                    let c = self.centre(ix, iy, iz);
                    if c[2] < 0.0 {
                        continue;
                    }
                    let r = sub(c, prev);
                    let (s_along, s_up, s_across, s_normal) = (
                        dot(r, tangent),
                        dot(sub(c, d.position), axis),
                        dot(r, across),
                        dot(r, normal),
                    );
                    // Along the segment with half a voxel to spare (a curved path's chords
                    // would leave gaps at the outside of each bend; a voxel taken twice is laid
                    // by the first). Up: the centre between what the bead lies on and its own
                    // top, a centre on the top going to the bead above (with slack there,
                    // rounding laid part of the next layer one revolution early).
                    // Both ends inclusive within rounding: a centre exactly half a voxel past
                    // either end is taken (rounding took it at the start, dropped it at the
                    // end, and a pad as long as its plate came out a row short).
                    let eps = 1e-6 * dx;
                    let inside = match (column, spot) {
                        (Some(side), _) => {
                            let r = sub(c, d.position);
                            across_bead(dot(r, across), d.width, dx)
                                && across_bead(dot(r, side), d.width, dx)
                        }
                        (None, false) => {
                            s_along >= -dx / 2.0 - eps
                                && s_along <= len + dx / 2.0 + eps
                                && across_bead(s_across, d.width, dx)
                                && across_bead(s_normal, thick, dx)
                        }
                        (None, true) => {
                            across_bead(s_along, d.width, dx)
                                && across_bead(s_across, d.width, dx)
                                && across_bead(s_normal, thick, dx)
                        }
                    };
                    if inside && s_up <= -sink - eps && s_up > -below - eps {
                        let before = self.cell.len();
                        let temp = self.settings.deposit_temperature;
                        let weights = match (column, spot) {
                            (None, false) => surface_weights(
                                weights,
                                (across, axis),
                                (s_across, s_up),
                                (d.width, sink),
                                dx,
                            ),
                            _ => weights,
                        };
                        let v = self.add([ix, iy, iz], temp, weights, false);
                        if self.cell.len() > before {
                            self.laid[i].push(v);
                            if self.filled.last() != Some(&(i as u32)) {
                                self.filled.push(i as u32);
                            }
                        }
                    }
                }
            }
        }
    }

    /// The cells [`Self::lay`] looks at, as index ranges: the cube round the deposit as wide as
    /// its reach (width or support, and its length), cut (`cut`) to the box round the bead's
    /// own segment where that is tighter. Every cell the deposit takes lies in that box: half a
    /// voxel past either end along the segment (`prev` to the deposit, `len` long), half the
    /// width across it, and along the normal within the height window over the axis's angle
    /// to the tangent and within the bead's thickness; a voxel's margin takes rounding. Where
    /// the deposit is no longer than a voxel the cube alone bounds what it takes. A deposit
    /// much longer than a voxel (`deposit_mm` 100 on 2 mm voxels) scanned a cube as wide as it
    /// is long, the run spending 98.6 % of its time here. A column has its own range
    /// ([`Self::column_range`]).
    pub(super) fn scan_range(
        &self,
        d: &Deposit,
        (prev, len): ([f64; 3], f64),
        (tangent, across): ([f64; 3], [f64; 3]),
        (below, sink): (f64, f64),
        cut: bool,
    ) -> ([usize; 3], [usize; 3]) {
        let dx = self.settings.size;
        let reach = d.width.max(below) + len + dx;
        let index = |x: f64, k: usize| (x - self.origin[k]) / dx;
        let mut lo: [usize; 3] =
            std::array::from_fn(|k| index(d.position[k] - reach, k).floor().max(0.0) as usize);
        let mut hi: [usize; 3] = std::array::from_fn(|k| {
            (index(d.position[k] + reach, k).ceil() as usize).min(self.dims[k] - 1)
        });
        // The axis in the plane of the tangent and the normal: the height window bounds a
        // cell's offset along the normal by its span over the axis's sine (unbounded as the
        // axis nears the tangent), and the bead's thickness (`lay`) by W/2 and the window's
        // share there.
        let normal = cross(tangent, across);
        let (cos, sin) = (dot(d.axis, tangent).abs(), dot(d.axis, normal).abs());
        if cut && len > dx {
            let along = len / 2.0 + dx / 2.0;
            let half_across = (d.width / 2.0).max(dx / 2.0);
            let up = below.abs().max(sink.abs());
            let window = match sin > 1e-9 {
                true => (up + (len + dx / 2.0) * cos) / sin,
                false => f64::INFINITY,
            };
            let out = window.min((d.width / 2.0 + up * sin).max(dx / 2.0));
            for k in 0..3 {
                let centre = prev[k] + tangent[k] * len / 2.0;
                let half = tangent[k].abs() * along
                    + across[k].abs() * half_across
                    + normal[k].abs() * out
                    + dx;
                lo[k] = lo[k].max(index(centre - half, k).floor().max(0.0) as usize);
                hi[k] = hi[k].min(index(centre + half, k).ceil() as usize);
            }
        }
        (lo, hi)
    }

    /// The cells a column (`column_growth`) may take, as index ranges: the box round its
    /// height window under the path point, half its width across the axis each way (`sides`)
    /// and a voxel's margin. Its window may lie far below a torch that outruns it, where the
    /// cube round the segment would have to reach.
    pub(super) fn column_range(
        &self,
        d: &Deposit,
        sides: ([f64; 3], [f64; 3]),
        (below, sink): (f64, f64),
    ) -> ([usize; 3], [usize; 3]) {
        let dx = self.settings.size;
        let centre = sub(d.position, scale(d.axis, (below + sink) / 2.0));
        let half_width = (d.width / 2.0).max(dx / 2.0);
        let index = |x: f64, k: usize| (x - self.origin[k]) / dx;
        let half = |k: usize| {
            d.axis[k].abs() * (below - sink).abs() / 2.0
                + (sides.0[k].abs() + sides.1[k].abs()) * half_width
                + dx
        };
        let lo = std::array::from_fn(|k| index(centre[k] - half(k), k).floor().max(0.0) as usize);
        let hi = std::array::from_fn(|k| {
            (index(centre[k] + half(k), k).ceil().max(0.0) as usize).min(self.dims[k] - 1)
        });
        (lo, hi)
    }

    /// Lay every deposit at once (no heat): the finished part, for timing the kernel.
    pub fn lay_all(&mut self, deps: &[Deposit]) {
        for i in 0..deps.len() {
            self.lay(deps, i);
        }
    }
}

/// Each face's share of its area that is the bead's surface, for a cell of a bead at
/// `s_across` off its centre line and `s_up` along the axis from its top (m), by the surface the
/// cell beyond the face lies outside of: off the bead's side (across it, `width` wide), the
/// side's normal `across` projected on the face's; above its top (the height window's `sink`),
/// the axis projected on it; neither (an end along the path), `weights`' share. A staircase of
/// cell faces on a flat surface of normal n exposes faces of normal e_k at |n·e_k| of its area
/// each, so these weights sum to the surface's own area. Before, every face took |e·across| +
/// |e·axis| (at most 1), which is right where the axis is a grid axis (the upright walls of the
/// measured builds, to the bit), but on a wall leaning 26° counted its sides 1.44 times
/// (`voxel::tests::a_leaning_walls_sides_expose_their_own_area`; docs/PHYSICS.md "A leaning
/// wall's faces").
pub(super) fn surface_weights(
    weights: [f32; 6],
    (across, axis): ([f64; 3], [f64; 3]),
    (s_across, s_up): (f64, f64),
    (width, sink): (f64, f64),
    dx: f64,
) -> [f32; 6] {
    let eps = 1e-6 * dx;
    std::array::from_fn(|f| {
        // Outward: the faces run −x, +x, −y, +y, −z, +z.
        let sign = if f % 2 == 0 { -1.0 } else { 1.0 };
        let e = FACE_NORMALS[f].map(|x| sign * x);
        let (a, u) = (dot(e, across), dot(e, axis));
        if !across_bead(s_across + dx * a, width, dx) {
            a.abs() as f32
        } else if s_up + dx * u > -sink + eps {
            u.abs() as f32
        } else {
            weights[f]
        }
    })
}

/// Whether a voxel centre `s_across` (m) off a bead's centre line lies across the bead of
/// `width` on voxels of `dx`: within W/2. A bead no wider than a voxel takes the one column of
/// centres within half a voxel, half-open so that a centre line on a cell boundary takes one
/// column, not none (at 2 mm voxels the GAMMA wall's 2 mm bead had its centres at exactly ±W/2,
/// which rounding dropped both ways, and the wall was never laid) nor two.
pub(super) fn across_bead(s_across: f64, width: f64, dx: f64) -> bool {
    if width > dx {
        return s_across.abs() <= width / 2.0;
    }
    let (half, eps) = (dx / 2.0, 1e-6 * dx);
    s_across > -half + eps && s_across <= half + eps
}

/// Deposit i's bead frame: the direction it runs and the direction across it, and whether it
/// is a spot. Along its segment; a deposit with no segment (a path's first point, a torch
/// standing) along the way the path goes on across the torch (the next deposit's direction less
/// its part along the axis, where that deposit continues this one), so that the bead starts
/// there W wide; where nothing goes on across the torch (a strut's foot), across the axis and a
/// spot, W wide every way. Across: square to the travel and the axis, or, where the torch
/// climbs along its own axis and the two give none, any direction square to the travel (the
/// bead is then a column, as wide every way across it: `lay`'s thickness).
pub(super) fn bead_frame(deps: &[Deposit], i: usize) -> ([f64; 3], [f64; 3], bool) {
    let d = &deps[i];
    let run = |k: usize| {
        let seg = sub(deps[k].position, segment_start(deps, k));
        (norm(seg) > 1e-12).then(|| normalize(seg))
    };
    let (tangent, spot) = match run(i) {
        Some(t) => (t, false),
        None => {
            let next = match deps.get(i + 1) {
                Some(n) if n.start.is_none() => run(i + 1),
                _ => None,
            };
            match next.map(|t| sub(t, scale(d.axis, dot(t, d.axis)))) {
                Some(t) if norm(t) > 1e-6 => (normalize(t), false),
                _ => (perpendicular(d.axis), true),
            }
        }
    };
    let across = cross(d.axis, tangent);
    let across = match norm(across) > 1e-9 {
        true => normalize(across),
        false => perpendicular(tangent),
    };
    (tangent, across, spot)
}

/// Where each deposit's metal settles. The path point is where the torch is; the molten bead
/// lies on what is beneath it, H thick. Per deposit, along its build direction down from the
/// path point: `below`, the distance to the top of what it lies on (its support's settled top,
/// or the plate), and `sink`, the distance to its own settled top, max(0, below − H). A helix
/// rising off a flat plate (its first revolution a layer higher at its end than at its start)
/// lays its first revolution on the plate, as the thin-wall model does, and every later one on
/// the one before; a path whose layers follow its supports has sink 0 throughout.
pub(super) fn settle(deps: &[Deposit]) -> (Vec<f64>, Vec<f64>) {
    let (mut below, mut sink) = (
        Vec::with_capacity(deps.len()),
        Vec::with_capacity(deps.len()),
    );
    for (i, d) in deps.iter().enumerate() {
        let growth = column_growth(deps, i);
        // A column grows on the metal its torch climbed from, however far behind it lags (a
        // logged path's supports are looked for within a layer of the path point).
        let support = match (d.support, growth) {
            (None, Some(_)) if i > 0 && d.start.is_none() => Some(i - 1),
            (support, _) => support,
        };
        let b = match support {
            Some(s) => dot(sub(d.position, deps[s].position), d.axis) + sink[s],
            None => d.position[2] / d.axis[2].max(0.1),
        };
        below.push(b);
        sink.push((b - growth.unwrap_or(d.height)).max(0.0));
    }
    (below, sink)
}

/// How far deposit i's metal rises along its axis where its torch climbs along that axis (its
/// segment within 26° of it: the cosine over 0.9), None elsewhere. Its bead is then a column W
/// wide every way across the axis, under the path point, fed the metal any bead of its width W
/// and height H gets over its length L (W·H·L: the wire's, whatever the way it runs), so that
/// it grows H·L/W and falls behind a torch that climbs faster, as a strut does whose torch
/// outruns its wire. A bead laid across the axis grows H whatever its length.
///
/// The torch climbs from the metal under it: a deposit laid on an earlier pass (a plan's point
/// on the revolution under it) is a bead of height H however its segment runs. Where a plan's
/// generators converge (a square dome's seam on its flat top, its points a few hundredths of a
/// millimetre apart, its step to the next revolution along its inward build direction), such
/// steps were taken as climbs, and each revolution's metal settled further back along the
/// axis, until beads were laid 20–46 mm behind their points, in the air (docs/PHYSICS.md
/// "Points bunched where generators converge").
pub(super) fn column_growth(deps: &[Deposit], i: usize) -> Option<f64> {
    let d = &deps[i];
    let seg = sub(d.position, segment_start(deps, i));
    let len = norm(seg);
    (len > 1e-12 && dot(seg, d.axis).abs() > 0.9 * len && climbs_from_support(deps, i))
        .then(|| d.height * len / d.width)
}

/// Whether deposit i's torch reached it from its support along a straight climb: the path
/// between them no longer than twice their distance and a bead width, as a strut's is (its
/// support the deposit before it, or a few back where it is logged in steps under a layer),
/// where a revolution laid on the one under it went round the part in between. Walks back at
/// most until the path passes that length.
pub(super) fn climbs_from_support(deps: &[Deposit], i: usize) -> bool {
    let Some(s) = deps[i].support else {
        return true;
    };
    let limit = 2.0 * norm(sub(deps[i].position, deps[s].position)) + deps[i].width;
    let mut path = 0.0;
    for k in (s + 1..=i).rev() {
        path += norm(sub(deps[k].position, segment_start(deps, k)));
        if path > limit {
            return false;
        }
    }
    true
}
