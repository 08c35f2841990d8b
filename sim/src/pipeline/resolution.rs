//! Whether the path is fine enough for the thin wall. Its nodes along the bead are the path's
//! deposits (merged where shorter than `node_mm`, never split), and its preheat depends on their
//! length: on the R 200 dome (measure.sh's) the lowest revolutions read 36–40 K above a path of
//! 2.6 mm deposits with 10.5 mm ones, 4–9 K with 5.2 mm ones, the error falling as the square of
//! the length (docs/PHYSICS.md "Resolution along the bead"). Deposits longer than twice
//! `node_mm` are reported, so that a preheat that is the grid's is not taken for the part's.

use thermal::schedule::{Deposit, arc_lengths};

/// The deposits longer than a node should be.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Coarse {
    /// How many are longer than `limit_m`, of `deposits`.
    pub over: usize,
    pub deposits: usize,
    /// The longest, m.
    pub longest_m: f64,
    pub limit_m: f64,
}

impl Coarse {
    /// A warning for the terminal.
    pub fn line(&self) -> String {
        format!(
            "warning: thin wall: {} of {} deposits are longer than {:.1} mm (twice \
             [thermal] node_mm), up to {:.1} mm; each is one node along the bead, and the \
             preheat depends on their length (R 200's lowest revolutions read 36-40 K hot \
             with 10.5 mm deposits, docs/PHYSICS.md \"Resolution along the bead\"): more \
             points ([planner] n_points) refine it",
            self.over,
            self.deposits,
            self.limit_m * 1e3,
            self.longest_m * 1e3
        )
    }
}

/// The deposits of `deps` longer than twice `node_m` (their segments along the path; travels
/// between tracks are not deposits), if more than one in a hundred are: a few long ones (a
/// seam) do not set the preheat of the part.
pub fn coarse_deposits(deps: &[Deposit], node_m: f64) -> Option<Coarse> {
    let s = arc_lengths(deps);
    let limit_m = 2.0 * node_m;
    let lengths = s.windows(2).map(|w| w[1] - w[0]);
    let (over, longest_m) = lengths
        .filter(|&l| l > limit_m)
        .fold((0, 0.0_f64), |(n, m), l| (n + 1, m.max(l)));
    (over * 100 > deps.len()).then_some(Coarse {
        over,
        deposits: deps.len(),
        longest_m,
        limit_m,
    })
}

#[cfg(test)]
mod tests {
    use super::coarse_deposits;
    use thermal::schedule::helix;

    /// A helix of 8 deposits a revolution at R 25 mm (19.1 mm chords) is reported against 3 mm
    /// nodes; one of 40 (3.9 mm) is not.
    #[test]
    fn deposits_longer_than_two_nodes_are_reported() {
        let coarse = helix(0.025, 8, 3, 2e-3, 5e-3, 10e-3, 1700.0);
        let c = coarse_deposits(&coarse, 3e-3).expect("reported");
        assert_eq!((c.over, c.deposits), (23, 24));
        assert!((c.longest_m - 0.0191).abs() < 1e-4, "{}", c.longest_m);
        assert!(c.line().contains("19.1 mm"), "{}", c.line());
        let fine = helix(0.025, 40, 3, 2e-3, 5e-3, 10e-3, 1700.0);
        assert_eq!(coarse_deposits(&fine, 3e-3), None);
    }
}
