use super::*;
use crate::mesh::{LowerLoop, Part, PartKind};
use crate::shapes::Shape;

fn cylinder() -> TriMesh {
    Shape::Cylinder {
        radius_mm: 20.0,
        height_mm: 30.0,
    }
    .mesh(4.0)
}

fn same_surface(a: &TriMesh, b: &TriMesh, tol: f64) {
    let pa = Part::from_mesh(a.clone(), LowerLoop::LowestZ).unwrap();
    let pb = Part::from_mesh(b.clone(), LowerLoop::LowestZ).unwrap();
    assert_eq!(pa.mesh.n_vertices(), pb.mesh.n_vertices());
    assert_eq!(pa.mesh.n_faces(), pb.mesh.n_faces());
    assert!((pa.mesh.area() - pb.mesh.area()).abs() < tol * pa.mesh.area());
}

#[test]
fn round_trip_every_format_and_encoding() {
    let m = cylinder();
    for (fmt, enc) in [
        (MeshFormat::Stl, Encoding::Binary),
        (MeshFormat::Stl, Encoding::Ascii),
        (MeshFormat::Obj, Encoding::Ascii),
        (MeshFormat::Ply, Encoding::Ascii),
        (MeshFormat::Ply, Encoding::Binary),
    ] {
        let bytes = write_mesh(&m, fmt, enc);
        let back = read_mesh(&bytes, fmt).unwrap_or_else(|e| panic!("{fmt:?} {enc:?}: {e}"));
        // STL binary stores f32: area agrees to single precision.
        same_surface(&m, &back, 1e-6);
        if fmt != MeshFormat::Stl {
            assert_eq!(back, m, "{fmt:?} {enc:?} must be exact");
        }
    }
}

#[test]
fn stl_soup_welds_back_to_the_indexed_mesh() {
    let m = cylinder();
    let soup = read_stl(&write_stl(&m, Encoding::Binary)).unwrap();
    assert_eq!(soup.n_vertices(), 3 * m.n_faces());
    let part = Part::from_mesh(soup, LowerLoop::LowestZ).unwrap();
    assert_eq!(part.mesh.n_vertices(), m.n_vertices());
    assert_eq!(part.weld.vertices_in, 3 * m.n_faces());
}

#[test]
fn binary_stl_that_starts_with_solid_is_still_binary() {
    let mut bytes = write_stl(&cylinder(), Encoding::Binary);
    bytes[..5].copy_from_slice(b"solid");
    assert_eq!(read_stl(&bytes).unwrap().n_faces(), cylinder().n_faces());
}

#[test]
fn lying_triangle_count_is_an_error_not_an_allocation() {
    let mut bytes = vec![0u8; 1000];
    bytes[80..84].copy_from_slice(&4_000_000_000u32.to_le_bytes());
    let e = read_stl(&bytes).unwrap_err();
    assert!(e.message.contains("claims 4000000000 triangles"), "{e}");
}

#[test]
fn truncated_binary_stl_names_the_shortfall() {
    let bytes = write_stl(&cylinder(), Encoding::Binary);
    let e = read_stl(&bytes[..bytes.len() - 7]).unwrap_err();
    assert!(e.message.contains("truncated"), "{e}");
}

#[test]
fn ascii_errors_name_the_line() {
    let src = b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\nvertex 1 zero 0\n";
    let e = read_stl(src).unwrap_err();
    assert_eq!(e.line, Some(5));
    assert!(e.message.contains("'zero'"), "{e}");
    let e = read_stl(b"solid x\nfacet normal 0 0 1\nouter loop\nvertex 0 0 0\n").unwrap_err();
    assert!(e.message.contains("truncated"), "{e}");
    assert!(read_stl(b"").unwrap_err().message.contains("empty"));
}

#[test]
fn obj_polygons_negative_indices_and_bad_index() {
    let src = b"v 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nf 1/1/1 2//2 -2 -1\n";
    let m = read_obj(src).unwrap();
    assert_eq!(m.faces, vec![[0, 1, 2], [0, 2, 3]]);
    let e = read_obj(b"v 0 0 0\nf 1 2 3\n").unwrap_err();
    assert_eq!(e.line, Some(2));
}

#[test]
fn ply_lying_vertex_count_is_an_error() {
    let mut bytes = b"ply\nformat binary_little_endian 1.0\nelement vertex 1000000000\nproperty float x\nproperty float y\nproperty float z\nend_header\n".to_vec();
    bytes.extend_from_slice(&[0u8; 24]);
    let e = read_ply(&bytes).unwrap_err();
    assert!(e.message.contains("claims 1000000000 records"), "{e}");
}

#[test]
fn ply_skips_extra_elements_and_properties() {
    let src = b"ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\nproperty uchar red\nelement face 1\nproperty list uchar int vertex_indices\nelement edge 1\nproperty int a\nproperty int b\nend_header\n0 0 0 255\n1 0 0 0\n0 1 0 0\n3 0 1 2\n0 1\n";
    let m = read_ply(src).unwrap();
    assert_eq!(m.n_vertices(), 3);
    assert_eq!(m.faces, vec![[0, 1, 2]]);
}

#[test]
fn classification_of_the_library() {
    let cases = [
        (
            Shape::Cylinder {
                radius_mm: 30.0,
                height_mm: 40.0,
            },
            PartKind::Open,
        ),
        (
            Shape::ConeFrustum {
                radius_mm: 30.0,
                top_radius_mm: 15.0,
                height_mm: 40.0,
                top_slope_mm: 0.0,
            },
            PartKind::Open,
        ),
        (
            Shape::Vase {
                radius_mm: 30.0,
                height_mm: 50.0,
                bulge_mm: 5.0,
                top_slope_mm: 5.0,
                top_wave_mm: 2.0,
                top_waves: 3,
            },
            PartKind::Open,
        ),
        (Shape::Hemisphere { radius_mm: 30.0 }, PartKind::Closed),
        (
            Shape::AsymmetricDome {
                radius_mm: 30.0,
                radius_y_mm: 30.0,
                height_mm: 40.0,
                lean_mm: 10.0,
            },
            PartKind::Closed,
        ),
        (
            Shape::QuarterTorus {
                bend_radius_mm: 60.0,
                tube_radius_mm: 10.0,
            },
            PartKind::Open,
        ),
        (Shape::Disk { radius_mm: 30.0 }, PartKind::Closed),
    ];
    for (shape, kind) in cases {
        let part = Part::from_mesh(shape.mesh(3.0), LowerLoop::LowestZ).unwrap();
        assert_eq!(part.kind, kind, "{}", shape.name());
        let expected_loops = if kind == PartKind::Open { 2 } else { 1 };
        assert_eq!(
            part.topology.loops.len(),
            expected_loops,
            "{}",
            shape.name()
        );
        assert!(
            part.lower_loop().mean_z.abs() < 1e-9,
            "{}: lower loop on z = 0",
            shape.name()
        );
    }
}

#[test]
fn reorients_flipped_faces_outward() {
    let mut m = Shape::Hemisphere { radius_mm: 10.0 }.mesh(2.0);
    for f in m.faces.iter_mut().step_by(3) {
        f.swap(0, 1);
    }
    let part = Part::from_mesh(m, LowerLoop::LowestZ).unwrap();
    assert!(part.topology.flipped_faces > 0);
    for f in 0..part.mesh.n_faces() {
        let [a, b, c] = part.mesh.corners(f);
        let mid = (a.coords + b.coords + c.coords) / 3.0;
        assert!(
            part.mesh.face_normal(f).dot(&mid) > 0.0,
            "face {f} points inward"
        );
    }
}
