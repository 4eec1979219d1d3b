//! Imaging effects between the exact scene and the 8-bit frame, one file per effect; this file
//! owns the combined [`EffectsConfig`] (the `[effects]` table of a scenario).
//!
//! Order in the renderer (physical order of image formation): camera vibration and motion blur
//! (scene sampled across the exposure), rolling shutter (row times), optical blur (PSF), lighting
//! (illumination), pixel noise (electrons), tone curve, sharpening, 8-bit quantisation,
//! compression; then, over the whole clip, the video codec.

pub mod camera_vibration;
pub mod compression;
pub mod lighting;
pub mod motion_blur;
pub mod optical_blur;
pub mod pixel_noise;
pub mod rolling_shutter;
pub mod sharpening;
pub mod video_codec;

use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};

pub use camera_vibration::{CameraVibrationConfig, RandomVibrationConfig, Sinusoid};
pub use compression::CompressionConfig;
pub use lighting::LightingConfig;
pub use motion_blur::MotionBlurConfig;
pub use optical_blur::OpticalBlurConfig;
pub use pixel_noise::PixelNoiseConfig;
pub use rolling_shutter::RollingShutterConfig;
pub use sharpening::SharpeningConfig;
pub use video_codec::{VideoCodec, VideoCodecConfig};

/// All imaging effects; each sub-table has an `enabled` flag. Defaults reproduce the seed rig's
/// real 4K frame (see [`crate::render::real_frame`]).
#[derive(Debug, Clone, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct EffectsConfig {
    /// Gaussian lens/sensor point-spread function.
    pub optical_blur: OpticalBlurConfig,
    /// Exposure time integration of the moving scene.
    pub motion_blur: MotionBlurConfig,
    /// Row-by-row readout.
    pub rolling_shutter: RollingShutterConfig,
    /// Shot and read noise (8-bit quantisation is always applied).
    pub pixel_noise: PixelNoiseConfig,
    /// Image-space shake of the camera.
    pub camera_vibration: CameraVibrationConfig,
    /// Black/white levels, gamma and uneven illumination.
    pub lighting: LightingConfig,
    /// JPEG compression of the 8-bit frame.
    pub compression: CompressionConfig,
    /// Unsharp mask of the tone-mapped frame (a phone's image processor). Left out of a
    /// written scenario while off and at its defaults, so scenarios without it read as before.
    #[serde(skip_serializing_if = "SharpeningConfig::is_default")]
    pub sharpening: SharpeningConfig,
    /// H.264 or HEVC over the whole clip (a phone's recording). Left out of a written scenario
    /// while off and at its defaults.
    #[serde(skip_serializing_if = "VideoCodecConfig::is_default")]
    pub video_codec: VideoCodecConfig,
}

impl EffectsConfig {
    /// Everything off: ideal optics, instantaneous exposure, global shutter, no noise, full
    /// 0–255 range (only the always-on 8-bit quantisation remains).
    pub fn none() -> Self {
        Self {
            optical_blur: OpticalBlurConfig {
                enabled: false,
                ..Default::default()
            },
            motion_blur: MotionBlurConfig {
                enabled: false,
                ..Default::default()
            },
            rolling_shutter: RollingShutterConfig {
                enabled: false,
                ..Default::default()
            },
            pixel_noise: PixelNoiseConfig {
                enabled: false,
                ..Default::default()
            },
            camera_vibration: CameraVibrationConfig {
                enabled: false,
                ..Default::default()
            },
            lighting: LightingConfig {
                enabled: false,
                ..Default::default()
            },
            compression: CompressionConfig {
                enabled: false,
                ..Default::default()
            },
            sharpening: SharpeningConfig::default(),
            video_codec: VideoCodecConfig::default(),
        }
    }

    pub fn validate(&self, path: &str, problems: &mut Problems) {
        self.optical_blur
            .validate(&join(path, "optical_blur"), problems);
        self.motion_blur
            .validate(&join(path, "motion_blur"), problems);
        self.rolling_shutter
            .validate(&join(path, "rolling_shutter"), problems);
        self.pixel_noise
            .validate(&join(path, "pixel_noise"), problems);
        self.camera_vibration
            .validate(&join(path, "camera_vibration"), problems);
        self.lighting.validate(&join(path, "lighting"), problems);
        self.compression
            .validate(&join(path, "compression"), problems);
        self.sharpening
            .validate(&join(path, "sharpening"), problems);
        self.video_codec
            .validate(&join(path, "video_codec"), problems);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid_and_round_trip_through_toml() {
        let c = EffectsConfig::default();
        let mut p = Problems::new();
        c.validate("effects", &mut p);
        assert!(p.is_empty(), "{:?}", p);
        let text = toml::to_string(&c).unwrap();
        let back: EffectsConfig = toml::from_str(&text).unwrap();
        assert_eq!(back, c);
    }

    #[test]
    fn bad_values_are_reported_with_their_field_paths() {
        let mut c = EffectsConfig::default();
        c.optical_blur.sigma_px = -1.0;
        c.pixel_noise.full_well_e = 0.0;
        c.lighting.white_level_dn = 300.0;
        c.compression.quality = 0;
        c.camera_vibration.random.band_max_hz = -3.0;
        let mut p = Problems::new();
        c.validate("effects", &mut p);
        let fields: Vec<&str> = p.iter().map(|x| x.field.as_str()).collect();
        for f in [
            "effects.optical_blur.sigma_px",
            "effects.pixel_noise.full_well_e",
            "effects.lighting.white_level_dn",
            "effects.compression.quality",
            "effects.camera_vibration.random.band_max_hz",
        ] {
            assert!(fields.contains(&f), "{f} missing from {fields:?}");
        }
    }

    #[test]
    fn unknown_fields_are_rejected() {
        assert!(toml::from_str::<EffectsConfig>("[optical_blur]\nsigma = 1.0\n").is_err());
    }
}
