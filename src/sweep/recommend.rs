//! The recommendation: the cheapest point whose 95 % intervals meet the accuracy target and
//! detect the impact (upper error bounds within the target, lower SNR bound above the
//! threshold), with the runner-up, or — when none qualifies — the closest point. Also renders
//! recommendation.md, which names cheaper points the seeds left undecided and flags neighbours
//! in camera distance or frame rate that break the expected order (`monotonic`).

use super::spec::SweepSpec;
use super::summary::{Decision, PointSummary};
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
    /// Points cheaper than the chosen one (all, when none is chosen) whose intervals still
    /// straddle a boundary: more seeds could make one of them the choice.
    pub undecided_cheaper: Vec<usize>,
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
    let chosen = qualifying.first().copied();
    let undecided_cheaper = summary
        .iter()
        .filter(|s| s.decision == Decision::Undecided)
        .filter(|s| chosen.is_none_or(|c| by_cost(s, c) == Ordering::Less))
        .map(|s| s.index)
        .collect();
    Recommendation {
        chosen: chosen.map(|s| s.index),
        runner_up: qualifying.get(1).map(|s| s.index),
        closest,
        undecided_cheaper,
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
            "impact peak |α̂| {:.3} rad/s² vs α noise σ while engaged {} rad/s² → SNR {:.2} [{:.2}, {:.2}]",
            d.peak_alpha_rad_s2,
            ci("engaged_alpha_noise_rad_s2"),
            d.snr,
            s.snr_ci95.0,
            s.snr_ci95.1
        ),
        None => "impact: not computed".into(),
    };
    format!(
        "`{}`\n  - ω RMS {} rad/s, α RMS {} rad/s² (mean [95 % CI] over {} seed(s))\n  - {}\n",
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
    let bound = |name: &str, symbol: &str, target: f64, unit: &str, r: &mut Vec<String>| {
        let m = s.ci(name);
        // NaN bounds (one seed) are not within the target.
        let within = m.ci95_high <= target;
        if m.ci95_low > target {
            r.push(format!(
                "{symbol} RMS {:.4} [{:.4}, {:.4}] > {target} {unit}",
                m.mean, m.ci95_low, m.ci95_high
            ));
        } else if !within {
            r.push(format!(
                "{symbol} RMS {:.4} [{:.4}, {:.4}]: upper bound not within {target} {unit}",
                m.mean, m.ci95_low, m.ci95_high
            ));
        }
    };
    bound(
        "omega_rms_rad_s",
        "ω",
        spec.target.omega_rms_rad_s,
        "rad/s",
        &mut r,
    );
    bound(
        "alpha_rms_rad_s2",
        "α",
        spec.target.alpha_rms_rad_s2,
        "rad/s²",
        &mut r,
    );
    let (lo, hi) = s.snr_ci95;
    let lower_clears = lo >= spec.impact.min_snr;
    match s.impact {
        Some(d) if hi < spec.impact.min_snr => r.push(format!(
            "impact SNR {:.2} [{lo:.2}, {hi:.2}] < {}",
            d.snr, spec.impact.min_snr
        )),
        Some(d) if !lower_clears => r.push(format!(
            "impact SNR {:.2} [{lo:.2}, {hi:.2}]: lower bound not above {}",
            d.snr, spec.impact.min_snr
        )),
        None if s.error.is_empty() => r.push("impact SNR unknown".into()),
        None => r.push(s.error.clone()),
        _ => {}
    }
    if s.decision == Decision::Undecided {
        r.push(format!("undecided after {} seed(s)", s.runs_ok));
    }
    r.join("; ")
}

/// How many seeds the points got, in words.
fn seeds_sentence(spec: &SweepSpec, summary: &[PointSummary]) -> String {
    let mut counts: Vec<usize> = summary.iter().map(|s| s.runs_expected).collect();
    counts.sort_unstable();
    counts.dedup();
    let per: Vec<String> = counts
        .iter()
        .map(|c| {
            let n = summary.iter().filter(|s| s.runs_expected == *c).count();
            format!("{n} point(s) with {c}")
        })
        .collect();
    let rule = match &spec.adaptive {
        Some(a) => format!(
            "Seeds: {} a point, doubled for the points whose decision an interval left open, up \
             to {}",
            spec.seeds, a.max_seeds
        ),
        None => format!("Seeds: {} a point", spec.seeds),
    };
    format!("{rule}; seeds run: {}.", per.join(", "))
}

/// recommendation.md text.
pub fn markdown(spec: &SweepSpec, summary: &[PointSummary], rec: &Recommendation) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# Sweep recommendation\n");
    let _ = writeln!(
        md,
        "Target: ω RMS ≤ {} rad/s and α RMS ≤ {} rad/s² at the upper end of the 95 % CI over \
         seeds; impact Δω = {} rad/s over {} s detectable at SNR ≥ {} at the lower end of its \
         95 % CI (SNR = the differentiator's computed peak |α̂| for that impact over the \
         measured σ of the α detection error while the pin drives the wheel, where impacts \
         happen; not the dwell, where a still marker's whole-pixel corners often never change). \
         Cheapest by: {}. {}\n",
        spec.target.omega_rms_rad_s,
        spec.target.alpha_rms_rad_s2,
        spec.impact.delta_omega_rad_s,
        spec.impact.duration_s,
        spec.impact.min_snr,
        spec.cost.order.join(", then "),
        seeds_sentence(spec, summary)
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
    if !rec.undecided_cheaper.is_empty() {
        let _ = writeln!(
            md,
            "## Cheaper points left undecided ({})\n\nTheir intervals straddle a boundary at the \
             seed cap; more seeds could make one of them the choice.\n",
            rec.undecided_cheaper.len()
        );
        for &i in &rec.undecided_cheaper {
            let _ = writeln!(md, "- `{}`: {}", summary[i].key, reasons(spec, &summary[i]));
        }
        let _ = writeln!(md);
    }
    md.push_str(&super::monotonic::markdown(spec, summary));
    let failing: Vec<&PointSummary> = summary.iter().filter(|s| !s.qualifies).collect();
    let _ = writeln!(md, "## Points that do not qualify ({})\n", failing.len());
    for s in failing {
        let _ = writeln!(md, "- `{}`: {}", s.key, reasons(spec, s));
    }
    md
}
