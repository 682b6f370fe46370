//! What a study writes: its Markdown, CSV and charts.

use super::*;

pub(super) fn sig(v: f64) -> String {
    if !v.is_finite() {
        return "–".into();
    }
    format!("{v:.3e}")
}

/// The Markdown report.
pub fn markdown(report: &StudyReport) -> String {
    let mut s = format!("# Study `{}`: speed against error\n\n", report.name);
    for p in &report.problems {
        s += &format!("## {}\n\n", p.name);
        if !p.description.is_empty() {
            s += &format!("{}\n\n", p.description);
        }
        let quantities: Vec<String> = p
            .cases
            .iter()
            .find(|c| !c.measurements.is_empty())
            .map(|c| c.measurements.iter().map(|m| m.quantity.clone()).collect())
            .unwrap_or_default();
        s += &case_table(p, &quantities);
        s += &reference_lines(p);
        s += &order_and_cheapest(p, &quantities);
        s += "\n";
    }
    s
}

/// The table of a problem's cases, peers and quoted results.
fn case_table(p: &ProblemResult, quantities: &[String]) -> String {
    let mut s = String::new();
    s += "| engine | rung | N | h | iterations | wall (s) | cost (s) |";
    for q in quantities {
        s += &format!(" {q} | error |");
    }
    s += " status |\n|---|---|---:|---:|---:|---:|---:|";
    for _ in quantities {
        s += "---:|---:|";
    }
    s += "---|\n";
    for c in p.cases.iter().chain(&p.peers) {
        s += &format!(
            "| {} | {} | {} | {} | {} | {} | {} |",
            c.engine,
            c.rung,
            c.vertices,
            sig(c.h),
            c.iterations,
            if c.wall_s.is_finite() {
                format!("{:.3}", c.wall_s)
            } else {
                "–".into()
            },
            sig(c.cost_s)
        );
        for k in 0..quantities.len() {
            match c.measurements.get(k) {
                Some(m) if c.is_reference => s += &format!(" {:.6} | (reference) |", m.measured),
                Some(m) => s += &format!(" {:.6} | {} |", m.measured, sig(m.error)),
                None => s += " – | – |",
            }
        }
        s += &format!(" {} |\n", c.status);
    }
    for q in &p.quoted {
        s += &format!(
            "| {} | {} | {} | – | {} | {:.0} | – |{} quoted: {} |\n",
            q.engine,
            q.rung,
            q.vertices,
            q.iterations,
            q.wall_s,
            " – | – |".repeat(quantities.len()),
            q.source
        );
    }
    s
}

/// The reference values: one line when every case shares them, else one
/// per case; then the peers' notes.
fn reference_lines(p: &ProblemResult) -> String {
    let mut s = String::new();
    let reference_line = |c: &CaseResult| {
        c.measurements
            .iter()
            .map(|m| {
                if m.reference_error > 0.0 {
                    format!(
                        "{} = {:.6} ± {:.1e}",
                        m.quantity, m.reference, m.reference_error
                    )
                } else {
                    format!("{} = {:.6}", m.quantity, m.reference)
                }
            })
            .collect::<Vec<String>>()
            .join(", ")
    };
    let measured: Vec<&CaseResult> = p
        .cases
        .iter()
        .filter(|c| !c.measurements.is_empty())
        .collect();
    let lines: Vec<String> = measured.iter().map(|c| reference_line(c)).collect();
    let noted = measured.iter().any(|c| !c.note.is_empty());
    if !noted && lines.windows(2).all(|w| w[0] == w[1]) {
        if let Some(line) = lines.first() {
            s += &format!("\nReference: {line}.\n");
        }
    } else {
        s += "\nReference per case (each at the case's own state):\n";
        for (c, line) in measured.iter().zip(&lines) {
            let note = if c.note.is_empty() {
                String::new()
            } else {
                format!(" ({})", c.note)
            };
            s += &format!("- `{}`: {line}{note}\n", c.rung);
        }
    }
    let mut noted = std::collections::BTreeSet::new();
    for c in &p.peers {
        if !c.note.is_empty() && noted.insert((c.engine.clone(), c.note.clone())) {
            s += &format!("- {} `{}`: {}\n", c.engine, c.rung, c.note);
        }
    }
    s
}

/// The observed order of the error and the cheapest rung reaching each
/// target.
fn order_and_cheapest(p: &ProblemResult, quantities: &[String]) -> String {
    let mut s = String::new();
    match p.order {
        Some(o) if o.std_error.is_finite() => {
            s += &format!(
                "Observed order of the {} error: p = {:.2} ± {:.2} ({} points; error ∝ h^p, {}).\n",
                quantities.first().map_or("", String::as_str),
                o.p,
                o.std_error,
                o.points,
                p.h_label
            )
        }
        Some(o) => {
            s += &format!(
                "Observed order: p = {:.2} (2 points; {}).\n",
                o.p, p.h_label
            )
        }
        None => s += "Observed order: not fitted (turned off, or fewer than two measured cases).\n",
    }
    for c in &p.cheapest {
        match &c.rung {
            Some((rung, cost)) => {
                s += &format!(
                    "- every error ≤ {:.0e}: `{rung}`, {} ({})\n",
                    c.target,
                    sig(*cost),
                    p.cost_label
                )
            }
            None => s += &format!("- every error ≤ {:.0e}: not reached\n", c.target),
        }
    }
    s
}

/// The long-format CSV: one row per (case, quantity).
pub fn csv(report: &StudyReport) -> String {
    let mut s = String::from(
        "engine,problem,rung,h,vertices,iterations,simulated_time_s,wall_s,cost_s,status,is_reference,quantity,measured,reference,reference_error,relative_error\n",
    );
    for p in &report.problems {
        for c in p.cases.iter().chain(&p.peers) {
            let head = format!(
                "{},{},{},{:e},{},{},{:e},{:e},{:e},{},{}",
                c.engine,
                p.name,
                c.rung,
                c.h,
                c.vertices,
                c.iterations,
                c.simulated_time,
                c.wall_s,
                c.cost_s,
                c.status.replace(',', ";"),
                c.is_reference
            );
            if c.measurements.is_empty() {
                s += &format!("{head},,,,,\n");
            }
            for m in &c.measurements {
                s += &format!(
                    "{head},{},{:e},{:e},{:e},{:e}\n",
                    m.quantity, m.measured, m.reference, m.reference_error, m.error
                );
            }
        }
    }
    s
}

/// One triangle-marked series per peer: (x(case), primary error).
pub(super) fn peer_series(p: &ProblemResult, x: fn(&CaseResult) -> f64) -> Vec<Series> {
    let mut names: Vec<&str> = Vec::new();
    for c in &p.peers {
        if !names.contains(&c.engine.as_str()) {
            names.push(&c.engine);
        }
    }
    names
        .iter()
        .enumerate()
        .map(|(k, name)| Series {
            name: (*name).to_string(),
            points: p
                .peers
                .iter()
                .filter(|c| c.engine == *name)
                .filter_map(|c| Some((x(c), c.primary_error()?)))
                .collect(),
            markers: true,
            marker: Marker::Triangle,
            // Not the Pareto front's colour (3).
            color: [2, 4, 5][k % 3],
            ..Default::default()
        })
        .collect()
}

/// The charts of one problem: error against cost with the Pareto front,
/// and error against h with the fitted order.
pub fn charts(p: &ProblemResult) -> [(String, Vec<u8>); 2] {
    let quantity = p
        .cases
        .iter()
        .find_map(|c| c.measurements.first())
        .map_or("error".to_string(), |m| {
            format!("relative error of {}", m.quantity)
        });
    let points: Vec<(f64, f64)> = p
        .cases
        .iter()
        .filter_map(|c| Some((c.cost_s, c.primary_error()?)))
        .collect();
    let cost = Chart {
        title: format!("{}: error against cost", p.name),
        x_label: p.cost_label.clone(),
        y_label: quantity.clone(),
        x_scale: Scale::Log,
        y_scale: Scale::Log,
        series: vec![
            Series {
                name: "remembrane".into(),
                points: points.clone(),
                markers: true,
                ..Default::default()
            },
            Series {
                name: "Pareto front".into(),
                points: pareto_front(&points),
                lines: true,
                color: 3,
                ..Default::default()
            },
        ]
        .into_iter()
        .chain(peer_series(p, |c| c.cost_s))
        .collect(),
        // Dominated points (expensive and inexact) sit upper right.
        legend: Legend::LowerLeft,
    };
    let by_h: Vec<(f64, f64)> = p
        .cases
        .iter()
        .filter_map(|c| Some((c.h, c.primary_error()?)))
        .collect();
    let mut series = vec![Series {
        name: "remembrane".into(),
        points: by_h.clone(),
        markers: true,
        ..Default::default()
    }];
    if let Some(o) = p.order {
        // The fitted line through the fitted points' centroid in log-log.
        let (cx, cy) = o.centroid;
        let (lo, hi) = by_h
            .iter()
            .filter(|q| q.0 > 0.0 && q.1 > 0.0)
            .fold((f64::INFINITY, 0.0f64), |(a, b), q| {
                (a.min(q.0), b.max(q.0))
            });
        let line = |h: f64| (h, cy * (h / cx).powf(o.p));
        series.push(Series {
            name: format!("fit: p = {:.2}", o.p),
            points: vec![line(lo), line(hi)],
            lines: true,
            color: 1,
            ..Default::default()
        });
    }
    series.extend(peer_series(p, |c| c.h));
    let resolution = Chart {
        title: format!("{}: convergence", p.name),
        x_label: p.h_label.clone(),
        y_label: quantity,
        x_scale: Scale::Log,
        y_scale: Scale::Log,
        series,
        legend: Legend::LowerRight,
    };
    [
        (
            format!("{}_error_vs_cost.png", p.name),
            crate::io::plot::chart(&cost),
        ),
        (
            format!("{}_error_vs_h.png", p.name),
            crate::io::plot::chart(&resolution),
        ),
    ]
}

/// Writes `study.csv`, `study.md`, `study.json` and the charts into `out`.
pub fn write_report(report: &StudyReport, out: &Path) -> Result<(), StudyError> {
    let write = |name: &str, bytes: &[u8]| {
        let path = out.join(name);
        crate::atomic_write(&path, bytes).map_err(|e| StudyError::Output {
            path: path.clone(),
            reason: e.to_string(),
        })
    };
    write("study.csv", csv(report).as_bytes())?;
    write("study.md", markdown(report).as_bytes())?;
    let json = serde_json::to_string_pretty(report).expect("the report serialises");
    write("study.json", json.as_bytes())?;
    for p in &report.problems {
        for (name, png) in charts(p) {
            write(&name, &png)?;
        }
    }
    Ok(())
}
