use super::*;

fn parse(text: &str) -> Result<Scenario> {
    Scenario::parse(text, "s.toml", Path::new("."))
}

#[test]
fn defaults_fill_in_and_convert_to_si() {
    let s = parse("[part]\nshape = \"hemisphere\"\nradius_mm = 100.0\n").unwrap();
    assert_eq!(s.process.deposit_m, 2.0e-3);
    assert!((s.process.wfs_max_m_s - 10.0 / 60.0).abs() < 1e-15);
    assert_eq!(s.thermal.ambient_k, 293.15);
    assert!((s.material.diffusivity_m2_s() - 14e-6).abs() < 1e-18);
    assert_eq!(
        s.part.source,
        PartSource::Shape {
            shape: Shape::Hemisphere { radius_mm: 100.0 },
            edge_mm: 2.0
        }
    );
}

#[test]
fn locate_finds_the_key_in_its_section() {
    let t = "[part]\ndeposit_mm = 1\n[process]\n# c\ndeposit_mm = 3\n";
    assert_eq!(locate(t, "process", "deposit_mm"), Some(5));
    assert_eq!(locate(t, "part", "deposit_mm"), Some(2));
    assert_eq!(locate(t, "thermal", "deposit_mm"), None);
}

#[test]
fn a_disc_plate_is_the_voxel_models_and_round() {
    let base = "[part]\nshape = \"hemisphere\"\nradius_mm = 30.0\n[thermal]\n";
    let s = parse(&format!(
        "{base}model = \"voxel\"\nplate_shape = \"disc\"\nplate_mm = [100.0, 100.0, 10.0]\n"
    ))
    .unwrap();
    assert!(s.thermal.plate_disc);
    for (keys, needle) in [
        (
            "model = \"voxel\"\nplate_shape = \"disc\"\nplate_mm = [100.0, 80.0, 10.0]\n",
            "a disc's diameter twice",
        ),
        (
            "plate_shape = \"disc\"\n",
            "\"box\" with model = \"thin-wall\"",
        ),
        ("plate_shape = \"round\"\n", "\"box\" or \"disc\""),
    ] {
        let e = parse(&format!("{base}{keys}")).unwrap_err();
        assert!(e.message.contains(needle), "{needle}: {}", e.message);
    }
}

/// `$WAAMTWIN_DATA/…` is the measured builds' folder: the variable's, else the shared folder
/// beside a checkout that holds the scenario; other paths lie beside the scenario file.
#[test]
fn data_paths_lead_to_the_shared_folder_beside_the_checkout() {
    let root = std::env::temp_dir().join(format!("waamtwin-data-{}", std::process::id()));
    let data = root.join("shared/validation-data");
    let base = root.join("checkout/scenarios");
    std::fs::create_dir_all(&data).unwrap();
    std::fs::create_dir_all(&base).unwrap();
    let found = super::resolve(&base, "$WAAMTWIN_DATA/ornl/log.csv");
    let expected = match std::env::var_os(super::DATA_VAR) {
        Some(d) => std::path::PathBuf::from(d).join("ornl/log.csv"),
        None if std::path::Path::new("../shared/validation-data").is_dir() => {
            std::path::PathBuf::from("../shared/validation-data/ornl/log.csv")
        }
        None => data.join("ornl/log.csv"),
    };
    assert_eq!(found, expected);
    assert_eq!(
        super::resolve(&base, "parts/a.obj"),
        base.join("parts/a.obj")
    );
    // A name that merely begins like the variable is a file beside the scenario.
    assert_eq!(
        super::resolve(&base, "$WAAMTWIN_DATAX/a.csv"),
        base.join("$WAAMTWIN_DATAX/a.csv")
    );
    std::fs::remove_dir_all(&root).unwrap();
}

/// The defaults have one home, the engine's types: a scenario that leaves a section out runs
/// at exactly `Default::default()` of its settings (the bead's width the default's).
#[test]
fn a_scenario_left_to_its_defaults_runs_at_the_engine_defaults() {
    use crate::pipeline::params::{BeadSettings, DwellSettings, ThermalSettings};
    let s = Scenario::parse(
        "[part]\nshape = \"disk\"\nradius_mm = 1.0\n",
        "d",
        ".".as_ref(),
    )
    .unwrap();
    let p = s.params();
    assert_eq!(p.thermal, ThermalSettings::default());
    assert_eq!(p.dwell, DwellSettings::default());
    assert_eq!(p.bead, BeadSettings::default());
    assert_eq!(p, crate::pipeline::params::Params::default());
    assert_eq!(s.plan_params(), planner::plan::PlanParams::default());
    assert_eq!(
        s.skeleton,
        crate::pipeline::skeleton::SkeletonSettings::default()
    );
    // Another bead width moves what follows it, as the reader does.
    let s = Scenario::parse(
        "[part]\nshape = \"disk\"\nradius_mm = 1.0\n[process]\nbead_width_mm = 3.5\n",
        "d",
        ".".as_ref(),
    )
    .unwrap();
    assert_eq!(s.params().thermal, ThermalSettings::for_bead(3.5));
    assert_eq!(s.params().dwell, DwellSettings::for_bead(3.5));
}

/// A value the engine refuses is named with the scenario's file, line and key, in the
/// interface's units; the same value set in Rust is refused by the engine with the same words.
#[test]
fn the_engine_and_the_reader_refuse_a_value_alike() {
    let text = "[part]\nshape = \"disk\"\nradius_mm = 1.0\n[thermal]\nvoxel_mm = 40.0\n";
    let e = Scenario::parse(text, "s.toml", ".".as_ref()).unwrap_err();
    assert_eq!(
        e.message,
        "s.toml line 5: thermal.voxel_mm = 40; expected between 0.25 and 20"
    );
    let mut p = crate::pipeline::params::Params::default();
    p.thermal.voxel_m = 0.04;
    let part = planner::mesh::Part::from_mesh(
        planner::shapes::Shape::Hemisphere { radius_mm: 20.0 }.mesh(2.5),
        planner::mesh::LowerLoop::default(),
    )
    .unwrap();
    let planning = planner::plan::PlanParams::default();
    match crate::pipeline::build(&part, &planning, p) {
        Err(crate::pipeline::Error::Invalid(e)) => {
            assert_eq!(
                e.to_string(),
                "thermal.voxel_mm = 40; expected between 0.25 and 20"
            )
        }
        other => panic!(
            "expected the voxel size refused, got {:?}",
            other.map(|_| ())
        ),
    }
    let planning = planner::plan::PlanParams {
        gap_max_mm: -1.0,
        ..planner::plan::PlanParams::default()
    };
    let e = crate::pipeline::build(&part, &planning, Default::default()).unwrap_err();
    assert_eq!(
        e.to_string(),
        "planner.gap_max_mm = -1; expected a number in (0, 100]"
    );
}

/// `[thermal] device`: "cpu" by default, "gpu" for the voxel model; the thin wall, a coarsened
/// plate and an unknown device are refused with the file, line, key and what was expected.
#[test]
fn the_gpu_is_the_voxel_models_and_named_when_refused() {
    let base = "[part]\nshape = \"hemisphere\"\nradius_mm = 30.0\n[thermal]\n";
    let s = parse(base).unwrap();
    assert_eq!(s.thermal.device, Device::Cpu);
    let s = parse(&format!("{base}model = \"voxel\"\ndevice = \"gpu\"\n")).unwrap();
    assert_eq!(s.thermal.device, Device::Gpu);
    for (keys, needle) in [
        (
            "device = \"gpu\"\n",
            "s.toml line 5: thermal.device = \"gpu\" with model",
        ),
        (
            "model = \"voxel\"\ndevice = \"gpu\"\ncoarse_plate = true\n",
            "line 7: thermal.coarse_plate = true with device = \"gpu\"",
        ),
        (
            "model = \"voxel\"\ndevice = \"cuda\"\n",
            "\"cpu\" or \"gpu\"",
        ),
    ] {
        let e = parse(&format!("{base}{keys}")).unwrap_err().to_string();
        assert!(e.contains(needle), "{e}");
    }
}
