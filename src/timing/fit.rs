//! Fits the VFR model to measured frame times (`geneva timing fit LOG`): rate, first interval,
//! paired alternation, residual jitter and drop rate, with goodness-of-fit numbers.

use std::fmt;

use super::config::{FrameTimingConfig, TimingModel, VfrModel};
use super::error::TimingError;
use super::stats::{median, DROP_THRESHOLD};
use super::timestamps::Timestamps;

/// The fitted model and how well it explains the data.
#[derive(Debug, Clone, PartialEq)]
pub struct TimingFit {
    /// `fps` = fitted actual rate, `rate_error_ppm` = 0 (the nominal rate is not observable).
    pub config: FrameTimingConfig,
    /// Fitted actual frame rate, fps, and its standard error.
    pub fps: f64,
    pub fps_stderr: f64,
    /// Fitted first interval (frame 0 → slot 1), s, and its standard error.
    pub first_interval_s: f64,
    pub first_interval_stderr_s: f64,
    /// Signed alternation amplitude (positive: slot m displaced by +a/2·(−1)^m), s, ± stderr.
    pub pair_alternation_s: f64,
    pub pair_alternation_stderr_s: f64,
    /// Residual timestamp jitter σ (RMS residual with n − 3 degrees of freedom), s.
    pub jitter_s: f64,
    /// Largest absolute residual, s.
    pub max_abs_residual_s: f64,
    /// Frames used (all of them) and grid slots they span after slot 1.
    pub frames: usize,
    pub dropped_frames: usize,
    /// dropped_frames / slots after slot 1.
    pub drop_probability: f64,
}

/// Least squares of `t_k − t_0` (k ≥ 1) on slot index m_k: `first + (m − 1)·Δ + h·(−1)^m`,
/// where slots come from rounding each interval by the median interval (so drops skip slots).
/// Needs at least 5 frames.
pub fn fit_vfr(ts: &Timestamps) -> Result<TimingFit, TimingError> {
    if ts.len() < 5 {
        return Err(TimingError::TooFewFrames {
            needed: 5,
            got: ts.len(),
        });
    }
    let t = ts.as_slice();
    let d = ts.intervals_s();
    let nominal_s = median(&d[1..]);
    let mut slots = vec![1u64];
    for &dk in &d[1..] {
        let step = if dk > DROP_THRESHOLD * nominal_s {
            (dk / nominal_s).round() as u64
        } else {
            1
        };
        slots.push(slots[slots.len() - 1] + step.max(1));
    }
    let last_slot = slots[slots.len() - 1];
    let dropped_frames = (last_slot - slots.len() as u64) as usize;
    let y: Vec<f64> = t[1..].iter().map(|tk| tk - t[0]).collect();
    // Centred slot regressor keeps the normal equations well conditioned for long logs.
    let x1: Vec<f64> = slots.iter().map(|&m| (m - 1) as f64).collect();
    let x1_mean = x1.iter().sum::<f64>() / x1.len() as f64;
    let rows: Vec<[f64; 3]> = slots
        .iter()
        .zip(&x1)
        .map(|(&m, &x)| [1.0, x - x1_mean, if m % 2 == 0 { 1.0 } else { -1.0 }])
        .collect();
    let (beta, cov_unscaled) = least_squares(&rows, &y).ok_or_else(|| {
        TimingError::InvalidConfig("frame times do not determine rate and alternation".into())
    })?;
    let residuals: Vec<f64> = rows
        .iter()
        .zip(&y)
        .map(|(r, yk)| yk - (beta[0] + beta[1] * r[1] + beta[2] * r[2]))
        .collect();
    let dof = (residuals.len() - 3).max(1) as f64;
    let sigma = (residuals.iter().map(|r| r * r).sum::<f64>() / dof).sqrt();
    let interval_s = beta[1];
    let first_interval_s = beta[0] - beta[1] * x1_mean;
    // Var(b0 − x̄·b1) = V00 + x̄²V11 − 2x̄V01 (unscaled), times σ².
    let first_var = cov_unscaled[0][0] + x1_mean * x1_mean * cov_unscaled[1][1]
        - 2.0 * x1_mean * cov_unscaled[0][1];
    let interval_stderr_s = sigma * cov_unscaled[1][1].sqrt();
    let fps = 1.0 / interval_s;
    let slots_after_first = (last_slot - 1).max(1) as f64;
    let drop_probability = dropped_frames as f64 / slots_after_first;
    let pair_alternation_s = 2.0 * beta[2];
    let vfr = VfrModel {
        jitter_s: sigma,
        pair_alternation_s: pair_alternation_s.abs(),
        first_interval_s,
        drop_probability,
        rate_error_ppm: 0.0,
    };
    Ok(TimingFit {
        config: FrameTimingConfig {
            fps,
            model: TimingModel::Vfr(vfr),
            ..FrameTimingConfig::default()
        },
        fps,
        fps_stderr: interval_stderr_s / (interval_s * interval_s),
        first_interval_s,
        first_interval_stderr_s: sigma * first_var.max(0.0).sqrt(),
        pair_alternation_s,
        pair_alternation_stderr_s: 2.0 * sigma * cov_unscaled[2][2].sqrt(),
        jitter_s: sigma,
        max_abs_residual_s: residuals.iter().fold(0.0, |m: f64, r| m.max(r.abs())),
        frames: ts.len(),
        dropped_frames,
        drop_probability,
    })
}

/// Solves the 3-parameter normal equations; returns β and (XᵀX)⁻¹, or None if singular.
fn least_squares(rows: &[[f64; 3]], y: &[f64]) -> Option<([f64; 3], [[f64; 3]; 3])> {
    let mut a = [[0.0; 3]; 3];
    let mut b = [0.0; 3];
    for (r, &yk) in rows.iter().zip(y) {
        for i in 0..3 {
            b[i] += r[i] * yk;
            for j in 0..3 {
                a[i][j] += r[i] * r[j];
            }
        }
    }
    let inv = crate::estimate::linalg::invert3(&a)?;
    let mut beta = [0.0; 3];
    for i in 0..3 {
        beta[i] = (0..3).map(|j| inv[i][j] * b[j]).sum();
    }
    Some((beta, inv))
}

impl fmt::Display for TimingFit {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ms = |s: f64| s * 1e3;
        writeln!(f, "VFR fit over {} frames", self.frames)?;
        writeln!(
            f,
            "rate               {:.4} ± {:.4} fps",
            self.fps, self.fps_stderr
        )?;
        writeln!(
            f,
            "first interval     {:.4} ± {:.4} ms",
            ms(self.first_interval_s),
            ms(self.first_interval_stderr_s)
        )?;
        writeln!(
            f,
            "pair alternation   {:.4} ± {:.4} ms",
            ms(self.pair_alternation_s),
            ms(self.pair_alternation_stderr_s)
        )?;
        writeln!(
            f,
            "jitter σ (residual) {:.4} ms, max |residual| {:.4} ms",
            ms(self.jitter_s),
            ms(self.max_abs_residual_s)
        )?;
        write!(
            f,
            "dropped frames     {} (drop probability {:.5})",
            self.dropped_frames, self.drop_probability
        )
    }
}
