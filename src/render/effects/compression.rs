//! JPEG compression of the 8-bit grey frame (jpeg-encoder → jpeg-decoder round trip). Blocks
//! are aligned to the absolute 8-pixel grid so a region of interest compresses exactly like the
//! same blocks of the full frame.

use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};
use thiserror::Error;

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CompressionConfig {
    /// Compress. Default: false.
    pub enabled: bool,
    /// JPEG quality, in [1, 100]. Default: 90.
    pub quality: u8,
}

impl Default for CompressionConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            quality: 90,
        }
    }
}

impl CompressionConfig {
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        problems.range(join(path, "quality"), self.quality as f64, 1.0, 100.0);
    }
}

#[derive(Debug, Error)]
pub enum CompressionError {
    #[error("image of {width}×{height} px is too large for JPEG (max 65535)")]
    TooLarge { width: usize, height: usize },
    #[error("JPEG encoding failed: {0}")]
    Encode(String),
    #[error("JPEG decoding failed: {0}")]
    Decode(String),
}

/// Encodes `data` (`width` × `height` grey, row-major) at `quality` and decodes it again.
pub fn jpeg_round_trip(
    data: &[u8],
    width: usize,
    height: usize,
    quality: u8,
) -> Result<Vec<u8>, CompressionError> {
    if width > 65535 || height > 65535 {
        return Err(CompressionError::TooLarge { width, height });
    }
    let mut bytes = Vec::new();
    let encoder = jpeg_encoder::Encoder::new(&mut bytes, quality.clamp(1, 100));
    encoder
        .encode(
            data,
            width as u16,
            height as u16,
            jpeg_encoder::ColorType::Luma,
        )
        .map_err(|e| CompressionError::Encode(e.to_string()))?;
    let mut decoder = jpeg_decoder::Decoder::new(bytes.as_slice());
    let pixels = decoder
        .decode()
        .map_err(|e| CompressionError::Decode(e.to_string()))?;
    if pixels.len() != width * height {
        return Err(CompressionError::Decode(format!(
            "expected {} pixels, got {}",
            width * height,
            pixels.len()
        )));
    }
    Ok(pixels)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_size_and_lower_quality_loses_more() {
        let (w, h) = (32, 24);
        let data: Vec<u8> = (0..w * h)
            .map(|i| {
                if (i % w) * 3 + (i / w) * 2 > 50 {
                    220
                } else {
                    30
                }
            })
            .collect();
        let err = |q| {
            let out = jpeg_round_trip(&data, w, h, q).unwrap();
            assert_eq!(out.len(), data.len());
            out.iter()
                .zip(&data)
                .map(|(&a, &b)| (a as f64 - b as f64).abs())
                .sum::<f64>()
        };
        let (hi, lo) = (err(95), err(20));
        assert!(lo > hi, "q20 error {lo} should exceed q95 error {hi}");
        assert!(hi > 0.0);
    }
}
