//! Summary statistics of a frame-time series (rate, jitter, first-frame gap, alternation,
//! drops) and their human-readable summary for `geneva timing show`.

use std::fmt;

use super::error::TimingError;
use super::timestamps::Timestamps;
use crate::numeric::robust::{mean, median, sample_sd};

/// An interval longer than this multiple of the nominal interval counts as a dropped frame.
pub const DROP_THRESHOLD: f64 = 1.5;

/// Statistics of one frame-time series. "Steady" intervals exclude the first one (phones show a
/// long gap before the second frame) and the intervals flagged as drops.
#[derive(Debug, Clone, PartialEq)]
pub struct TimingStats {
    /// Number of frames.
    pub count: usize,
    /// Last minus first timestamp, s.
    pub span_s: f64,
    /// Span / (count − 1), s.
    pub mean_interval_s: f64,
    /// (count − 1) / span, frames per second.
    pub mean_fps: f64,
    /// (count − 2) / (last − second timestamp): the rate once the first gap is over, fps.
    pub steady_fps: f64,
    /// Median interval excluding the first: the nominal interval used for drop detection, s.
    pub median_interval_s: f64,
    /// Sample standard deviation of the steady intervals (jitter), s.
    pub interval_std_s: f64,
    /// Smallest interval excluding the first, s.
    pub min_interval_s: f64,
    /// Largest interval excluding the first, s.
    pub max_interval_s: f64,
    /// The interval between frames 0 and 1, s.
    pub first_interval_s: f64,
    /// Mean |Δᵢ − Δᵢ₊₁| / 2 over consecutive steady intervals, s: the brief's "paired jitter".
    /// It reacts to any jitter (≈ 0.98 σ for white timestamp jitter σ), not only to alternation.
    pub mean_abs_alternation_s: f64,
    /// |mean of (−1)ⁱ (Δᵢ − mean Δ)| over steady intervals, s: the amplitude `a` of a coherent
    /// alternation Δ ± a; for white jitter it only reaches ~σ·√(2/n).
    pub coherent_alternation_s: f64,
    /// Frames missing according to intervals > DROP_THRESHOLD × median (each such interval
    /// contributes round(Δ / median) − 1), excluding the first interval.
    pub dropped_frames: usize,
}

/// Median of the positive intervals between consecutive times (NaN for fewer than 2 times).
pub fn median_interval_s(times_s: &[f64]) -> f64 {
    let d: Vec<f64> = times_s
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| d.is_finite() && *d > 0.0)
        .collect();
    if d.is_empty() {
        return f64::NAN;
    }
    median(&d)
}

impl TimingStats {
    /// Needs at least 3 frames (a first interval plus one steady interval).
    pub fn of(ts: &Timestamps) -> Result<Self, TimingError> {
        if ts.len() < 3 {
            return Err(TimingError::TooFewFrames {
                needed: 3,
                got: ts.len(),
            });
        }
        let t = ts.as_slice();
        let d = ts.intervals_s();
        let later = &d[1..];
        let median_interval_s = median(later);
        let is_drop = |x: f64| x > DROP_THRESHOLD * median_interval_s;
        let steady: Vec<f64> = later.iter().copied().filter(|&x| !is_drop(x)).collect();
        let dropped_frames = later
            .iter()
            .filter(|&&x| is_drop(x))
            .map(|&x| ((x / median_interval_s).round() as usize).saturating_sub(1))
            .sum();
        let pairs: Vec<f64> = later
            .windows(2)
            .filter(|w| !is_drop(w[0]) && !is_drop(w[1]))
            .map(|w| (w[0] - w[1]).abs() / 2.0)
            .collect();
        let steady_mean = mean(&steady);
        let coherent = steady
            .iter()
            .enumerate()
            .map(|(i, x)| {
                if i % 2 == 0 {
                    x - steady_mean
                } else {
                    steady_mean - x
                }
            })
            .sum::<f64>()
            / steady.len() as f64;
        let span_s = t[t.len() - 1] - t[0];
        Ok(Self {
            count: t.len(),
            span_s,
            mean_interval_s: span_s / d.len() as f64,
            mean_fps: d.len() as f64 / span_s,
            steady_fps: later.len() as f64 / (t[t.len() - 1] - t[1]),
            median_interval_s,
            interval_std_s: sample_sd(&steady),
            min_interval_s: later.iter().copied().fold(f64::INFINITY, f64::min),
            max_interval_s: later.iter().copied().fold(f64::NEG_INFINITY, f64::max),
            first_interval_s: d[0],
            mean_abs_alternation_s: if pairs.is_empty() { 0.0 } else { mean(&pairs) },
            coherent_alternation_s: coherent.abs(),
            dropped_frames,
        })
    }
}

impl fmt::Display for TimingStats {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let ms = |s: f64| s * 1e3;
        writeln!(f, "frames               {}", self.count)?;
        writeln!(f, "span                 {:.6} s", self.span_s)?;
        writeln!(
            f,
            "mean rate            {:.4} fps (mean interval {:.4} ms)",
            self.mean_fps,
            ms(self.mean_interval_s)
        )?;
        writeln!(
            f,
            "steady rate          {:.4} fps (after the first interval)",
            self.steady_fps
        )?;
        writeln!(
            f,
            "first interval       {:.4} ms",
            ms(self.first_interval_s)
        )?;
        writeln!(
            f,
            "median interval      {:.4} ms",
            ms(self.median_interval_s)
        )?;
        writeln!(
            f,
            "interval min / max   {:.4} / {:.4} ms",
            ms(self.min_interval_s),
            ms(self.max_interval_s)
        )?;
        writeln!(
            f,
            "interval std         {:.4} ms (jitter)",
            ms(self.interval_std_s)
        )?;
        writeln!(
            f,
            "paired |Δi−Δi+1|/2   {:.4} ms mean",
            ms(self.mean_abs_alternation_s)
        )?;
        writeln!(
            f,
            "coherent alternation {:.4} ms",
            ms(self.coherent_alternation_s)
        )?;
        write!(
            f,
            "dropped frames       {} (intervals > {DROP_THRESHOLD} × median)",
            self.dropped_frames
        )
    }
}
