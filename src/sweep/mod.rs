//! Design sweeps: which camera setup (distance, frame rate, resolution, detector, differentiator,
//! exposure, marker) should be used before filming? A sweep file names a base scenario and axes;
//! every point of their cartesian product is evaluated over several seeds by an [`Evaluator`]
//! (the render → detect → estimate pipeline, or a fake in tests), and the cheapest point that
//! meets an accuracy target and can see an impact is recommended.
//!
//! Files: `spec` (the sweep file), `grid` (points, keys, overrides, seeds), `results`
//! (results.csv rows), `engine` (the sweep as a study of work units: parallel, resumable,
//! shardable, committed all at once; see `shard`; with `[adaptive]`, seeds added in rounds to the
//! undecided points), `summary` (per-point Monte Carlo means and CIs, detectability, the decision
//! on the 95 % bounds), `adaptive` (which points get more seeds), `recommend` (the choice and
//! recommendation.md), `monotonic` (neighbours out of the expected order), `heatmaps`.

pub mod adaptive;
pub mod engine;
pub mod error;
pub mod grid;
pub mod heatmaps;
pub mod monotonic;
pub mod recommend;
pub mod results;
pub mod spec;
pub mod summary;

#[cfg(test)]
mod tests;

pub use engine::{
    check, merge_sweep, run_sweep, run_sweep_with, sweep_file_of, Control, SweepOutcome, SweepRun,
};
pub use error::SweepError;
pub use grid::{load_base, point_scenario, points, run_seed, Point};
pub use recommend::{recommend, Recommendation};
pub use results::{ResultRow, Status, METRICS};
pub use spec::{AdaptiveSpec, AxisSpec, CostSpec, ImpactSpec, LevelSpec, SweepSpec, TargetSpec};
pub use summary::PointSummary;

use crate::scenario::Scenario;

/// Errors of ONE run (one point, one seed), SI units.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct PointMetrics {
    /// θ RMS error, rad.
    pub theta_rms_rad: f64,
    /// ω RMS error, rad/s.
    pub omega_rms_rad_s: f64,
    /// α RMS error, rad/s².
    pub alpha_rms_rad_s2: f64,
    /// 95th percentile of |ω error|, rad/s.
    pub omega_p95_rad_s: f64,
    /// 95th percentile of |α error|, rad/s².
    pub alpha_p95_rad_s2: f64,
    /// Frames in the recording.
    pub frames_total: usize,
    /// Frames where the marker was detected.
    pub frames_detected: usize,
    /// σ of the α detection error (α̂ − D(θ̄): what detection adds, the differentiator's bias
    /// cancelled) over the engaged frames (entry, drive, exit): the noise an impact must beat,
    /// rad/s² (`budget::report::ENGAGED_PHASES` says why not the dwell).
    pub engaged_alpha_noise_rad_s2: f64,
    /// Mean frame interval, s.
    pub mean_frame_interval_s: f64,
    /// The Kalman smoother's λ as the run resolved it on its measured series, 1/s⁶ (NaN for
    /// other differentiators): what the impact SNR of an automatic-λ point is computed with.
    pub kalman_lambda_per_s6: f64,
}

/// Evaluates one scenario with one seed (the scenario's `seed` is already set to it).
pub trait Evaluator: Sync {
    /// Why a run failed; its text goes into the row's `error` column.
    type Error: std::error::Error;
    fn evaluate(&self, scenario: &Scenario, seed: u64) -> Result<PointMetrics, Self::Error>;
}
