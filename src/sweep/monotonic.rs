//! Neighbours that break the expected order along camera distance or frame rate.
//!
//! Along `camera.distance_m` (other axes fixed) a farther camera sees fewer pixels per mm, so the
//! ω and α errors should not fall and the impact SNR should not rise with distance: a farther
//! camera that looks better is flagged. Along `frame_timing.fps` the errors may rise or fall
//! (more frames, but shorter differentiation steps), but not both: a point whose error is above
//! or below both of its frame-rate neighbours is flagged. Each flag says whether the two
//! intervals overlap (the reversal is within the seed noise) or not (something real, worth a
//! look). With the seed's whole-pixel rotation centre a note says why an ω or α reversal can be
//! real for that estimator. Pure: summaries in, findings out.

use super::grid::points;
use super::spec::SweepSpec;
use super::summary::PointSummary;
use crate::budget::MeanCi;
use std::fmt::Write;

/// Scenario fields whose neighbours are checked.
pub const DISTANCE_FIELD: &str = "camera.distance_m";
pub const FPS_FIELD: &str = "frame_timing.fps";

/// One flagged pair or triple of neighbours.
#[derive(Debug, Clone, PartialEq)]
pub struct Finding {
    /// Point indices in axis order (two for distance, three for frame rate).
    pub points: Vec<usize>,
    /// `ω RMS`, `α RMS` or `impact SNR`.
    pub metric: &'static str,
    /// Means in the same order.
    pub values: Vec<f64>,
    /// The flagged reversal is larger than the intervals allow (they do not overlap).
    pub separated: bool,
    pub axis: String,
}

fn overlap(a: &MeanCi, b: &MeanCi) -> bool {
    a.ci95_low <= b.ci95_high && b.ci95_low <= a.ci95_high
}

fn snr_ci(s: &PointSummary) -> Option<MeanCi> {
    s.impact.map(|d| MeanCi {
        mean: d.snr,
        ci95_low: s.snr_ci95.0,
        ci95_high: s.snr_ci95.1,
        n: s.runs_ok,
    })
}

/// Lines of points along `axis` (other levels fixed), each in ascending axis value.
fn lines(spec: &SweepSpec, axis: usize) -> Vec<Vec<usize>> {
    let grid = points(spec);
    let values: Vec<f64> = spec.axes[axis]
        .values
        .as_ref()
        .map(|v| {
            v.iter()
                .map(|x| x.as_float().or(x.as_integer().map(|i| i as f64)))
                .map(|x| x.unwrap_or(f64::NAN))
                .collect()
        })
        .unwrap_or_default();
    let mut out: std::collections::BTreeMap<Vec<usize>, Vec<usize>> = Default::default();
    for p in &grid {
        let mut rest = p.levels.clone();
        rest.remove(axis);
        out.entry(rest).or_default().push(p.index);
    }
    out.into_values()
        .map(|mut line| {
            line.sort_by(|a, b| {
                let v = |i: usize| {
                    values
                        .get(grid[i].levels[axis])
                        .copied()
                        .unwrap_or(f64::NAN)
                };
                v(*a).total_cmp(&v(*b))
            });
            line
        })
        .collect()
}

/// Every flagged neighbour along the distance and frame-rate axes of `spec`.
pub fn findings(spec: &SweepSpec, summary: &[PointSummary]) -> Vec<Finding> {
    let mut found = Vec::new();
    type Metric = (&'static str, fn(&PointSummary) -> Option<MeanCi>, bool);
    let metrics: [Metric; 3] = [
        ("ω RMS", |s| Some(s.ci("omega_rms_rad_s")), true),
        ("α RMS", |s| Some(s.ci("alpha_rms_rad_s2")), true),
        ("impact SNR", snr_ci, false),
    ];
    for (a, axis) in spec.axes.iter().enumerate() {
        let field = axis.field.as_deref().unwrap_or("");
        if field != DISTANCE_FIELD && field != FPS_FIELD {
            continue;
        }
        for line in lines(spec, a) {
            let ok: Vec<usize> = line
                .into_iter()
                .filter(|&i| summary.get(i).is_some_and(|s| s.status == "ok"))
                .collect();
            for (name, get, is_error) in metrics {
                let m: Vec<Option<MeanCi>> = ok.iter().map(|&i| get(&summary[i])).collect();
                if field == DISTANCE_FIELD {
                    for k in 1..ok.len() {
                        let (Some(near), Some(far)) = (m[k - 1], m[k]) else {
                            continue;
                        };
                        // Errors should not fall with distance, the SNR should not rise.
                        let better = if is_error {
                            far.mean < near.mean
                        } else {
                            far.mean > near.mean
                        };
                        if better {
                            found.push(Finding {
                                points: vec![ok[k - 1], ok[k]],
                                metric: name,
                                values: vec![near.mean, far.mean],
                                separated: !overlap(&near, &far),
                                axis: axis.name.clone(),
                            });
                        }
                    }
                } else {
                    for k in 1..ok.len().saturating_sub(1) {
                        let (Some(a0), Some(a1), Some(a2)) = (m[k - 1], m[k], m[k + 1]) else {
                            continue;
                        };
                        let (d0, d1) = (a1.mean - a0.mean, a2.mean - a1.mean);
                        if d0 * d1 < 0.0 {
                            found.push(Finding {
                                points: vec![ok[k - 1], ok[k], ok[k + 1]],
                                metric: name,
                                values: vec![a0.mean, a1.mean, a2.mean],
                                separated: !overlap(&a0, &a1) && !overlap(&a1, &a2),
                                axis: axis.name.clone(),
                            });
                        }
                    }
                }
            }
        }
    }
    found
}

/// The `## Non-monotonic neighbours` section of recommendation.md.
pub fn markdown(spec: &SweepSpec, summary: &[PointSummary]) -> String {
    let checked: Vec<&str> = spec
        .axes
        .iter()
        .filter(|a| matches!(a.field.as_deref(), Some(DISTANCE_FIELD | FPS_FIELD)))
        .map(|a| a.name.as_str())
        .collect();
    if checked.is_empty() {
        return String::new();
    }
    let found = findings(spec, summary);
    let mut md = format!(
        "## Non-monotonic neighbours ({})\n\nChecked along {}: a farther camera should not have \
         smaller errors or a larger impact SNR; along the frame rate a point should not be above \
         or below both neighbours. \"within the intervals\": the 95 % CIs overlap, so the \
         reversal can be seed noise; \"intervals separated\": it cannot.\n\n",
        found.len(),
        checked.join(", ")
    );
    for f in &found {
        let keys: Vec<String> = f
            .points
            .iter()
            .map(|&i| format!("`{}`", summary[i].key))
            .collect();
        let values: Vec<String> = f.values.iter().map(|v| format!("{v:.4}")).collect();
        let _ = writeln!(
            md,
            "- {} along {}: {} → {} ({})",
            f.metric,
            f.axis,
            keys.join(" → "),
            values.join(" → "),
            if f.separated {
                "intervals separated"
            } else {
                "within the intervals"
            }
        );
    }
    if let Some(note) = seed_centre_note(summary, &found) {
        md.push_str(&note);
    }
    md.push('\n');
    md
}

/// Why an error reversal can be real with the seed's rotation centre, with the sweep's own range
/// of θ RMS; `None` when no ω or α reversal involves such a point.
fn seed_centre_note(summary: &[PointSummary], found: &[Finding]) -> Option<String> {
    let involved = found.iter().any(|f| {
        f.metric != "impact SNR" && f.points.iter().any(|&i| summary[i].seed_rotation_centre)
    });
    if !involved {
        return None;
    }
    let theta: Vec<f64> = summary
        .iter()
        .filter(|s| s.seed_rotation_centre && s.runs_ok > 0)
        .map(|s| s.mean("theta_rms_rad"))
        .filter(|v| v.is_finite())
        .collect();
    let lo = theta.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = theta.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let range = if lo <= hi {
        format!(" (θ RMS {lo:.4}–{hi:.4} rad over this sweep's points)")
    } else {
        String::new()
    };
    Some(format!(
        "\nω and α reversals with `estimator.rotation_centre = \"seed\"`: the seed's rotation centre \
         (perpendicular bisectors of whole-pixel corners in two frames, truncated to whole \
         pixels) is off by an amount set by where the marker falls on the pixel grid — different \
         at every distance and resolution, the same for every seed. Its angle error{range} can \
         outweigh the pixel scale, so such a reversal is real for the seed's estimator, not a \
         property of the camera: sweep with `rotation_centre = \"geometric\"` to compare cameras \
         alone.\n"
    ))
}
