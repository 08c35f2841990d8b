//! Build direction, tool axis and true deposit (CTPP §2.4, Fig. 17–18), and the feasibility
//! criterion (§2.5, Eq.6).
//!
//! At each path point the build direction is b = n × t, with n the surface normal and t the unit
//! direction of travel; it lies in the tangent plane, across the bead. t is the discrete
//! Frenet tangent (from the previous to the next point of the same revolution, the paper's
//! Fig. 22 frame). At the spiral's seam the path climbs to the next revolution over one generator
//! spacing; a revolution's last and first points take the direction of their own revolution's
//! run, so the climb, which near a flat top is a whole layer, does not tilt the bead on either
//! side of it. The deposit d laid along the generator is projected on b: H = d·cos θ, θ the angle
//! between b and the generator. The tool axis (from the deposit to the torch) is b.

use nalgebra::Vector3;

/// Shortest chord over which the direction of travel is taken, mm.
pub const MIN_CHORD_MM: f64 = 1.0;

/// Per path point: tool axis and true deposit.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Oriented {
    pub tool: Vector3<f64>,
    pub deposit_mm: f64,
}

/// `normals[i]` the surface normal, `along[i]` the generator's unit direction (upwards) and
/// `step[i]` the deposit d along it, at each of the path `points`.
pub fn orient(
    points: &[nalgebra::Point3<f64>],
    layers: &[usize],
    normals: &[Vector3<f64>],
    along: &[Vector3<f64>],
    step: &[f64],
) -> Vec<Oriented> {
    let n = points.len();
    let unit = |d: Vector3<f64>| d.try_normalize(1e-9);
    // The direction of travel over at least a chord: where generators converge (a bent tube's
    // inside) neighbouring points can be hundredths of a millimetre apart, mostly along the
    // generators, and their difference says nothing of where the torch goes.
    let chord = |d: Vector3<f64>| (d.norm() >= MIN_CHORD_MM).then(|| d / d.norm());
    let mut last_t = Vector3::x();
    (0..n)
        .map(|i| {
            let same = |j: &usize| layers[*j] == layers[i];
            let ahead = (i + 1..n)
                .take_while(same)
                .map(|j| points[j] - points[i])
                .find_map(chord)
                .or_else(|| {
                    (i + 1..n)
                        .take_while(same)
                        .map(|j| points[j] - points[i])
                        .find_map(unit)
                });
            let behind = (0..i)
                .rev()
                .take_while(same)
                .map(|j| points[i] - points[j])
                .find_map(chord)
                .or_else(|| {
                    (0..i)
                        .rev()
                        .take_while(same)
                        .map(|j| points[i] - points[j])
                        .find_map(unit)
                });
            let t = match (behind, ahead) {
                (Some(a), Some(b)) => unit(a + b).unwrap_or(b),
                (None, Some(t)) | (Some(t), None) => t,
                (None, None) => last_t,
            };
            last_t = t;
            let b = normals[i]
                .cross(&t)
                .try_normalize(1e-12)
                .unwrap_or(along[i]);
            let b = if b.dot(&along[i]) < 0.0 { -b } else { b };
            Oriented {
                tool: b,
                deposit_mm: step[i] * b.dot(&along[i]).clamp(0.0, 1.0),
            }
        })
        .collect()
}

/// A deposit outside the window (Eq.6), located.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Violation {
    pub point: usize,
    pub layer: usize,
    pub generator: usize,
    pub deposit_mm: f64,
    /// The bound it breaks (h_min or h_max).
    pub bound_mm: f64,
}

/// Eq.6: max(H) ≤ h_max and min(H) ≥ h_min, up to `tolerance_mm` (what the process can resolve).
pub fn violations(
    deposit: &[f64],
    layer: &[usize],
    generator: &[usize],
    h_min: f64,
    h_max: f64,
    tolerance_mm: f64,
) -> Vec<Violation> {
    deposit
        .iter()
        .enumerate()
        .filter_map(|(i, &h)| {
            let bound = if h < h_min - tolerance_mm {
                h_min
            } else if h > h_max + tolerance_mm {
                h_max
            } else {
                return None;
            };
            Some(Violation {
                point: i,
                layer: layer[i],
                generator: generator[i],
                deposit_mm: h,
                bound_mm: bound,
            })
        })
        .collect()
}
