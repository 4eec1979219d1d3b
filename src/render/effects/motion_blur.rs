//! Motion blur: the exposure integrates the moving scene, approximated by averaging the scene
//! sampled at K instants spread evenly (midpoint rule) across the exposure window.

use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct MotionBlurConfig {
    /// Integrate over the exposure. Default: true.
    pub enabled: bool,
    /// Exposure time in seconds, in [0, 1]. Default: 0.004 (1/250 s, a bright indoor phone
    /// video exposure).
    pub exposure_s: f64,
    /// Number of sub-exposure samples K; 0 = automatic: the smallest K for which the image moves
    /// at most `max_step_px` between samples (measured from the scene's vertex motion and the
    /// camera vibration). Default: 0, in [0, 4096].
    pub samples: u32,
    /// Largest image motion between samples for automatic K, in pixels, in (0, 10].
    /// Default: 0.05.
    pub max_step_px: f64,
    /// Cap on automatic K, in [1, 4096]. Default: 256.
    pub max_samples: u32,
}

impl Default for MotionBlurConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            exposure_s: 0.004,
            samples: 0,
            max_step_px: 0.05,
            max_samples: 256,
        }
    }
}

impl MotionBlurConfig {
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        problems.range(join(path, "exposure_s"), self.exposure_s, 0.0, 1.0);
        problems.range(join(path, "samples"), self.samples as f64, 0.0, 4096.0);
        if !(self.max_step_px > 0.0 && self.max_step_px <= 10.0) {
            problems.push(
                join(path, "max_step_px"),
                format!(
                    "must be in (0, 10], got {}",
                    crate::validation::short(self.max_step_px)
                ),
            );
        }
        problems.range(
            join(path, "max_samples"),
            self.max_samples as f64,
            1.0,
            4096.0,
        );
    }

    /// Effective exposure (0 when disabled: one instantaneous sample).
    pub fn exposure_or_zero_s(&self) -> f64 {
        if self.enabled {
            self.exposure_s
        } else {
            0.0
        }
    }

    /// K for a path of `travel_px` pixels during the exposure.
    pub fn sample_count(&self, travel_px: f64) -> usize {
        if !self.enabled || self.exposure_s <= 0.0 {
            return 1;
        }
        if self.samples > 0 {
            return self.samples as usize;
        }
        let k = (travel_px / self.max_step_px).ceil();
        if k.is_finite() {
            (k as usize).clamp(1, self.max_samples.max(1) as usize)
        } else {
            self.max_samples.max(1) as usize
        }
    }
}

/// Offsets (s) of K midpoint samples from the exposure centre.
pub fn sample_offsets_s(exposure_s: f64, k: usize) -> Vec<f64> {
    (0..k)
        .map(|i| exposure_s * ((i as f64 + 0.5) / k as f64 - 0.5))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sample_count_keeps_steps_below_the_limit() {
        let c = MotionBlurConfig::default();
        assert_eq!(c.sample_count(0.0), 1);
        assert_eq!(c.sample_count(1.0), 20);
        assert_eq!(c.sample_count(1e9), 256);
        let off = sample_offsets_s(0.01, 4);
        assert_eq!(off.len(), 4);
        assert!((off[0] + 0.00375).abs() < 1e-15 && (off[3] - 0.00375).abs() < 1e-15);
    }
}
