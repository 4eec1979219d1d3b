//! Rolling shutter: row y is exposed around t + readout_s · y / height_px, with t the centre of
//! row 0's exposure (where the frame's timestamp lies relative to it is
//! `frame_timing.timestamp_marks`), each row rendered from the scene at its own time.

use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RollingShutterConfig {
    /// Rows read out one after another. Default: false.
    pub enabled: bool,
    /// Time from the start of row 0's exposure to the start of row `height_px`, in seconds, in
    /// [0, 1]. Default: 0.02 (typical phone sensor readout at 30 fps).
    pub readout_s: f64,
}

impl Default for RollingShutterConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            readout_s: 0.02,
        }
    }
}

impl RollingShutterConfig {
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        problems.range(join(path, "readout_s"), self.readout_s, 0.0, 1.0);
    }

    /// Effective readout (0 when disabled: a global shutter), s.
    pub fn readout_or_zero_s(&self) -> f64 {
        if self.enabled {
            self.readout_s
        } else {
            0.0
        }
    }

    /// Delay of absolute row `y` after row 0, in seconds.
    pub fn row_delay_s(&self, y: i64, height_px: usize) -> f64 {
        if self.enabled && height_px > 0 {
            self.readout_s * y as f64 / height_px as f64
        } else {
            0.0
        }
    }
}
