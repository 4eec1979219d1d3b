//! Fits the VFR model to measured frame times (`geneva timing fit LOG`): rate, first interval,
//! paired alternation, residual jitter and drop rate, with goodness-of-fit numbers.

use std::fmt;

use super::config::{FrameTimingConfig, TimingModel, VfrModel};
use super::error::TimingError;
use super::stats::DROP_THRESHOLD;
use super::timestamps::Timestamps;
use crate::numeric::robust::median;

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

/// Intervals kept to find the median interval: logs up to this many intervals use them all,
/// longer ones an evenly spread sample of them (every 2^k-th interval).
pub const MEDIAN_SAMPLE: usize = 4096;

/// Least squares of `t_k − t_0` (k ≥ 1) on slot index m_k: `first + (m − 1)·Δ + h·(−1)^m`,
/// where slots come from rounding each interval by the median interval (so drops skip slots).
/// Needs at least 5 frames.
pub fn fit_vfr(ts: &Timestamps) -> Result<TimingFit, TimingError> {
    fit_vfr_passes(|each: &mut dyn FnMut(f64) -> Result<(), TimingError>| {
        ts.as_slice().iter().try_for_each(|&t| each(t))
    })
}

/// [`fit_vfr`] over frame times that `replay` hands to its argument, in order, each time it is
/// called (three times: median interval, normal equations, residuals), so a log of any length
/// is fitted in constant memory by reading it three times.
pub fn fit_vfr_passes<E: From<TimingError>>(
    mut replay: impl FnMut(&mut dyn FnMut(f64) -> Result<(), TimingError>) -> Result<(), E>,
) -> Result<TimingFit, E> {
    // Pass 1: frame count, first time, and the slot unit: the median of half the span of two
    // consecutive intervals after the first. A pair alternation (intervals I ± a) cancels in a
    // pair's span, so the unit is I itself; the median single interval is I + a or I − a
    // whenever drops tilt the count, and a run of 4 drops at a = 0.09 I (a span of 5I − a)
    // then rounded to 4 slots of I + a, which bent the fitted rate (0.0501 s for 0.05).
    let mut frames = 0usize;
    let (mut previous_s, mut before_previous_s) = (0.0, 0.0);
    let mut t0_s = 0.0;
    let mut sample = IntervalSample::default();
    replay(&mut |t| {
        if frames == 0 {
            t0_s = t;
        } else if frames >= 3 {
            sample.push(0.5 * (t - before_previous_s));
        }
        before_previous_s = previous_s;
        previous_s = t;
        frames += 1;
        Ok(())
    })?;
    if frames < 5 {
        return Err(TimingError::TooFewFrames {
            needed: 5,
            got: frames,
        }
        .into());
    }
    let nominal_s = sample.median();

    // Pass 2: slots, and the normal equations of y' = y − x·nominal on the centred slot index
    // (integer sums exact in i128; the small y' keep the float sums well conditioned).
    let mut sums = Sums::default();
    let mut slots = Slots::new(nominal_s);
    let mut k = 0usize;
    replay(&mut |t| {
        if k > 0 {
            let (x, s) = slots.next(k, t)?;
            sums.add(x, s, t - t0_s - x as f64 * nominal_s)?;
        }
        slots.previous_s = t;
        k += 1;
        Ok(())
    })?;
    changed_between_passes(frames, k)?;
    let solved = sums.solve().ok_or_else(|| {
        TimingError::InvalidConfig(
            "frame times do not determine rate and alternation (all intervals fall on slots of \
             one parity, or too few distinct slots)"
                .into(),
        )
    })?;

    // Pass 3: residuals.
    let mut slots_again = Slots::new(nominal_s);
    let (mut rss, mut max_abs, mut k3) = (0.0f64, 0.0f64, 0usize);
    replay(&mut |t| {
        if k3 > 0 {
            let (x, s) = slots_again.next(k3, t)?;
            let y = t - t0_s - x as f64 * nominal_s;
            let r = y - solved.predict(x, s);
            rss += r * r;
            max_abs = max_abs.max(r.abs());
        }
        slots_again.previous_s = t;
        k3 += 1;
        Ok(())
    })?;
    changed_between_passes(frames, k3)?;

    let n = frames - 1;
    let dof = (n.saturating_sub(3)).max(1) as f64;
    let sigma = (rss / dof).sqrt();
    let [b0, b1, b2] = solved.beta;
    let inv = solved.inverse;
    let x_mean = solved.x_mean;
    let interval_s = b1 + nominal_s;
    let first_interval_s = b0 - b1 * x_mean;
    // Var(b0 − x̄·b1) = V00 + x̄²V11 − 2x̄V01 (unscaled), times σ².
    let first_var = inv[0][0] + x_mean * x_mean * inv[1][1] - 2.0 * x_mean * inv[0][1];
    let interval_stderr_s = sigma * inv[1][1].max(0.0).sqrt();
    let fps = 1.0 / interval_s;
    let last_slot = slots.last_slot;
    let dropped_frames = (last_slot - n as u64) as usize;
    let slots_after_first = (last_slot - 1).max(1) as f64;
    let drop_probability = dropped_frames as f64 / slots_after_first;
    let pair_alternation_s = 2.0 * b2;
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
        pair_alternation_stderr_s: 2.0 * sigma * inv[2][2].max(0.0).sqrt(),
        jitter_s: sigma,
        max_abs_residual_s: max_abs,
        frames,
        dropped_frames,
        drop_probability,
    })
}

fn changed_between_passes(first: usize, now: usize) -> Result<(), TimingError> {
    if first == now {
        Ok(())
    } else {
        Err(TimingError::InvalidConfig(format!(
            "the log changed while it was read ({first} frames, then {now})"
        )))
    }
}

/// An evenly spread sample of at most [`MEDIAN_SAMPLE`] intervals: every one while they fit,
/// then every second of those kept (and of those to come), and so on.
#[derive(Default)]
pub(super) struct IntervalSample {
    kept: Vec<f64>,
    seen: u64,
    stride: u64,
}

impl IntervalSample {
    pub(super) fn push(&mut self, d: f64) {
        let stride = self.stride.max(1);
        if self.seen % stride == 0 {
            if self.kept.len() == MEDIAN_SAMPLE {
                let mut i = 0;
                self.kept.retain(|_| {
                    i += 1;
                    i % 2 == 1
                });
                self.stride = stride * 2;
            }
            if self.seen % self.stride.max(1) == 0 {
                self.kept.push(d);
            }
        }
        self.seen += 1;
    }

    pub(super) fn median(&self) -> f64 {
        median(&self.kept)
    }

    #[cfg(test)]
    pub(super) fn len(&self) -> usize {
        self.kept.len()
    }
}

/// Slot numbers of frames 1, 2, …: frame 1 is slot 1; each later interval advances by one slot,
/// or by its rounded ratio to the nominal interval when it is a drop.
struct Slots {
    nominal_s: f64,
    previous_s: f64,
    last_slot: u64,
}

impl Slots {
    fn new(nominal_s: f64) -> Self {
        Slots {
            nominal_s,
            previous_s: 0.0,
            last_slot: 0,
        }
    }

    /// (x = slot − 1, s = ±1 by the slot's parity) of frame `k` ≥ 1 at time `t`.
    fn next(&mut self, k: usize, t: f64) -> Result<(u64, f64), TimingError> {
        let slot = if k == 1 {
            1
        } else {
            let dk = t - self.previous_s;
            let step = if dk > DROP_THRESHOLD * self.nominal_s {
                (dk / self.nominal_s).round()
            } else {
                1.0
            };
            // Slots stay exact in an f64 (and in the i128 sums) below 2^53.
            let slot = self.last_slot as f64 + step.max(1.0);
            if slot >= 2f64.powi(53) {
                return Err(TimingError::InvalidConfig(format!(
                    "frame {k} falls {} nominal intervals after frame 0: too many to fit",
                    crate::validation::short(slot)
                )));
            }
            slot as u64
        };
        self.last_slot = slot;
        Ok((slot - 1, if slot % 2 == 0 { 1.0 } else { -1.0 }))
    }
}

/// Sums of the normal equations over rows (1, x, s) and the response y'.
#[derive(Default)]
struct Sums {
    n: i128,
    sx: i128,
    sxx: i128,
    ss: i128,
    sxs: i128,
    sy: f64,
    sxy: f64,
    ssy: f64,
}

/// The solved centred model y' = b0 + b1·(x − x̄) + b2·s and its unscaled covariance.
struct Solved {
    beta: [f64; 3],
    inverse: [[f64; 3]; 3],
    x_mean: f64,
}

impl Solved {
    fn predict(&self, x: u64, s: f64) -> f64 {
        self.beta[0] + self.beta[1] * (x as f64 - self.x_mean) + self.beta[2] * s
    }
}

impl Sums {
    fn add(&mut self, x: u64, s: f64, y: f64) -> Result<(), TimingError> {
        let xi = x as i128;
        let si = s as i128;
        let too_many = || {
            TimingError::InvalidConfig(
                "the log spans too many frame slots to fit (sums overflow)".into(),
            )
        };
        self.n += 1;
        self.sx = self.sx.checked_add(xi).ok_or_else(too_many)?;
        self.sxx = self.sxx.checked_add(xi * xi).ok_or_else(too_many)?;
        self.ss += si;
        self.sxs = self.sxs.checked_add(xi * si).ok_or_else(too_many)?;
        self.sy += y;
        self.sxy += x as f64 * y;
        self.ssy += s * y;
        Ok(())
    }

    fn solve(&self) -> Option<Solved> {
        let n = self.n as f64;
        let x_mean = self.sx as f64 / n;
        // Centred sums, exact in integers before the one division.
        let centred = |sum_xz: i128, sum_z: i128| {
            let exact = self
                .n
                .checked_mul(sum_xz)
                .zip(self.sx.checked_mul(sum_z))
                .and_then(|(a, b)| a.checked_sub(b));
            match exact {
                Some(v) => v as f64 / n,
                // Beyond i128: slots spread from 0 keep the float form well conditioned.
                None => sum_xz as f64 - x_mean * sum_z as f64,
            }
        };
        let a11 = centred(self.sxx, self.sx);
        let a12 = centred(self.sxs, self.ss);
        let a02 = self.ss as f64;
        let a = [[n, 0.0, a02], [0.0, a11, a12], [a02, a12, n]];
        let b = [self.sy, self.sxy - x_mean * self.sy, self.ssy];
        // Unit diagonal first, so that the singularity test of `invert3` is scale-free (the
        // slope's sum grows as n³ while the others grow as n).
        let d: Vec<f64> = (0..3).map(|i| a[i][i].sqrt()).collect();
        if d.iter().any(|v| !(v.is_finite() && *v > 0.0)) {
            return None;
        }
        let mut scaled = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                scaled[i][j] = a[i][j] / (d[i] * d[j]);
            }
        }
        let inv_scaled = crate::numeric::linalg::invert3(&scaled)?;
        let mut inverse = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                inverse[i][j] = inv_scaled[i][j] / (d[i] * d[j]);
            }
        }
        let mut beta = [0.0; 3];
        for i in 0..3 {
            beta[i] = (0..3).map(|j| inverse[i][j] * b[j]).sum();
        }
        Some(Solved {
            beta,
            inverse,
            x_mean,
        })
    }
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

impl TimingFit {
    /// The fitted model as a scenario section (`[frame_timing]` and `[frame_timing.model]`),
    /// which the scenario loader reads back to the same configuration.
    pub fn scenario_toml(&self) -> String {
        #[derive(serde::Serialize)]
        struct Section<'a> {
            frame_timing: &'a FrameTimingConfig,
        }
        toml::to_string_pretty(&Section {
            frame_timing: &self.config,
        })
        .unwrap_or_else(|e| format!("# cannot write the fit as TOML: {e}\n"))
    }
}
