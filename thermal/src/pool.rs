//! The melt pool behind the torch, measured along the bead from the models' samples of it (the
//! thin wall's nodes, the voxel model's deposits), its tail placed where the solidus falls
//! between the last molten sample and the first solid one.
//!
//! Counting whole samples above the solidus moves the pool by a whole sample at once: on a
//! large part the thin wall's nodes are up to 10 mm long (R 200), two thirds of the humping
//! limit's 15.7 mm, so a node a fraction of a kelvin either side of the solidus halved or doubled
//! the pool and flipped the humping judgment (docs/PHYSICS.md "The melt pool's tail"). Each
//! sample stands for the stretch of bead centred on it, its temperature taken as the stretch's
//! centre's, and the temperature linear between two centres (the thin wall's own linear elements
//! along the bead); the pool then ends where that line crosses the solidus, and moves
//! continuously with the temperatures. A linear profile is measured exactly (unit test).

/// One sample of the bead behind the torch: its temperature (K; `None` where the model has none
/// of its own, a stretch between the samples around it), the length of bead it stands for
/// (m) and its volume (m³).
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sample {
    pub t: Option<f64>,
    pub length: f64,
    pub volume: f64,
}

/// The molten bead behind the torch: its length (m) and volume (m³), from `samples` taken from
/// the torch backwards along the bead. Zero if the first sample with a temperature is solid;
/// the whole of the samples if none is (the bead's start bounds the pool). A sample with no
/// temperature of its own (the voxel model's deposits that laid no cell where no cell lies near
/// their beads either; those with one read it) is a stretch between the samples around it, the
/// temperature linear across it as between any two centres: molten where it lies before the
/// last molten sample, and cut where the solidus crosses it. Before, every such stretch ahead
/// of the first solid sample was counted molten whole, which read the voxel model's pool longer
/// the coarser its cells against its deposits (docs/PHYSICS.md "The voxel grid against the
/// layer").
pub(crate) fn behind(samples: impl IntoIterator<Item = Sample>, solidus: f64) -> (f64, f64) {
    let (mut length, mut volume) = (0.0, 0.0);
    // The last molten sample with a temperature of its own, and the stretch without one since.
    let mut last: Option<(Sample, f64)> = None;
    let (mut gap, mut gap_volume) = (0.0, 0.0);
    for s in samples {
        match s.t {
            Some(t) if t <= solidus => {
                if let Some((l, tl)) = last {
                    // From the last molten centre to the crossing, across the stretch between
                    // the two centres, in place of its back half.
                    let f = (tl - solidus) / (tl - t);
                    length += f * (0.5 * (l.length + s.length) + gap) - 0.5 * l.length;
                    volume += f * (0.5 * (l.volume + s.volume) + gap_volume) - 0.5 * l.volume;
                }
                return (length, volume);
            }
            Some(t) => {
                length += gap + s.length;
                volume += gap_volume + s.volume;
                (gap, gap_volume) = (0.0, 0.0);
                last = Some((s, t));
            }
            None => {
                gap += s.length;
                gap_volume += s.volume;
            }
        }
    }
    (length + gap, volume + gap_volume)
}

#[cfg(test)]
mod tests {
    use super::{Sample, behind};

    const SOLIDUS: f64 = 1700.0;

    fn samples(temps: &[f64], length: f64) -> Vec<Sample> {
        temps
            .iter()
            .map(|&t| Sample {
                t: Some(t),
                length,
                volume: length * 1e-5,
            })
            .collect()
    }

    /// Temperature falling linearly behind the torch, sampled at the centres of 10 mm nodes: the
    /// pool ends where the line crosses the solidus, wherever that falls.
    #[test]
    fn a_linear_profile_is_measured_exactly() {
        let l = 0.010;
        for crossing in [0.0061, 0.0104, 0.0157, 0.0199, 0.0388] {
            // T(s) = solidus + g·(crossing − s), s from the torch.
            let g = 20_000.0;
            let temps: Vec<f64> = (0..8)
                .map(|k| SOLIDUS + g * (crossing - (k as f64 + 0.5) * l))
                .collect();
            let (length, volume) = behind(samples(&temps, l), SOLIDUS);
            assert!((length - crossing).abs() < 1e-12, "{crossing}: {length}");
            assert!(
                (volume - crossing * 1e-5).abs() < 1e-15,
                "{crossing}: {volume}"
            );
        }
    }

    /// The same line sampled as the voxel model samples it where its cells are longer than the
    /// deposits: a cell's temperature on one deposit, the two or three after it (nearer the
    /// torch) with none of their own. The crossing is still found exactly; counting the
    /// stretches without a temperature molten read these pools 0.8-1.1 mm long.
    #[test]
    fn stretches_without_a_temperature_lie_between_the_centres() {
        let d = 0.001;
        // Deposits of 1 mm from the torch back; every third has a temperature, at its centre.
        for crossing in [0.0043, 0.0071, 0.0102, 0.0188] {
            let g = 20_000.0;
            let s: Vec<Sample> = (0..30)
                .map(|k| Sample {
                    t: (k % 3 == 2).then_some(SOLIDUS + g * (crossing - (k as f64 + 0.5) * d)),
                    length: d,
                    volume: 0.0,
                })
                .collect();
            let (length, _) = behind(s, SOLIDUS);
            // The first sample's stretch starts at the torch: the profile is linear between
            // centres, so the pool ends at the crossing wherever it falls past the first centre.
            assert!((length - crossing).abs() < 1e-12, "{crossing}: {length}");
        }
    }

    /// As the sample at the pool's tail warms through the solidus the pool grows without a jump:
    /// whole samples would move it by a whole node (10 mm) there.
    #[test]
    fn the_pool_grows_continuously_through_the_solidus() {
        let l = 0.010;
        let at = |tail: f64| behind(samples(&[1900.0, 1800.0, tail, 1500.0], l), SOLIDUS).0;
        let mut before = at(1650.0);
        for k in 1..=200 {
            let now = at(1650.0 + k as f64 * 0.5);
            assert!(
                now >= before - 1e-15,
                "shrank at {}",
                1650.0 + k as f64 * 0.5
            );
            assert!(now - before < 0.001, "jumped {} m at {}", now - before, k);
            before = now;
        }
        // Across the solidus: 1 K either side moves it by far less than a node.
        assert!((at(SOLIDUS + 0.5) - at(SOLIDUS - 0.5)).abs() < 0.2e-3);
    }

    /// A solid first sample is no pool; no solid sample, the whole bead behind; a sample with
    /// no temperature of its own is a stretch between the samples around it.
    #[test]
    fn edges() {
        let l = 0.002;
        assert_eq!(behind(samples(&[1600.0, 1900.0], l), SOLIDUS), (0.0, 0.0));
        let (length, _) = behind(samples(&[1900.0, 1800.0], l), SOLIDUS);
        assert!((length - 2.0 * l).abs() < 1e-15);
        let mut s = samples(&[1900.0, 0.0, 1500.0], l);
        s[1].t = None;
        let (length, _) = behind(s, SOLIDUS);
        // The tail interpolated from the last sample with a temperature (1900 K) to 1500 K,
        // across the stretch without one: the centres 2l apart, the crossing at f of it.
        let f = (1900.0 - SOLIDUS) / (1900.0 - 1500.0);
        assert!((length - (0.5 * l + f * 2.0 * l)).abs() < 1e-15, "{length}");
        // With nothing molten ahead of it the stretch is no pool; with nothing solid behind it,
        // the whole bead.
        let mut s = samples(&[0.0, 1500.0], l);
        s[0].t = None;
        assert_eq!(behind(s, SOLIDUS), (0.0, 0.0));
        let mut s = samples(&[1900.0, 0.0], l);
        s[1].t = None;
        let (length, _) = behind(s, SOLIDUS);
        assert!((length - 2.0 * l).abs() < 1e-15, "{length}");
    }
}
