//! `waamtwin inspect` on every library shape and on broken files.

use crate::{assert_input_error, scratch, waamtwin};
use planner::io::{Encoding, MeshFormat, write_mesh};
use planner::shapes::Shape;

fn library() -> Vec<(Shape, &'static str, usize)> {
    vec![
        (
            Shape::Cylinder {
                radius_mm: 40.0,
                height_mm: 50.0,
            },
            "open",
            2,
        ),
        (
            Shape::ConeFrustum {
                radius_mm: 40.0,
                top_radius_mm: 20.0,
                height_mm: 50.0,
                top_slope_mm: 0.0,
            },
            "open",
            2,
        ),
        (
            Shape::Vase {
                radius_mm: 40.0,
                height_mm: 60.0,
                bulge_mm: 5.0,
                top_slope_mm: 6.0,
                top_wave_mm: 2.0,
                top_waves: 3,
            },
            "open",
            2,
        ),
        (Shape::Hemisphere { radius_mm: 40.0 }, "closed", 1),
        (
            Shape::AsymmetricDome {
                radius_mm: 40.0,
                radius_y_mm: 40.0,
                height_mm: 60.0,
                lean_mm: 15.0,
            },
            "closed",
            1,
        ),
        (
            Shape::QuarterTorus {
                bend_radius_mm: 60.0,
                tube_radius_mm: 10.0,
            },
            "open",
            2,
        ),
    ]
}

#[test]
fn every_library_shape_as_stl_reports_its_kind_and_loops() {
    let dir = scratch("inspect_library");
    for (shape, kind, loops) in library() {
        let path = dir.join(format!("{}.stl", shape.name()));
        std::fs::write(
            &path,
            write_mesh(&shape.mesh(3.0), MeshFormat::Stl, Encoding::Binary),
        )
        .unwrap();
        let out = waamtwin(&["inspect", path.to_str().unwrap(), "--json"]);
        assert!(
            out.status.success(),
            "{}: {}",
            shape.name(),
            String::from_utf8_lossy(&out.stderr)
        );
        let r: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(r["part_kind"], kind, "{}", shape.name());
        assert_eq!(r["boundary_loops"], loops, "{}", shape.name());
    }
}

fn write(dir: &std::path::Path, name: &str, bytes: &[u8]) -> String {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p.to_str().unwrap().to_string()
}

#[test]
fn broken_meshes_exit_2_with_one_precise_line() {
    let dir = scratch("inspect_broken");
    let good = write_mesh(
        &Shape::Cylinder {
            radius_mm: 20.0,
            height_mm: 20.0,
        }
        .mesh(4.0),
        MeshFormat::Stl,
        Encoding::Binary,
    );

    let truncated = write(&dir, "truncated.stl", &good[..good.len() - 30]);
    assert_input_error(
        &waamtwin(&["inspect", &truncated]),
        &["truncated.stl", "truncated"],
    );

    let nan = write(&dir, "nan.obj", b"v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n");
    assert_input_error(
        &waamtwin(&["inspect", &nan]),
        &["nan.obj", "vertex 2", "non-finite y"],
    );

    let nm = write(
        &dir,
        "nonmanifold.obj",
        b"v 0 0 0\nv 1 0 0\nv 0 1 0\nv 0 -1 0\nv 0 0 1\nf 1 2 3\nf 2 1 4\nf 1 2 5\n",
    );
    assert_input_error(
        &waamtwin(&["inspect", &nm]),
        &["nonmanifold.obj", "non-manifold edge", "3 faces"],
    );

    let mut disk = Shape::Disk { radius_mm: 30.0 }.mesh(2.0);
    disk.faces.retain(|f| {
        let c = f.iter().fold(planner::nalgebra::Vector3::zeros(), |s, &v| {
            s + disk.positions[v as usize].coords
        }) / 3.0;
        (c.x - 12.0).hypot(c.y) > 5.0 && (c.x + 12.0).hypot(c.y) > 5.0
    });
    let three = write(
        &dir,
        "three_loops.ply",
        &write_mesh(&disk, MeshFormat::Ply, Encoding::Binary),
    );
    assert_input_error(
        &waamtwin(&["inspect", &three]),
        &["three_loops.ply", "3 boundary loops", "expected 2"],
    );

    let empty = write(&dir, "empty.stl", b"");
    assert_input_error(&waamtwin(&["inspect", &empty]), &["empty.stl", "empty"]);

    let mut lying = vec![0u8; 1024];
    lying[80..84].copy_from_slice(&4_000_000_000u32.to_le_bytes());
    let lying = write(&dir, "lying.stl", &lying);
    assert_input_error(
        &waamtwin(&["inspect", &lying]),
        &["lying.stl", "claims 4000000000 triangles", "1024 bytes"],
    );

    assert_input_error(
        &waamtwin(&["inspect", "no/such/file.stl"]),
        &["no/such/file.stl"],
    );
    let txt = write(&dir, "mesh.txt", b"x");
    assert_input_error(&waamtwin(&["inspect", &txt]), &["mesh.txt", "extension"]);
}
