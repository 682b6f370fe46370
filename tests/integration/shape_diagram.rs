//! The shape diagram (`remembrane diagram`, issue 30): a walk down the
//! reduced volume on the prolate and oblate branches against the
//! axisymmetric solver's curves, its tables and chart, and its clean
//! refusals.

use std::path::PathBuf;
use std::process::{Command, Output};

fn remembrane(args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_remembrane"))
        .args(args)
        .output()
        .unwrap()
}

fn branch_scene(name: &str) -> PathBuf {
    crate::common::repo("scenes/minimise/shape_diagram").join(name)
}

/// A diagram of the bundled branch scenes at 642 vertices.
fn diagram(volumes: &str, extra: &str) -> String {
    format!(
        "ShapeDiagram(\n  name: \"quick\",\n  reduced_volumes: [{volumes}],\n  branches: [\n    \
         (name: \"prolate\", scene: \"{}\", reference: Prolate),\n    \
         (name: \"oblate\", scene: \"{}\", reference: Oblate),\n  ],{extra}\n)\n",
        branch_scene("prolate.ron").display(),
        branch_scene("oblate.ron").display()
    )
}

#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn a_walk_down_two_branches_meets_the_continuum_and_writes_its_tables() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("quick.ron");
    std::fs::write(&file, diagram("0.95, 0.9", "")).unwrap();
    let out = dir.path().join("out");
    let o = remembrane(&[
        "diagram",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert!(o.status.success(), "{stderr}");
    assert!(!dir.path().join("out.incomplete").exists());
    for name in ["diagram.csv", "diagram.md", "diagram.json", "diagram.png"] {
        assert!(out.join(name).exists(), "{name}");
    }
    // Each point is a run directory; the second starts from the first.
    assert!(out.join("scene/oblate/v0.9/summary.json").exists());
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("diagram.json")).unwrap()).unwrap();
    let points = summary["points"].as_array().unwrap();
    assert_eq!(points.len(), 4);
    let energy = |branch: &str, v: f64| {
        let p = points
            .iter()
            .find(|p| p["branch"] == branch && p["target"] == v)
            .unwrap();
        assert_eq!(p["status"], "completed", "{p}");
        assert!(p["converged"].as_bool().unwrap(), "{p}");
        assert!((p["reduced_volume"].as_f64().unwrap() - v).abs() < 1e-6);
        let e = p["energy"].as_f64().unwrap();
        let reference = p["reference"]["energy"].as_f64().unwrap();
        // 642 vertices, the dihedral bending: measured -0.07 to -0.21 %
        // here (the cotangent form read -0.91 to -1.11 %); the issue's
        // bound is 1.5 %.
        let error = (e - reference) / reference;
        assert!(error.abs() < 0.015, "{branch} v = {v}: {error}");
        (e, p["class"].as_str().unwrap().to_string())
    };
    let (prolate_95, class) = energy("prolate", 0.95);
    assert_eq!(class, "prolate");
    let (oblate_95, class) = energy("oblate", 0.95);
    assert_eq!(class, "convex");
    // Above the crossing at v = 0.651 the prolate branch is the lower one.
    assert!(prolate_95 < oblate_95);
    let (prolate_90, _) = energy("prolate", 0.9);
    let (oblate_90, _) = energy("oblate", 0.9);
    assert!(prolate_90 < oblate_90 && oblate_95 < oblate_90);
    // The continuum's curves are drawn, and they cross where Seifert,
    // Berndl & Lipowsky put the prolate/oblate transition only if the walk
    // reaches it: not here, so no measured crossing is claimed.
    assert_eq!(summary["curves"].as_array().unwrap().len(), 2);
    assert!(
        summary["crossings"]
            .as_array()
            .unwrap()
            .iter()
            .all(|c| c["mesh"] == "continuum")
    );
    let csv = std::fs::read_to_string(out.join("diagram.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5, "{csv}");
    assert!(csv.starts_with("mesh,branch,reference_branch,target_v"));
}

#[test]
fn bad_diagrams_are_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    let run = |text: &str| {
        let file = dir.path().join("d.ron");
        std::fs::write(&file, text).unwrap();
        remembrane(&[
            "diagram",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
        ])
    };
    for (text, needle) in [
        (diagram("0.95, 1.2", ""), "reduced_volumes"),
        (diagram("", ""), "reduced_volumes"),
        (
            diagram("0.9", "\n  meshes: [(label: \"a\"), (label: \"a\")],"),
            "meshes[1]",
        ),
        (
            diagram(
                "0.9",
                "\n  meshes: [(label: \"a\", set: [(\"membrane.Ellipsoid.level\", 99)])],",
            ),
            "level",
        ),
    ] {
        let o = run(&text);
        let stderr = String::from_utf8_lossy(&o.stderr);
        assert_eq!(o.status.code(), Some(2), "{needle}: {stderr}");
        assert!(stderr.contains(needle), "{needle}: {stderr}");
        assert!(!out.exists() && !dir.path().join("out.incomplete").exists());
    }
    // A branch scene that runs dynamics is refused: a diagram holds
    // equilibrium shapes.
    let dynamics = crate::common::repo("scenes/red_blood_cell.ron");
    let text = format!(
        "ShapeDiagram(name: \"d\", reduced_volumes: [0.9], branches: [(name: \"b\", scene: \"{}\", reference: Oblate)])",
        dynamics.display()
    );
    let o = run(&text);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("branches[0].scene"), "{stderr}");
    // A branch walked on a mesh the diagram does not declare.
    let text = diagram("0.9", "").replace(
        "reference: Oblate)",
        "reference: Oblate, meshes: Some([\"fine\"]))",
    );
    let o = run(&text);
    let stderr = String::from_utf8_lossy(&o.stderr);
    assert_eq!(o.status.code(), Some(2), "{stderr}");
    assert!(stderr.contains("branches[1].meshes"), "{stderr}");
    // `run` on a diagram refuses the options that mean nothing for it.
    let file = dir.path().join("d.ron");
    std::fs::write(&file, diagram("0.9", "")).unwrap();
    let o = remembrane(&["run", file.to_str().unwrap(), "--seed", "3"]);
    assert_eq!(o.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&o.stderr).contains("--seed"));
}

#[test]
fn run_is_the_front_door_for_a_diagram() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("one.ron");
    let text = format!(
        "ShapeDiagram(name: \"one\", reduced_volumes: [0.95], branches: [(name: \"oblate\", scene: \"{}\", reference: Oblate)])",
        branch_scene("oblate.ron").display()
    );
    std::fs::write(&file, text).unwrap();
    let out = dir.path().join("out");
    let o = remembrane(&[
        "run",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
        "--quiet",
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    // --quiet: no table, no progress.
    assert!(o.stdout.is_empty() && o.stderr.is_empty());
    let csv = std::fs::read_to_string(out.join("diagram.csv")).unwrap();
    assert_eq!(csv.lines().count(), 2, "{csv}");
    assert!(
        csv.lines()
            .nth(1)
            .unwrap()
            .starts_with("scene,oblate,oblate,0.95,completed,642,")
    );
    // An existing output directory is refused without --overwrite.
    let o = remembrane(&[
        "run",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert_eq!(o.status.code(), Some(2));
}

/// The stomatocyte branch (issue 30): started from the continuum's own cup
/// at v = 0.65 (`membrane: Axisymmetric(...)`, a surface of revolution in
/// rings), the walk stays a stomatocyte as the neck narrows, and reads low
/// by the cotangent energy's O(h²) at 632-668 vertices (measured −1.59 %,
/// −1.58 %; benches/RESULTS.md commit eefae4d (2026-12-04)).
#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn the_stomatocyte_branch_walks_down_from_the_continuums_cup() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("sto.ron");
    let text = format!(
        "ShapeDiagram(name: \"sto\", reduced_volumes: [0.65, 0.6], branches: [(name: \"stomatocyte\", \
         scene: \"{}\", reference: Stomatocyte)])",
        branch_scene("stomatocyte.ron").display()
    );
    std::fs::write(&file, text).unwrap();
    let out = dir.path().join("out");
    let o = remembrane(&[
        "diagram",
        file.to_str().unwrap(),
        "--out",
        out.to_str().unwrap(),
    ]);
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("diagram.json")).unwrap()).unwrap();
    let points = summary["points"].as_array().unwrap();
    assert_eq!(points.len(), 2);
    let mut energies = Vec::new();
    for p in points {
        assert_eq!(p["status"], "completed", "{p}");
        assert!(p["converged"].as_bool().unwrap(), "{p}");
        assert_eq!(p["class"], "stomatocyte", "{p}");
        let e = p["energy"].as_f64().unwrap();
        let reference = p["reference"]["energy"].as_f64().unwrap();
        let error = (e - reference) / reference;
        // Measured +0.30 % (the cotangent form read -1.6 %); a sphere-like
        // or discocyte end would read +20 % or −1 % against a different
        // curve.
        assert!(error.abs() < 0.01, "{p}");
        energies.push(e);
    }
    // Along the branch the energy rises slowly as v falls (continuum
    // 1.9668 → 1.9774).
    assert!(energies[1] > energies[0] && energies[1] < energies[0] * 1.02);
}

/// A mesh's change that names a membrane kind applies to the branches that
/// start from that kind, and must apply to one.
#[test]
fn membrane_kind_changes_apply_to_their_kind_only() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("d.ron");
    let branches = format!(
        "branches: [(name: \"oblate\", scene: \"{}\", reference: Oblate), (name: \"stomatocyte\", \
         scene: \"{}\", reference: Stomatocyte, reduced_volumes: [0.6])]",
        branch_scene("oblate.ron").display(),
        branch_scene("stomatocyte.ron").display()
    );
    let fine = "meshes: [(label: \"fine\", set: [(\"membrane.Ellipsoid.level\", 4), \
                (\"membrane.Axisymmetric.mean_edge_length\", 0.5)])]";
    std::fs::write(
        &file,
        format!("ShapeDiagram(name: \"d\", reduced_volumes: [0.9], {branches}, {fine})"),
    )
    .unwrap();
    let loaded = remembrane::workflow::shape_diagram::ShapeDiagram::load(&file).unwrap();
    let vertices = |branch: &str| {
        let walk = loaded.walks.iter().find(|w| w.branch == branch).unwrap();
        walk.points[0]
            .1
            .initial_mesh(&walk.scene_path)
            .unwrap()
            .vertex_count()
    };
    assert_eq!(vertices("oblate"), 2562);
    // 2562-2670 vertices at edge 1/2 (632 at edge 1).
    let sto = vertices("stomatocyte");
    assert!((2400..2800).contains(&sto), "{sto}");
    // Walking only the oblate branch, the stomatocyte's change applies to
    // nothing: refused, naming it.
    std::fs::write(
        &file,
        format!(
            "ShapeDiagram(name: \"d\", reduced_volumes: [0.9], branches: [(name: \"oblate\", \
             scene: \"{}\", reference: Oblate)], {fine})",
            branch_scene("oblate.ron").display()
        ),
    )
    .unwrap();
    let e = remembrane::workflow::shape_diagram::ShapeDiagram::load(&file)
        .err()
        .unwrap()
        .to_string();
    assert!(e.contains("meshes[0].set[1]"), "{e}");
}

/// The oblate branch with the Sobolev minimiser (issue 47): held
/// axisymmetric (`axisymmetric: (0.0, 0.0, 1.0)` in the bundled scene)
/// it stays oblate and every point converges by the force tolerance
/// (642 vertices, v = 0.9, 0.85, 0.8); the same walk without the setting
/// leaves the branch for the prolate one, the triaxial deformation that
/// makes the oblate a saddle near v = 1 growing in the long-wavelength
/// steps of the metric. Measured (2026-12-08, FIRE's largest step 0.1 in
/// the metric): at 2562 vertices the free walk is prolate from v = 0.9
/// (E_b/8πκ = 1.1895, the oblate continuum's 1.2179, the prolate's
/// 1.1896); at 642 vertices it now converges on the saddle by the force
/// tolerance (with the largest step 1 it left from v = 0.85).
#[test]
#[ignore = "slow tier: `.ci/run` runs it; by hand: cargo test -- --ignored --skip by_hand_"]
fn the_oblate_branch_stays_oblate_only_when_held_axisymmetric() {
    let dir = tempfile::tempdir().unwrap();
    let walk = |name: &str, volumes: &str, mesh: &str, set: &str| {
        let file = dir.path().join(format!("{name}.ron"));
        let text = format!(
            "ShapeDiagram(name: \"{name}\", reduced_volumes: [{volumes}], branches: [(name: \
             \"oblate\", scene: \"{}\", reference: Oblate)], meshes: [({mesh}, set: [{set}])])",
            branch_scene("oblate.ron").display()
        );
        std::fs::write(&file, text).unwrap();
        let out = dir.path().join(name);
        let o = remembrane(&[
            "diagram",
            file.to_str().unwrap(),
            "--out",
            out.to_str().unwrap(),
            "--quiet",
        ]);
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let summary: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(out.join("diagram.json")).unwrap())
                .unwrap();
        summary["points"].as_array().unwrap().clone()
    };
    for p in walk("held", "0.9, 0.85, 0.8", "label: \"642\", h: 1.0", "") {
        assert_eq!(p["stopped_by"], "force_residual", "{p}");
        assert_eq!(p["class"], "convex", "{p}");
        let error = p["relative_error"].as_f64().unwrap();
        assert!(error.abs() < 0.004, "{p}");
    }
    let free = walk(
        "free",
        "0.9",
        "label: \"2562\", h: 0.5",
        "(\"membrane.Ellipsoid.level\", 4), (\"resolution\", {\"EdgeLength\": 0.5}), \
         (\"dynamics.method\", {\"Minimise\": {\"force_tolerance\": 1e-3, \"preconditioner\": \
         {\"Sobolev\": {}}}})",
    );
    let last = free.last().unwrap();
    assert_eq!(last["class"], "prolate", "{last}");
    // Below the oblate continuum by more than the mesh's error (the
    // prolate's energy at v = 0.9 is 1.1896 against the oblate's 1.2179).
    assert!(last["relative_error"].as_f64().unwrap() < -0.015, "{last}");
}
