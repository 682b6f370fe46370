//! Protein species in scenes: their fields relax with the minimiser, the
//! counts hold, the outputs carry them, and bad declarations are refused
//! with the file, the field and the reason, before anything is written.

use crate::common::{cli, summary};
use remembrane::scene::Scene;
use remembrane::species::model::SpeciesStatus;
use std::path::{Path, PathBuf};

/// A 162-vertex vesicle at its initial volume (v = 0.90) with one conserved species
/// that prefers positive curvature; `species` replaces the declaration.
fn scene_text(species: &str) -> String {
    format!(
        r#"Scene(
    name: "species",
    membrane: Ellipsoid(level: 2, semi_axes: (3.6, 3.6, 2.0)),
    model: Fluid(),
    energy: [
        Vin(form: Exact),
        Bending(kappa: 1.0),
    ],
    constraints: (
        area: OfInitial(1.0),
        volume: OfInitial(1.0),
    ),
    dynamics: (
        method: Minimise(force_tolerance: 1e-3, field_tolerance: 1e-10),
        iterations: 1500,
        frames: 4,
    ),
    remesh: (mode: FreeEnergy),
    species: {species},
)"#
    )
}

const BAR: &str = r#"(
        species: [(
            name: "bar",
            area_per_protein: 0.05,
            curvature_coupling: 4.0,
            initial: Fraction(0.2),
        )],
    )"#;

fn write(dir: &Path, text: &str) -> PathBuf {
    let path = dir.join("scene.ron");
    std::fs::write(&path, text).unwrap();
    path
}

/// The run's output directory and whether the CLI succeeded.
fn run(dir: &Path, text: &str) -> (PathBuf, bool) {
    let path = write(dir, text);
    let out = dir.join("out");
    let code = cli(&[&"run", &path, &"--out", &out, &"--quiet"]);
    (out, code == std::process::ExitCode::SUCCESS)
}

#[test]
fn a_species_relaxes_with_the_shape_and_its_count_holds() {
    let dir = tempfile::tempdir().unwrap();
    let (out, ok) = run(dir.path(), &scene_text(BAR));
    assert!(ok);
    let s = summary(&out);
    let status: SpeciesStatus = s.section("species").unwrap().unwrap();
    assert_eq!(status.names, ["bar"]);
    let (n0, n) = (status.initial_counts[0], status.counts[0]);
    assert!(
        (n - n0).abs() <= 1e-12 * n0,
        "{n0} proteins at the start, {n} at the end"
    );
    assert!(
        status.relaxations > 0 && status.residual <= 1e-10,
        "{status:?}"
    );
    assert!(status.chemical_potentials[0].is_finite());
    // The outputs: phi_bar in final.ply, the species columns in series.csv.
    let ply = std::fs::read(out.join("final.ply")).unwrap();
    let header = String::from_utf8_lossy(&ply[..ply.len().min(2000)]).to_string();
    assert!(header.contains("phi_bar"), "{header}");
    for column in [
        "count_bar",
        "mu_bar",
        "phi_min_bar",
        "phi_mean_bar",
        "phi_max_bar",
    ] {
        let values = crate::common::series_column(&out, column);
        assert!(!values.is_empty(), "{column}");
    }
    let counts = crate::common::series_column(&out, "count_bar");
    assert!(
        counts.iter().all(|c| (c - n0).abs() <= 1e-12 * n0),
        "{counts:?}"
    );
    // The proteins sorted to the curved rim: the field is not uniform.
    let (lo, hi) = (
        crate::common::series_column(&out, "phi_min_bar"),
        crate::common::series_column(&out, "phi_max_bar"),
    );
    assert!(
        hi.last().unwrap() > &(1.2 * lo.last().unwrap()),
        "{lo:?} {hi:?}"
    );
}

/// The message of the scene's load-and-build error, and that the CLI
/// refuses it (non-zero, no output directory left behind).
fn refused(species: &str) -> String {
    let dir = tempfile::tempdir().unwrap();
    let text = scene_text(species);
    let path = write(dir.path(), &text);
    let msg = match Scene::load(&path).and_then(|s| s.build(&path).map(|_| ())) {
        Ok(()) => panic!("accepted:\n{text}"),
        Err(e) => e.to_string(),
    };
    assert!(msg.contains("scene.ron"), "{msg}");
    let (out, ok) = run(dir.path(), &text);
    assert!(!ok, "the CLI ran it");
    assert!(!out.exists() && !dir.path().join("out.incomplete").exists());
    msg
}

#[test]
fn bad_species_are_refused_naming_the_file_the_field_and_the_reason() {
    let msg = refused(&BAR.replace("Fraction(0.2)", "Fraction(1.3)"));
    assert!(
        msg.contains("species.species[0].initial") && msg.contains("outside (0, 1)"),
        "{msg}"
    );
    let msg = refused(&BAR.replace("Fraction(0.2)", "Fraction(-0.1)"));
    assert!(msg.contains("species.species[0].initial"), "{msg}");
    let msg = refused(&BAR.replace("area_per_protein: 0.05,", ""));
    assert!(msg.contains("area_per_protein"), "{msg}");
    // 162 vertices on about 110 l̄²: 4000 proteins of 0.05 l̄² need 200.
    let msg = refused(&BAR.replace("Fraction(0.2)", "Count(4000.0)"));
    assert!(
        msg.contains("species.species[0].initial") && msg.contains("cannot carry"),
        "{msg}"
    );
    let msg = refused(&BAR.replace(
        "initial: Fraction(0.2),",
        "initial: Fraction(0.2), chemical_potential: Some(-0.2),",
    ));
    assert!(
        msg.contains("species.species[0].chemical_potential") && msg.contains("conserved"),
        "{msg}"
    );
}
