//! PNG charts drawn with `plotters`: line and point charts with error bars,
//! linear or logarithmic axes and a legend (`collect`, `spectrum`, `study`),
//! and bar panels (`compare`). The font (DejaVu Sans) is embedded in the
//! binary, so a chart looks the same on every machine and needs no system
//! fonts.

use std::sync::Once;

use plotters::coord::Shift;
use plotters::coord::ranged1d::{AsRangedCoord, ValueFormatter};
use plotters::prelude::*;

/// The font family every chart uses (registered from embedded bytes).
const FONT: &str = "sans-serif";

/// Chart size in pixels.
const WIDTH: u32 = 800;
const HEIGHT: u32 = 520;

/// Series colours, in order (matplotlib's first six "tab" colours).
pub const COLORS: [RGBColor; 6] = [
    RGBColor(31, 119, 180),
    RGBColor(255, 127, 14),
    RGBColor(44, 160, 44),
    RGBColor(214, 39, 40),
    RGBColor(148, 103, 189),
    RGBColor(127, 127, 127),
];

/// An axis' scale.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Scale {
    /// Linear.
    #[default]
    Linear,
    /// Base-10 logarithmic; non-positive values are left out.
    Log,
}

/// How a series marks its points.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Marker {
    /// A filled circle.
    #[default]
    Circle,
    /// A filled triangle (used for peer engines on the study charts).
    Triangle,
}

/// One series of a line chart (an empty name: no legend entry).
#[derive(Clone, Debug, Default)]
pub struct Series {
    /// Legend entry.
    pub name: String,
    /// Points (x, y); non-finite points (and non-positive ones on a log axis)
    /// are skipped.
    pub points: Vec<(f64, f64)>,
    /// Half-height of an error bar per point (empty = none).
    pub errors: Vec<f64>,
    /// Join the points with lines.
    pub lines: bool,
    /// Draw a marker at each point.
    pub markers: bool,
    /// The marker's shape.
    pub marker: Marker,
    /// Colour index into [`COLORS`] (wraps).
    pub color: usize,
}

/// A line/point chart: title, axis labels and scales, series.
#[derive(Clone, Debug, Default)]
pub struct Chart {
    /// Title above the plot.
    pub title: String,
    /// x-axis label.
    pub x_label: String,
    /// y-axis label.
    pub y_label: String,
    /// x-axis scale.
    pub x_scale: Scale,
    /// y-axis scale.
    pub y_scale: Scale,
    /// The series, drawn in order.
    pub series: Vec<Series>,
    /// Where the legend goes (default upper right).
    pub legend: Legend,
}

/// Where a chart's legend goes.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Legend {
    /// Upper right (for falling data).
    #[default]
    UpperRight,
    /// Lower right (for rising data).
    LowerRight,
    /// Lower left (error against cost: no point is both cheap and exact).
    LowerLeft,
}

/// A panel of a bar chart: one bar per label, each labelled with its value.
pub struct BarPanel {
    /// Title above the panel.
    pub title: String,
    /// One label (x tick) per bar.
    pub labels: Vec<String>,
    /// The bar heights.
    pub values: Vec<f64>,
    /// How a value is printed above its bar.
    pub format: fn(f64) -> String,
}

fn register_font() {
    static ONCE: Once = Once::new();
    ONCE.call_once(|| {
        // The bytes are a valid TrueType font compiled into the binary.
        let _ = plotters::style::register_font(FONT, FontStyle::Normal, dejavu::sans::regular());
    });
}

/// Why a chart could not be drawn or encoded.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// Drawing on the canvas failed.
    #[error("{0}")]
    Drawing(String),
    /// The PNG could not be encoded.
    #[error(transparent)]
    Png(#[from] png::EncodingError),
}

/// Renders `draw` on a white RGB canvas and returns the PNG bytes.
fn render(
    draw: impl FnOnce(&DrawingArea<BitMapBackend<'_>, Shift>) -> Result<(), PlotError>,
) -> Result<Vec<u8>, PlotError> {
    register_font();
    let mut pixels = vec![255u8; (WIDTH * HEIGHT * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut pixels, (WIDTH, HEIGHT)).into_drawing_area();
        root.fill(&WHITE).map_err(drawing_error)?;
        draw(&root)?;
        root.present().map_err(drawing_error)?;
    }
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, WIDTH, HEIGHT);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header()?;
    writer.write_image_data(&pixels)?;
    writer.finish()?;
    Ok(out)
}

/// A linear line/point chart (see [`Chart`] for log axes).
pub fn line_chart(title: &str, x_label: &str, y_label: &str, series: &[Series]) -> Vec<u8> {
    chart(&Chart {
        title: title.into(),
        x_label: x_label.into(),
        y_label: y_label.into(),
        series: series.to_vec(),
        ..Default::default()
    })
}

/// PNG bytes of a chart (an empty PNG-less vector only if drawing failed,
/// which a fixed-size in-memory canvas does not do).
pub fn chart(spec: &Chart) -> Vec<u8> {
    render(|root| draw_chart(root, spec)).unwrap_or_default()
}

/// The range an axis shows: the data's extent with 5 % padding (a factor on
/// a log axis), or a unit range when there is no data.
fn axis_range(values: &[f64], scale: Scale) -> (f64, f64) {
    let usable: Vec<f64> = values
        .iter()
        .copied()
        .filter(|v| v.is_finite() && (scale == Scale::Linear || *v > 0.0))
        .collect();
    let lo = usable.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = usable.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    match scale {
        _ if !lo.is_finite() => match scale {
            Scale::Linear => (0.0, 1.0),
            Scale::Log => (0.1, 10.0),
        },
        Scale::Linear if hi - lo < 1e-12 * lo.abs().max(1.0) => (lo - 0.5, hi + 0.5),
        Scale::Linear => {
            let pad = 0.05 * (hi - lo);
            (lo - pad, hi + pad)
        }
        Scale::Log if hi / lo < 1.0 + 1e-9 => (lo / 2.0, hi * 2.0),
        Scale::Log => {
            let pad = (hi / lo).powf(0.05);
            (lo / pad, hi * pad)
        }
    }
}

/// A tick label: at most 4 significant digits, scientific notation for
/// very large or small magnitudes.
fn tick_label(v: f64) -> String {
    let a = v.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        let s = format!("{v:.2e}");
        let (m, e) = s.split_once('e').unwrap_or((&s, "0"));
        let m = m.trim_end_matches('0').trim_end_matches('.');
        return format!("{m}e{e}");
    }
    let s = format!(
        "{:.*}",
        (3 - a.log10().floor().max(-3.0) as i32).clamp(0, 6) as usize,
        v
    );
    let s = if s.contains('.') {
        s.trim_end_matches('0').trim_end_matches('.').to_string()
    } else {
        s
    };
    if s == "-0" { "0".into() } else { s }
}

fn draw_chart(root: &DrawingArea<BitMapBackend<'_>, Shift>, spec: &Chart) -> Result<(), PlotError> {
    let mut xs = Vec::new();
    let mut ys = Vec::new();
    for s in &spec.series {
        for (k, p) in s.points.iter().enumerate() {
            if !(p.0.is_finite() && p.1.is_finite()) {
                continue;
            }
            let e = s
                .errors
                .get(k)
                .copied()
                .filter(|e| e.is_finite())
                .unwrap_or(0.0);
            xs.push(p.0);
            ys.extend([p.1, p.1 - e, p.1 + e]);
        }
    }
    let (x0, x1) = axis_range(&xs, spec.x_scale);
    let (y0, y1) = axis_range(&ys, spec.y_scale);
    // Log axes get their ticks from `log_ticks`: plotters' own log key
    // points leave a range shorter than a decade without any.
    let log_x = || (x0..x1).log_scale().with_key_points(log_ticks(x0, x1));
    let log_y = || (y0..y1).log_scale().with_key_points(log_ticks(y0, y1));
    match (spec.x_scale, spec.y_scale) {
        (Scale::Linear, Scale::Linear) => draw_series(root, spec, x0..x1, y0..y1),
        (Scale::Linear, Scale::Log) => draw_series(root, spec, x0..x1, log_y()),
        (Scale::Log, Scale::Linear) => draw_series(root, spec, log_x(), y0..y1),
        (Scale::Log, Scale::Log) => draw_series(root, spec, log_x(), log_y()),
    }
}

/// Ticks of a log axis over [lo, hi]: the values 1, 2 and 5 times a power of
/// ten inside it, or, when fewer than three are, 1 to 9 times (a range
/// shorter than a decade), or else 10 steps of the range's own order.
fn log_ticks(lo: f64, hi: f64) -> Vec<f64> {
    // m·10^k rounded once (0.3, not 3 × 0.1).
    let scaled = |m: f64, k: i32| {
        if k < 0 {
            m / 10f64.powi(-k)
        } else {
            m * 10f64.powi(k)
        }
    };
    let within = |mantissas: &[f64]| -> Vec<f64> {
        let (first, last) = (lo.log10().floor() as i32, hi.log10().ceil() as i32);
        let mut ticks: Vec<f64> = (first..=last)
            .flat_map(|k| mantissas.iter().map(move |&m| scaled(m, k)))
            .filter(|v| *v >= lo * (1.0 - 1e-12) && *v <= hi * (1.0 + 1e-12))
            .collect();
        ticks.dedup();
        ticks
    };
    for mantissas in [
        &[1.0, 2.0, 5.0][..],
        &[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0],
    ] {
        let ticks = within(mantissas);
        if ticks.len() >= 3 {
            return ticks;
        }
    }
    let order = ((hi - lo) / 10.0).log10().floor() as i32;
    let first = (lo / scaled(1.0, order)).ceil() as i64;
    (first..first + 40)
        .map(|n| scaled(n as f64, order))
        .take_while(|v| *v <= hi)
        .collect()
}

/// A chart's drawing error.
fn drawing_error<E: std::error::Error + Send + Sync>(e: DrawingAreaErrorKind<E>) -> PlotError {
    PlotError::Drawing(e.to_string())
}

/// The chart `draw_series` draws on, with x and y axes `X` and `Y`.
type Plot<'a, 'b, X, Y> = ChartContext<'a, BitMapBackend<'b>, Cartesian2d<X, Y>>;

/// Draws `spec` on `root` with axes `x` and `y`: the axes, every series,
/// and the legend if a series is named.
fn draw_series<X, Y>(
    root: &DrawingArea<BitMapBackend<'_>, Shift>,
    spec: &Chart,
    x: X,
    y: Y,
) -> Result<(), PlotError>
where
    X: AsRangedCoord<Value = f64>,
    Y: AsRangedCoord<Value = f64>,
    X::CoordDescType: ValueFormatter<f64>,
    Y::CoordDescType: ValueFormatter<f64>,
{
    let mut chart = ChartBuilder::on(root)
        .caption(&spec.title, (FONT, 22))
        .margin(12)
        .x_label_area_size(48)
        .y_label_area_size(78)
        .build_cartesian_2d(x, y)
        .map_err(drawing_error)?;
    draw_axes(&mut chart, spec)?;
    let mut named = false;
    for s in &spec.series {
        named |= draw_one_series(&mut chart, spec, s)?;
    }
    if named {
        draw_legend(&mut chart, spec.legend)?;
    }
    Ok(())
}

/// Draws the axes of `spec`'s chart: their labels, ticks and grid.
fn draw_axes<X, Y>(chart: &mut Plot<'_, '_, X, Y>, spec: &Chart) -> Result<(), PlotError>
where
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let log_x = spec.x_scale == Scale::Log;
    let log_y = spec.y_scale == Scale::Log;
    chart
        .configure_mesh()
        .x_desc(spec.x_label.as_str())
        .y_desc(spec.y_label.as_str())
        .label_style((FONT, 15))
        .axis_desc_style((FONT, 17))
        .x_labels(if log_x { 40 } else { 8 })
        .y_labels(if log_y { 40 } else { 8 })
        .x_label_formatter(&|v| tick_label(*v))
        .y_label_formatter(&|v| tick_label(*v))
        // Minor grid lines only on linear charts: on a log axis plotters
        // draws them at every key point, which crowds short ranges.
        .light_line_style(if log_x || log_y {
            WHITE
        } else {
            RGBColor(235, 235, 235)
        })
        .bold_line_style(RGBColor(210, 210, 210))
        .draw()
        .map_err(drawing_error)
}

/// Draws one series of `spec`'s chart (its lines, error bars and markers,
/// over the points its axes show); returns whether it got a legend entry.
fn draw_one_series<X, Y>(
    chart: &mut Plot<'_, '_, X, Y>,
    spec: &Chart,
    s: &Series,
) -> Result<bool, PlotError>
where
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    let log_x = spec.x_scale == Scale::Log;
    let log_y = spec.y_scale == Scale::Log;
    let shown = |p: &(f64, f64)| {
        p.0.is_finite() && p.1.is_finite() && (!log_x || p.0 > 0.0) && (!log_y || p.1 > 0.0)
    };
    let color = COLORS[s.color % COLORS.len()];
    let points: Vec<(usize, (f64, f64))> = s
        .points
        .iter()
        .copied()
        .enumerate()
        .filter(|(_, p)| shown(p))
        .collect();
    let legend_marker = |c: RGBColor| {
        move |(x, y): (i32, i32)| Rectangle::new([(x, y - 5), (x + 14, y + 5)], c.filled())
    };
    let mut labelled = false;
    if s.lines {
        let line = chart
            .draw_series(LineSeries::new(
                points.iter().map(|&(_, p)| p),
                color.stroke_width(2),
            ))
            .map_err(drawing_error)?;
        if !s.name.is_empty() {
            line.label(s.name.as_str()).legend(legend_marker(color));
            labelled = true;
        }
    }
    draw_error_bars(chart, s, &points, color, log_y)?;
    if s.markers {
        let coords = points.iter().map(|&(_, p)| p);
        let drawn = match s.marker {
            Marker::Circle => chart
                .draw_series(coords.map(|p| Circle::new(p, 4, color.filled())))
                .map_err(drawing_error)?,
            Marker::Triangle => chart
                .draw_series(coords.map(|p| TriangleMarker::new(p, 6, color.filled())))
                .map_err(drawing_error)?,
        };
        if !labelled && !s.name.is_empty() {
            drawn.label(s.name.as_str()).legend(legend_marker(color));
            labelled = true;
        }
    }
    Ok(labelled)
}

/// Draws the error bars of series `s` at its shown `points` (index into
/// `s.points`, point); on a log y axis a bar reaching zero stops at a
/// tenth of the point.
fn draw_error_bars<X, Y>(
    chart: &mut Plot<'_, '_, X, Y>,
    s: &Series,
    points: &[(usize, (f64, f64))],
    color: RGBColor,
    log_y: bool,
) -> Result<(), PlotError>
where
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    for &(k, (px, py)) in points {
        let Some(&e) = s.errors.get(k).filter(|e| e.is_finite() && **e > 0.0) else {
            continue;
        };
        let lo = if log_y && py - e <= 0.0 {
            py / 10.0
        } else {
            py - e
        };
        chart
            .draw_series(std::iter::once(PathElement::new(
                vec![(px, lo), (px, py + e)],
                color.stroke_width(2),
            )))
            .map_err(drawing_error)?;
    }
    Ok(())
}

/// Draws the legend of the named series at `legend`.
fn draw_legend<'a, 'b: 'a, X, Y>(
    chart: &mut Plot<'a, 'b, X, Y>,
    legend: Legend,
) -> Result<(), PlotError>
where
    X: Ranged<ValueType = f64> + ValueFormatter<f64>,
    Y: Ranged<ValueType = f64> + ValueFormatter<f64>,
{
    chart
        .configure_series_labels()
        .position(match legend {
            Legend::UpperRight => SeriesLabelPosition::UpperRight,
            Legend::LowerRight => SeriesLabelPosition::LowerRight,
            Legend::LowerLeft => SeriesLabelPosition::LowerLeft,
        })
        .label_font((FONT, 15))
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()
        .map_err(drawing_error)
}

/// PNG bytes of bar panels side by side: one bar per label, its value
/// printed above it.
pub fn bar_chart(panels: &[BarPanel]) -> Vec<u8> {
    render(|root| {
        let err = drawing_error;
        let areas = root.split_evenly((1, panels.len().max(1)));
        for (area, panel) in areas.iter().zip(panels) {
            let n = panel.values.len().max(1);
            let max = panel
                .values
                .iter()
                .copied()
                .filter(|v| v.is_finite())
                .fold(0.0, f64::max);
            let top = if max > 0.0 { 1.2 * max } else { 1.0 };
            let mut chart = ChartBuilder::on(area)
                .caption(&panel.title, (FONT, 22))
                .margin(14)
                .x_label_area_size(40)
                .y_label_area_size(64)
                .build_cartesian_2d((0..n - 1).into_segmented(), 0.0..top)
                .map_err(err)?;
            let labels = panel.labels.clone();
            chart
                .configure_mesh()
                .disable_x_mesh()
                .label_style((FONT, 15))
                .y_label_formatter(&|v| tick_label(*v))
                .x_label_formatter(&|v| match v {
                    SegmentValue::CenterOf(i) => labels.get(*i).cloned().unwrap_or_default(),
                    _ => String::new(),
                })
                .draw()
                .map_err(err)?;
            for (i, &v) in panel.values.iter().enumerate() {
                let color = COLORS[i % COLORS.len()];
                let mut bar = Rectangle::new(
                    [
                        (SegmentValue::Exact(i), 0.0),
                        (SegmentValue::Exact(i + 1), v),
                    ],
                    color.filled(),
                );
                bar.set_margin(0, 0, 12, 12);
                chart.draw_series(std::iter::once(bar)).map_err(err)?;
                chart
                    .draw_series(std::iter::once(Text::new(
                        (panel.format)(v),
                        (SegmentValue::CenterOf(i), v + 0.04 * top),
                        (FONT, 16).into_font().color(&BLACK),
                    )))
                    .map_err(err)?;
            }
        }
        Ok(())
    })
    .unwrap_or_default()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_axes_get_ticks_on_short_and_long_ranges() {
        // Shorter than a decade (the tether ladder's h): 1-9 times 0.1.
        assert_eq!(log_ticks(0.23, 0.66), vec![0.3, 0.4, 0.5, 0.6]);
        // Several decades: 1, 2 and 5 times each power of ten.
        let t = log_ticks(4e-5, 1.1e-3);
        assert_eq!(t.len(), 5, "{t:?}");
        for (got, want) in t.iter().zip([5e-5, 1e-4, 2e-4, 5e-4, 1e-3]) {
            assert!((got / want - 1.0).abs() < 1e-12, "{t:?}");
        }
        // Within one step of 1-9 (2.05..2.95): tenths of the range's order.
        let t = log_ticks(2.05, 2.95);
        assert!(
            t.len() >= 3 && t.iter().all(|v| (2.05..=2.95).contains(v)),
            "{t:?}"
        );
    }

    /// Decodes a PNG into (width, height, RGB pixels).
    fn decode(bytes: &[u8]) -> (u32, u32, Vec<u8>) {
        let mut reader = png::Decoder::new(std::io::Cursor::new(bytes))
            .read_info()
            .expect("a PNG");
        let mut pixels = vec![0; reader.output_buffer_size().expect("size")];
        let info = reader.next_frame(&mut pixels).expect("a frame");
        (info.width, info.height, pixels)
    }

    /// Dark pixels in the rows [y0, y1): text, axes or lines were drawn there.
    fn dark_pixels(pixels: &[u8], y0: u32, y1: u32) -> usize {
        pixels[(y0 * WIDTH * 3) as usize..(y1 * WIDTH * 3) as usize]
            .chunks(3)
            .filter(|p| p.iter().all(|&c| c < 100))
            .count()
    }

    #[test]
    fn a_log_log_chart_has_a_title_axes_and_coloured_series() {
        let png = chart(&Chart {
            title: "error against cost".into(),
            x_label: "wall time (s)".into(),
            y_label: "relative error".into(),
            x_scale: Scale::Log,
            y_scale: Scale::Log,
            series: vec![
                Series {
                    name: "remembrane".into(),
                    points: vec![(0.01, 1e-2), (0.1, 1e-3), (1.0, 1e-4), (2.0, -1.0)],
                    errors: vec![1e-3, 1e-4, 1e-5, 0.0],
                    lines: true,
                    markers: true,
                    ..Default::default()
                },
                Series {
                    name: "peer".into(),
                    points: vec![(0.2, 2e-3)],
                    markers: true,
                    marker: Marker::Triangle,
                    color: 1,
                    ..Default::default()
                },
            ],
            legend: Legend::UpperRight,
        });
        let (w, h, pixels) = decode(&png);
        assert_eq!((w, h), (WIDTH, HEIGHT));
        assert!(dark_pixels(&pixels, 0, 40) > 100, "no title text");
        let blue = pixels.chunks(3).filter(|p| p == &[31, 119, 180]).count();
        let orange = pixels.chunks(3).filter(|p| p == &[255, 127, 14]).count();
        assert!(
            blue > 200 && orange > 20,
            "series not drawn: {blue} {orange}"
        );
    }

    #[test]
    fn bar_panels_draw_one_bar_per_value() {
        let png = bar_chart(&[BarPanel {
            title: "events".into(),
            labels: vec!["a".into(), "b".into()],
            values: vec![10.0, 5.0],
            format: |v| format!("{v:.0}"),
        }]);
        let (_, _, pixels) = decode(&png);
        let first = pixels.chunks(3).filter(|p| p == &[31, 119, 180]).count();
        let second = pixels.chunks(3).filter(|p| p == &[255, 127, 14]).count();
        // Equal widths: the areas are in the ratio of the values.
        let ratio = first as f64 / second as f64;
        assert!((ratio - 2.0).abs() < 0.1, "bar areas {first} {second}");
    }

    #[test]
    fn tick_labels_are_short() {
        assert_eq!(tick_label(0.30000000000000004), "0.3");
        assert_eq!(tick_label(1e-6), "1e-6");
        assert_eq!(tick_label(2500.0), "2500");
        assert_eq!(tick_label(-0.0), "0");
    }
}
