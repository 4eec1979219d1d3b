//! From corner tracks to per-signal angles and derivatives — the part of the pipeline shared by
//! synthetic runs and real footage.

use crate::budget::compare::{to_wheel_convention, SignalErrors, TruthSeries};
use crate::estimate::{estimate, Estimate, EstimateError, EstimatorConfig};
use crate::io::tracks_csv::Corners;

/// Runs the estimator on a track; `reference` only when a static reference marker was tracked.
pub fn estimate_track(
    config: &EstimatorConfig,
    t_s: &[f64],
    corners: &[Option<Corners>],
    reference: Option<&[Option<Corners>]>,
) -> Result<Estimate, EstimateError> {
    estimate(config, t_s, corners, reference)
}

/// Per-signal measured series in a wheel convention without truth (real footage): angles
/// relative to the first detected frame, `sign` chooses the positive sense (+1: counter-
/// clockwise on screen).
pub fn relative_series(est: &Estimate, sign: f64) -> Vec<SignalErrors> {
    let n = est.t_used_s.len();
    let zero = TruthSeries {
        t_s: est.t_used_s.clone(),
        theta2_rad: vec![0.0; n],
        omega2_rad_s: vec![0.0; n],
        alpha2_rad_s2: vec![0.0; n],
        phase: vec![""; n],
    };
    est.signals
        .iter()
        .map(|s| {
            let first = s
                .theta_rad
                .iter()
                .copied()
                .find(|v| v.is_finite())
                .unwrap_or(0.0);
            to_wheel_convention(
                s.signal.name(),
                &s.theta_rad,
                &s.omega_rad_s,
                &s.alpha_rad_s2,
                sign,
                first,
                0.0,
                &zero,
            )
        })
        .collect()
}
