//! Heatmap PNGs: a grid of cells coloured on a log scale, each labelled with its value.
//! Errors across a design sweep span decades, hence the log colour scale.

use super::{register_font, write_rgb_png, PlotError};
use plotters::prelude::*;
use std::path::Path;

/// One heatmap: `values[row][col]`, rows along y (bottom to top), columns along x.
#[derive(Debug, Clone)]
pub struct Heatmap {
    pub title: String,
    pub x_label: String,
    pub y_label: String,
    pub x_ticks: Vec<String>,
    pub y_ticks: Vec<String>,
    pub values: Vec<Vec<f64>>,
}

/// Five-stop viridis approximation, t in [0, 1].
fn viridis(t: f64) -> RGBColor {
    const STOPS: [(f64, f64, f64); 5] = [
        (68.0, 1.0, 84.0),
        (59.0, 82.0, 139.0),
        (33.0, 145.0, 140.0),
        (94.0, 201.0, 98.0),
        (253.0, 231.0, 37.0),
    ];
    let t = if t.is_finite() {
        t.clamp(0.0, 1.0)
    } else {
        0.0
    };
    let x = t * 4.0;
    let i = (x.floor() as usize).min(3);
    let f = x - i as f64;
    let (a, b) = (STOPS[i], STOPS[i + 1]);
    let lerp = |p: f64, q: f64| (p + (q - p) * f).round() as u8;
    RGBColor(lerp(a.0, b.0), lerp(a.1, b.1), lerp(a.2, b.2))
}

/// Position of `v` on the log scale between the smallest and largest positive finite values.
pub fn log_position(v: f64, lo: f64, hi: f64) -> f64 {
    if !(v > 0.0 && v.is_finite()) {
        return f64::NAN;
    }
    if hi <= lo {
        return 0.5;
    }
    (v.ln() - lo.ln()) / (hi.ln() - lo.ln())
}

/// Writes the heatmap; missing cells (NaN, ≤ 0) are grey and labelled `–`.
pub fn heatmap_png(path: &Path, map: &Heatmap) -> Result<(), PlotError> {
    register_font();
    let err = |m: String| PlotError {
        file: path.display().to_string(),
        message: m,
    };
    let nx = map.x_ticks.len().max(1);
    let ny = map.y_ticks.len().max(1);
    let positive: Vec<f64> = map
        .values
        .iter()
        .flatten()
        .copied()
        .filter(|v| *v > 0.0 && v.is_finite())
        .collect();
    let lo = positive.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = positive.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let (w, h) = (
        (160 + 110 * nx as u32).max(500),
        (140 + 60 * ny as u32).max(300),
    );
    let mut rgb = vec![255u8; (w * h * 3) as usize];
    {
        let root = BitMapBackend::with_buffer(&mut rgb, (w, h)).into_drawing_area();
        root.fill(&WHITE).map_err(|e| err(e.to_string()))?;
        let mut chart = ChartBuilder::on(&root)
            .caption(&map.title, ("sans-serif", 18))
            .margin(10)
            .x_label_area_size(50)
            .y_label_area_size(90)
            // plotters' integer ranges include their end: 0..n-1 gives n segments.
            .build_cartesian_2d((0..nx - 1).into_segmented(), (0..ny - 1).into_segmented())
            .map_err(|e| err(e.to_string()))?;
        let tick = |ticks: &[String], v: &SegmentValue<usize>| match v {
            SegmentValue::CenterOf(i) => ticks.get(*i).cloned().unwrap_or_default(),
            _ => String::new(),
        };
        chart
            .configure_mesh()
            .disable_mesh()
            .x_desc(map.x_label.as_str())
            .y_desc(map.y_label.as_str())
            .x_labels(nx)
            .y_labels(ny)
            .x_label_formatter(&|v| tick(&map.x_ticks, v))
            .y_label_formatter(&|v| tick(&map.y_ticks, v))
            .label_style(("sans-serif", 13))
            .draw()
            .map_err(|e| err(e.to_string()))?;
        for (row, values) in map.values.iter().enumerate().take(ny) {
            for (col, v) in values.iter().enumerate().take(nx) {
                let t = log_position(*v, lo, hi);
                let fill = if t.is_nan() {
                    RGBColor(200, 200, 200)
                } else {
                    viridis(t)
                };
                chart
                    .draw_series(std::iter::once(Rectangle::new(
                        [
                            (SegmentValue::Exact(col), SegmentValue::Exact(row)),
                            (SegmentValue::Exact(col + 1), SegmentValue::Exact(row + 1)),
                        ],
                        fill.filled(),
                    )))
                    .map_err(|e| err(e.to_string()))?;
                let label = if t.is_nan() {
                    "–".to_string()
                } else {
                    format!("{v:.3}")
                };
                // Dark text on the bright end of the map, white on the dark end.
                let ink = if t > 0.6 { BLACK } else { WHITE };
                let style = TextStyle::from(("sans-serif", 14).into_font())
                    .color(&ink)
                    .pos(plotters::style::text_anchor::Pos::new(
                        plotters::style::text_anchor::HPos::Center,
                        plotters::style::text_anchor::VPos::Center,
                    ));
                chart
                    .draw_series(std::iter::once(Text::new(
                        label,
                        (SegmentValue::CenterOf(col), SegmentValue::CenterOf(row)),
                        style,
                    )))
                    .map_err(|e| err(e.to_string()))?;
            }
        }
        root.present().map_err(|e| err(e.to_string()))?;
    }
    write_rgb_png(path, w, h, &rgb)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_positions_span_the_range() {
        assert_eq!(log_position(0.01, 0.01, 1.0), 0.0);
        assert!((log_position(0.1, 0.01, 1.0) - 0.5).abs() < 1e-12);
        assert_eq!(log_position(1.0, 0.01, 1.0), 1.0);
        assert!(log_position(f64::NAN, 0.01, 1.0).is_nan());
        assert!(log_position(0.0, 0.01, 1.0).is_nan());
    }

    #[test]
    fn writes_a_heatmap_whose_cells_differ_in_colour() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("h.png");
        let map = Heatmap {
            title: "α RMS".into(),
            x_label: "fps".into(),
            y_label: "distance_m".into(),
            x_ticks: vec!["24".into(), "30".into(), "60".into()],
            y_ticks: vec!["0.2".into(), "0.4".into()],
            values: vec![vec![0.01, 0.1, 1.0], vec![10.0, f64::NAN, 100.0]],
        };
        heatmap_png(&path, &map).unwrap();
        let decoder = png::Decoder::new(std::fs::File::open(&path).unwrap());
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        let px: std::collections::HashSet<[u8; 3]> = buf[..info.buffer_size()]
            .chunks(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        // The two ends of the colour map and the grey of the missing cell are all present.
        for c in [viridis(0.0), viridis(1.0), RGBColor(200, 200, 200)] {
            assert!(px.contains(&[c.0, c.1, c.2]), "{c:?} missing");
        }
        // A single cell (one-axis sweep with one level) still draws.
        let one = Heatmap {
            x_ticks: vec!["30".into()],
            y_ticks: vec![String::new()],
            values: vec![vec![0.5]],
            ..map
        };
        heatmap_png(&dir.path().join("one.png"), &one).unwrap();
    }
}
