//! Lighting and tone: uneven illumination (linear gradient and vignetting) and illumination that
//! changes over time (a camera's exposure drifting or stepping, a lamp flickering) multiply the
//! radiance; the tone curve maps the normalised signal through gamma onto [black, white] DN.
//!
//! The gain over time is the product of three factors, each averaged over the exposure window
//! of the row it lights (so a rolling shutter shows a flicker as bands across the frame): a
//! linear drift `1 + gain_drift_per_s·(t − gain_reference_s)`, auto-exposure steps (the gain
//! of the last step at or before t, 1 before the first), and a sinusoidal flicker
//! `1 + flicker_frac·sin(2π·flicker_hz·t + flicker_phase_rad)`, whose average over an exposure
//! τ is damped by sinc(f·τ) = sin(π f τ)/(π f τ).

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
    /// Relative change of the illumination per second of scenario time (auto-exposure or a
    /// lamp warming up): gain 1 + gain_drift_per_s·(t − gain_reference_s), in [−1, 1] per s.
    /// Default: 0.
    pub gain_drift_per_s: f64,
    /// The instant at which the drift's gain is 1, s (`geneva calibrate` writes the footage's
    /// median time, where its levels are measured). Default: 0.
    pub gain_reference_s: f64,
    /// Steps of the gain (an auto-exposure that adjusts in steps): from `at_s` on, the gain is
    /// that step's `gain` (relative to the levels above); 1 before the first. Times strictly
    /// increasing. Default: none.
    pub gain_steps: Vec<GainStep>,
    /// Amplitude of a sinusoidal flicker of the light (mains-powered lamps: twice the mains
    /// frequency), relative, in [0, 1). Default: 0.
    pub flicker_frac: f64,
    /// The flicker's frequency, Hz, in [0.001, 100000]. Default: 100.
    pub flicker_hz: f64,
    /// The flicker's phase at t = 0, rad, in [−2π, 2π]. Default: 0.
    pub flicker_phase_rad: f64,
}

/// One step of the illumination gain over time.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct GainStep {
    /// From this instant on, s (≥ 0).
    pub at_s: f64,
    /// The gain from then on, relative to the stated levels, in (0, 10].
    pub gain: f64,
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
            gain_drift_per_s: 0.0,
            gain_reference_s: 0.0,
            gain_steps: Vec::new(),
            flicker_frac: 0.0,
            flicker_hz: 100.0,
            flicker_phase_rad: 0.0,
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
        self.validate_over_time(path, problems);
    }

    fn validate_over_time(&self, path: &str, problems: &mut Problems) {
        problems.range(
            join(path, "gain_drift_per_s"),
            self.gain_drift_per_s,
            -1.0,
            1.0,
        );
        problems.range(
            join(path, "gain_reference_s"),
            self.gain_reference_s,
            0.0,
            1e6,
        );
        problems.range(join(path, "flicker_frac"), self.flicker_frac, 0.0, 0.999);
        problems.range(join(path, "flicker_hz"), self.flicker_hz, 1e-3, 1e5);
        problems.range(
            join(path, "flicker_phase_rad"),
            self.flicker_phase_rad,
            -std::f64::consts::TAU,
            std::f64::consts::TAU,
        );
        let mut last_s = f64::NEG_INFINITY;
        for (i, step) in self.gain_steps.iter().enumerate() {
            let field = join(path, &format!("gain_steps[{i}]"));
            problems.range(join(&field, "at_s"), step.at_s, 0.0, 1e6);
            problems.range(join(&field, "gain"), step.gain, 1e-3, 10.0);
            problems.increasing(join(&field, "at_s"), step.at_s, last_s, ("time", " s"));
            last_s = step.at_s;
        }
    }

    /// True when the illumination changes over time (a per-row gain is needed).
    pub fn varies_in_time(&self) -> bool {
        self.enabled
            && (self.gain_drift_per_s != 0.0
                || !self.gain_steps.is_empty()
                || self.flicker_frac != 0.0)
    }

    /// The illumination's gain over time for an exposure of `exposure_s` centred at `t_s`
    /// (each factor averaged over the window; 1 when the light is steady), never negative.
    pub fn temporal_gain(&self, t_s: f64, exposure_s: f64) -> f64 {
        if !self.varies_in_time() {
            return 1.0;
        }
        let drift = 1.0 + self.gain_drift_per_s * (t_s - self.gain_reference_s);
        let flicker = if self.flicker_frac != 0.0 {
            let w = std::f64::consts::TAU * self.flicker_hz;
            let x = std::f64::consts::PI * self.flicker_hz * exposure_s.max(0.0);
            let sinc = if x.abs() < 1e-9 { 1.0 } else { x.sin() / x };
            1.0 + self.flicker_frac * sinc * (w * t_s + self.flicker_phase_rad).sin()
        } else {
            1.0
        };
        (drift * self.step_gain(t_s, exposure_s) * flicker).max(0.0)
    }

    /// The steps' gain averaged over [t − τ/2, t + τ/2] (exactly: the share of the window each
    /// step holds).
    fn step_gain(&self, t_s: f64, exposure_s: f64) -> f64 {
        let at = |t: f64| {
            self.gain_steps
                .iter()
                .take_while(|s| s.at_s <= t)
                .last()
                .map_or(1.0, |s| s.gain)
        };
        if self.gain_steps.is_empty() || exposure_s <= 0.0 {
            return at(t_s);
        }
        let (a, b) = (t_s - exposure_s / 2.0, t_s + exposure_s / 2.0);
        let mut edges: Vec<f64> = vec![a];
        edges.extend(
            self.gain_steps
                .iter()
                .map(|s| s.at_s)
                .filter(|&t| t > a && t < b),
        );
        edges.push(b);
        edges
            .windows(2)
            .map(|w| at(w[0]) * (w[1] - w[0]))
            .sum::<f64>()
            / exposure_s
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
        self.gain_with(x, y, width_px, height_px, 1.0)
    }

    /// [`Self::gain`] times `temporal` ([`Self::temporal_gain`] of the pixel's row), in one
    /// rounding to f32 (with `temporal` = 1 the bits of [`Self::gain`]).
    pub fn gain_with(
        &self,
        x: i64,
        y: i64,
        width_px: usize,
        height_px: usize,
        temporal: f64,
    ) -> f32 {
        if !self.uneven() {
            return temporal as f32;
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
        ((1.0 + self.gradient_x_frac * dx / w + self.gradient_y_frac * dy / h)
            * vignette
            * temporal) as f32
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

    #[test]
    fn the_gain_over_time_drifts_steps_and_flickers_as_stated() {
        let steady = LightingConfig::default();
        assert!(!steady.varies_in_time());
        assert_eq!(steady.temporal_gain(3.0, 0.01), 1.0);
        let drift = LightingConfig {
            gain_drift_per_s: 0.02,
            gain_reference_s: 4.0,
            ..Default::default()
        };
        assert_eq!(drift.temporal_gain(4.0, 0.01), 1.0);
        assert!((drift.temporal_gain(9.0, 0.01) - 1.1).abs() < 1e-12);
        assert!((drift.temporal_gain(0.0, 0.0) - 0.92).abs() < 1e-12);
        // A step inside the exposure counts by the share of the window after it.
        let steps = LightingConfig {
            gain_steps: vec![
                GainStep {
                    at_s: 1.0,
                    gain: 1.2,
                },
                GainStep {
                    at_s: 2.0,
                    gain: 0.9,
                },
            ],
            ..Default::default()
        };
        assert_eq!(steps.temporal_gain(0.5, 0.0), 1.0);
        assert_eq!(steps.temporal_gain(1.5, 0.0), 1.2);
        assert_eq!(steps.temporal_gain(2.5, 0.0), 0.9);
        let straddling = steps.temporal_gain(1.0 + 0.025, 0.1);
        assert!((straddling - (0.25 * 1.0 + 0.75 * 1.2)).abs() < 1e-12);
        // A flicker's mean over an exposure of whole periods is zero; over an instant, its value.
        let flicker = LightingConfig {
            flicker_frac: 0.1,
            flicker_hz: 100.0,
            flicker_phase_rad: 0.5,
            ..Default::default()
        };
        assert!((flicker.temporal_gain(0.0, 0.0) - (1.0 + 0.1 * 0.5f64.sin())).abs() < 1e-12);
        assert!((flicker.temporal_gain(0.0123, 0.02) - 1.0).abs() < 1e-12);
        // The mean over a window, by quadrature, is the sinc-damped value.
        let (t, tau) = (0.0123, 0.003);
        let n = 20_000;
        let mean = (0..n)
            .map(|i| {
                let u = t - tau / 2.0 + tau * (i as f64 + 0.5) / n as f64;
                flicker.temporal_gain(u, 0.0)
            })
            .sum::<f64>()
            / n as f64;
        assert!((flicker.temporal_gain(t, tau) - mean).abs() < 1e-9);
        // Disabled lighting has steady light whatever the fields say.
        let off = LightingConfig {
            enabled: false,
            ..drift.clone()
        };
        assert_eq!(off.temporal_gain(9.0, 0.0), 1.0);
        // One rounding: a steady gain keeps the bits of the spatial gain.
        let uneven = LightingConfig {
            vignetting_frac: 0.3,
            ..Default::default()
        };
        assert_eq!(
            uneven.gain_with(3, 4, 50, 40, 1.0),
            uneven.gain(3, 4, 50, 40)
        );
        assert_eq!(steady.gain_with(3, 4, 50, 40, 1.1), 1.1f32);
    }

    #[test]
    fn gains_over_time_outside_their_ranges_are_named() {
        let c = LightingConfig {
            gain_drift_per_s: 2.0,
            flicker_frac: 0.5,
            flicker_hz: 0.0,
            gain_steps: vec![
                GainStep {
                    at_s: 2.0,
                    gain: 1.1,
                },
                GainStep {
                    at_s: 1.0,
                    gain: 0.0,
                },
            ],
            ..Default::default()
        };
        let mut p = Problems::new();
        c.validate("effects.lighting", &mut p);
        let fields: Vec<&str> = p.iter().map(|p| p.field.as_str()).collect();
        for f in [
            "effects.lighting.gain_drift_per_s",
            "effects.lighting.flicker_hz",
            "effects.lighting.gain_steps[1].at_s",
            "effects.lighting.gain_steps[1].gain",
        ] {
            assert!(fields.contains(&f), "{f} not in {fields:?}");
        }
        assert_eq!(p.len(), 4, "{fields:?}");
    }
}
