//! From corner tracks to per-signal angles and derivatives — the part of the pipeline shared by
//! synthetic runs and real footage.

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
