//! PNG charts (plotters, bitmap backend, embedded DejaVu Sans so no system font is needed).
//!
//! One job: turn series of numbers into a PNG file. Callers decide what to plot.

pub mod heatmap;
pub mod histogram;

use plotters::prelude::*;
use std::path::Path;
use std::sync::Once;

static FONT: &[u8] = include_bytes!("../../assets/fonts/DejaVuSans.ttf");
static REGISTER: Once = Once::new();

pub(crate) fn register_font() {
    REGISTER.call_once(|| {
        // Registration only fails for unparsable font bytes; the embedded font is known-good.
        let _ = plotters::style::register_font("sans-serif", FontStyle::Normal, FONT);
    });
}

#[derive(Debug, thiserror::Error)]
#[error("plot {file}: {message}")]
pub struct PlotError {
    pub file: String,
    pub message: String,
}

/// How a series is drawn.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Style {
    Line,
    Points,
}

/// One named series of (x, y) points; non-finite points are skipped (missing frames), and a
/// line is broken there (a gap is drawn as a gap).
#[derive(Debug, Clone)]
pub struct Series {
    pub name: String,
    pub points: Vec<(f64, f64)>,
    pub style: Style,
    pub color: RGBColor,
}

impl Series {
    pub fn line(name: impl Into<String>, points: Vec<(f64, f64)>, color: RGBColor) -> Self {
        Self {
            name: name.into(),
            points,
            style: Style::Line,
            color,
        }
    }
    pub fn points(name: impl Into<String>, points: Vec<(f64, f64)>, color: RGBColor) -> Self {
        Self {
            name: name.into(),
            points,
            style: Style::Points,
            color,
        }
    }
}

/// One chart panel.
#[derive(Debug, Clone)]
pub struct Panel {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub series: Vec<Series>,
}

/// Colours used consistently: truth black, measured blue, second measured red.
pub const TRUTH: RGBColor = RGBColor(0, 0, 0);
pub const MEASURED: RGBColor = RGBColor(31, 119, 180);
pub const SECOND: RGBColor = RGBColor(214, 39, 40);
pub const THIRD: RGBColor = RGBColor(44, 160, 44);
pub const FOURTH: RGBColor = RGBColor(148, 103, 189);
pub const PALETTE: [RGBColor; 5] = [MEASURED, SECOND, THIRD, FOURTH, RGBColor(255, 127, 14)];

fn bounds(series: &[Series]) -> ((f64, f64), (f64, f64)) {
    let mut x = (f64::INFINITY, f64::NEG_INFINITY);
    let mut y = (f64::INFINITY, f64::NEG_INFINITY);
    for (px, py) in series.iter().flat_map(|s| s.points.iter()) {
        if px.is_finite() && py.is_finite() {
            x = (x.0.min(*px), x.1.max(*px));
            y = (y.0.min(*py), y.1.max(*py));
        }
    }
    let pad = |(lo, hi): (f64, f64)| {
        if !lo.is_finite() {
            (0.0, 1.0)
        } else if hi - lo < 1e-12 {
            (lo - 0.5, hi + 0.5)
        } else {
            let m = 0.05 * (hi - lo);
            (lo - m, hi + m)
        }
    };
    (pad(x), pad(y))
}

/// Draws panels stacked vertically into one PNG of `width_px` × (`panel_height_px` · n).
pub fn stacked_png(
    path: &Path,
    panels: &[Panel],
    width_px: u32,
    panel_height_px: u32,
) -> Result<(), PlotError> {
    register_font();
    let err = |m: String| PlotError {
        file: path.display().to_string(),
        message: m,
    };
    let n = panels.len().max(1) as u32;
    let (w, h) = (width_px, panel_height_px * n);
    let mut rgb = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let areas = root.split_evenly((n as usize, 1));
        for (panel, area) in panels.iter().zip(areas.iter()) {
            let ((x0, x1), (y0, y1)) = bounds(&panel.series);
            let mut chart = ChartBuilder::on(area)
                .caption(&panel.title, ("sans-serif", 18))
                .margin(8)
                .x_label_area_size(36)
                .y_label_area_size(64)
                .build_cartesian_2d(x0..x1, y0..y1)
                .map_err(|e| err(e.to_string()))?;
            chart
                .configure_mesh()
                .x_desc(panel.x_label.as_str())
                .y_desc(panel.y_label.as_str())
                .label_style(("sans-serif", 13))
                .draw()
                .map_err(|e| err(e.to_string()))?;
            for s in &panel.series {
                let color = s.color;
                let finite = |(a, b): &(f64, f64)| a.is_finite() && b.is_finite();
                let drawn = match s.style {
                    Style::Line => {
                        // One polyline per run of finite points; the legend entry is the last.
                        let runs: Vec<&[(f64, f64)]> = s
                            .points
                            .split(|p| !finite(p))
                            .filter(|r| !r.is_empty())
                            .collect();
                        let empty: &[(f64, f64)] = &[];
                        let (last, before) = runs.split_last().unwrap_or((&empty, &[]));
                        for run in before {
                            chart
                                .draw_series(LineSeries::new(
                                    run.iter().copied(),
                                    color.stroke_width(2),
                                ))
                                .map_err(|e| err(e.to_string()))?;
                        }
                        chart.draw_series(LineSeries::new(
                            last.iter().copied(),
                            color.stroke_width(2),
                        ))
                    }
                    Style::Points => chart.draw_series(
                        s.points
                            .iter()
                            .copied()
                            .filter(finite)
                            .map(move |p| Circle::new(p, 2, color.filled())),
                    ),
                }
                .map_err(|e| err(e.to_string()))?;
                drawn.label(s.name.as_str()).legend(move |(x, y)| {
                    PathElement::new(vec![(x, y), (x + 18, y)], color.stroke_width(3))
                });
            }
            chart
                .configure_series_labels()
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK)
                .label_font(("sans-serif", 13))
                .position(SeriesLabelPosition::UpperRight)
                .draw()
                .map_err(|e| err(e.to_string()))?;
        }
        root.present().map_err(|e| err(e.to_string()))?;
    }
    write_rgb_png(path, w, h, &rgb)
}

/// A bar chart of named values (used for per-source error shares).
pub fn bars_png(
    path: &Path,
    title: &str,
    y_label: &str,
    bars: &[(String, f64)],
) -> Result<(), PlotError> {
    register_font();
    let err = |m: String| PlotError {
        file: path.display().to_string(),
        message: m,
    };
    let (w, h) = (900u32, 500u32);
    let mut rgb = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let max = bars
            .iter()
            .map(|b| b.1)
            .filter(|v| v.is_finite())
            .fold(0.0_f64, f64::max)
            .max(1e-12);
        let min = bars
            .iter()
            .map(|b| b.1)
            .filter(|v| v.is_finite())
            .fold(0.0_f64, f64::min);
        let n = bars.len().max(1);
        let mut chart = ChartBuilder::on(&root)
            .caption(title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(90)
            .y_label_area_size(70)
            .build_cartesian_2d((0..n).into_segmented(), (min * 1.1)..(max * 1.1))
            .map_err(|e| err(e.to_string()))?;
        let names: Vec<String> = bars.iter().map(|b| b.0.clone()).collect();
        chart
            .configure_mesh()
            .y_desc(y_label)
            .x_labels(n)
            .x_label_formatter(&|v| match v {
                SegmentValue::CenterOf(i) => names.get(*i).cloned().unwrap_or_default(),
                _ => String::new(),
            })
            .label_style(("sans-serif", 12))
            .draw()
            .map_err(|e| err(e.to_string()))?;
        chart
            .draw_series(bars.iter().enumerate().map(|(i, (_, v))| {
                let v = if v.is_finite() { *v } else { 0.0 };
                let mut bar = Rectangle::new(
                    [
                        (SegmentValue::Exact(i), 0.0),
                        (SegmentValue::Exact(i + 1), v),
                    ],
                    PALETTE[i % PALETTE.len()].filled(),
                );
                bar.set_margin(0, 0, 6, 6);
                bar
            }))
            .map_err(|e| err(e.to_string()))?;
        root.present().map_err(|e| err(e.to_string()))?;
    }
    write_rgb_png(path, w, h, &rgb)
}

/// plotters' file output needs the `image` crate; we encode the RGB buffer with `png` instead.
pub(crate) fn write_rgb_png(path: &Path, w: u32, h: u32, rgb: &[u8]) -> Result<(), PlotError> {
    let err = |m: String| PlotError {
        file: path.display().to_string(),
        message: m,
    };
    let file = std::fs::File::create(path).map_err(|e| err(e.to_string()))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), w, h);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(|e| err(e.to_string()))?;
    writer
        .write_image_data(rgb)
        .map_err(|e| err(e.to_string()))?;
    writer.finish().map_err(|e| err(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn png_size(path: &Path) -> (u32, u32) {
        let decoder = png::Decoder::new(std::fs::File::open(path).unwrap());
        let reader = decoder.read_info().unwrap();
        (reader.info().width, reader.info().height)
    }

    #[test]
    fn writes_stacked_png_with_expected_size_and_ink() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("p.png");
        let sine: Vec<(f64, f64)> = (0..200)
            .map(|i| (i as f64 * 0.05, (i as f64 * 0.05).sin()))
            .collect();
        let mut with_gap = sine.clone();
        with_gap[50].1 = f64::NAN;
        let panels = vec![
            Panel {
                title: "a".into(),
                x_label: "t_s".into(),
                y_label: "y".into(),
                series: vec![Series::line("truth", sine, TRUTH)],
            },
            Panel {
                title: "b".into(),
                x_label: "t_s".into(),
                y_label: "y".into(),
                series: vec![Series::points("m", with_gap, MEASURED)],
            },
        ];
        stacked_png(&path, &panels, 640, 300).unwrap();
        assert_eq!(png_size(&path), (640, 600));
        let bars = dir.path().join("b.png");
        bars_png(
            &bars,
            "shares",
            "%",
            &[
                ("noise".into(), 60.0),
                ("blur".into(), 30.0),
                ("rest".into(), -5.0),
            ],
        )
        .unwrap();
        assert_eq!(png_size(&bars), (900, 500));
    }

    #[test]
    fn unwritable_path_is_an_error_not_a_panic() {
        let r = stacked_png(Path::new("/nonexistent-dir/x.png"), &[], 100, 100);
        assert!(r.is_err());
    }
}
