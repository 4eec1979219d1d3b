//! Deterministic frame schedules: the frame times a configured camera produces over a duration.

use rand::Rng;
use rand_distr::StandardNormal;

use super::config::{FrameTimingConfig, LogModel, TimingModel, VfrModel};
use super::error::TimingError;
use super::timestamps::Timestamps;
use crate::rng::{stream, Stream};
use crate::validation::Problems;

/// Jitter draws beyond this many σ are redrawn; the ordering guarantee relies on the bound.
pub const JITTER_TRUNCATION_SIGMA: f64 = 4.0;

impl FrameTimingConfig {
    /// Frame times in `[0, duration_s)` (for `log`: the log's frames before `duration_s`).
    /// Same config + seed ⇒ same times; a longer duration extends the same schedule.
    /// `loaded_log` must be the parsed log file when the model is `log`.
    pub fn schedule(
        &self,
        duration_s: f64,
        seed: u64,
        loaded_log: Option<&Timestamps>,
    ) -> Result<Timestamps, TimingError> {
        let mut problems = Problems::new();
        self.validate("frame_timing", &mut problems);
        problems.positive("duration_s", duration_s);
        if !problems.is_empty() {
            let msgs: Vec<String> = problems.iter().map(|p| p.to_string()).collect();
            return Err(TimingError::InvalidConfig(msgs.join("; ")));
        }
        match &self.model {
            TimingModel::Constant => constant(self.fps, duration_s),
            TimingModel::Vfr(v) => vfr(v, self.fps, duration_s, seed),
            TimingModel::Log(l) => {
                from_log(l, duration_s, loaded_log.ok_or(TimingError::MissingLog)?)
            }
        }
    }
}

impl FrameTimingConfig {
    /// The analysis timebase for `n` frames: `k / fps` at the nominal rate, whatever the model.
    pub fn timebase(&self, n: usize) -> Result<Timestamps, TimingError> {
        super::timestamps::timebase(n, self.fps)
    }
}

fn constant(fps: f64, duration_s: f64) -> Result<Timestamps, TimingError> {
    let times = (0u64..)
        .map(|k| k as f64 / fps)
        .take_while(|&t| t < duration_s)
        .collect();
    Timestamps::new(times)
}

fn vfr(v: &VfrModel, fps: f64, duration_s: f64, seed: u64) -> Result<Timestamps, TimingError> {
    let mut rng = stream(seed, Stream::FrameTiming, 0);
    let interval_s = 1.0 / v.actual_fps(fps);
    let first_s = if v.first_interval_s == 0.0 {
        interval_s
    } else {
        v.first_interval_s
    };
    let half_alternation_s = 0.5 * v.pair_alternation_s;
    let mut times = vec![0.0];
    for slot in 1u64.. {
        // Every slot consumes its draws whether or not it is kept, so the sequence of draws
        // (and hence the schedule) does not depend on the duration.
        let dropped = rng.gen::<f64>() < v.drop_probability && slot >= 2;
        let z = loop {
            let z: f64 = rng.sample(StandardNormal);
            if z.abs() <= JITTER_TRUNCATION_SIGMA {
                break z;
            }
        };
        let sign = if slot % 2 == 0 { 1.0 } else { -1.0 };
        let t =
            first_s + (slot - 1) as f64 * interval_s + sign * half_alternation_s + v.jitter_s * z;
        // Validation bounds the displacement to a quarter interval, so once one slot lands
        // past the end every later slot does too.
        if t >= duration_s {
            break;
        }
        if !dropped {
            times.push(t);
        }
    }
    Timestamps::new(times)
}

fn from_log(l: &LogModel, duration_s: f64, log: &Timestamps) -> Result<Timestamps, TimingError> {
    let rebase_s = if l.rebase_to_zero {
        -log.as_slice().first().copied().unwrap_or(0.0)
    } else {
        0.0
    };
    Ok(log
        .shifted(rebase_s + l.offset_s)?
        .truncated_before(duration_s))
}
