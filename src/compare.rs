//! Comparison of two remeshing runs (paper Fig 3C/D): number of remesh
//! events and the spread σ(|r|) of their positions, as a table, a CSV and
//! a PNG bar chart.

use crate::plot::{COLORS, Canvas, INK};
use crate::run::RunSummary;

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

const W: usize = 640;
const H: usize = 360;

/// A chart panel: title, the two values, and how to print a value.
type Panel = (&'static str, [f64; 2], fn(f64) -> String);

/// A PNG with two panels: remesh events and σ(|r|), one bar per run,
/// labelled with its value; scene names in the legend.
pub fn chart_png(rows: &[ComparisonRow; 2]) -> Vec<u8> {
    let mut c = Canvas::new(W, H);
    let panels: [Panel; 2] = [
        (
            "remesh events",
            [rows[0].events as f64, rows[1].events as f64],
            |v| format!("{v:.0}"),
        ),
        (
            "sigma |r|",
            [rows[0].position_spread, rows[1].position_spread],
            |v| format!("{v:.3}"),
        ),
    ];
    let (top, bottom) = (60, 280);
    for (p, (title, values, label)) in panels.iter().enumerate() {
        let x_mid = W / 4 + p * W / 2;
        c.text(x_mid, 20, title, INK, 2);
        c.rect(x_mid - 110, bottom, x_mid + 110, bottom + 2, INK);
        let max = values
            .iter()
            .copied()
            .fold(0.0, f64::max)
            .max(f64::MIN_POSITIVE);
        for (k, &v) in values.iter().enumerate() {
            let height = ((v / max) * (bottom - top) as f64) as usize;
            let x0 = x_mid - 90 + k * 100;
            c.rect(x0, bottom - height, x0 + 80, bottom, COLORS[k]);
            c.text(x0 + 40, bottom - height - 20, &label(v), INK, 2);
        }
    }
    for (k, r) in rows.iter().enumerate() {
        let y = 300 + k * 24;
        c.rect(40, y, 56, y + 16, COLORS[k]);
        c.text(70 + r.scene.chars().count() * 8, y, &r.scene, INK, 2);
    }
    c.png()
}
