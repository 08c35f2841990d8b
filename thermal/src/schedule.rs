//! The deposition schedule: what the thermal models take. Where and when the torch lays metal,
//! how much, and how much heat enters the part; nothing about generators, layers or files.

use crate::error::ThermalError;

/// One deposit, in path order. SI units.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Deposit {
    /// Where the bead segment ends (the path point), m.
    pub position: [f64; 3],
    /// When the torch reaches it, s. A dwell before it lies in [previous time, time − arc_time].
    pub time: f64,
    /// How long the arc burns to lay this segment, s.
    pub arc_time: f64,
    /// Heat entering the part over the segment (η·P·arc_time), J.
    pub heat: f64,
    pub width: f64,
    pub height: f64,
    /// Build direction (unit): the bead's height runs along it, from the deposit beneath.
    pub axis: [f64; 3],
    /// The deposit this one is laid on, or `None` for the substrate plate.
    pub support: Option<usize>,
    /// Where its bead segment begins when it does not continue the previous deposit (a new
    /// track after a travel move with the arc off); `None` on a continuous path.
    pub start: Option<[f64; 3]>,
    /// Laid as part of a drop ([`DropPart`]); `None` on a running torch.
    pub drop: Option<DropPart>,
}

/// A deposit laid as part of a drop, as skeleton arc AM lays its nodes (Radel et al. 2019): the
/// torch stands while the arc melts the drop's wire, and the drop's metal lands on the part as it
/// was when the arc struck. Its preheat is read then, on the metal beneath it, not `lead`
/// upstream of a torch that does not run; a wait before the strike (a dwell) acts on it whatever
/// it lies on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum DropPart {
    /// The arc strikes here, after the wait before it, for a drop of this deposit and the
    /// `deposits − 1` after it.
    Strikes { deposits: usize },
    /// The drop struck before goes on.
    Continues,
}

/// The preheats of a drop struck at deposit i over `deposits` deposits, read as it strikes: each
/// one's metal beneath when that lies outside the drop, else (it lies on the drop's own metal)
/// the strike point's. `beneath(k)` is the temperature now beneath deposit k.
pub fn strike_readings(
    deps: &[Deposit],
    i: usize,
    deposits: usize,
    beneath: impl Fn(usize) -> f64,
) -> Vec<(usize, f64)> {
    let own = beneath(i);
    (i..(i + deposits.max(1)).min(deps.len()))
        .map(|k| match deps[k].support {
            Some(s) if s >= i => (k, own),
            _ => (k, beneath(k)),
        })
        .collect()
}

impl Deposit {
    pub fn arc_start(&self) -> f64 {
        self.time - self.arc_time
    }
}

/// Where deposit i's bead segment begins: its own `start`, else the previous deposit's end
/// (the first deposit of a path is a segment of no length).
pub fn segment_start(deps: &[Deposit], i: usize) -> [f64; 3] {
    match (deps[i].start, i) {
        (Some(p), _) => p,
        (None, 0) => deps[0].position,
        (None, _) => deps[i - 1].position,
    }
}

/// Checks the schedule: times increase, arc times fit, sizes positive and finite, supports
/// earlier.
pub fn validate(deposits: &[Deposit]) -> Result<(), ThermalError> {
    let bad = |deposit: usize, reason: String| Err(ThermalError::Schedule { deposit, reason });
    let mut previous = f64::NEG_INFINITY;
    for (i, d) in deposits.iter().enumerate() {
        if !d.position.iter().all(|x| x.is_finite()) || !d.time.is_finite() {
            return bad(
                i,
                format!(
                    "position {:?} m at {} s; expected finite numbers",
                    d.position, d.time
                ),
            );
        }
        if !(d.arc_time >= 0.0 && d.arc_start() >= previous - 1e-9) {
            return bad(
                i,
                format!(
                    "arc starts at {} s, before the previous deposit ends ({previous} s)",
                    d.arc_start()
                ),
            );
        }
        if !(d.width > 0.0 && d.height > 0.0 && d.heat >= 0.0 && d.heat.is_finite()) {
            return bad(
                i,
                format!(
                    "width {} m, height {} m, heat {} J; expected positive and finite",
                    d.width, d.height, d.heat
                ),
            );
        }
        if let Some(s) = d.support
            && s >= i
        {
            return bad(i, format!("laid on deposit {s}, which comes later"));
        }
        previous = d.time;
    }
    Ok(())
}

/// Per deposit, the deposit during whose arc the torch passes `lead` upstream of it (`None`:
/// before the path starts).
pub fn read_points(deps: &[Deposit], lead: f64) -> Vec<Option<usize>> {
    read_fractions(deps, lead)
        .into_iter()
        .map(|r| r.map(|(j, _)| j))
        .collect()
}

/// [`read_points`] with the fraction of that deposit's segment (and so of its arc time) at
/// which the torch is exactly `lead` upstream: the reading is interpolated there, as the
/// interface defines it, not taken at the arc's end (which would put it up to one point
/// spacing closer to the arc, by how the spacing happens to fall). A drop's reading is taken
/// again as its arc strikes ([`DropPart`]).
pub fn read_fractions(deps: &[Deposit], lead: f64) -> Vec<Option<(usize, f64)>> {
    let s = arc_lengths(deps);
    (0..deps.len())
        .map(|i| {
            let target = s[i] - lead;
            (target >= 0.0).then(|| {
                let j = s.partition_point(|&x| x < target).min(i);
                let f = if j == 0 {
                    1.0
                } else {
                    ((target - s[j - 1]) / (s[j] - s[j - 1]).max(1e-12)).clamp(0.0, 1.0)
                };
                (j, f)
            })
        })
        .collect()
}

/// Where the torch is when it is at `fraction` of deposit `j`'s segment (a reading moment of
/// [`read_fractions`]), m.
pub fn torch_at(deps: &[Deposit], j: usize, fraction: f64) -> [f64; 3] {
    let (a, b) = (segment_start(deps, j), deps[j].position);
    std::array::from_fn(|k| a[k] + fraction * (b[k] - a[k]))
}

/// Per deposit, whether the metal it lies on counts as just laid when its preheat is read
/// (`reads`, as [`read_fractions`] gives them): laid during or after the reading deposit, or
/// within `reach(i)` of the torch at that moment. There the reading is the arc's own heat and
/// no dwell can come between the metal and the point laid on it.
///
/// The torch is where the reading puts it, inside the reading deposit's segment, not at that
/// segment's end: at a revolution's seam the end of the deposit being laid lies beside the
/// revolution's first point, whose metal is a revolution old. Judged by that end, the first point
/// of every revolution of an elliptic leaning dome was "just laid", and the dwell planner laid
/// the whole part as drops from its second revolution on (issue 27).
pub fn just_laid(
    deps: &[Deposit],
    reads: &[Option<(usize, f64)>],
    reach: impl Fn(usize) -> f64,
) -> Vec<bool> {
    (0..deps.len())
        .map(|i| match (deps[i].support, reads[i]) {
            (Some(s), Some((r, f))) => {
                s >= r || distance(deps[s].position, torch_at(deps, r, f)) < reach(i)
            }
            _ => false,
        })
        .collect()
}

/// The metal the path's beads hold, m³: each deposit's width × height × its segment (the
/// wire's metal, what the voxel model lays: `Cells::Voxel::metal_m3`).
pub fn bead_volume(deps: &[Deposit]) -> f64 {
    (0..deps.len())
        .map(|i| {
            let d = &deps[i];
            d.width * d.height * distance(d.position, segment_start(deps, i))
        })
        .sum()
}

/// Length of deposited path at each deposit, m.
pub fn arc_lengths(deps: &[Deposit]) -> Vec<f64> {
    let mut s = vec![0.0; deps.len()];
    for i in 1..deps.len() {
        // Travel with the arc off is not deposited path: a track starts where its bead does.
        s[i] = s[i - 1] + distance(deps[i].position, segment_start(deps, i));
    }
    s
}

fn distance(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// A helical wall on the plate: `per_revolution` deposits a revolution of radius `r`, each
/// revolution `height` higher, bead `width`, travel `speed`, heat entering at `heat_rate` (η·P,
/// W). The simplest schedule, for verification and benchmarks.
pub fn helix(
    r: f64,
    per_revolution: usize,
    revolutions: usize,
    height: f64,
    width: f64,
    speed: f64,
    heat_rate: f64,
) -> Vec<Deposit> {
    let n = per_revolution;
    let dt = 2.0 * std::f64::consts::PI * r / n as f64 / speed;
    (0..n * revolutions)
        .map(|i| {
            let th = 2.0 * std::f64::consts::PI * i as f64 / n as f64;
            Deposit {
                position: [
                    r * th.cos(),
                    r * th.sin(),
                    height * (1.0 + i as f64 / n as f64),
                ],
                time: (i + 1) as f64 * dt,
                arc_time: dt,
                heat: heat_rate * dt,
                width,
                height,
                axis: [0.0, 0.0, 1.0],
                support: (i >= n).then(|| i - n),
                start: None,
                drop: None,
            }
        })
        .collect()
}
