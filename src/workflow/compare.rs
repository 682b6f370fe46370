//! Comparison of two remeshing runs (paper Fig 3C/D): number of remesh
//! events and the spread σ(|r|) of their positions, as a table, a CSV and
//! a PNG bar chart.

use crate::io::plot::{BarPanel, bar_chart};
use crate::io::summary::RunSummary;

/// One row of the comparison.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ComparisonRow {
    /// Scene name.
    pub scene: String,
    /// Successful splits + merges.
    pub events: u64,
    /// Successful splits.
    pub splits: u64,
    /// Successful merges.
    pub merges: u64,
    /// σ(|r|) of the event positions (l̄).
    pub position_spread: f64,
    /// Iterations run.
    pub iterations: u64,
}

impl ComparisonRow {
    /// The row of a finished run.
    pub fn from_summary(s: &RunSummary) -> Self {
        Self {
            scene: s.last.scene.clone(),
            events: s.remesh.events,
            splits: s.remesh.split.success,
            merges: s.remesh.merge.success,
            position_spread: s.remesh.event_position_spread,
            iterations: s.iterations,
        }
    }
}

/// The comparison as aligned text, with the ratio second/first.
pub fn table(rows: &[ComparisonRow; 2]) -> String {
    let mut s = format!(
        "{:<24} {:>10} {:>8} {:>8} {:>12}\n",
        "scene", "events", "splits", "merges", "sigma |r|"
    );
    for r in rows {
        s += &format!(
            "{:<24} {:>10} {:>8} {:>8} {:>12.4}\n",
            r.scene, r.events, r.splits, r.merges, r.position_spread
        );
    }
    let ratio = |a: f64, b: f64| {
        if a > 0.0 {
            format!("{:.2}", b / a)
        } else {
            "n/a".into()
        }
    };
    s += &format!(
        "{:<24} {:>10} {:>8} {:>8} {:>12}\n",
        "ratio (2nd / 1st)",
        ratio(rows[0].events as f64, rows[1].events as f64),
        ratio(rows[0].splits as f64, rows[1].splits as f64),
        ratio(rows[0].merges as f64, rows[1].merges as f64),
        ratio(rows[0].position_spread, rows[1].position_spread)
    );
    s
}

/// The comparison as CSV.
pub fn csv(rows: &[ComparisonRow; 2]) -> String {
    let mut s = String::from("scene,iterations,events,splits,merges,position_spread\n");
    for r in rows {
        s += &format!(
            "{},{},{},{},{},{:e}\n",
            r.scene, r.iterations, r.events, r.splits, r.merges, r.position_spread
        );
    }
    s
}

/// A PNG with two panels: remesh events and σ(|r|), one bar per run
/// labelled with its value, the scene names under the bars.
pub fn chart_png(rows: &[ComparisonRow; 2]) -> Vec<u8> {
    let labels: Vec<String> = rows.iter().map(|r| r.scene.clone()).collect();
    bar_chart(&[
        BarPanel {
            title: "remesh events".into(),
            labels: labels.clone(),
            values: rows.iter().map(|r| r.events as f64).collect(),
            format: |v| format!("{v:.0}"),
        },
        BarPanel {
            title: "σ(|r|) of the vertices".into(),
            labels,
            values: rows.iter().map(|r| r.position_spread).collect(),
            format: |v| format!("{v:.3}"),
        },
    ])
}
