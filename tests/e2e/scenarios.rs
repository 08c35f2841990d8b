//! Scenarios as data: every file under `scenarios/` and `tests/scenarios/good` must load; every
//! file under `tests/scenarios/bad` must fail with the message its first line announces
//! (`# expect: TEXT`, where each `|`-separated part must appear in the one-line error).

use crate::{assert_input_error, root, scratch, waamtwin};

fn toml_files(dir: &str) -> Vec<std::path::PathBuf> {
    let mut v: Vec<_> = std::fs::read_dir(root().join(dir))
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "toml"))
        .collect();
    v.sort();
    v
}

#[test]
fn shipped_and_good_scenarios_load() {
    let files: Vec<_> = toml_files("scenarios")
        .into_iter()
        .chain(toml_files("tests/scenarios/good"))
        .collect();
    assert!(files.len() >= 8);
    for f in files {
        if std::fs::read_to_string(&f)
            .unwrap()
            .contains("\n[toolpath]")
        {
            sim::scenario::replay::ReplayScenario::load(&f)
                .unwrap_or_else(|e| panic!("{}: {e}", f.display()));
            // And the planning commands send the user to `replay`.
            let e = sim::scenario::Scenario::load(&f).unwrap_err();
            assert!(e.message.contains("waamtwin replay"), "{e}");
            continue;
        }
        let s =
            sim::scenario::Scenario::load(&f).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
        if std::fs::read_to_string(&f)
            .unwrap()
            .contains("\n[skeleton]")
        {
            sim::part::load_skeleton(&s.part, &s.skeleton)
                .unwrap_or_else(|e| panic!("{}: {e}", f.display()));
            // And the surface commands send the user to `skeleton`.
            let e = sim::part::load_part(&s.part).unwrap_err();
            assert!(e.message.contains("waamtwin skeleton"), "{e}");
            continue;
        }
        sim::part::load_part(&s.part).unwrap_or_else(|e| panic!("{}: {e}", f.display()));
    }
}

/// Every shipped surface scenario plans (a mesh file's part included: `mesh_file.toml`'s cone
/// once lost a lower point to a ray through a loop vertex and could not be planned, while
/// loading it passed).
#[test]
fn shipped_surface_scenarios_plan() {
    let dir = scratch("shipped_plans");
    let mut planned = 0;
    for f in toml_files("scenarios") {
        let text = std::fs::read_to_string(&f).unwrap();
        if text.contains("\n[toolpath]") || text.contains("\n[skeleton]") {
            continue;
        }
        let out = waamtwin(&[
            "plan",
            f.to_str().unwrap(),
            "-o",
            dir.join("out").to_str().unwrap(),
        ]);
        assert!(
            out.status.success(),
            "{}: {}",
            f.display(),
            String::from_utf8_lossy(&out.stderr)
        );
        planned += 1;
    }
    assert!(planned >= 12, "{planned} surface scenarios planned");
}

#[test]
fn every_library_shape_has_a_scenario() {
    let text: String = toml_files("scenarios")
        .iter()
        .map(|f| std::fs::read_to_string(f).unwrap())
        .collect();
    for name in planner::shapes::SIGNATURES
        .map(|s| s.name)
        .iter()
        .filter(|n| **n != "disk")
    {
        assert!(
            text.contains(&format!("shape = \"{name}\"")),
            "no scenario for {name}"
        );
    }
}

#[test]
fn bad_scenarios_fail_with_their_announced_message() {
    let files = toml_files("tests/scenarios/bad");
    assert!(files.len() >= 10);
    let dir = scratch("bad_scenarios");
    for f in files {
        let text = std::fs::read_to_string(&f).unwrap();
        let expect = text
            .lines()
            .next()
            .and_then(|l| l.strip_prefix("# expect: "))
            .unwrap_or_else(|| panic!("{} has no '# expect:' line", f.display()));
        let needles: Vec<&str> = expect.split('|').map(str::trim).collect();
        let out = waamtwin(&[
            "mesh",
            f.to_str().unwrap(),
            "-o",
            dir.join("x.stl").to_str().unwrap(),
        ]);
        assert_input_error(&out, &needles);
    }
}
