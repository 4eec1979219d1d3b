//! Heatmaps of a finished sweep: ω RMS and α RMS over the first two axes, the other axes held at
//! the recommended point (or the closest one, or their first level).

use super::error::SweepError;
use super::grid::Point;
use super::recommend::Recommendation;
use super::spec::SweepSpec;
use super::summary::PointSummary;
use crate::plot::heatmap::{heatmap_png, Heatmap};
use std::path::{Path, PathBuf};

/// (metric, file stem, title) pairs drawn.
const MAPS: [(&str, &str, &str); 2] = [
    (
        "alpha_rms_rad_s2",
        "heatmap_alpha_rms",
        "α RMS error, rad/s² (mean over seeds)",
    ),
    (
        "omega_rms_rad_s",
        "heatmap_omega_rms",
        "ω RMS error, rad/s (mean over seeds)",
    ),
];

/// The heatmap grids: x = axis 0, y = axis 1 (a single row when there is one axis).
pub fn heatmaps(
    spec: &SweepSpec,
    grid: &[Point],
    summary: &[PointSummary],
    rec: &Recommendation,
) -> Vec<(String, Heatmap)> {
    let Some(axis_x) = spec.axes.first() else {
        return Vec::new();
    };
    let anchor = rec.chosen.or(rec.closest).and_then(|i| grid.get(i));
    let fixed = |a: usize| anchor.map_or(0, |p| p.levels[a]);
    let ticks = |a: usize| -> Vec<String> {
        let mut t: Vec<(usize, String)> = grid
            .iter()
            .map(|p| (p.levels[a], p.labels[a].clone()))
            .collect();
        t.sort();
        t.dedup();
        t.into_iter().map(|(_, l)| l).collect()
    };
    let x_ticks = ticks(0);
    let (y_label, y_ticks) = match spec.axes.get(1) {
        Some(a) => (a.name.clone(), ticks(1)),
        None => (String::new(), vec![String::new()]),
    };
    let others: Vec<String> = spec
        .axes
        .iter()
        .enumerate()
        .skip(2)
        .filter_map(|(a, axis)| {
            grid.iter()
                .find(|p| p.levels[a] == fixed(a))
                .map(|p| format!("{}={}", axis.name, p.labels[a]))
        })
        .collect();
    MAPS.iter()
        .map(|(metric, stem, title)| {
            let mut values = vec![vec![f64::NAN; x_ticks.len()]; y_ticks.len()];
            for (p, s) in grid.iter().zip(summary) {
                let on_slice = (2..spec.axes.len()).all(|a| p.levels[a] == fixed(a));
                if on_slice {
                    let row = if spec.axes.len() > 1 { p.levels[1] } else { 0 };
                    values[row][p.levels[0]] = s.mean(metric);
                }
            }
            let title = if others.is_empty() {
                title.to_string()
            } else {
                format!("{title}; {}", others.join(", "))
            };
            (
                stem.to_string(),
                Heatmap {
                    title,
                    x_label: axis_x.name.clone(),
                    y_label: y_label.clone(),
                    x_ticks: x_ticks.clone(),
                    y_ticks: y_ticks.clone(),
                    values,
                },
            )
        })
        .collect()
}

/// Writes the heatmap PNGs into `out_dir`; returns their paths.
pub fn write_heatmaps(
    spec: &SweepSpec,
    grid: &[Point],
    summary: &[PointSummary],
    rec: &Recommendation,
    out_dir: &Path,
) -> Result<Vec<PathBuf>, SweepError> {
    let mut written = Vec::new();
    for (stem, map) in heatmaps(spec, grid, summary, rec) {
        let path = out_dir.join(format!("{stem}.png"));
        heatmap_png(&path, &map)?;
        written.push(path);
    }
    Ok(written)
}
