//! A small software renderer: flat-shaded, z-buffered orthographic views of
//! a mesh in its principal frame, written as PNG (side view | top view),
//! optionally coloured by a per-vertex field.

use crate::analysis::shape::principal_frame;
use glam::DVec3;
use std::path::Path;

/// Renders `positions`/`faces` as a side view (symmetry axis vertical) and a
/// top view (looking down the axis), each `size` × `size` pixels, side by
/// side, into PNG bytes.
pub fn render_png(positions: &[DVec3], faces: &[[u32; 3]], size: u32) -> Vec<u8> {
    render_png_coloured(positions, faces, None, size)
}

/// [`render_png`] with each face coloured by the mean of a per-vertex
/// `field` over its corners, from grey-blue at the field's 2nd percentile
/// to red at its 98th (a constant field is drawn at the middle).
pub fn render_png_coloured(
    positions: &[DVec3],
    faces: &[[u32; 3]],
    field: Option<&[f64]>,
    size: u32,
) -> Vec<u8> {
    // The range between the field's 2nd and 98th percentiles, so that a
    // few extreme vertices (a bud's neck) do not wash out the rest.
    let range = field.filter(|f| !f.is_empty()).map(|f| {
        let mut sorted = f.to_vec();
        sorted.sort_by(f64::total_cmp);
        let at = |q: f64| sorted[((sorted.len() - 1) as f64 * q).round() as usize];
        (at(0.02), at(0.98))
    });
    // The base colour of a face: the renderer's red, or the field's.
    let base = |face: &[u32; 3]| -> [f64; 3] {
        match (field, range) {
            (Some(f), Some((lo, hi))) => {
                let mean = face.iter().map(|&v| f[v as usize]).sum::<f64>() / 3.0;
                let t = if hi > lo {
                    ((mean - lo) / (hi - lo)).clamp(0.0, 1.0)
                } else {
                    0.5
                };
                let (cold, hot) = ([90.0, 120.0, 170.0], [225.0, 55.0, 35.0]);
                std::array::from_fn(|k| cold[k] + t * (hot[k] - cold[k]))
            }
            _ => [220.0, 100.0, 100.0],
        }
    };
    let frame = principal_frame(positions, faces);
    let [thin, mid, wide] = frame.axes;
    // Side: screen x = widest axis, screen y = symmetry axis, depth = middle.
    // Top: screen x = widest, screen y = middle axis, depth = symmetry axis.
    let views = [(wide, thin, mid), (wide, mid, thin)];
    let extent = positions
        .iter()
        .map(|p| (*p - frame.centroid).length())
        .fold(0.0, f64::max)
        * 1.1;
    let (w, h) = (2 * size as usize, size as usize);
    let mut rgb = vec![245u8; w * h * 3];
    for (panel, &(sx, sy, depth)) in views.iter().enumerate() {
        let mut zbuf = vec![f64::NEG_INFINITY; h * size as usize];
        let project = |p: DVec3| {
            let d = p - frame.centroid;
            let scale = 0.5 * size as f64 / extent;
            (
                0.5 * size as f64 + d.dot(sx) * scale,
                0.5 * size as f64 - d.dot(sy) * scale,
                d.dot(depth),
            )
        };
        let light = (0.4 * sx + 0.6 * sy + 0.7 * depth).normalize();
        for f in faces {
            let [a, b, c] = f.map(|v| positions[v as usize]);
            let n = (b - a).cross(c - a).normalize_or_zero();
            if n.dot(depth) <= 0.0 {
                continue; // back face of a closed surface
            }
            let shade = 0.25 + 0.75 * n.dot(light).max(0.0);
            let [red, green, blue] = base(f);
            // (With the renderer's red, the colours it always drew.)
            let color = [
                (70.0 + (red - 70.0) * shade) as u8,
                (40.0 + (green - 40.0) * shade) as u8,
                (40.0 + (blue - 40.0) * shade) as u8,
            ];
            let pts = [project(a), project(b), project(c)];
            let (x0, x1) = (
                pts.iter().map(|p| p.0).fold(f64::MAX, f64::min),
                pts.iter().map(|p| p.0).fold(f64::MIN, f64::max),
            );
            let (y0, y1) = (
                pts.iter().map(|p| p.1).fold(f64::MAX, f64::min),
                pts.iter().map(|p| p.1).fold(f64::MIN, f64::max),
            );
            let area = edge(pts[0], pts[1], pts[2]);
            if area.abs() < 1e-12 {
                continue;
            }
            for py in (y0.floor().max(0.0) as usize)..=(y1.ceil().min(h as f64 - 1.0) as usize) {
                for px in
                    (x0.floor().max(0.0) as usize)..=(x1.ceil().min(size as f64 - 1.0) as usize)
                {
                    let q = (px as f64 + 0.5, py as f64 + 0.5, 0.0);
                    let w0 = edge(pts[1], pts[2], q) / area;
                    let w1 = edge(pts[2], pts[0], q) / area;
                    let w2 = 1.0 - w0 - w1;
                    if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                        continue;
                    }
                    let z = w0 * pts[0].2 + w1 * pts[1].2 + w2 * pts[2].2;
                    let zi = py * size as usize + px;
                    if z > zbuf[zi] {
                        zbuf[zi] = z;
                        let o = (py * w + panel * size as usize + px) * 3;
                        rgb[o..o + 3].copy_from_slice(&color);
                    }
                }
            }
        }
    }
    let mut out = Vec::new();
    {
        let mut encoder = png::Encoder::new(&mut out, w as u32, h as u32);
        encoder.set_color(png::ColorType::Rgb);
        encoder.set_depth(png::BitDepth::Eight);
        if let Ok(mut writer) = encoder.write_header() {
            let _ = writer.write_image_data(&rgb);
        }
    }
    out
}

fn edge(a: (f64, f64, f64), b: (f64, f64, f64), c: (f64, f64, f64)) -> f64 {
    (b.0 - a.0) * (c.1 - a.1) - (b.1 - a.1) * (c.0 - a.0)
}

/// Renders and writes the PNG atomically.
pub fn write_png(
    path: &Path,
    positions: &[DVec3],
    faces: &[[u32; 3]],
    size: u32,
) -> std::io::Result<()> {
    crate::atomic_write(path, &render_png(positions, faces, size))
}
