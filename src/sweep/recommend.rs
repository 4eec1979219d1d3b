//! The recommendation: the cheapest point that meets the accuracy target and detects the
//! impact, with the runner-up, or — when none qualifies — the closest point. Also renders
//! recommendation.md.

use super::spec::SweepSpec;
use super::summary::PointSummary;
use std::cmp::Ordering;
use std::fmt::Write;

/// What the sweep recommends (indices into the summary, which is in grid order).
#[derive(Debug, Clone, PartialEq)]
pub struct Recommendation {
    /// The cheapest qualifying point.
    pub chosen: Option<usize>,
    /// The next cheapest qualifying point.
    pub runner_up: Option<usize>,
    /// When nothing qualifies: the evaluated point with the smallest worst shortfall ratio.
    pub closest: Option<usize>,
}

fn by_cost(a: &PointSummary, b: &PointSummary) -> Ordering {
    for (x, y) in a.cost.iter().zip(&b.cost) {
        match x.total_cmp(y) {
            Ordering::Equal => continue,
            o => return o,
        }
    }
    a.index.cmp(&b.index)
}

/// How far a point is from qualifying: the largest of (ω RMS / target, α RMS / target,
/// min SNR / SNR); ≤ 1 on every term means it meets everything.
pub fn shortfall(spec: &SweepSpec, s: &PointSummary) -> f64 {
    let snr = s.impact.map_or(0.0, |d| d.snr);
    let terms = [
        s.mean("omega_rms_rad_s") / spec.target.omega_rms_rad_s,
        s.mean("alpha_rms_rad_s2") / spec.target.alpha_rms_rad_s2,
        spec.impact.min_snr / snr,
    ];
    if terms.iter().any(|t| t.is_nan()) {
        return f64::INFINITY;
    }
    terms.iter().fold(0.0, |m, t| m.max(*t))
}

/// Picks the cheapest qualifying point (cost order, then grid order) and the runner-up.
pub fn recommend(spec: &SweepSpec, summary: &[PointSummary]) -> Recommendation {
    let mut qualifying: Vec<&PointSummary> = summary.iter().filter(|s| s.qualifies).collect();
    qualifying.sort_by(|a, b| by_cost(a, b));
    let closest = if qualifying.is_empty() {
        summary
            .iter()
            .filter(|s| s.runs_ok > 0)
            .min_by(|a, b| {
                shortfall(spec, a)
                    .total_cmp(&shortfall(spec, b))
                    .then(a.index.cmp(&b.index))
            })
            .map(|s| s.index)
    } else {
        None
    };
    Recommendation {
        chosen: qualifying.first().map(|s| s.index),
        runner_up: qualifying.get(1).map(|s| s.index),
        closest,
    }
}

fn describe(s: &PointSummary) -> String {
    let ci = |name: &str| {
        let i = super::results::METRICS
            .iter()
            .position(|m| *m == name)
            .unwrap_or(0);
        let m = s.metrics[i];
        format!("{:.4} [{:.4}, {:.4}]", m.mean, m.ci95_low, m.ci95_high)
    };
    let impact = match &s.impact {
        Some(d) => format!(
            "impact peak |α̂| {:.3} rad/s² vs dwell σ_α {:.3} rad/s² → SNR {:.2}",
            d.peak_alpha_rad_s2, d.noise_alpha_rad_s2, d.snr
        ),
        None => "impact: not computed".into(),
    };
    format!(
        "`{}`\n  - ω RMS {} rad/s, α RMS {} rad/s² (mean [95 % CI] over {} run(s))\n  - {}\n",
        s.key,
        ci("omega_rms_rad_s"),
        ci("alpha_rms_rad_s2"),
        s.runs_ok,
        impact
    )
}

/// Why a point does not qualify, in words.
pub fn reasons(spec: &SweepSpec, s: &PointSummary) -> String {
    if s.status != "ok" {
        return if s.error.is_empty() {
            s.status.clone()
        } else {
            format!("{}: {}", s.status, s.error)
        };
    }
    let mut r = Vec::new();
    let w = s.mean("omega_rms_rad_s");
    if w > spec.target.omega_rms_rad_s || w.is_nan() {
        r.push(format!(
            "ω RMS {w:.4} > {} rad/s",
            spec.target.omega_rms_rad_s
        ));
    }
    let a = s.mean("alpha_rms_rad_s2");
    if a > spec.target.alpha_rms_rad_s2 || a.is_nan() {
        r.push(format!(
            "α RMS {a:.4} > {} rad/s²",
            spec.target.alpha_rms_rad_s2
        ));
    }
    match s.impact {
        Some(d) if !d.detectable => {
            r.push(format!("impact SNR {:.2} < {}", d.snr, spec.impact.min_snr))
        }
        None if s.error.is_empty() => r.push("impact SNR unknown".into()),
        None => r.push(s.error.clone()),
        _ => {}
    }
    r.join("; ")
}

/// recommendation.md text.
pub fn markdown(spec: &SweepSpec, summary: &[PointSummary], rec: &Recommendation) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# Sweep recommendation\n");
    let _ = writeln!(
        md,
        "Target: mean ω RMS ≤ {} rad/s, mean α RMS ≤ {} rad/s²; impact Δω = {} rad/s over {} s \
         detectable at SNR ≥ {}. Cheapest by: {}.\n",
        spec.target.omega_rms_rad_s,
        spec.target.alpha_rms_rad_s2,
        spec.impact.delta_omega_rad_s,
        spec.impact.duration_s,
        spec.impact.min_snr,
        spec.cost.order.join(", then ")
    );
    match rec.chosen {
        Some(i) => {
            let _ = writeln!(md, "## Recommended\n\n{}", describe(&summary[i]));
            match rec.runner_up {
                Some(j) => {
                    let _ = writeln!(md, "## Runner-up\n\n{}", describe(&summary[j]));
                }
                None => {
                    let _ = writeln!(md, "## Runner-up\n\nNo other point qualifies.\n");
                }
            }
        }
        None => {
            let _ = writeln!(md, "## No point qualifies\n");
            if let Some(c) = rec.closest {
                let _ = writeln!(
                    md,
                    "Closest (worst shortfall ratio {:.2}): {}  - fails: {}\n",
                    shortfall(spec, &summary[c]),
                    describe(&summary[c]),
                    reasons(spec, &summary[c])
                );
            }
        }
    }
    let failing: Vec<&PointSummary> = summary.iter().filter(|s| !s.qualifies).collect();
    let _ = writeln!(md, "## Points that do not qualify ({})\n", failing.len());
    for s in failing {
        let _ = writeln!(md, "- `{}`: {}", s.key, reasons(spec, s));
    }
    md
}
