//! The temperature colour map every sink uses, anchored on what a process engineer reads off a
//! part: blue at ambient, green at the interpass limit, yellow at 600 °C (the metal glows), red
//! at 1200 °C, white at 1500 °C and above (the melt pool). Linear in between. The raw values
//! always travel beside the colours.

pub type Colour = [u8; 4];

/// Anchors above the interpass limit, °C.
const HOT: [(f64, [u8; 3]); 3] = [
    (600.0, [250, 220, 30]),
    (1200.0, [220, 30, 30]),
    (1500.0, [255, 255, 255]),
];
const AMBIENT: [u8; 3] = [40, 60, 200];
const LIMIT: [u8; 3] = [40, 190, 90];
/// Not yet laid.
const NONE: Colour = [128, 128, 128, 0];

pub fn temperature_colour(t_c: f64, ambient_c: f64, interpass_c: f64) -> Colour {
    if !t_c.is_finite() {
        return NONE;
    }
    let mut anchors = vec![
        (ambient_c, AMBIENT),
        (interpass_c.max(ambient_c + 1.0), LIMIT),
    ];
    anchors.extend(HOT.iter().filter(|a| a.0 > interpass_c));
    let rgb = match anchors.windows(2).find(|w| t_c <= w[1].0) {
        _ if t_c <= anchors[0].0 => anchors[0].1,
        Some(w) => {
            let f = (t_c - w[0].0) / (w[1].0 - w[0].0);
            std::array::from_fn(|k| {
                (w[0].1[k] as f64 + f * (w[1].1[k] as f64 - w[0].1[k] as f64)).round() as u8
            })
        }
        None => anchors[anchors.len() - 1].1,
    };
    [rgb[0], rgb[1], rgb[2], 255]
}

#[cfg(test)]
mod tests {
    use super::temperature_colour as c;

    #[test]
    fn anchors_and_interpolation() {
        assert_eq!(c(20.0, 20.0, 200.0), [40, 60, 200, 255]);
        assert_eq!(c(-5.0, 20.0, 200.0), [40, 60, 200, 255]);
        assert_eq!(c(200.0, 20.0, 200.0), [40, 190, 90, 255]);
        assert_eq!(c(110.0, 20.0, 200.0), [40, 125, 145, 255]);
        assert_eq!(c(1200.0, 20.0, 200.0), [220, 30, 30, 255]);
        assert_eq!(c(3000.0, 20.0, 200.0), [255, 255, 255, 255]);
        assert_eq!(c(f64::NAN, 20.0, 200.0)[3], 0);
    }
}
