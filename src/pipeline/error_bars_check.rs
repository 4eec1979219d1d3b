//! Whether `analyze`'s error bars hold where the truth is known: footage drawn by a renderer
//! (by default the second one, not the one the bars simulate), each at its own sub-pixel
//! placement and seed, analysed with error bars from the stated scenario; the z-scores
//! (measured − truth)/σ pooled per quantity and motion phase. Right bars give a z RMS of 1.

use super::analyze::{analyze, AnalyzeError, AnalyzeOptions, Source};
use super::decompose::place_for_seed;
use super::error_bars::{error_bars, ErrorBarOptions, ErrorBarsError};
use super::render_job::{render_job, RenderJob, RenderJobError, Renderer};
use super::rig::{Rig, RigError};
use crate::budget::error_bars::z_rms;
use crate::detect::CornerRefinement;
use crate::rng::Stream;
use crate::scenario::Scenario;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum CheckError {
    #[error("footage {footage}: rendering")]
    Render {
        footage: usize,
        #[source]
        source: Box<RenderJobError>,
    },
    #[error("footage {footage}: analysis")]
    Analyze {
        footage: usize,
        #[source]
        source: Box<AnalyzeError>,
    },
    #[error("footage {footage}: error bars")]
    Bars {
        footage: usize,
        #[source]
        source: Box<ErrorBarsError>,
    },
    #[error("footage {footage}: its truth")]
    Truth {
        footage: usize,
        #[source]
        source: Box<RigError>,
    },
    #[error("the built-in scenario")]
    Scenario(#[from] Box<crate::scenario::ScenarioError>),
    #[error("{}: cannot write", file.display())]
    Write {
        file: std::path::PathBuf,
        source: std::io::Error,
    },
    #[error("{}: cannot remove the footage", dir.display())]
    Cleanup {
        dir: std::path::PathBuf,
        source: std::io::Error,
    },
}

/// One quantity in one phase, pooled over the footages.
#[derive(Debug, Clone, PartialEq)]
pub struct CoverageRow {
    /// `theta2`, `omega2` or `alpha2`.
    pub quantity: &'static str,
    /// A motion phase, or `all`.
    pub phase: String,
    pub frames: usize,
    /// Root mean square of (measured − truth)/σ (1 when the bars are right).
    pub z_rms: f64,
    /// Its standard error from the scatter of the footages' own mean z² (frames within a
    /// footage are correlated; footages are not): SE(mean z²) / (2 z RMS).
    pub z_rms_se: f64,
    /// Fraction of frames with |z| > 3 (0.27 % for Gaussian errors).
    pub beyond_3: f64,
}

/// What the check ran on.
#[derive(Debug, Clone)]
pub struct CoverageCheck {
    pub footages: usize,
    pub seeds: usize,
    pub renderer: Renderer,
    pub rows: Vec<CoverageRow>,
}

/// Renders `footages` footages of `base` (seed base.seed + 1000 + k, each placed on the pixel grid
/// by its seed) with `renderer` into `work_dir` (removed after), analyses each with error bars
/// from `base` on `seeds` seeds, and pools the fused signal's z-scores.
pub fn coverage_check(
    base: &Scenario,
    footages: usize,
    seeds: usize,
    renderer: Renderer,
    work_dir: &Path,
) -> Result<CoverageCheck, CheckError> {
    let mut z: Vec<ZRow> = Vec::new();
    for k in 0..footages {
        let mut f = base.clone();
        f.seed = base.seed.wrapping_add(1000 + k as u64);
        place_for_seed(&mut f, Stream::ErrorBarPlacement);
        let dir = work_dir.join(format!("footage-{k}"));
        let job = RenderJob {
            frames: None,
            roi_margin_px: None,
            video: None,
            png: true,
            renderer,
        };
        render_job(&f, &dir, &job, &|_, _| {}).map_err(|e| CheckError::Render {
            footage: k,
            source: Box::new(e),
        })?;
        let options = AnalyzeOptions::from_scenario(base, AnalyzeOptions::default().angle_sign);
        let source = Source::Frames {
            dir: dir.clone(),
            timestamps: dir.join("timestamps.csv"),
        };
        let out_dir = dir.join("analysis");
        let analysis =
            analyze(&source, &options, &out_dir, &|_, _| {}).map_err(|e| CheckError::Analyze {
                footage: k,
                source: Box::new(e),
            })?;
        let bar_options = ErrorBarOptions {
            seeds,
            ..ErrorBarOptions::default()
        };
        let bars = error_bars(
            base,
            &analysis,
            options.angle_sign,
            &bar_options,
            &|_, _| {},
        )
        .map_err(|e| CheckError::Bars {
            footage: k,
            source: Box::new(e),
        })?;
        let rig = Rig::new(&f).map_err(|e| CheckError::Truth {
            footage: k,
            source: Box::new(e),
        })?;
        let to_analysis = options.angle_sign * rig.screen_sign;
        let fused = crate::estimate::Signal::Fused.name();
        let (Some(m), Some(b)) = (
            analysis.signals.iter().find(|s| s.signal == fused),
            bars.signal(fused),
        ) else {
            continue;
        };
        let times: Vec<f64> = analysis.tracks.iter().map(|r| r.t_s).collect();
        let Some(&t_first) = times.first() else {
            continue;
        };
        let th0 = rig.mechanism.actual(t_first).theta2_rad;
        for (i, t) in times.iter().enumerate() {
            let s = rig.mechanism.actual(*t);
            let truth = [s.theta2_rad - th0, s.omega2_rad_s, s.alpha2_rad_s2];
            let measured = [m.theta2_rad[i], m.omega2_rad_s[i], m.alpha2_rad_s2[i]];
            for (q, name) in ["theta2", "omega2", "alpha2"].into_iter().enumerate() {
                let error = measured[q] - to_analysis * truth[q];
                z.push((k, name, s.phase.as_str().to_string(), error, b.sigma[q][i]));
            }
        }
        std::fs::remove_dir_all(&dir).map_err(|source| CheckError::Cleanup {
            dir: dir.clone(),
            source,
        })?;
    }
    Ok(CoverageCheck {
        footages,
        seeds,
        renderer,
        rows: pooled(&z),
    })
}

/// One frame's z-score parts: footage, quantity, phase, error, σ.
type ZRow = (usize, &'static str, String, f64, f64);

/// z RMS per quantity and phase (and over all phases), in a fixed order.
fn pooled(z: &[ZRow]) -> Vec<CoverageRow> {
    let mut rows = Vec::new();
    for quantity in ["theta2", "omega2", "alpha2"] {
        for phase in ["all", "dwell", "entry", "drive", "exit"] {
            let picked: Vec<&ZRow> = z
                .iter()
                .filter(|r| r.1 == quantity && (phase == "all" || r.2 == phase))
                .collect();
            let error: Vec<f64> = picked.iter().map(|r| r.3).collect();
            let sigma: Vec<f64> = picked.iter().map(|r| r.4).collect();
            let (z_rms, frames) = z_rms(&error, &sigma);
            if frames == 0 {
                continue;
            }
            let z2 = |r: &&ZRow| {
                let v = (r.3 / r.4).powi(2);
                v.is_finite().then_some(v)
            };
            let beyond = picked.iter().filter_map(z2).filter(|v| *v > 9.0).count();
            let mut per_footage: Vec<f64> = Vec::new();
            let last = picked.iter().map(|r| r.0).max().unwrap_or(0);
            for k in 0..=last {
                let v: Vec<f64> = picked.iter().filter(|r| r.0 == k).filter_map(z2).collect();
                if !v.is_empty() {
                    per_footage.push(crate::numeric::robust::mean(&v));
                }
            }
            let se_z2 =
                crate::numeric::robust::sample_sd(&per_footage) / (per_footage.len() as f64).sqrt();
            rows.push(CoverageRow {
                quantity,
                phase: phase.to_string(),
                frames,
                z_rms,
                z_rms_se: se_z2 / (2.0 * z_rms),
                beyond_3: beyond as f64 / frames as f64,
            });
        }
    }
    rows
}

/// The z RMS that exact bars estimated from `seeds` seeds give: √(N/(N−2)) (E[N/χ²_N]).
pub fn exact_z_rms(seeds: usize) -> f64 {
    let n = seeds as f64;
    (n / (n - 2.0)).sqrt()
}

/// Whether a z RMS is within 10 % of what exact bars give.
fn within(z_rms: f64, exact: f64) -> bool {
    (z_rms / exact - 1.0).abs() <= 0.1
}

/// The check as a Markdown table: quantity, phase, frames, z RMS with its standard error,
/// whether it is within 10 % of what exact bars give, and the fraction beyond 3σ.
pub fn coverage_table(c: &CoverageCheck) -> String {
    let exact = exact_z_rms(c.seeds);
    let mut t = format!(
        "| quantity | phase | frames | z RMS ± SE | within 10 % of {exact:.3} (exact bars) | \\|z\\| > 3 |\n|---|---|---:|---:|---|---:|\n",
    );
    for r in &c.rows {
        t.push_str(&format!(
            "| {} | {} | {} | {:.2} ± {:.2} | {} | {:.1} % |\n",
            r.quantity,
            r.phase,
            r.frames,
            r.z_rms,
            r.z_rms_se,
            if within(r.z_rms, exact) { "yes" } else { "no" },
            100.0 * r.beyond_3
        ));
    }
    t
}

/// The `reports/error-bars/` folder: the check on footage of the second renderer and, as the
/// control, of the simulating renderer itself, for the `fast` rig over 4 s, with whole-pixel
/// corners (the rig's, and the seed study's) and with sub-pixel ones.
pub fn error_bars_report(out_dir: &Path, footages: usize, seeds: usize) -> Result<(), CheckError> {
    let mut base = crate::scenario::load_any("fast").map_err(Box::new)?;
    base.duration_s = 4.0;
    let mut text = format!(
        "# Error bars of `geneva analyze` against the truth\n\n\
         `geneva analyze --scenario` gives every measured θ2, ω2, α2 a standard uncertainty σ from \
         simulations of the rig at the footage's own frame times. Here the truth is known: \
         {footages} footages of the built-in `fast` rig (1280×720, 30 fps, 4 s, 120 frames each; \
         each footage at its own seed and its own sub-pixel placement), analysed with error bars \
         from the stated scenario on {seeds} seeds each. Right bars give a root-mean-square z = \
         (measured − truth)/σ of 1 (bias included); σ itself is known to ± {:.0} % per frame \
         (1/√(2·{seeds})), and because σ is itself estimated, exact bars give a z RMS of \
         √(N/(N−2)) = {:.3} for N = {seeds} seeds (E[N/χ²_N]), not 1. The fused signal, per \
         quantity and motion phase; the standard error comes from the scatter between footages \
         (frames within one are correlated). A z RMS above it means bars too narrow by that \
         factor.\n",
        100.0 * crate::budget::error_bars::sigma_relative_se(seeds),
        exact_z_rms(seeds)
    );
    for (refinement, name) in [
        (CornerRefinement::None, "none"),
        (CornerRefinement::Subpix, "subpix"),
    ] {
        let mut rig = base.clone();
        rig.detector.corner_refinement_method = refinement;
        for (renderer, title) in [
            (
                Renderer::Independent,
                "footage of the second renderer (not the one the bars simulate)",
            ),
            (
                Renderer::Own,
                "footage of the simulating renderer (the control)",
            ),
        ] {
            let c = coverage_check(&rig, footages, seeds, renderer, &out_dir.join("work"))?;
            let held: Vec<String> = c
                .rows
                .iter()
                .filter(|r| r.phase != "all" && !within(r.z_rms, exact_z_rms(c.seeds)))
                .map(|r| {
                    format!(
                        "{} in {} ({:.2} ± {:.2})",
                        r.quantity, r.phase, r.z_rms, r.z_rms_se
                    )
                })
                .collect();
            let verdict = if held.is_empty() {
                "Every quantity and phase is within 10 % of what exact bars give.".to_string()
            } else {
                format!(
                    "Not within 10 % of what exact bars give: {}.",
                    held.join(", ")
                )
            };
            text.push_str(&format!(
                "\n## Corners `{name}`, {title}\n\n{}\n{verdict}\n",
                coverage_table(&c)
            ));
        }
    }
    let work = out_dir.join("work");
    if work.exists() {
        std::fs::remove_dir_all(&work)
            .map_err(|source| CheckError::Cleanup { dir: work, source })?;
    }
    let readme = out_dir.join("README.md");
    std::fs::write(&readme, text).map_err(|source| CheckError::Write {
        file: readme.clone(),
        source,
    })?;
    Ok(())
}
