//! The part seated on the plate. Both heat models lay the plate's top at z = 0 and take the
//! first revolution as laid on it, and the planner builds up from the part's lower boundary
//! (CTPP §2.2: the lower boundary lies on the substrate). A mesh drawn elsewhere, on its side,
//! or in another unit would still plan, and the thin wall would heat it as if it stood on the
//! plate while the voxel model laid part of its metal and its heat (a dome drawn 250 mm up: two
//! thirds of its metal, half its heat): both answers wrong, neither saying so. So a part is
//! taken only where it stands on z = 0, within half a layer (docs/PHYSICS.md "The part on the
//! plate").

use planner::mesh::Part;
use std::fmt;

/// Why a part does not stand on the plate, with the evidence (mm).
#[derive(Debug, Clone, PartialEq)]
pub enum Unseated {
    /// The part is less than a layer tall: nothing could be built of it.
    Tiny { height_mm: f64, layer_mm: f64 },
    /// The lower boundary is not level: its points span more than the tolerance twice over.
    Tilted {
        loop_index: usize,
        z_min_mm: f64,
        z_max_mm: f64,
        tolerance_mm: f64,
    },
    /// The lower boundary is level, away from the plate's top.
    Raised {
        z_min_mm: f64,
        z_max_mm: f64,
        z_mean_mm: f64,
        tolerance_mm: f64,
    },
    /// The part reaches below the plate's top.
    Below {
        vertex: usize,
        position_mm: [f64; 3],
        tolerance_mm: f64,
    },
}

impl fmt::Display for Unseated {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Unseated::Tiny {
                height_mm,
                layer_mm,
            } => write!(
                f,
                "part: it is {height_mm:.3} mm tall (its top above its lower boundary), less than one layer ({layer_mm} mm); expected a part at least a layer tall, in mm (a mesh file drawn in other units takes [part] mesh_unit = \"m\", \"cm\" or \"in\")"
            ),
            Unseated::Tilted {
                loop_index,
                z_min_mm,
                z_max_mm,
                tolerance_mm,
            } => write!(
                f,
                "part: its lower boundary (loop {loop_index}) is not level: its z runs from {z_min_mm:.2} to {z_max_mm:.2} mm; expected it flat on the plate's top, z = 0, within {tolerance_mm} mm (half a layer): stand the part on its lower boundary with z up (`waamtwin inspect` lists the mesh's loops; [part] lower_loop picks another)"
            ),
            Unseated::Raised {
                z_min_mm,
                z_max_mm,
                z_mean_mm,
                tolerance_mm,
            } => write!(
                f,
                "part: its lower boundary lies at z = {z_mean_mm:.2} mm ({z_min_mm:.2} to {z_max_mm:.2}), where the plate's top is z = 0; expected it within {tolerance_mm} mm (half a layer) of z = 0: [part] offset_mm = [0, 0, {:.2}] moves it there (the path and the programs are then in the moved frame)",
                -z_mean_mm
            ),
            Unseated::Below {
                vertex,
                position_mm: [x, y, z],
                tolerance_mm,
            } => write!(
                f,
                "part: vertex {vertex} at ({x:.2}, {y:.2}, {z:.2}) mm lies below the plate's top, z = 0; expected every vertex at z ≥ -{tolerance_mm} mm (half a layer): a part is built up from its lower boundary on the plate"
            ),
        }
    }
}

impl std::error::Error for Unseated {}

/// Whether `part` stands on the plate: its lower boundary within half of a `layer_mm` of z = 0,
/// no vertex below that, and the part at least a layer tall.
pub fn check(part: &Part, layer_mm: f64) -> Result<(), Unseated> {
    let tolerance_mm = layer_mm / 2.0;
    let z = |v: u32| part.mesh.positions[v as usize].z;
    let lower = part.lower_loop();
    let (z_min_mm, z_max_mm) = planner::plan::range(lower.vertices.iter().map(|&v| z(v)));
    let top = planner::plan::range(part.mesh.positions.iter().map(|p| p.z)).1;
    if top - z_min_mm < layer_mm {
        return Err(Unseated::Tiny {
            height_mm: top - z_min_mm,
            layer_mm,
        });
    }
    if z_max_mm - z_min_mm > 2.0 * tolerance_mm {
        return Err(Unseated::Tilted {
            loop_index: part.lower,
            z_min_mm,
            z_max_mm,
            tolerance_mm,
        });
    }
    if z_min_mm < -tolerance_mm || z_max_mm > tolerance_mm {
        return Err(Unseated::Raised {
            z_min_mm,
            z_max_mm,
            z_mean_mm: lower.mean_z,
            tolerance_mm,
        });
    }
    let lowest = (0..part.mesh.positions.len())
        .min_by(|&a, &b| {
            part.mesh.positions[a]
                .z
                .total_cmp(&part.mesh.positions[b].z)
        })
        .expect("a part has vertices");
    let p = part.mesh.positions[lowest];
    if p.z < -tolerance_mm {
        return Err(Unseated::Below {
            vertex: lowest,
            position_mm: [p.x, p.y, p.z],
            tolerance_mm,
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use planner::mesh::LowerLoop;
    use planner::shapes::Shape;

    fn dome_moved(f: impl Fn(nalgebra::Point3<f64>) -> nalgebra::Point3<f64>) -> Part {
        let mut mesh = Shape::Hemisphere { radius_mm: 20.0 }.mesh(2.0);
        mesh.map_positions(f);
        Part::from_mesh(mesh, LowerLoop::default()).unwrap()
    }

    /// A dome on the plate is taken; the same dome raised, tilted, laid on its side or drawn in
    /// metres is refused, each for its own reason and with its evidence.
    #[test]
    fn only_a_part_standing_on_the_plate_is_taken() {
        assert_eq!(check(&dome_moved(|p| p), 2.0), Ok(()));
        // Within half a layer: a CAD export's rounding, a base a little off.
        let near = dome_moved(|p| p + nalgebra::Vector3::new(0.0, 0.0, 0.6));
        assert_eq!(check(&near, 2.0), Ok(()));
        match check(
            &dome_moved(|p| p + nalgebra::Vector3::new(100.0, 0.0, 250.0)),
            2.0,
        ) {
            Err(Unseated::Raised { z_mean_mm, .. }) => assert!((z_mean_mm - 250.0).abs() < 1e-9),
            other => panic!("{other:?}"),
        }
        // Tilted 5°: the boundary's 40 mm span rises 3.5 mm.
        let (s, c) = 5f64.to_radians().sin_cos();
        match check(
            &dome_moved(|p| nalgebra::Point3::new(p.x, c * p.y - s * p.z, s * p.y + c * p.z)),
            2.0,
        ) {
            Err(Unseated::Tilted {
                z_min_mm, z_max_mm, ..
            }) => assert!((z_max_mm - z_min_mm - 40.0 * s).abs() < 0.1),
            other => panic!("{other:?}"),
        }
        // On its side: the boundary stands upright.
        assert!(matches!(
            check(&dome_moved(|p| nalgebra::Point3::new(p.z, p.y, -p.x)), 2.0),
            Err(Unseated::Tilted { .. })
        ));
        match check(&dome_moved(|p| p * 1e-3), 2.0) {
            Err(Unseated::Tiny { height_mm, .. }) => assert!((height_mm - 0.02).abs() < 1e-6),
            other => panic!("{other:?}"),
        }
        // A level boundary on the plate with the part bulging under it (z = 5 → -2.07 mm).
        let bulb = |p: nalgebra::Point3<f64>| {
            nalgebra::Point3::new(
                p.x,
                p.y,
                p.z - 10.0 * (std::f64::consts::PI * p.z / 20.0).sin(),
            )
        };
        match check(&dome_moved(bulb), 2.0) {
            Err(Unseated::Below { position_mm, .. }) => assert!(position_mm[2] < -1.0),
            other => panic!("{other:?}"),
        }
    }
}
