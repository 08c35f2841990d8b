use super::*;
use crate::shapes::Shape;
use nalgebra::Point3;

fn square() -> TriMesh {
    let p = |x: f64, y: f64| Point3::new(x, y, 0.0);
    TriMesh::new(
        vec![p(0., 0.), p(1., 0.), p(1., 1.), p(0., 1.)],
        vec![[0, 1, 2], [0, 2, 3]],
    )
}

#[test]
fn non_finite_coordinate_is_named() {
    let mut m = square();
    m.positions[2].y = f64::NAN;
    let e = Part::from_mesh(m, LowerLoop::LowestZ).unwrap_err();
    assert!(
        matches!(
            e,
            MeshError::NonFinite {
                vertex: 2,
                axis: 'y',
                ..
            }
        ),
        "{e}"
    );
}

#[test]
fn non_manifold_edge_names_edge_and_faces() {
    let mut m = square();
    m.positions.push(Point3::new(0.5, 0.5, 1.0));
    m.faces.push([0, 2, 4]);
    let e = Part::from_mesh(m, LowerLoop::LowestZ).unwrap_err();
    assert!(
        matches!(&e, MeshError::NonManifoldEdge { edge: [0, 2], faces } if faces.len() == 3),
        "{e}"
    );
}

#[test]
fn bowtie_vertex_is_non_manifold() {
    let p = |x: f64, y: f64| Point3::new(x, y, 0.0);
    let m = TriMesh::new(
        vec![p(0., 0.), p(1., 0.), p(0., 1.), p(-1., 0.), p(0., -1.)],
        vec![[0, 1, 2], [0, 3, 4]],
    );
    let e = Part::from_mesh(m, LowerLoop::LowestZ).unwrap_err();
    assert!(
        matches!(e, MeshError::NonManifoldVertex { vertex: 0, .. }),
        "{e}"
    );
}

#[test]
fn two_components_are_an_error() {
    let mut a = Shape::Cylinder {
        radius_mm: 10.0,
        height_mm: 10.0,
    }
    .mesh(2.0);
    let mut b = a.clone();
    b.map_positions(|p| p + nalgebra::Vector3::new(50.0, 0.0, 0.0));
    let off = a.n_vertices() as u32;
    a.positions.extend(b.positions);
    a.faces.extend(b.faces.iter().map(|f| f.map(|v| v + off)));
    let e = Part::from_mesh(a, LowerLoop::LowestZ).unwrap_err();
    assert!(matches!(e, MeshError::Components { count: 2, .. }), "{e}");
}

#[test]
fn three_loops_are_an_error() {
    // An annulus-with-a-hole: a disk with two holes has three loops.
    let mut m = Shape::Disk { radius_mm: 30.0 }.mesh(2.0);
    m.faces.retain(|f| {
        let c = f.iter().fold(nalgebra::Vector3::zeros(), |s, &v| {
            s + m.positions[v as usize].coords
        }) / 3.0;
        (c - nalgebra::Vector3::new(12.0, 0.0, 0.0)).norm() > 5.0
            && (c + nalgebra::Vector3::new(12.0, 0.0, 0.0)).norm() > 5.0
    });
    let e = Part::from_mesh(m, LowerLoop::LowestZ).unwrap_err();
    assert_eq!(e, MeshError::LoopCount { loops: 3 });
}

#[test]
fn degenerate_faces_are_dropped() {
    let mut m = square();
    m.faces.push([0, 0, 1]);
    m.positions.push(Point3::new(2.0, 0.0, 0.0));
    m.faces.push([0, 1, 4]); // collinear
    let part = Part::from_mesh(m, LowerLoop::LowestZ).unwrap();
    assert_eq!(part.weld.degenerate_faces, 2);
    assert_eq!(part.mesh.n_faces(), 2);
    assert_eq!(part.kind, PartKind::Closed);
}

#[test]
fn explicit_lower_loop() {
    let m = Shape::Cylinder {
        radius_mm: 10.0,
        height_mm: 10.0,
    }
    .mesh(2.0);
    let a = Part::from_mesh(m.clone(), LowerLoop::LowestZ).unwrap();
    let b = Part::from_mesh(m.clone(), LowerLoop::Index(a.upper.unwrap())).unwrap();
    assert!(b.lower_loop().mean_z > 9.0);
    assert!(Part::from_mesh(m, LowerLoop::Index(5)).is_err());
}
