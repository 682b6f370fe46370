//! What a diagram writes: its CSV, Markdown table and chart.

use super::*;

/// Writes `diagram.csv`, `diagram.md`, `diagram.json` and `diagram.png`.
pub(super) fn write_outputs(
    dir: &Path,
    s: &DiagramSummary,
) -> Result<(), (PathBuf, std::io::Error)> {
    let write = |name: &str, bytes: &[u8]| {
        let path = dir.join(name);
        crate::atomic_write(&path, bytes).map_err(|e| (path, e))
    };
    write("diagram.csv", csv(s).as_bytes())?;
    write("diagram.md", markdown(s).as_bytes())?;
    let json = serde_json::to_string_pretty(s).unwrap_or_default();
    write("diagram.json", json.as_bytes())?;
    write("diagram.png", &chart(s))
}

pub(super) fn num(x: f64) -> String {
    if x.is_finite() {
        format!("{x}")
    } else {
        String::new()
    }
}

/// `diagram.csv`: one row per point.
pub fn csv(s: &DiagramSummary) -> String {
    let mut out = String::from(
        "mesh,branch,reference_branch,target_v,status,vertices,v,energy_over_8pi_kappa,\
         reference,reference_error,relative_error,pressure,reference_pressure,tension,\
         reference_tension,class,converged,stopped_by,iterations,remesh_events,wall_time_s\n",
    );
    for p in &s.points {
        let r = p.reference;
        let row = [
            p.mesh.clone(),
            p.branch.clone(),
            p.reference_branch.to_string(),
            num(p.target),
            p.status.replace([',', '\n'], ";"),
            p.vertices.to_string(),
            num(p.reduced_volume),
            num(p.energy),
            r.map_or(String::new(), |r| num(r.energy)),
            r.map_or(String::new(), |r| num(r.error)),
            p.relative_error.map_or(String::new(), num),
            num(p.pressure),
            r.map_or(String::new(), |r| num(r.pressure)),
            num(p.tension),
            r.map_or(String::new(), |r| num(r.tension)),
            p.class.clone(),
            p.converged.to_string(),
            p.stopped_by.clone(),
            p.iterations.to_string(),
            p.remesh_events.to_string(),
            num(p.wall_time_s),
        ];
        out.push_str(&row.join(","));
        out.push('\n');
    }
    out
}

/// `diagram.md`: the table, the crossings and the wall time.
pub fn markdown(s: &DiagramSummary) -> String {
    let mut out = format!(
        "# Shape diagram `{}`\n\nE_b/8πκ against the reduced volume v; the continuum is the \
         axisymmetric solver's (Richardson-extrapolated) on the same branch. Δp in κ/R0³, σ in \
         κ/R0², R0 = √(A/4π).\n\n\
         | mesh | branch | v | vertices | E_b/8πκ | continuum | error | Δp (continuum) | \
         σ (continuum) | shape | iterations | stopped by | s |\n\
         |---|---|---:|---:|---:|---:|---:|---|---|---|---:|---|---:|\n",
        s.name
    );
    for p in &s.points {
        if p.status != "completed" {
            out.push_str(&format!(
                "| {} | {} | {} | | {} | | | | | | | | |\n",
                p.mesh, p.branch, p.target, p.status
            ));
            continue;
        }
        let (reference, error, dp, sigma) = match p.reference {
            Some(r) => (
                format!("{:.4}", r.energy),
                p.relative_error
                    .map_or(String::new(), |e| format!("{:+.2} %", 100.0 * e)),
                format!("{:.3} ({:.3})", p.pressure, r.pressure),
                format!("{:.3} ({:.3})", p.tension, r.tension),
            ),
            None => (
                "none".into(),
                String::new(),
                format!("{:.3}", p.pressure),
                format!("{:.3}", p.tension),
            ),
        };
        out.push_str(&format!(
            "| {} | {} | {} | {} | {:.4} | {reference} | {error} | {dp} | {sigma} | {} | {} | {} | {:.2} |\n",
            p.mesh,
            p.branch,
            p.target,
            p.vertices,
            p.energy,
            p.class,
            p.iterations,
            p.stopped_by,
            p.wall_time_s
        ));
    }
    if !s.crossings.is_empty() {
        out.push_str("\n| crossing | on | v | E_b/8πκ |\n|---|---|---:|---:|\n");
        for c in &s.crossings {
            out.push_str(&format!(
                "| {} / {} | {} | {:.4} | {:.4} |\n",
                c.branches.0, c.branches.1, c.mesh, c.reduced_volume, c.energy
            ));
        }
    }
    if !s.extrapolated.is_empty() {
        out.push_str(
            "\nExtrapolated to h → 0 (order 2, from the two finest meshes):\n\n\
             | branch | v | meshes | E_b/8πκ | continuum | error |\n|---|---:|---|---:|---:|---:|\n",
        );
        for e in &s.extrapolated {
            out.push_str(&format!(
                "| {} | {} | {}, {} | {:.5} | {} | {} |\n",
                e.branch,
                e.target,
                e.meshes.0,
                e.meshes.1,
                e.energy,
                e.reference.map_or("none".into(), |r| format!("{r:.5}")),
                e.relative_error
                    .map_or(String::new(), |x| format!("{:+.3} %", 100.0 * x))
            ));
        }
    }
    out.push_str(&format!("\nWall time: {:.1} s.\n", s.wall_time_s));
    out
}

/// `diagram.png`: the continuum curves as lines, each mesh's points as
/// markers in its branch's colour.
pub(super) fn chart(s: &DiagramSummary) -> Vec<u8> {
    use crate::io::plot::{Chart, Legend, Marker, Series};
    let colour = |b: Branch| match b {
        Branch::Prolate => 0,
        Branch::Oblate => 1,
        Branch::Stomatocyte => 2,
    };
    let mut series: Vec<Series> = s
        .curves
        .iter()
        .map(|(b, c)| Series {
            name: format!("{b} (continuum)"),
            points: c.clone(),
            lines: true,
            color: colour(*b),
            ..Default::default()
        })
        .collect();
    let mut meshes: Vec<&str> = s.points.iter().map(|p| p.mesh.as_str()).collect();
    meshes.dedup();
    for (m, mesh) in meshes.iter().enumerate() {
        let mut branches: Vec<(&str, Branch)> = s
            .points
            .iter()
            .filter(|p| p.mesh == *mesh)
            .map(|p| (p.branch.as_str(), p.reference_branch))
            .collect();
        branches.dedup();
        for (b, kind) in branches {
            let points = s
                .points
                .iter()
                .filter(|p| p.mesh == *mesh && p.branch == b && p.status == "completed")
                .map(|p| (p.reduced_volume, p.energy))
                .collect();
            series.push(Series {
                name: format!("{b}, {mesh}"),
                points,
                markers: true,
                marker: if m % 2 == 0 {
                    Marker::Circle
                } else {
                    Marker::Triangle
                },
                color: colour(kind),
                ..Default::default()
            });
        }
    }
    crate::io::plot::chart(&Chart {
        title: format!("Shape diagram: {}", s.name),
        x_label: "reduced volume v".into(),
        y_label: "E_b / 8πκ".into(),
        series,
        legend: Legend::UpperRight,
        ..Default::default()
    })
}
