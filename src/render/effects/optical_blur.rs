//! Optical blur: a Gaussian point-spread function applied as a separable convolution with a
//! fixed truncation radius (so a region of interest needs exactly that much margin).

use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};

/// Truncation of the Gaussian kernel in standard deviations (weights beyond are < 3.4·10⁻⁴ of
/// the peak and are dropped; the kernel is renormalised).
pub const TRUNCATION_SIGMAS: f64 = 4.0;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct OpticalBlurConfig {
    /// Apply the blur. Default: true.
    pub enabled: bool,
    /// Standard deviation of the Gaussian PSF in pixels, in [0, 20]. Default: 0.5 (median
    /// per-row fit of a straight marker edge on the seed rig's real 4K frame: 0.485 px, see
    /// `render::real_frame`).
    pub sigma_px: f64,
}

impl Default for OpticalBlurConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            sigma_px: 0.5,
        }
    }
}

impl OpticalBlurConfig {
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        problems.range(join(path, "sigma_px"), self.sigma_px, 0.0, 20.0);
    }

    /// Kernel radius in pixels (0 when disabled).
    pub fn radius_px(&self) -> usize {
        if self.enabled && self.sigma_px > 0.0 {
            (TRUNCATION_SIGMAS * self.sigma_px).ceil() as usize
        } else {
            0
        }
    }
}

/// Standard deviation of the discrete kernel actually applied for `sigma_px` (√Σ w_k k²), px:
/// the σ of the continuous Gaussian PSF that gives the same edge spread. Equal to `sigma_px`
/// from about 0.7 px up; below, the kernel sampled at whole pixels blurs less (0.46 px at 0.5,
/// 0.09 px at 0.3).
pub fn effective_sigma_px(sigma_px: f64) -> f64 {
    let c = OpticalBlurConfig {
        enabled: true,
        sigma_px,
    };
    let r = c.radius_px();
    if r == 0 {
        return 0.0;
    }
    let w = kernel(sigma_px, r);
    w.iter()
        .enumerate()
        .map(|(i, &v)| v as f64 * (i as f64 - r as f64).powi(2))
        .sum::<f64>()
        .sqrt()
}

/// The `sigma_px` whose kernel has effective σ `effective_px` ([`effective_sigma_px`] inverted
/// by bisection on [0, 20]); for a measured continuous PSF σ this is the scenario's value.
pub fn sigma_for_effective_px(effective_px: f64) -> f64 {
    if effective_px.is_nan() || effective_px <= 0.0 {
        return 0.0;
    }
    let (mut lo, mut hi) = (0.0, 20.0);
    for _ in 0..60 {
        let mid = 0.5 * (lo + hi);
        if effective_sigma_px(mid) < effective_px {
            lo = mid;
        } else {
            hi = mid;
        }
    }
    0.5 * (lo + hi)
}

/// Normalised Gaussian weights for offsets −r..=r.
pub fn kernel(sigma_px: f64, radius_px: usize) -> Vec<f32> {
    let r = radius_px as i64;
    // The centre weight is 1 whatever σ: for a σ so small that 2σ² underflows, 0/0 would make it
    // NaN and every pixel of the frame with it.
    let w: Vec<f64> = (-r..=r)
        .map(|k| match k {
            0 => 1.0,
            _ => (-(k * k) as f64 / (2.0 * sigma_px * sigma_px)).exp(),
        })
        .collect();
    let sum: f64 = w.iter().sum();
    w.iter().map(|v| (v / sum) as f32).collect()
}

/// Separable blur of `src` (`src_w` × `src_h`, row-major) with `weights` (odd length 2r + 1);
/// the result is the `src_w − 2r` × `src_h − 2r` interior. Every output depends only on its
/// (2r+1)² neighbourhood, computed in a fixed order, so the result is independent of the window
/// (a flat neighbourhood gives exactly `constant_response` applied twice).
pub fn blur_separable(src: &[f32], src_w: usize, src_h: usize, weights: &[f32]) -> Vec<f32> {
    let mut out = Vec::new();
    blur_separable_into(src, src_w, src_h, weights, &mut Vec::new(), &mut out);
    out
}

/// [`blur_separable`] into reused buffers (`tmp` is scratch); fresh multi-megabyte buffers
/// per frame cost more in page faults than the blur itself.
pub fn blur_separable_into(
    src: &[f32],
    src_w: usize,
    src_h: usize,
    weights: &[f32],
    tmp: &mut Vec<f32>,
    out: &mut Vec<f32>,
) {
    let r = weights.len() / 2;
    let (out_w, out_h) = (src_w - 2 * r, src_h - 2 * r);
    tmp.clear();
    tmp.resize(out_w * src_h, 0.0);
    for (tmp_row, src_row) in tmp.chunks_exact_mut(out_w).zip(src.chunks_exact(src_w)) {
        convolve_row(src_row, weights, tmp_row);
    }
    out.clear();
    out.resize(out_w * out_h, 0.0);
    for (y, out_row) in out.chunks_exact_mut(out_w).enumerate() {
        convolve_column(tmp, out_w, y, weights, out_row);
    }
}

/// One row: `out[x] = Σ_k w[k]·src[x + k]`, summed from 0 in tap order. Tap-major loops keep
/// that per-pixel order (so the bits do not depend on the window) and vectorise.
pub fn convolve_row(src: &[f32], weights: &[f32], out: &mut [f32]) {
    out.fill(0.0);
    let n = out.len();
    for (k, &w) in weights.iter().enumerate() {
        for (o, &v) in out.iter_mut().zip(&src[k..k + n]) {
            *o += w * v;
        }
    }
}

/// Output row `y` of the vertical pass over `src` (rows of `width`): `out[x] = Σ_k w[k]·src[y +
/// k][x]`, summed from 0 in tap order.
pub fn convolve_column(src: &[f32], width: usize, y: usize, weights: &[f32], out: &mut [f32]) {
    out.fill(0.0);
    for (k, &w) in weights.iter().enumerate() {
        let row = &src[(y + k) * width..][..out.len()];
        for (o, &v) in out.iter_mut().zip(row) {
            *o += w * v;
        }
    }
}

/// The convolution of a constant `v`, evaluated in the same order as the general case.
pub fn constant_response(weights: &[f32], v: f32) -> f32 {
    let mut a = 0.0f32;
    for &w in weights {
        a += w * v;
    }
    a
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn kernel_is_normalised_symmetric_and_sized_by_truncation() {
        let c = OpticalBlurConfig {
            enabled: true,
            sigma_px: 1.3,
        };
        let k = kernel(c.sigma_px, c.radius_px());
        assert_eq!(k.len(), 2 * 6 + 1);
        assert!((k.iter().sum::<f32>() - 1.0).abs() < 1e-6);
        for i in 0..k.len() {
            assert_eq!(k[i], k[k.len() - 1 - i]);
        }
    }

    #[test]
    fn a_vanishing_sigma_is_the_identity_never_nan() {
        // Regression: sigma_px = 1e-300 (valid: in [0, 20]) made every pixel NaN and `run`
        // found no marker.
        assert_eq!(kernel(1e-300, 1), vec![0.0, 1.0, 0.0]);
        assert_eq!(kernel(1e-160, 1), vec![0.0, 1.0, 0.0]);
    }

    #[test]
    fn effective_sigma_follows_the_parameter_above_0_7_px_and_inverts() {
        assert!((effective_sigma_px(0.5) - 0.46).abs() < 0.01);
        assert!(effective_sigma_px(0.3) < 0.1);
        for s in [0.7, 1.0, 2.5] {
            assert!((effective_sigma_px(s) / s - 1.0).abs() < 0.01, "{s}");
        }
        for s in [0.3, 0.45, 0.8, 1.7] {
            assert!((sigma_for_effective_px(effective_sigma_px(s)) - s).abs() < 1e-6);
        }
        assert_eq!(sigma_for_effective_px(0.0), 0.0);
    }

    #[test]
    fn blur_preserves_constants_and_total_of_an_impulse() {
        let k = kernel(1.0, 4);
        let (w, h) = (21, 21);
        let mut src = vec![0.5f32; w * h];
        let flat = blur_separable(&src, w, h, &k);
        assert!(flat.iter().all(|&v| (v - 0.5).abs() < 1e-6));
        src[10 * w + 10] = 1.5;
        let out = blur_separable(&src, w, h, &k);
        let total: f32 = out.iter().map(|v| v - 0.5).sum();
        assert!((total - 1.0).abs() < 1e-4, "{total}");
        // Second moment of the impulse response = σ² per axis.
        let (ow, _) = (w - 8, h - 8);
        let var_x: f32 = out
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let x = (i % ow) as f32 - 6.0;
                (v - 0.5) * x * x
            })
            .sum();
        assert!((var_x - 1.0).abs() < 0.01, "{var_x}");
    }
}
