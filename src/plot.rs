//! A small PNG chart renderer (RGB canvas, 8×8 bitmap font): bar charts for
//! `compare`, line/point charts with error bars for `collect`. No system
//! fonts or plotting stack needed, so charts render the same everywhere.

use font8x8::UnicodeFonts;

/// White.
pub const BACKGROUND: [u8; 3] = [255, 255, 255];
/// Text and axes.
pub const INK: [u8; 3] = [30, 30, 30];
/// Series colours, in order.
pub const COLORS: [[u8; 3]; 6] = [
    [60, 110, 180],
    [220, 120, 40],
    [60, 160, 80],
    [190, 60, 60],
    [130, 90, 170],
    [120, 120, 120],
];

/// An RGB image.
pub struct Canvas {
    width: usize,
    height: usize,
    pixels: Vec<u8>,
}

impl Canvas {
    /// A blank canvas.
    pub fn new(width: usize, height: usize) -> Self {
        Self {
            width,
            height,
            pixels: BACKGROUND.repeat(width * height),
        }
    }

    /// Fills the rectangle [x0, x1) × [y0, y1) (clipped).
    pub fn rect(&mut self, x0: usize, y0: usize, x1: usize, y1: usize, c: [u8; 3]) {
        for y in y0.min(self.height)..y1.min(self.height) {
            for x in x0.min(self.width)..x1.min(self.width) {
                let i = (y * self.width + x) * 3;
                self.pixels[i..i + 3].copy_from_slice(&c);
            }
        }
    }

    /// A line of thickness 2 from (x0, y0) to (x1, y1) (pixels, clipped).
    pub fn line(&mut self, (x0, y0): (f64, f64), (x1, y1): (f64, f64), c: [u8; 3]) {
        let steps = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).max(1);
        for k in 0..=steps {
            let t = k as f64 / steps as f64;
            let (x, y) = (x0 + t * (x1 - x0), y0 + t * (y1 - y0));
            if x >= 0.0 && y >= 0.0 {
                self.rect(x as usize, y as usize, x as usize + 2, y as usize + 2, c);
            }
        }
    }

    /// Text with the 8×8 bitmap font scaled by `scale`, centred at `cx`.
    pub fn text(&mut self, cx: usize, y: usize, s: &str, c: [u8; 3], scale: usize) {
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

    /// PNG bytes of the canvas.
    pub fn png(&self) -> Vec<u8> {
        let mut out = Vec::new();
        {
            let mut encoder = png::Encoder::new(&mut out, self.width as u32, self.height as u32);
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            if let Ok(mut writer) = encoder.write_header() {
                let _ = writer.write_image_data(&self.pixels);
            }
        }
        out
    }
}

/// One series of a line chart (an empty name: no legend entry).
#[derive(Clone, Debug, Default)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// Points (x, y); non-finite points are skipped.
    pub points: Vec<(f64, f64)>,
    /// Half-height of an error bar per point (empty = none).
    pub errors: Vec<f64>,
    /// Join the points with lines.
    pub lines: bool,
    /// Draw a marker at each point.
    pub markers: bool,
    /// Colour index into [`COLORS`] (wraps).
    pub color: usize,
}

/// "Nice" tick positions covering [lo, hi].
fn ticks(lo: f64, hi: f64) -> Vec<f64> {
    let span = (hi - lo).max(1e-12);
    let raw = span / 5.0;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0]
        .iter()
        .map(|m| m * mag)
        .find(|s| span / s <= 6.0)
        .unwrap_or(10.0 * mag);
    let mut t = (lo / step).ceil() * step;
    let mut out = Vec::new();
    while t <= hi + 1e-9 * span {
        out.push(t);
        t += step;
    }
    out
}

fn label(v: f64) -> String {
    let s = format!("{v:.3}");
    let s = s.trim_end_matches('0').trim_end_matches('.');
    if s == "-0" { "0".into() } else { s.into() }
}

/// A line/point chart with axes, ticks, title, axis labels and a legend.
pub fn line_chart(title: &str, x_label: &str, y_label: &str, series: &[Series]) -> Vec<u8> {
    let (w, h) = (720usize, 480usize);
    let (left, right, top, bottom) = (80.0, 180.0, 50.0, 60.0);
    let mut c = Canvas::new(w, h);
    let finite = |p: &&(f64, f64)| p.0.is_finite() && p.1.is_finite();
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for s in series {
        for (k, p) in s.points.iter().enumerate().filter(|(_, p)| finite(p)) {
            let e = s
                .errors
                .get(k)
                .copied()
                .filter(|e| e.is_finite())
                .unwrap_or(0.0);
            xs.push(p.0);
            ys.extend([p.1 - e, p.1 + e]);
        }
    }
    let range = |v: &[f64]| {
        let lo = v.iter().copied().fold(f64::INFINITY, f64::min);
        let hi = v.iter().copied().fold(f64::NEG_INFINITY, f64::max);
        if !lo.is_finite() {
            (0.0, 1.0)
        } else if hi - lo < 1e-12 {
            (lo - 0.5, hi + 0.5)
        } else {
            let pad = 0.05 * (hi - lo);
            (lo - pad, hi + pad)
        }
    };
    let (x0, x1) = range(&xs);
    let (y0, y1) = range(&ys);
    let (pw, ph) = (w as f64 - left - right, h as f64 - top - bottom);
    let px = |x: f64| left + (x - x0) / (x1 - x0) * pw;
    let py = |y: f64| top + (1.0 - (y - y0) / (y1 - y0)) * ph;
    // Scale-2 text when the title fits, else scale 1.
    let title_scale = if title.chars().count() * 16 + 20 <= w {
        2
    } else {
        1
    };
    c.text(w / 2, 15, title, INK, title_scale);
    c.text((left + pw / 2.0) as usize, h - 22, x_label, INK, 2);
    c.text(left as usize, (top - 22.0) as usize, y_label, INK, 1);
    c.line((left, top), (left, top + ph), INK);
    c.line((left, top + ph), (left + pw, top + ph), INK);
    for t in ticks(x0, x1) {
        let x = px(t);
        c.line((x, top + ph), (x, top + ph + 5.0), INK);
        c.text(x as usize, (top + ph + 10.0) as usize, &label(t), INK, 1);
    }
    for t in ticks(y0, y1) {
        let y = py(t);
        c.line((left - 5.0, y), (left, y), INK);
        let s = label(t);
        c.text(
            (left - 10.0) as usize - s.len() * 4,
            y as usize - 4,
            &s,
            INK,
            1,
        );
    }
    let mut legend = 0;
    for s in series {
        let color = COLORS[s.color % COLORS.len()];
        let pts: Vec<(usize, (f64, f64))> = s
            .points
            .iter()
            .copied()
            .enumerate()
            .filter(|(_, p)| finite(&p))
            .collect();
        if s.lines {
            for pair in pts.windows(2) {
                let (a, b) = (pair[0].1, pair[1].1);
                c.line((px(a.0), py(a.1)), (px(b.0), py(b.1)), color);
            }
        }
        for &(i, (x, y)) in &pts {
            if s.markers {
                let (cx, cy) = (px(x) as usize, py(y) as usize);
                c.rect(
                    cx.saturating_sub(3),
                    cy.saturating_sub(3),
                    cx + 4,
                    cy + 4,
                    color,
                );
            }
            if let Some(&e) = s.errors.get(i).filter(|e| e.is_finite() && **e > 0.0) {
                c.line((px(x), py(y - e)), (px(x), py(y + e)), color);
            }
        }
        if s.name.is_empty() {
            continue; // unnamed: no legend entry
        }
        let ly = top as usize + 10 + legend * 22;
        legend += 1;
        let lx = (left + pw) as usize + 15;
        c.rect(lx, ly, lx + 14, ly + 14, color);
        c.text(
            lx + 22 + s.name.chars().count() * 4,
            ly + 3,
            &s.name,
            INK,
            1,
        );
    }
    c.png()
}
