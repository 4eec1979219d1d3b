//! Lighting and tone: uneven illumination (linear gradient and vignetting) multiplies the
//! radiance; the tone curve maps the normalised signal through gamma onto [black, white] DN.

use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LightingConfig {
    /// Apply these levels; disabled = black 0 DN, white 255 DN, gamma 1, even light.
    /// Default: true.
    pub enabled: bool,
    /// Grey level of radiance 0 (black ink), DN in [0, 255]. Default: 51 (median of the large
    /// marker's ink on the seed rig's real 4K frame, see `render::real_frame`).
    pub black_level_dn: f64,
    /// Grey level of radiance 1 (white paper), DN in [0, 255], above the black level.
    /// Default: 206 (median of the marker's paper on the seed rig's real 4K frame).
    pub white_level_dn: f64,
    /// Display gamma: DN = black + (white − black) · s^(1/gamma); in [0.1, 10]. Default: 1.
    pub gamma: f64,
    /// Relative illumination change from the left to the right frame edge: gain
    /// 1 + gradient_x_frac·(x − cx)/width_px (−0.1 = 10 % darker on the right), in [−1, 1].
    /// Default: 0.
    pub gradient_x_frac: f64,
    /// As `gradient_x_frac`, top to bottom, in [−1, 1]. Default: 0.
    pub gradient_y_frac: f64,
    /// Illumination loss at the frame corners (gain 1 − vignetting_frac·r²/r_corner²), in
    /// [0, 1]. Default: 0.
    pub vignetting_frac: f64,
}

impl Default for LightingConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            black_level_dn: 51.0,
            white_level_dn: 206.0,
            gamma: 1.0,
            gradient_x_frac: 0.0,
            gradient_y_frac: 0.0,
            vignetting_frac: 0.0,
        }
    }
}

impl LightingConfig {
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        problems.range(
            join(path, "black_level_dn"),
            self.black_level_dn,
            0.0,
            255.0,
        );
        problems.range(
            join(path, "white_level_dn"),
            self.white_level_dn,
            0.0,
            255.0,
        );
        if self.white_level_dn <= self.black_level_dn {
            problems.push(
                join(path, "white_level_dn"),
                format!(
                    "must be above black_level_dn ({}), got {}",
                    crate::validation::short(self.black_level_dn),
                    crate::validation::short(self.white_level_dn)
                ),
            );
        }
        problems.range(join(path, "gamma"), self.gamma, 0.1, 10.0);
        problems.range(
            join(path, "gradient_x_frac"),
            self.gradient_x_frac,
            -1.0,
            1.0,
        );
        problems.range(
            join(path, "gradient_y_frac"),
            self.gradient_y_frac,
            -1.0,
            1.0,
        );
        problems.range(
            join(path, "vignetting_frac"),
            self.vignetting_frac,
            0.0,
            1.0,
        );
    }

    /// The tone mapping actually applied (identity levels when disabled).
    pub fn tone(&self) -> Tone {
        if self.enabled {
            Tone {
                black_dn: self.black_level_dn as f32,
                span_dn: (self.white_level_dn - self.black_level_dn) as f32,
                inv_gamma: (1.0 / self.gamma) as f32,
            }
        } else {
            Tone {
                black_dn: 0.0,
                span_dn: 255.0,
                inv_gamma: 1.0,
            }
        }
    }

    /// The tone curve's span in DN, radiance 0 to 1 ([`Self::tone`]'s, in f64): what the
    /// noise a sensor adds in full-well units becomes in the footage's DN.
    pub fn span_dn(&self) -> f64 {
        if self.enabled {
            self.white_level_dn - self.black_level_dn
        } else {
            255.0
        }
    }

    /// True when illumination is uneven (per-pixel gain needed).
    pub fn uneven(&self) -> bool {
        self.enabled
            && (self.gradient_x_frac != 0.0
                || self.gradient_y_frac != 0.0
                || self.vignetting_frac != 0.0)
    }

    /// Illumination gain at absolute pixel (x, y) of a `width_px` × `height_px` frame.
    pub fn gain(&self, x: i64, y: i64, width_px: usize, height_px: usize) -> f32 {
        if !self.uneven() {
            return 1.0;
        }
        let (w, h) = (width_px.max(1) as f64, height_px.max(1) as f64);
        let (cx, cy) = ((w - 1.0) / 2.0, (h - 1.0) / 2.0);
        let (dx, dy) = (x as f64 - cx, y as f64 - cy);
        let r2_corner = cx * cx + cy * cy;
        let vignette = if r2_corner > 0.0 {
            1.0 - self.vignetting_frac * (dx * dx + dy * dy) / r2_corner
        } else {
            1.0
        };
        ((1.0 + self.gradient_x_frac * dx / w + self.gradient_y_frac * dy / h) * vignette) as f32
    }
}

/// Normalised signal (1 = white) → grey level in DN (not yet quantised).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Tone {
    pub black_dn: f32,
    pub span_dn: f32,
    pub inv_gamma: f32,
}

impl Tone {
    #[inline]
    pub fn dn(&self, s: f32) -> f32 {
        let s = s.clamp(0.0, 1.0);
        let s = if self.inv_gamma == 1.0 {
            s
        } else {
            s.powf(self.inv_gamma)
        };
        self.black_dn + self.span_dn * s
    }
}

/// 8-bit quantisation (round to nearest, saturate).
#[inline]
pub fn quantise(dn: f32) -> u8 {
    (dn + 0.5).clamp(0.0, 255.0) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tone_maps_levels_and_gamma() {
        let mut c = LightingConfig {
            black_level_dn: 20.0,
            white_level_dn: 220.0,
            ..Default::default()
        };
        let t = c.tone();
        assert_eq!(t.dn(0.0), 20.0);
        assert_eq!(t.dn(1.0), 220.0);
        assert_eq!(t.dn(0.5), 120.0);
        // The span the noise fits read DN through is the tone curve's, enabled or not.
        for enabled in [true, false] {
            let l = LightingConfig {
                enabled,
                ..c.clone()
            };
            assert_eq!(l.span_dn() as f32, l.tone().dn(1.0) - l.tone().dn(0.0));
        }
        c.gamma = 2.0;
        assert!((c.tone().dn(0.25) - 120.0).abs() < 1e-4);
        assert_eq!(quantise(-3.0), 0);
        assert_eq!(quantise(254.6), 255);
        assert_eq!(quantise(300.0), 255);
        assert_eq!(quantise(10.49), 10);
    }

    #[test]
    fn illumination_gradient_and_vignetting_shape_the_gain() {
        let c = LightingConfig {
            gradient_x_frac: -0.2,
            vignetting_frac: 0.3,
            ..Default::default()
        };
        let (w, h) = (101, 51);
        assert!((c.gain(50, 25, w, h) - 1.0).abs() < 1e-6);
        assert!(c.gain(0, 25, w, h) > c.gain(100, 25, w, h));
        assert!((c.gain(100, 50, w, h) - (1.0 - 0.2 * 50.0 / 101.0) * 0.7).abs() < 1e-6);
    }
}
