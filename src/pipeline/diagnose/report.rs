//! The diagnosis's files: `diagnosis.json` and `diagnosis.md` (formatted by
//! [`crate::diagnose::report`]), gap-map heatmaps, a ranking chart and the before/after residual
//! curves ([`super::overlay`]); written into a staging folder that replaces the output folder
//! only once everything is written.

use super::overlay::Overlay;
use super::{candidate_name, DiagnoseError, Diagnosis};
use crate::diagnose::bands::band_edges_hz;
use crate::diagnose::cells::{CellKey, CHANNELS, PHASES};
use crate::diagnose::gap::GapMap;
pub use crate::diagnose::report::{
    markdown, set_aside_reason, skipped_reason, to_json, verdict_reason,
};
use crate::errors::FileError;
use crate::io::output_dir::OutputDir;
use crate::plot::{bars_png, heatmap::heatmap_png, heatmap::Heatmap, stacked_png, Panel, Series};
use crate::plot::{MEASURED, SECOND, THIRD};
use std::path::{Path, PathBuf};

fn plot_err(e: crate::plot::PlotError) -> DiagnoseError {
    DiagnoseError::Plot(e)
}

/// Heatmaps of |z|: one per banded channel (band × phase) and one for the others.
fn gap_heatmaps(g: &GapMap, nyquist_hz: f64, dir: &Path) -> Result<Vec<PathBuf>, DiagnoseError> {
    let mut files = Vec::new();
    let phases = &PHASES[..4];
    let edges = band_edges_hz(nyquist_hz);
    let z = |key: CellKey| g.cell(&key).map_or(f64::NAN, |c| c.z.abs().max(1e-3));
    for ch in CHANNELS.iter().filter(|c| c.banded) {
        if !g.cells.iter().any(|c| c.key.channel == ch.name) {
            continue;
        }
        let values: Vec<Vec<f64>> = (0..3u8)
            .map(|b| {
                phases
                    .iter()
                    .map(|p| {
                        z(CellKey {
                            channel: ch.name,
                            phase: p,
                            band: Some(b),
                        })
                    })
                    .collect()
            })
            .collect();
        let path = dir.join(format!("gap_map_{}.png", ch.name));
        heatmap_png(
            &path,
            &Heatmap {
                title: format!("|z| of {} ({}): real vs nominal", ch.name, ch.description),
                x_label: "phase".into(),
                y_label: "band (Hz)".into(),
                x_ticks: phases.iter().map(|p| p.to_string()).collect(),
                y_ticks: edges
                    .iter()
                    .map(|e| format!("{:.1}-{:.1}", e[0], e[1]))
                    .collect(),
                values,
            },
        )
        .map_err(plot_err)?;
        files.push(path);
    }
    let others: Vec<&str> = CHANNELS
        .iter()
        .filter(|c| !c.banded && g.cells.iter().any(|x| x.key.channel == c.name))
        .map(|c| c.name)
        .collect();
    if !others.is_empty() {
        let values: Vec<Vec<f64>> = others
            .iter()
            .map(|ch| {
                PHASES
                    .iter()
                    .map(|p| {
                        z(CellKey {
                            channel: ch,
                            phase: p,
                            band: None,
                        })
                    })
                    .collect()
            })
            .collect();
        let path = dir.join("gap_map_other.png");
        heatmap_png(
            &path,
            &Heatmap {
                title: "|z| of the unbanded channels: real vs nominal".into(),
                x_label: "phase".into(),
                y_label: "channel".into(),
                x_ticks: PHASES.iter().map(|p| p.to_string()).collect(),
                y_ticks: others.iter().map(|c| c.to_string()).collect(),
                values,
            },
        )
        .map_err(plot_err)?;
        files.push(path);
    }
    Ok(files)
}

/// Draws the before/after residual curves ([`Overlay`]).
fn overlay_png(o: &Overlay, path: &Path) -> Result<(), DiagnoseError> {
    let (real, nominal) = (&o.real, &o.nominal);
    let pts = |t: &[f64], v: &[f64]| t.iter().copied().zip(v.iter().copied()).collect::<Vec<_>>();
    let mut theta = vec![
        Series::points("real", pts(&real.t_s, &real.theta_rad), MEASURED),
        Series::line(
            "nominal (seed 1)",
            pts(&nominal.t_s, &nominal.theta_rad),
            SECOND,
        ),
    ];
    let mut omega = vec![
        Series::points("real", pts(&real.t_s, &real.omega_rad_s), MEASURED),
        Series::line(
            "nominal (seed 1)",
            pts(&nominal.t_s, &nominal.omega_rad_s),
            SECOND,
        ),
    ];
    if let Some((name, b)) = &o.best {
        let label = format!("with {name}");
        theta.push(Series::line(
            label.clone(),
            pts(&b.t_s, &b.theta_rad),
            THIRD,
        ));
        omega.push(Series::line(label, pts(&b.t_s, &b.omega_rad_s), THIRD));
    }
    stacked_png(
        path,
        &[
            Panel {
                title: "angle residual after the aligned nominal motion".into(),
                x_label: "t (s)".into(),
                y_label: "rad".into(),
                series: theta,
            },
            Panel {
                title: "omega residual".into(),
                x_label: "t (s)".into(),
                y_label: "rad/s".into(),
                series: omega,
            },
        ],
        1200,
        420,
    )
    .map_err(plot_err)?;
    Ok(())
}

/// Writes every output into the staging folder: what `d` holds, and `overlay`'s curves.
pub fn write(
    d: &Diagnosis,
    overlay: &Overlay,
    staging: &OutputDir,
) -> Result<Vec<PathBuf>, DiagnoseError> {
    let dir = staging.path();
    let mut files = gap_heatmaps(&d.nominal_gap, d.nyquist_hz, dir)?;
    if !d.ranking.is_empty() {
        let path = dir.join("ranking.png");
        let bars: Vec<(String, f64)> = d
            .ranking
            .iter()
            .map(|r| (candidate_name(&r.evaluated), r.shrink))
            .collect();
        bars_png(
            &path,
            "shrink of the gap per candidate (fresh seeds)",
            "1 − D_k / D0",
            &bars,
        )
        .map_err(plot_err)?;
        files.push(path);
    }
    let overlay_path = dir.join("residuals_before_after.png");
    overlay_png(overlay, &overlay_path)?;
    files.push(overlay_path);
    let figures: Vec<String> = files
        .iter()
        .filter_map(|f| f.file_name().map(|n| n.to_string_lossy().to_string()))
        .collect();
    let md_path = dir.join("diagnosis.md");
    std::fs::write(&md_path, markdown(d, &figures)).map_err(FileError::io(&md_path))?;
    let json_path = dir.join("diagnosis.json");
    let text = serde_json::to_string_pretty(&to_json(d)).map_err(FileError::json(&json_path))?;
    std::fs::write(&json_path, text + "\n").map_err(FileError::io(&json_path))?;
    files.insert(0, md_path);
    files.insert(0, json_path);
    Ok(files)
}
