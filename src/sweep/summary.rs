//! Per-point summary: Monte Carlo mean and 95 % CI of every metric over the point's seeds,
//! impact detectability with its SNR interval, the decision on the 95 % bounds (qualifies,
//! fails, undecided), and the point's cost. Rows are in grid
//! order whatever order results.csv was written in, so summary.csv is deterministic.

use super::error::SweepError;
use super::grid::Point;
use super::results::{ResultRow, Status, METRICS};
use super::spec::{SweepSpec, COST_FPS, COST_PIXELS};
use crate::budget::detectability::{detectability, Detectability};
use crate::budget::MeanCi;
use crate::estimate::Differentiator;
use crate::scenario::{Scenario, ScenarioError};
use std::path::Path;

/// Summary of one point.
#[derive(Debug, Clone, PartialEq)]
pub struct PointSummary {
    pub index: usize,
    pub key: String,
    pub labels: Vec<String>,
    /// `ok` (all runs evaluated), `invalid`, `failed` (some run failed), `incomplete` (runs missing).
    pub status: String,
    pub runs_ok: usize,
    pub runs_expected: usize,
    /// Mean and CI of each metric, in [`METRICS`] order.
    pub metrics: Vec<MeanCi>,
    /// Impact detectability (absent when no run succeeded or the differentiator failed).
    pub impact: Option<Detectability>,
    /// Lower and upper 95 % bounds of the impact SNR (σ_α,engaged at its upper and lower bound).
    pub snr_ci95: (f64, f64),
    /// The upper 95 % bounds of ω and α RMS are within the target.
    pub meets_target: bool,
    /// Status ok, meets the target and the lower SNR bound clears the threshold.
    pub qualifies: bool,
    /// What the intervals say: qualifies, fails, or undecided (an interval straddles a boundary).
    pub decision: Decision,
    /// Cost key values in `cost.order` priority (smaller is cheaper).
    pub cost: Vec<f64>,
    /// First error message met (invalid settings or a failed run).
    pub error: String,
    /// The point's estimator uses the seed's rotation centre (whole pixels: its error depends on
    /// where the marker falls on the pixel grid; `monotonic` explains reversals with it).
    pub seed_rotation_centre: bool,
}

/// What a point's 95 % intervals say about the recommendation's conditions.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Decision {
    /// Upper error bounds within the target and lower SNR bound above the threshold.
    Qualifies,
    /// An error's lower bound above the target, the SNR's upper bound below the threshold, or
    /// the point did not run.
    Fails,
    /// Neither: more seeds could settle it.
    Undecided,
}

impl Decision {
    pub fn label(self) -> &'static str {
        match self {
            Decision::Qualifies => "qualifies",
            Decision::Fails => "fails",
            Decision::Undecided => "undecided",
        }
    }
}

impl PointSummary {
    /// The interval of the named metric (NaN when unknown).
    pub fn ci(&self, metric: &str) -> MeanCi {
        METRICS
            .iter()
            .position(|m| *m == metric)
            .and_then(|i| self.metrics.get(i))
            .copied()
            .unwrap_or(MeanCi {
                mean: f64::NAN,
                ci95_low: f64::NAN,
                ci95_high: f64::NAN,
                n: 0,
            })
    }

    /// Mean of the named metric (NaN when unknown).
    pub fn mean(&self, metric: &str) -> f64 {
        METRICS
            .iter()
            .position(|m| *m == metric)
            .and_then(|i| self.metrics.get(i))
            .map_or(f64::NAN, |m| m.mean)
    }
}

/// Summarises `rows` per point of `points` (grid order). `scenarios[i]` is point i's scenario
/// (or its validation error), used for the differentiator and the cost.
pub fn summarise(
    spec: &SweepSpec,
    points: &[Point],
    scenarios: &[Result<Scenario, ScenarioError>],
    rows: &[ResultRow],
) -> Vec<PointSummary> {
    // Rows grouped by point key once (in file order), so summarising is linear in the rows.
    let mut by_key: std::collections::HashMap<&str, Vec<&ResultRow>> = Default::default();
    for r in rows {
        by_key.entry(r.key.as_str()).or_default().push(r);
    }
    points
        .iter()
        .zip(scenarios)
        .map(|(point, scenario)| {
            let mine: Vec<&ResultRow> = by_key.get(point.key.as_str()).cloned().unwrap_or_default();
            let ok: Vec<&ResultRow> = mine
                .iter()
                .copied()
                .filter(|r| r.status == Status::Ok)
                .collect();
            let mut seen: Vec<usize> = mine.iter().map(|r| r.seed_index).collect();
            seen.sort_unstable();
            seen.dedup();
            let error = mine
                .iter()
                .find(|r| r.status != Status::Ok)
                .map(|r| r.error.clone())
                .or_else(|| {
                    scenario
                        .as_ref()
                        .err()
                        .map(|e| crate::errors::full(&e).replace('\n', " "))
                })
                .unwrap_or_default();
            let status = if scenario.is_err() || mine.iter().any(|r| r.status == Status::Invalid) {
                "invalid"
            } else if mine.iter().any(|r| r.status == Status::Failed) {
                "failed"
            } else if seen.len() < spec.seeds {
                "incomplete"
            } else {
                "ok"
            };
            let metrics: Vec<MeanCi> = (0..METRICS.len())
                .map(|i| {
                    let v: Vec<f64> = ok
                        .iter()
                        .filter_map(|r| r.metrics.map(|m| m.values()[i]))
                        .collect();
                    MeanCi::of(&v)
                })
                .collect();
            let mut s = PointSummary {
                index: point.index,
                key: point.key.clone(),
                labels: point.labels.clone(),
                status: status.to_string(),
                runs_ok: ok.len(),
                runs_expected: spec.seeds.max(seen.len()),
                metrics,
                impact: None,
                snr_ci95: (f64::NAN, f64::NAN),
                meets_target: false,
                qualifies: false,
                decision: Decision::Fails,
                cost: Vec::new(),
                error,
                seed_rotation_centre: false,
            };
            if let Ok(sc) = scenario {
                s.seed_rotation_centre =
                    sc.estimator.rotation_centre == crate::estimate::RotationCentreMethod::Seed;
                s.cost = cost(spec, point, sc);
                if !ok.is_empty() {
                    match detectability(
                        &as_run(&sc.estimator.differentiator, &ok),
                        s.mean("mean_frame_interval_s"),
                        spec.impact.delta_omega_rad_s,
                        spec.impact.duration_s,
                        s.mean("engaged_alpha_noise_rad_s2"),
                        spec.impact.min_snr,
                    ) {
                        Ok(d) => s.impact = Some(d),
                        Err(e) if s.error.is_empty() => s.error = format!("impact: {e}"),
                        Err(_) => {}
                    }
                }
            }
            decide(spec, &mut s);
            s
        })
        .collect()
}

/// The differentiator as the point's runs ran it: a Kalman smoother with automatic λ takes the
/// median of the λ its runs resolved on their measured series (the impact response depends on
/// λ, and a λ chosen on a noiseless impact series would make the SNR wildly optimistic); any
/// other differentiator is its own.
fn as_run(diff: &Differentiator, ok: &[&ResultRow]) -> Differentiator {
    if !matches!(
        diff,
        Differentiator::KalmanRts {
            lambda_per_s6: None
        }
    ) {
        return diff.clone();
    }
    let lambdas: Vec<f64> = ok
        .iter()
        .filter_map(|r| r.metrics.map(|m| m.kalman_lambda_per_s6))
        .collect();
    match crate::numeric::robust::median_finite(lambdas) {
        Some(l) => Differentiator::KalmanRts {
            lambda_per_s6: Some(l),
        },
        None => diff.clone(),
    }
}

/// The point's SNR interval, target verdict and decision, all on the 95 % bounds.
fn decide(spec: &SweepSpec, s: &mut PointSummary) {
    let (w, a) = (s.ci("omega_rms_rad_s"), s.ci("alpha_rms_rad_s2"));
    let noise = s.ci("engaged_alpha_noise_rad_s2");
    if let Some(d) = &s.impact {
        let snr = |sigma: f64| {
            if sigma > 0.0 {
                d.peak_alpha_rad_s2 / sigma
            } else {
                f64::INFINITY
            }
        };
        s.snr_ci95 = (snr(noise.ci95_high), snr(noise.ci95_low));
    }
    let (tw, ta, min_snr) = (
        spec.target.omega_rms_rad_s,
        spec.target.alpha_rms_rad_s2,
        spec.impact.min_snr,
    );
    s.meets_target = w.ci95_high <= tw && a.ci95_high <= ta;
    let ok = s.status == "ok" && s.impact.is_some();
    s.decision = if ok && s.meets_target && s.snr_ci95.0 >= min_snr {
        Decision::Qualifies
    } else if !ok || w.ci95_low > tw || a.ci95_low > ta || s.snr_ci95.1 < min_snr {
        Decision::Fails
    } else {
        Decision::Undecided
    };
    s.qualifies = s.decision == Decision::Qualifies;
}

/// Cost key values of a point, in `cost.order` priority.
fn cost(spec: &SweepSpec, point: &Point, scenario: &Scenario) -> Vec<f64> {
    // The scenario as TOML: the cost reads fields by path, whatever section defines them.
    let value = toml::Value::try_from(scenario).ok();
    let field = |path: &str| -> f64 {
        let mut cur = value.as_ref();
        for part in path.split('.') {
            cur = cur.and_then(|v| v.get(part));
        }
        match cur {
            Some(toml::Value::Integer(i)) => *i as f64,
            Some(toml::Value::Float(f)) => *f,
            // Unknown field (e.g. a camera section without a resolution): no cost difference.
            _ => 0.0,
        }
    };
    spec.cost
        .order
        .iter()
        .map(|key| match key.as_str() {
            COST_PIXELS => field("camera.width_px") * field("camera.height_px"),
            COST_FPS => field("frame_timing.fps"),
            axis_name => {
                let a = spec.axes.iter().position(|a| a.name == axis_name);
                match a {
                    Some(a) => match spec.axes[a].values.as_ref().map(|v| &v[point.levels[a]]) {
                        Some(toml::Value::Integer(i)) => *i as f64,
                        Some(toml::Value::Float(f)) => *f,
                        // Levels and non-numeric values: listed cheapest first.
                        _ => point.levels[a] as f64,
                    },
                    None => 0.0,
                }
            }
        })
        .collect()
}

/// The summary.csv header for these axis names.
pub fn header(axis_names: &[String]) -> Vec<String> {
    let mut h = vec!["point".to_string(), "key".to_string()];
    h.extend(axis_names.iter().cloned());
    h.extend(["status", "runs_ok", "runs"].map(String::from));
    for m in METRICS {
        h.push(format!("{m}_mean"));
        h.push(format!("{m}_ci95_low"));
        h.push(format!("{m}_ci95_high"));
    }
    h.extend(
        [
            "impact_peak_alpha_rad_s2",
            "impact_snr",
            "detectable",
            "impact_snr_ci95_low",
            "impact_snr_ci95_high",
            "decision",
            "meets_target",
            "qualifies",
            "cost",
            "error",
        ]
        .map(String::from),
    );
    h
}

/// Writes summary.csv (grid order).
pub fn write_csv(
    path: &Path,
    axis_names: &[String],
    rows: &[PointSummary],
) -> Result<(), SweepError> {
    let e = SweepError::csv(path);
    let mut w = csv::Writer::from_path(path).map_err(e)?;
    w.write_record(header(axis_names)).map_err(e)?;
    for s in rows {
        let mut c = vec![s.index.to_string(), s.key.clone()];
        c.extend(s.labels.iter().cloned());
        c.push(s.status.clone());
        c.push(s.runs_ok.to_string());
        c.push(s.runs_expected.to_string());
        for m in &s.metrics {
            c.push(m.mean.to_string());
            c.push(m.ci95_low.to_string());
            c.push(m.ci95_high.to_string());
        }
        match &s.impact {
            Some(d) => {
                c.push(d.peak_alpha_rad_s2.to_string());
                c.push(d.snr.to_string());
                c.push(d.detectable.to_string());
            }
            None => c.extend(["", "", "false"].map(String::from)),
        }
        c.push(s.snr_ci95.0.to_string());
        c.push(s.snr_ci95.1.to_string());
        c.push(s.decision.label().to_string());
        c.push(s.meets_target.to_string());
        c.push(s.qualifies.to_string());
        c.push(
            s.cost
                .iter()
                .map(|v| v.to_string())
                .collect::<Vec<_>>()
                .join(";"),
        );
        c.push(s.error.clone());
        w.write_record(&c).map_err(e)?;
    }
    w.flush().map_err(SweepError::write(path))
}
