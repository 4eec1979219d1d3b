//! Sharpening: the unsharp mask a phone's image processor applies to the tone-mapped image,
//! `out = dn + amount·(dn − G_σ ∗ dn)` with G_σ a Gaussian of `sigma_px`, before 8-bit
//! quantisation and the codec. It puts a bright and a dark halo on every edge and amplifies the
//! pixel noise (which it sees, as the phone's does).
//!
//! Why display space: a phone sharpens its luma after the tone curve, so the halo on the dark
//! side of an edge is as large in DN as on the bright side; an unsharp mask on linear radiance
//! would clip it at black.

use super::optical_blur::{kernel, TRUNCATION_SIGMAS};
use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct SharpeningConfig {
    /// Apply the unsharp mask. Default: false.
    pub enabled: bool,
    /// Gain of the added detail (dn − blurred), in [0, 5]. Default: 0.5.
    pub amount: f64,
    /// Standard deviation of the Gaussian whose residual is added, px, in [0.3, 10]. Default: 1.
    pub sigma_px: f64,
}

impl Default for SharpeningConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            amount: 0.5,
            sigma_px: 1.0,
        }
    }
}

impl SharpeningConfig {
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        problems.range(join(path, "amount"), self.amount, 0.0, 5.0);
        problems.range(join(path, "sigma_px"), self.sigma_px, 0.3, 10.0);
    }

    /// Off with the default values (how a scenario without the table reads).
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    /// Whether the mask changes any pixel.
    pub fn active(&self) -> bool {
        self.enabled && self.amount > 0.0 && self.sigma_px > 0.0
    }

    /// Margin the mask needs around a window, px (0 when inactive).
    pub fn radius_px(&self) -> usize {
        if self.active() {
            (TRUNCATION_SIGMAS * self.sigma_px).ceil() as usize
        } else {
            0
        }
    }

    /// The separable Gaussian taps of the mask's blur (empty when inactive).
    pub fn weights(&self) -> Vec<f32> {
        match self.radius_px() {
            0 => Vec::new(),
            r => kernel(self.sigma_px, r),
        }
    }

    /// Factor by which the mask multiplies the standard deviation of white noise: √Σk² over the
    /// 2-D taps k = (1 + a)·δ − a·G (1 when inactive).
    pub fn white_noise_gain(&self) -> f64 {
        let w = self.weights();
        if w.is_empty() {
            return 1.0;
        }
        let a = self.amount;
        let r = w.len() / 2;
        let g_sq: f64 = w.iter().map(|&v| (v as f64).powi(2)).sum::<f64>().powi(2);
        let g_centre = (w[r] as f64).powi(2);
        ((1.0 + a).powi(2) - 2.0 * a * (1.0 + a) * g_centre + a * a * g_sq).sqrt()
    }
}

/// The sharpened value of `dn` whose Gaussian-blurred neighbourhood is `blurred_dn`.
#[inline]
pub fn sharpen(dn: f32, blurred_dn: f32, amount: f32) -> f32 {
    dn + amount * (dn - blurred_dn)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::effects::optical_blur::blur_separable;

    #[test]
    fn the_noise_gain_is_the_measured_spread_of_sharpened_white_noise() {
        let c = SharpeningConfig {
            enabled: true,
            amount: 1.2,
            sigma_px: 1.4,
        };
        let (w, h) = (300usize, 300usize);
        let mut noise = vec![0.0f32; w * h];
        for (y, row) in noise.chunks_exact_mut(w).enumerate() {
            crate::render::effects::pixel_noise::normals_row(7, 0, y as i64, row);
        }
        let weights = c.weights();
        let r = weights.len() / 2;
        let blurred = blur_separable(&noise, w, h, &weights);
        let inner_w = w - 2 * r;
        let out: Vec<f64> = blurred
            .iter()
            .enumerate()
            .map(|(i, &b)| {
                let (x, y) = (i % inner_w + r, i / inner_w + r);
                sharpen(noise[y * w + x], b, c.amount as f32) as f64
            })
            .collect();
        let sd = (out.iter().map(|v| v * v).sum::<f64>() / out.len() as f64).sqrt();
        // 84 100 samples of unit variance: the sample sd's relative standard error is
        // 1/√(2n) ≈ 0.0024 (times a small factor for the mask's correlation); 2 % is > 5 se.
        let gain = c.white_noise_gain();
        assert!(
            (sd / gain - 1.0).abs() < 0.02,
            "measured {sd}, predicted {gain}"
        );
        assert!(gain > 1.5, "{gain}");
        let off = SharpeningConfig::default();
        assert_eq!(off.white_noise_gain(), 1.0);
        assert_eq!(off.radius_px(), 0);
    }

    #[test]
    fn out_of_range_values_name_their_fields() {
        let c = SharpeningConfig {
            enabled: true,
            amount: -1.0,
            sigma_px: 0.0,
        };
        let mut p = Problems::new();
        c.validate("effects.sharpening", &mut p);
        let fields: Vec<&str> = p.iter().map(|x| x.field.as_str()).collect();
        assert_eq!(
            fields,
            ["effects.sharpening.amount", "effects.sharpening.sigma_px"]
        );
    }
}
