//! The typed run-directory reader (`remembrane::io::run_dir`): a run's
//! `summary.json` and `series.csv` read back whole, and a renamed or
//! missing field is an error naming the file and the field, not a NaN.

use remembrane::io::run_dir::Series;
use remembrane::io::summary::RunSummary;
use std::process::Command;

#[test]
fn a_run_directory_reads_back_typed_and_a_renamed_field_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("run");
    let scene = concat!(
        env!("CARGO_MANIFEST_DIR"),
        "/scenes/minimise/red_blood_cell.ron"
    );
    let o = Command::new(env!("CARGO_BIN_EXE_remembrane"))
        .args(["run", scene, "--out", out.to_str().unwrap(), "--quiet"])
        .args(["--iterations", "300", "--frames", "1"])
        .output()
        .unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let summary = RunSummary::read(&out).unwrap();
    assert_eq!(summary.iterations, 300);
    assert_eq!(summary.last.vertices, 642);
    assert!(summary.last.energies.iter().any(|t| t.term == "bending"));
    let minimiser = summary.minimiser.as_ref().unwrap();
    assert_eq!(minimiser.stopped_by, "iteration_cap");
    assert!(summary.constraints.is_some());
    assert!(summary.timings.iter().any(|t| t.stage == "Forces"));
    let series = Series::read(&out).unwrap();
    assert_eq!(series.first("vertices").unwrap(), 642.0);
    let iterations = series.column("iteration").unwrap();
    assert_eq!(iterations.last().copied(), Some(300.0));
    // Written again, the summary is the same JSON.
    let text = std::fs::read_to_string(out.join("summary.json")).unwrap();
    let again = serde_json::to_value(&summary).unwrap();
    assert_eq!(
        again,
        serde_json::from_str::<serde_json::Value>(&text).unwrap()
    );

    // A renamed field (here a nested one) is named, with the file.
    let renamed = text.replacen("\"force_residual\"", "\"residual\"", 1);
    std::fs::write(out.join("summary.json"), renamed).unwrap();
    let e = RunSummary::read(&out).unwrap_err().to_string();
    assert!(e.contains("summary.json"), "{e}");
    assert!(
        e.contains("field `minimiser.force_residual`: missing"),
        "{e}"
    );
    // A value of the wrong type too.
    let wrong = text.replacen("\"iterations\": 300", "\"iterations\": \"many\"", 1);
    assert_ne!(wrong, text);
    std::fs::write(out.join("summary.json"), wrong).unwrap();
    let e = RunSummary::read(&out).unwrap_err().to_string();
    assert!(e.contains("field `iterations`"), "{e}");
    // A renamed column of series.csv is named when asked for.
    let csv = std::fs::read_to_string(out.join("series.csv")).unwrap();
    std::fs::write(out.join("series.csv"), csv.replacen("vertices", "nodes", 1)).unwrap();
    let e = Series::read(&out)
        .unwrap()
        .first("vertices")
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("series.csv") && e.contains("field `vertices`"),
        "{e}"
    );
}
