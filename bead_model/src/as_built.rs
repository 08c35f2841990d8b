//! Predicted as-built geometry: walk the path and stack the beads. A bead laid on hot metal
//! spreads: it comes out lower and wider for the same wire (the effect seen in WAAM walls built
//! with short interlayer times). The law here is linear in the preheat above a reference, with the
//! area of the section conserved; its coefficient is the scenario's (off by default). The torch
//! follows the plan, so a layer that comes out low leaves the next one further from the contact
//! tip: the stick-out grows by the accumulated height error beneath.

/// Height factor 1 − k·max(0, T − T_ref), floored at `min_factor`; width by area conservation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HotMetalLaw {
    pub reference_k: f64,
    /// k, 1/K.
    pub height_loss_per_k: f64,
    pub min_factor: f64,
}

impl HotMetalLaw {
    pub const OFF: HotMetalLaw = HotMetalLaw {
        reference_k: 293.15,
        height_loss_per_k: 0.0,
        min_factor: 0.5,
    };

    pub fn height_factor(&self, preheat_k: f64) -> f64 {
        (1.0 - self.height_loss_per_k * (preheat_k - self.reference_k).max(0.0))
            .max(self.min_factor)
    }
}

/// One bead as built.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BuiltBead {
    pub height: f64,
    pub width: f64,
    /// Contact tip to work distance when this bead is laid, m.
    pub stickout: f64,
    /// Built minus planned height of the wall at this point after this bead, m.
    pub height_error: f64,
}

/// Stack beads along a path. `generator[i]` says which column point i builds on (the previous
/// bead of the same generator lies beneath it); `planned[i]` its planned height; `preheat_k[i]`
/// the temperature of the metal under it.
pub fn stack(
    planned: &[f64],
    generator: &[usize],
    preheat_k: &[f64],
    width: f64,
    nominal_stickout: f64,
    law: &HotMetalLaw,
) -> Vec<BuiltBead> {
    let columns = generator.iter().max().map_or(0, |g| g + 1);
    let mut error = vec![0.0; columns];
    planned
        .iter()
        .zip(generator)
        .zip(preheat_k)
        .map(|((&h, &g), &t)| {
            let stickout = nominal_stickout - error[g];
            let f = law.height_factor(t);
            let built = h * f;
            error[g] += built - h;
            BuiltBead {
                height: built,
                width: width / f,
                stickout,
                height_error: error[g],
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Made-up preheat history: every bead is laid 300 K above the reference with k = 2e-4/K, so
    /// each comes out 6 % low and 1/0.94 wide; after n layers a column is 0.06·n·h short, and the
    /// stick-out of layer n is the nominal plus the error of the n layers beneath.
    #[test]
    fn height_loss_and_stickout_accumulate_as_the_law_says() {
        let law = HotMetalLaw {
            reference_k: 300.0,
            height_loss_per_k: 2e-4,
            min_factor: 0.5,
        };
        let (columns, layers, h, w, ctwd) = (4, 10, 2e-3, 5e-3, 15e-3);
        let n = columns * layers;
        let generator: Vec<usize> = (0..n).map(|i| i % columns).collect();
        let beads = stack(&vec![h; n], &generator, &vec![600.0; n], w, ctwd, &law);
        for (i, b) in beads.iter().enumerate() {
            let layer = (i / columns) as f64;
            assert!((b.height - 0.94 * h).abs() < 1e-15);
            assert!((b.width - w / 0.94).abs() < 1e-15);
            assert!((b.height * b.width - h * w).abs() < 1e-18, "area conserved");
            assert!(
                (b.stickout - (ctwd + 0.06 * h * layer)).abs() < 1e-15,
                "stick-out at layer {layer}"
            );
            assert!((b.height_error + 0.06 * h * (layer + 1.0)).abs() < 1e-15);
        }
        // Cold metal: no change.
        let cold = stack(&vec![h; n], &generator, &vec![250.0; n], w, ctwd, &law);
        assert!(cold.iter().all(|b| b.height == h && b.stickout == ctwd));
        // The floor holds.
        assert_eq!(law.height_factor(1e6), 0.5);
    }
}
