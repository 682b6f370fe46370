//! Comparison of two remeshing runs (paper Fig 3C/D): number of remesh
//! events and the spread σ(|r|) of their positions, as a table, a CSV and
//! a PNG bar chart.

use crate::run::RunSummary;
use font8x8::UnicodeFonts;

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
const BACKGROUND: [u8; 3] = [255, 255, 255];
const INK: [u8; 3] = [30, 30, 30];
const COLORS: [[u8; 3]; 2] = [[60, 110, 180], [220, 120, 40]];

/// A chart panel: title, the two values, and how to print a value.
type Panel = (&'static str, [f64; 2], fn(f64) -> String);

struct Canvas(Vec<u8>);

impl Canvas {
    fn rect(&mut self, x0: usize, y0: usize, x1: usize, y1: usize, c: [u8; 3]) {
        for y in y0.min(H)..y1.min(H) {
            for x in x0.min(W)..x1.min(W) {
                self.0[(y * W + x) * 3..(y * W + x) * 3 + 3].copy_from_slice(&c);
            }
        }
    }

    /// Text with the 8×8 bitmap font scaled by 2, centred at `cx`.
    fn text(&mut self, cx: usize, y: usize, s: &str, c: [u8; 3]) {
        let scale = 2;
        let width = s.chars().count() * 8 * scale;
        let x0 = cx.saturating_sub(width / 2);
        for (k, ch) in s.chars().enumerate() {
            let glyph = font8x8::BASIC_FONTS.get(ch).unwrap_or([0; 8]);
            for (row, bits) in glyph.iter().enumerate() {
                for col in 0..8 {
                    if bits & (1 << col) != 0 {
                        let x = x0 + (k * 8 + col) * scale;
                        let yy = y + row * scale;
                        self.rect(x, yy, x + scale, yy + scale, c);
                    }
                }
            }
        }
    }
}

/// A PNG with two panels: remesh events and σ(|r|), one bar per run,
/// labelled with its value; scene names in the legend.
pub fn chart_png(rows: &[ComparisonRow; 2]) -> Vec<u8> {
    let mut c = Canvas(BACKGROUND.repeat(W * H));
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
        c.text(x_mid, 20, title, INK);
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
            c.text(x0 + 40, bottom - height - 20, &label(v), INK);
        }
    }
    for (k, r) in rows.iter().enumerate() {
        let y = 300 + k * 24;
        c.rect(40, y, 56, y + 16, COLORS[k]);
        c.text(70 + r.scene.chars().count() * 8, y, &r.scene, INK);
    }
    let mut out = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut out, W as u32, H as u32);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        if let Ok(mut writer) = encoder.write_header() {
            let _ = writer.write_image_data(&c.0);
        }
    }
    out
}
