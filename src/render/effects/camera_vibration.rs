//! Camera vibration: an image-space rigid motion (translation in px, rotation in rad about the
//! image centre) as a deterministic function of time: sums of configured sinusoids plus a
//! band-limited random part (random-phase, random-frequency sinusoids drawn once from the seed).

use crate::render::raster::RigidTransform;
use crate::rng::{stream, Stream};
use crate::validation::{join, Problems};
use glam::DVec2;
use rand::Rng;
use serde::{Deserialize, Serialize};
use std::f64::consts::TAU;

/// One sinusoid a·sin(2π f t + φ); the amplitude unit is that of the list it is in.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Sinusoid {
    /// Amplitude (px for translations, rad for rotation). Default: 0.
    pub amplitude: f64,
    /// Frequency in Hz, in [0, 10⁴]. Default: 0.
    pub frequency_hz: f64,
    /// Phase in radians. Default: 0.
    pub phase_rad: f64,
}

impl Default for Sinusoid {
    fn default() -> Self {
        Self {
            amplitude: 0.0,
            frequency_hz: 0.0,
            phase_rad: 0.0,
        }
    }
}

/// Band-limited random shake: `components` sinusoids per axis with frequencies uniform in
/// [band_min_hz, band_max_hz] and uniform random phases, scaled to the given RMS.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RandomVibrationConfig {
    /// RMS of the random x translation, px, in [0, 10000]. Default: 0.
    pub x_rms_px: f64,
    /// RMS of the random y translation, px, in [0, 10000]. Default: 0.
    pub y_rms_px: f64,
    /// RMS of the random rotation, rad, in [0, 1]. Default: 0.
    pub rotation_rms_rad: f64,
    /// Lower band edge, Hz, ≥ 0. Default: 1.
    pub band_min_hz: f64,
    /// Upper band edge, Hz, ≥ band_min_hz. Default: 20.
    pub band_max_hz: f64,
    /// Sinusoids per axis, in [1, 1000]. Default: 16.
    pub components: u32,
}

impl Default for RandomVibrationConfig {
    fn default() -> Self {
        Self {
            x_rms_px: 0.0,
            y_rms_px: 0.0,
            rotation_rms_rad: 0.0,
            band_min_hz: 1.0,
            band_max_hz: 20.0,
            components: 16,
        }
    }
}

#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraVibrationConfig {
    /// Shake the image. Default: false.
    pub enabled: bool,
    /// Sinusoids of the x translation (amplitudes in px). Default: none.
    pub x_px: Vec<Sinusoid>,
    /// Sinusoids of the y translation (amplitudes in px). Default: none.
    pub y_px: Vec<Sinusoid>,
    /// Sinusoids of the rotation about the image centre (amplitudes in rad). Default: none.
    pub rotation_rad: Vec<Sinusoid>,
    /// Band-limited random part.
    pub random: RandomVibrationConfig,
}

fn validate_sinusoids(list: &[Sinusoid], path: &str, problems: &mut Problems) {
    for (i, s) in list.iter().enumerate() {
        let p = format!("{path}[{i}]");
        problems.range(join(&p, "amplitude"), s.amplitude, -1e4, 1e4);
        problems.range(join(&p, "frequency_hz"), s.frequency_hz, 0.0, 1e4);
        problems.range(join(&p, "phase_rad"), s.phase_rad, -1e3, 1e3);
    }
}

impl CameraVibrationConfig {
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        validate_sinusoids(&self.x_px, &join(path, "x_px"), problems);
        validate_sinusoids(&self.y_px, &join(path, "y_px"), problems);
        validate_sinusoids(&self.rotation_rad, &join(path, "rotation_rad"), problems);
        let r = &self.random;
        let rp = join(path, "random");
        // As the sinusoids' amplitudes: up to 1e4 px, and a rotation of at most 1 rad RMS.
        problems.range(join(&rp, "x_rms_px"), r.x_rms_px, 0.0, 1e4);
        problems.range(join(&rp, "y_rms_px"), r.y_rms_px, 0.0, 1e4);
        problems.range(join(&rp, "rotation_rms_rad"), r.rotation_rms_rad, 0.0, 1.0);
        problems.range(join(&rp, "band_min_hz"), r.band_min_hz, 0.0, 1e4);
        problems.range(
            join(&rp, "band_max_hz"),
            r.band_max_hz,
            r.band_min_hz.max(0.0),
            1e4,
        );
        problems.range(join(&rp, "components"), r.components as f64, 1.0, 1000.0);
    }
}

/// The vibration of one scenario: configured and seeded random sinusoids, evaluated at any time.
#[derive(Debug, Clone)]
pub struct Vibration {
    x_px: Vec<Sinusoid>,
    y_px: Vec<Sinusoid>,
    rotation_rad: Vec<Sinusoid>,
    centre_px: DVec2,
}

fn random_sinusoids<R: Rng>(rng: &mut R, rms: f64, r: &RandomVibrationConfig) -> Vec<Sinusoid> {
    let n = r.components.max(1);
    // Each unit sinusoid has RMS 1/√2, so the sum of n has RMS √(n/2).
    let amplitude = rms * (2.0 / n as f64).sqrt();
    (0..n)
        .map(|_| Sinusoid {
            amplitude,
            frequency_hz: rng.gen_range(r.band_min_hz..=r.band_max_hz.max(r.band_min_hz)),
            phase_rad: rng.gen_range(0.0..TAU),
        })
        .collect()
}

impl Vibration {
    /// `None` when vibration is disabled. Random components come from `seed`'s
    /// camera-vibration stream, so the motion is a fixed function of time for a seed.
    pub fn new(
        config: &CameraVibrationConfig,
        seed: u64,
        width_px: usize,
        height_px: usize,
    ) -> Option<Self> {
        if !config.enabled {
            return None;
        }
        let mut rng = stream(seed, Stream::CameraVibration, 0);
        let r = &config.random;
        let mut x_px = config.x_px.clone();
        let mut y_px = config.y_px.clone();
        let mut rotation_rad = config.rotation_rad.clone();
        x_px.extend(random_sinusoids(&mut rng, r.x_rms_px, r));
        y_px.extend(random_sinusoids(&mut rng, r.y_rms_px, r));
        rotation_rad.extend(random_sinusoids(&mut rng, r.rotation_rms_rad, r));
        let centre_px = DVec2::new(
            (width_px as f64 - 1.0) / 2.0,
            (height_px as f64 - 1.0) / 2.0,
        );
        Some(Self {
            x_px,
            y_px,
            rotation_rad,
            centre_px,
        })
    }

    fn eval(list: &[Sinusoid], t_s: f64) -> f64 {
        list.iter()
            .map(|s| s.amplitude * (TAU * s.frequency_hz * t_s + s.phase_rad).sin())
            .sum()
    }

    /// The image transform at `t_s`.
    pub fn at(&self, t_s: f64) -> RigidTransform {
        RigidTransform {
            centre_px: self.centre_px,
            rotation_rad: Self::eval(&self.rotation_rad, t_s),
            translation_px: DVec2::new(Self::eval(&self.x_px, t_s), Self::eval(&self.y_px, t_s)),
        }
    }

    /// Upper bound of the image speed in px/s anywhere in a frame (for motion-blur sampling).
    pub fn max_speed_px_s(&self) -> f64 {
        let rate = |l: &[Sinusoid]| {
            l.iter()
                .map(|s| (s.amplitude * TAU * s.frequency_hz).abs())
                .sum::<f64>()
        };
        let radius = self.centre_px.length();
        rate(&self.x_px) + rate(&self.y_px) + rate(&self.rotation_rad) * radius
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sinusoid_and_random_part_are_deterministic_with_the_requested_rms() {
        let cfg = CameraVibrationConfig {
            enabled: true,
            x_px: vec![Sinusoid {
                amplitude: 2.0,
                frequency_hz: 5.0,
                phase_rad: 0.0,
            }],
            random: RandomVibrationConfig {
                y_rms_px: 0.5,
                ..Default::default()
            },
            ..Default::default()
        };
        let v = Vibration::new(&cfg, 9, 100, 100).unwrap();
        assert!((v.at(0.05).translation_px.x - 2.0).abs() < 1e-12); // sin(π/2)
        let w = Vibration::new(&cfg, 9, 100, 100).unwrap();
        assert_eq!(v.at(1.234), w.at(1.234));
        let other = Vibration::new(&cfg, 10, 100, 100).unwrap();
        assert_ne!(
            v.at(1.234).translation_px.y,
            other.at(1.234).translation_px.y
        );
        // RMS over a long time ≈ requested (sinusoids at distinct frequencies are orthogonal).
        let n = 20000;
        let ms = (0..n)
            .map(|i| v.at(i as f64 * 0.01).translation_px.y.powi(2))
            .sum::<f64>()
            / n as f64;
        assert!((ms.sqrt() - 0.5).abs() < 0.1, "{}", ms.sqrt());
        assert!(Vibration::new(&CameraVibrationConfig::default(), 9, 10, 10).is_none());
    }
}
