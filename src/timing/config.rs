//! `FrameTimingConfig`: the `[frame_timing]` scenario section (nominal rate plus the model that
//! turns it into frame times) and its validation.

use serde::{Deserialize, Serialize};

use super::format::LogFormat;
use crate::validation::{join, Problems};

/// Frame timing of the camera. TOML:
/// ```toml
/// [frame_timing]
/// fps = 30.0
/// [frame_timing.model]
/// kind = "vfr"            # "constant" | "vfr" | "log"
/// first_interval_s = 0.055
/// ```
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct FrameTimingConfig {
    /// Nominal frame rate, frames per second; also the rate of the analysis timebase
    /// (`k / fps`) when the analysis assumes a constant rate. Range [0.1, 10000]. Default 30.
    pub fps: f64,
    /// Which instant of the frame its timestamp marks. Default `first_row_exposure_centre`.
    /// (Before `model`: TOML writes plain values before tables.)
    pub timestamp_marks: TimestampMark,
    /// How frame times are generated from the nominal rate. Default `constant`.
    pub model: TimingModel,
}

impl Default for FrameTimingConfig {
    fn default() -> Self {
        Self {
            fps: 30.0,
            timestamp_marks: TimestampMark::default(),
            model: TimingModel::Constant,
        }
    }
}

/// The instant of a frame that its timestamp marks. A frame is not an instant: every row is
/// exposed for the exposure time E, and under a rolling shutter row y starts readout·y/H after
/// row 0. Without a rolling shutter "first row" and "middle row" are the same instant.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum TimestampMark {
    /// The centre of the first row's exposure (a global shutter's mid-exposure instant).
    #[default]
    FirstRowExposureCentre,
    /// The start of the first row's exposure: Android's `SENSOR_TIMESTAMP` ("time at start of
    /// exposure of first row of the image sensor active array").
    FirstRowExposureStart,
    /// The centre of the middle row's exposure: the frame's mean instant ("mid-frame").
    MiddleRowExposureCentre,
}

impl TimestampMark {
    /// Seconds from a frame's timestamp to the centre of its first row's exposure, for an
    /// exposure of `exposure_s` and a rolling-shutter readout of `readout_s` (0 when off).
    pub fn to_first_row_centre_s(self, exposure_s: f64, readout_s: f64) -> f64 {
        match self {
            TimestampMark::FirstRowExposureCentre => 0.0,
            TimestampMark::FirstRowExposureStart => 0.5 * exposure_s,
            TimestampMark::MiddleRowExposureCentre => -0.5 * readout_s,
        }
    }
}

/// The frame-time model, selected by `kind`.
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum TimingModel {
    /// Frame k at exactly k / fps.
    #[default]
    Constant,
    /// Variable frame rate like a phone camera: long first interval, alternation, jitter, drops.
    Vfr(VfrModel),
    /// Real timestamps read from a log file.
    Log(LogModel),
}

/// Variable frame rate. Frame 0 is at 0 s; grid slot m ≥ 1 is at
/// `first_interval_s + (m − 1) / actual_fps`, where `actual_fps = fps · (1 + rate_error_ppm·1e-6)`;
/// the frame in slot m is displaced by `(pair_alternation_s / 2)·(−1)^m` plus Gaussian jitter
/// (σ = `jitter_s`, truncated at ±4σ), and slots m ≥ 2 are dropped with `drop_probability`.
/// Validation keeps `pair_alternation_s + 8·jitter_s ≤ 0.5 / actual_fps`, which guarantees
/// strictly increasing times. Defaults: the fit of the seed's phone logs.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct VfrModel {
    /// Standard deviation of each timestamp's Gaussian jitter, s (interval jitter is √2 larger).
    /// In [0, 1]. Default 5.5e-5 (the residual of the phone-log fits, 46–61 µs).
    pub jitter_s: f64,
    /// Amplitude a of the paired alternation: consecutive intervals alternate 1/actual_fps ± a,
    /// s, in [0, 1]. Default 0.
    pub pair_alternation_s: f64,
    /// Interval between frame 0 and frame 1, s; 0 means one regular interval. 0 or in
    /// [0.5 / actual_fps, 10]. Default 0.055.
    pub first_interval_s: f64,
    /// Probability that a frame (slot m ≥ 2) is dropped. [0, 0.5]. Default 0.
    pub drop_probability: f64,
    /// Actual rate relative to nominal, parts per million. [-100000, 100000]. Default -4500
    /// (30 fps nominal runs at 29.865 fps).
    pub rate_error_ppm: f64,
}

impl Default for VfrModel {
    fn default() -> Self {
        Self {
            jitter_s: 5.5e-5,
            pair_alternation_s: 0.0,
            first_interval_s: 0.055,
            drop_probability: 0.0,
            rate_error_ppm: -4500.0,
        }
    }
}

impl VfrModel {
    /// The frame rate the clock really runs at, fps.
    pub fn actual_fps(&self, nominal_fps: f64) -> f64 {
        nominal_fps * (1.0 + self.rate_error_ppm * 1e-6)
    }
}

/// Real timestamps. The scenario loader reads `file` and parses it with
/// [`super::load_from_text`]; the schedule then applies `rebase_to_zero` and `offset_s` and keeps
/// the frames before the scenario's duration.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LogModel {
    /// Path of the log file (relative to the scenario file). Required, no default.
    pub file: String,
    /// Log format: `showinfo` | `showinfo_pts` | `ffprobe_csv` | `ffprobe_json` | `frames_csv`. Default `showinfo`.
    pub format: LogFormat,
    /// Subtract the first frame's time so the schedule starts at 0 s. Default true.
    pub rebase_to_zero: bool,
    /// Added to every time after rebasing, s, in [−10000, 10000]. Default 0.
    pub offset_s: f64,
}

impl Default for LogModel {
    fn default() -> Self {
        Self {
            file: String::new(),
            format: LogFormat::Showinfo,
            rebase_to_zero: true,
            offset_s: 0.0,
        }
    }
}

impl FrameTimingConfig {
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        problems.range(join(path, "fps"), self.fps, 0.1, 10_000.0);
        let model = join(path, "model");
        match &self.model {
            TimingModel::Constant => {}
            TimingModel::Vfr(v) => v.validate(&model, self.fps, problems),
            TimingModel::Log(l) => l.validate(&model, problems),
        }
    }
}

impl VfrModel {
    /// This schedule moved just enough to be valid at `nominal_fps` (for a candidate rate
    /// that a search tries): a first interval shorter than half a frame becomes one regular
    /// interval, and alternation and jitter shrink together until frames stay in order.
    pub fn valid_at(&self, nominal_fps: f64) -> VfrModel {
        let mut m = self.clone();
        let half_interval_s = 0.5 / (nominal_fps * (1.0 + m.rate_error_ppm * 1e-6));
        if !(half_interval_s.is_finite() && half_interval_s > 0.0) {
            return m;
        }
        if m.first_interval_s != 0.0 && m.first_interval_s < half_interval_s {
            m.first_interval_s = 0.0;
        }
        let used_s = m.pair_alternation_s + 8.0 * m.jitter_s;
        if used_s > half_interval_s {
            // A hair inside the bound, which rounding would otherwise cross.
            let k = (1.0 - 1e-9) * half_interval_s / used_s;
            m.pair_alternation_s *= k;
            m.jitter_s *= k;
        }
        m
    }

    fn validate(&self, path: &str, nominal_fps: f64, problems: &mut Problems) {
        let before = problems.len();
        problems.range(
            join(path, "rate_error_ppm"),
            self.rate_error_ppm,
            -100_000.0,
            100_000.0,
        );
        problems.range(
            join(path, "drop_probability"),
            self.drop_probability,
            0.0,
            0.5,
        );
        problems.range(join(path, "jitter_s"), self.jitter_s, 0.0, 1.0);
        problems.range(
            join(path, "pair_alternation_s"),
            self.pair_alternation_s,
            0.0,
            1.0,
        );
        if problems.len() > before || !nominal_fps.is_finite() || nominal_fps <= 0.0 {
            return; // the derived checks below need sane inputs
        }
        let interval_s = 1.0 / self.actual_fps(nominal_fps);
        let budget_s = 0.5 * interval_s;
        let used_s = self.pair_alternation_s + 8.0 * self.jitter_s;
        if used_s > budget_s {
            problems.push(
                join(path, "jitter_s"),
                format!(
                    "pair_alternation_s + 8 × jitter_s must be <= half the frame interval \
                     ({budget_s} s) so frames stay in order, got {used_s} s"
                ),
            );
        }
        if self.first_interval_s != 0.0 {
            problems.range(
                join(path, "first_interval_s"),
                self.first_interval_s,
                budget_s,
                10.0,
            );
        }
    }
}

impl LogModel {
    fn validate(&self, path: &str, problems: &mut Problems) {
        if self.file.trim().is_empty() {
            problems.push(
                join(path, "file"),
                "must name the timing log file, got an empty path",
            );
        }
        problems.range(join(path, "offset_s"), self.offset_s, -1e4, 1e4);
    }
}
