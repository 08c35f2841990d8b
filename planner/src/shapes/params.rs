//! Each shape's parameters as scenario files name them: the one place that knows which shape
//! takes which, how they are checked, and how large the shape is. A new shape is its variant,
//! its mesh, and a row and an arm here.

use super::Shape;
use std::fmt;

/// The parameters a shape needs, and those it may take (0 where left out).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Signature {
    pub name: &'static str,
    pub needs: &'static [&'static str],
    pub optional: &'static [&'static str],
}

/// Every shape of the library.
pub const SIGNATURES: [Signature; 8] = [
    Signature {
        name: "cylinder",
        needs: &["radius_mm", "height_mm"],
        optional: &[],
    },
    Signature {
        name: "cone_frustum",
        needs: &["radius_mm", "top_radius_mm", "height_mm"],
        optional: &["top_slope_mm"],
    },
    Signature {
        name: "vase",
        needs: &["radius_mm", "height_mm"],
        optional: &["bulge_mm", "top_slope_mm", "top_wave_mm", "top_waves"],
    },
    Signature {
        name: "hemisphere",
        needs: &["radius_mm"],
        optional: &[],
    },
    Signature {
        name: "asymmetric_dome",
        needs: &["radius_mm", "height_mm"],
        optional: &["radius_y_mm", "lean_mm"],
    },
    Signature {
        name: "bottle",
        needs: &["radius_mm", "height_mm", "neck_radius_mm", "neck_height_mm"],
        optional: &[],
    },
    Signature {
        name: "quarter_torus",
        needs: &["bend_radius_mm", "tube_radius_mm"],
        optional: &[],
    },
    Signature {
        name: "disk",
        needs: &["radius_mm"],
        optional: &[],
    },
];

/// Largest needed length, mm.
const MAX_MM: f64 = 100_000.0;

/// Why parameters make no shape; each names the parameter and its value.
#[derive(Debug, Clone, PartialEq)]
pub enum ShapeError {
    Unknown(String),
    Missing {
        shape: &'static str,
        key: &'static str,
    },
    NotTaken {
        shape: &'static str,
        key: String,
        value: f64,
    },
    OutOfRange {
        key: String,
        value: f64,
        expected: String,
    },
}

impl ShapeError {
    /// The parameter it concerns ("shape" for an unknown name).
    pub fn key(&self) -> &str {
        match self {
            ShapeError::Unknown(_) => "shape",
            ShapeError::Missing { key, .. } => key,
            ShapeError::NotTaken { key, .. } | ShapeError::OutOfRange { key, .. } => key,
        }
    }
}

impl fmt::Display for ShapeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            ShapeError::Unknown(name) => {
                let names: Vec<&str> = SIGNATURES.iter().map(|s| s.name).collect();
                write!(
                    f,
                    "shape = \"{name}\"; expected one of {}",
                    names.join(", ")
                )
            }
            ShapeError::Missing { shape, key } => {
                let needs = Shape::signature(shape).map_or(&[][..], |s| s.needs);
                write!(
                    f,
                    "{key} is missing; shape \"{shape}\" needs {}",
                    needs.join(", ")
                )
            }
            ShapeError::NotTaken { shape, key, value } => {
                let s = Shape::signature(shape).expect("a known shape");
                write!(
                    f,
                    "{key} = {value}; expected no {key} for shape \"{shape}\" (it takes {})",
                    [s.needs, s.optional].concat().join(", ")
                )
            }
            ShapeError::OutOfRange {
                key,
                value,
                expected,
            } => write!(f, "{key} = {}; expected {expected}", Typed(*value)),
        }
    }
}

/// A value as a person types it: as written at ordinary sizes, in exponent form where its
/// digits would run on (`1e300`, not three hundred digits).
struct Typed(f64);

impl fmt::Display for Typed {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = self.0;
        match v != 0.0 && v.is_finite() && !(1e-9..1e15).contains(&v.abs()) {
            true => write!(f, "{v:e}"),
            false => write!(f, "{v}"),
        }
    }
}

impl std::error::Error for ShapeError {}

impl Shape {
    pub fn signature(name: &str) -> Option<&'static Signature> {
        SIGNATURES.iter().find(|s| s.name == name)
    }

    /// The shape `name` from its parameters (`given`: each parameter's value, if set).
    pub fn from_params(name: &str, given: &[(&str, Option<f64>)]) -> Result<Shape, ShapeError> {
        let sig = Shape::signature(name).ok_or_else(|| ShapeError::Unknown(name.into()))?;
        for &(key, v) in given {
            if let Some(value) =
                v.filter(|_| !sig.needs.contains(&key) && !sig.optional.contains(&key))
            {
                return Err(ShapeError::NotTaken {
                    shape: sig.name,
                    key: key.into(),
                    value,
                });
            }
        }
        let out_of_range = |key: &str, value: f64, expected: String| ShapeError::OutOfRange {
            key: key.into(),
            value,
            expected,
        };
        let get = |key: &'static str| -> Result<f64, ShapeError> {
            let v = given.iter().find(|(k, _)| *k == key).and_then(|(_, v)| *v);
            match v {
                Some(v) if sig.needs.contains(&key) => {
                    match v.is_finite() && v > 0.0 && v <= MAX_MM {
                        true => Ok(v),
                        false => Err(out_of_range(key, v, format!("a number in (0, {MAX_MM}]"))),
                    }
                }
                Some(v) if v.is_finite() && v.abs() <= MAX_MM => Ok(v),
                Some(v) => Err(out_of_range(key, v, "a finite length".into())),
                None if sig.needs.contains(&key) => Err(ShapeError::Missing {
                    shape: sig.name,
                    key,
                }),
                None => Ok(0.0),
            }
        };
        let shape = match sig.name {
            "cylinder" => Shape::Cylinder {
                radius_mm: get("radius_mm")?,
                height_mm: get("height_mm")?,
            },
            "cone_frustum" => {
                let height_mm = get("height_mm")?;
                let top_slope_mm = get("top_slope_mm")?;
                if top_slope_mm.abs() >= height_mm {
                    return Err(out_of_range(
                        "top_slope_mm",
                        top_slope_mm,
                        format!("smaller than height_mm ({height_mm}) in magnitude"),
                    ));
                }
                Shape::ConeFrustum {
                    radius_mm: get("radius_mm")?,
                    top_radius_mm: get("top_radius_mm")?,
                    height_mm,
                    top_slope_mm,
                }
            }
            "vase" => {
                let (radius_mm, height_mm) = (get("radius_mm")?, get("height_mm")?);
                let (bulge_mm, top_slope_mm, top_wave_mm) =
                    (get("bulge_mm")?, get("top_slope_mm")?, get("top_wave_mm")?);
                let top_waves = get("top_waves")?;
                if bulge_mm.abs() >= radius_mm {
                    return Err(out_of_range(
                        "bulge_mm",
                        bulge_mm,
                        format!("smaller than radius_mm ({radius_mm}) in magnitude"),
                    ));
                }
                if top_slope_mm.abs() + top_wave_mm.abs() >= height_mm {
                    return Err(out_of_range(
                        "top_slope_mm",
                        top_slope_mm,
                        "|top_slope_mm| + |top_wave_mm| below height_mm".into(),
                    ));
                }
                if !(0.0..=1000.0).contains(&top_waves) || top_waves.fract() != 0.0 {
                    return Err(out_of_range(
                        "top_waves",
                        top_waves,
                        "a whole number from 0 to 1000".into(),
                    ));
                }
                Shape::Vase {
                    radius_mm,
                    height_mm,
                    bulge_mm,
                    top_slope_mm,
                    top_wave_mm,
                    top_waves: top_waves as u32,
                }
            }
            "hemisphere" => Shape::Hemisphere {
                radius_mm: get("radius_mm")?,
            },
            "asymmetric_dome" => {
                let radius_mm = get("radius_mm")?;
                let radius_y_mm = match get("radius_y_mm")? {
                    0.0 => radius_mm,
                    v if v > 0.0 => v,
                    v => {
                        return Err(out_of_range(
                            "radius_y_mm",
                            v,
                            "a positive length (left out: radius_mm, a round base)".into(),
                        ));
                    }
                };
                Shape::AsymmetricDome {
                    radius_mm,
                    radius_y_mm,
                    height_mm: get("height_mm")?,
                    lean_mm: get("lean_mm")?,
                }
            }
            "bottle" => {
                let (radius_mm, height_mm) = (get("radius_mm")?, get("height_mm")?);
                let (neck_radius_mm, neck_height_mm) =
                    (get("neck_radius_mm")?, get("neck_height_mm")?);
                if neck_radius_mm >= radius_mm {
                    return Err(out_of_range(
                        "neck_radius_mm",
                        neck_radius_mm,
                        format!("smaller than radius_mm ({radius_mm})"),
                    ));
                }
                let body = height_mm - neck_height_mm - (radius_mm - neck_radius_mm);
                if body <= 0.0 {
                    return Err(out_of_range(
                        "height_mm",
                        height_mm,
                        format!(
                            "more than neck_height_mm + radius_mm − neck_radius_mm ({}), the \
                             neck and the shoulder",
                            neck_height_mm + radius_mm - neck_radius_mm
                        ),
                    ));
                }
                Shape::Bottle {
                    radius_mm,
                    height_mm,
                    neck_radius_mm,
                    neck_height_mm,
                }
            }
            "quarter_torus" => {
                let (big, small) = (get("bend_radius_mm")?, get("tube_radius_mm")?);
                if small >= big {
                    return Err(out_of_range(
                        "tube_radius_mm",
                        small,
                        format!("smaller than bend_radius_mm ({big})"),
                    ));
                }
                Shape::QuarterTorus {
                    bend_radius_mm: big,
                    tube_radius_mm: small,
                }
            }
            _ => Shape::Disk {
                radius_mm: get("radius_mm")?,
            },
        };
        Ok(shape)
    }

    /// The largest dimension of the shape, mm (for mesh-size guards).
    pub fn extent_mm(&self) -> f64 {
        match *self {
            Shape::Cylinder {
                radius_mm,
                height_mm,
            } => (2.0 * radius_mm).max(height_mm),
            Shape::ConeFrustum {
                radius_mm,
                top_radius_mm,
                height_mm,
                top_slope_mm,
            } => (2.0 * radius_mm.max(top_radius_mm)).max(height_mm + top_slope_mm.abs()),
            Shape::Vase {
                radius_mm,
                height_mm,
                bulge_mm,
                top_slope_mm,
                top_wave_mm,
                ..
            } => (2.0 * (radius_mm + bulge_mm.abs()))
                .max(height_mm + top_slope_mm.abs() + top_wave_mm.abs()),
            Shape::Hemisphere { radius_mm } | Shape::Disk { radius_mm } => 2.0 * radius_mm,
            Shape::AsymmetricDome {
                radius_mm,
                radius_y_mm,
                height_mm,
                lean_mm,
            } => (2.0 * radius_mm + lean_mm.abs())
                .max(2.0 * radius_y_mm)
                .max(height_mm),
            Shape::Bottle {
                radius_mm,
                height_mm,
                ..
            } => (2.0 * radius_mm).max(height_mm),
            Shape::QuarterTorus {
                bend_radius_mm,
                tube_radius_mm,
            } => bend_radius_mm + tube_radius_mm,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_signature_makes_its_shape() {
        for sig in SIGNATURES {
            let given: Vec<(&str, Option<f64>)> = sig
                .needs
                .iter()
                .map(|&k| {
                    let small = ["tube_radius_mm", "neck_radius_mm", "neck_height_mm"];
                    // A bottle is taller than its neck and shoulder.
                    let v = match k {
                        _ if small.contains(&k) => 5.0,
                        "height_mm" if sig.name == "bottle" => 40.0,
                        _ => 20.0,
                    };
                    (k, Some(v))
                })
                .collect();
            let shape = Shape::from_params(sig.name, &given).unwrap();
            assert_eq!(shape.name(), sig.name);
            assert!(shape.extent_mm() >= 20.0);
            // Its vertices counted without meshing are the mesh's, at a coarse and a fine edge.
            for edge_mm in [2.5, 0.7] {
                assert_eq!(
                    shape.vertices(edge_mm),
                    shape.mesh(edge_mm).n_vertices(),
                    "{} at {edge_mm} mm",
                    sig.name
                );
            }
        }
    }

    #[test]
    fn parameters_are_checked_by_name() {
        let e = Shape::from_params("hemisphere", &[("radius_mm", None)]).unwrap_err();
        assert_eq!(e.key(), "radius_mm");
        let e = Shape::from_params(
            "hemisphere",
            &[("radius_mm", Some(5.0)), ("height_mm", Some(3.0))],
        )
        .unwrap_err();
        assert_eq!(e.key(), "height_mm");
        assert!(e.to_string().contains("it takes radius_mm"), "{e}");
        let e = Shape::from_params(
            "cylinder",
            &[("radius_mm", Some(-1.0)), ("height_mm", Some(3.0))],
        )
        .unwrap_err();
        assert_eq!(e.key(), "radius_mm");
        assert_eq!(Shape::from_params("cube", &[]).unwrap_err().key(), "shape");
        // A value far out of range as a person writes it, not its three hundred digits.
        let e = Shape::from_params("hemisphere", &[("radius_mm", Some(1e300))]).unwrap_err();
        assert!(
            e.to_string().starts_with("radius_mm = 1e300; expected"),
            "{e}"
        );
    }
}
