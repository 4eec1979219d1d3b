//! The sweep evaluator backed by the real pipeline: one `run` per (point, seed), no files.

use super::run::{run, RunError, RunOptions};
use crate::scenario::Scenario;
use crate::sweep::{Evaluator, PointMetrics};

/// Evaluates sweep points with render → detect → estimate → budget.
pub struct PipelineEvaluator;

impl Evaluator for PipelineEvaluator {
    type Error = RunError;

    fn evaluate(&self, scenario: &Scenario, _seed: u64) -> Result<PointMetrics, RunError> {
        // The engine has already written the run seed into `scenario.seed`.
        let options = RunOptions {
            plots: false,
            write_files: false,
            ..RunOptions::default()
        };
        let out = run(scenario, std::path::Path::new("."), &options, &|_, _| {})?;
        let b = &out.budget;
        let t = &out.truth.t_s;
        let mean_interval = if t.len() > 1 {
            (t[t.len() - 1] - t[0]) / (t.len() - 1) as f64
        } else {
            f64::NAN
        };
        Ok(PointMetrics {
            theta_rms_rad: b.theta.rms,
            omega_rms_rad_s: b.omega.rms,
            alpha_rms_rad_s2: b.alpha.rms,
            omega_p95_rad_s: b.omega.p95,
            alpha_p95_rad_s2: b.alpha.p95,
            frames_total: b.frames.total,
            frames_detected: b.frames.detected,
            // The headline (fused) signal's α detection noise while the pin drives the wheel.
            engaged_alpha_noise_rad_s2: b
                .bounds
                .get(crate::estimate::Signal::Fused.name())
                .map_or(f64::NAN, |r| r.engaged_detection_alpha_std_rad_s2),
            mean_frame_interval_s: mean_interval,
            kalman_lambda_per_s6: match out.differentiator {
                crate::estimate::Differentiator::KalmanRts {
                    lambda_per_s6: Some(l),
                } => l,
                _ => f64::NAN,
            },
        })
    }
}
