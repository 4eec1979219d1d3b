//! Appearance textures as files: grey PNGs of 8 or 16 bits whose samples are linear radiance
//! (0 = black, full scale = 1), read and written exactly (no colour conversion, no gamma).
//!
//! A texture is refused from its header, before any pixel buffer is allocated, when it is not a
//! plain grey image of 8 or 16 bits or when it holds more than [`MAX_TEXTURE_TEXELS`] texels.

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

/// Largest texture accepted: 2^26 texels (8192 × 8192), 128 MB at 16 bits.
pub const MAX_TEXTURE_TEXELS: usize = 1 << 26;

/// A decoded texture: `values` row-major, scaled to 16 bits (an 8-bit sample v is v · 257, so
/// 255 is 65535 and radiance = value / 65535 either way).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TextureImage {
    pub width: usize,
    pub height: usize,
    /// Bits per sample in the file (8 or 16).
    pub bits: u8,
    pub values: Vec<u16>,
}

#[derive(Debug, thiserror::Error)]
pub enum TextureError {
    #[error("{path}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: not a PNG file: {message}")]
    Decode { path: PathBuf, message: String },
    #[error("{path}: a texture is a grey PNG of 8 or 16 bits; this one is {what}")]
    Format { path: PathBuf, what: String },
    #[error("{path}: {width}x{height} texels exceed the limit of {MAX_TEXTURE_TEXELS}")]
    TooLarge {
        path: PathBuf,
        width: usize,
        height: usize,
    },
    #[error("{path}: {message}")]
    Write { path: PathBuf, message: String },
}

impl TextureError {
    /// The message without the file name (for errors that name the file already).
    pub fn reason(&self) -> String {
        match self {
            TextureError::Io { source, .. } => source.to_string(),
            TextureError::Decode { message, .. } => format!("not a PNG file: {message}"),
            TextureError::Format { what, .. } => {
                format!("a texture is a grey PNG of 8 or 16 bits; this one is {what}")
            }
            TextureError::TooLarge { width, height, .. } => {
                format!("{width}x{height} texels exceed the limit of {MAX_TEXTURE_TEXELS}")
            }
            TextureError::Write { message, .. } => message.clone(),
        }
    }
}

fn describe(color: png::ColorType, depth: png::BitDepth) -> String {
    let layout = match color {
        png::ColorType::Grayscale => "grey",
        png::ColorType::GrayscaleAlpha => "grey+alpha",
        png::ColorType::Rgb => "RGB",
        png::ColorType::Rgba => "RGBA",
        png::ColorType::Indexed => "palette",
    };
    format!("{}-bit {layout}", depth as u8)
}

/// Reads a grey PNG of 8 or 16 bits as a texture.
pub fn read_texture(path: &Path) -> Result<TextureImage, TextureError> {
    let file = File::open(path).map_err(|source| TextureError::Io {
        path: path.into(),
        source,
    })?;
    let mut decoder = png::Decoder::new(BufReader::new(file));
    decoder.set_transformations(png::Transformations::IDENTITY);
    let decode = |e: png::DecodingError| TextureError::Decode {
        path: path.into(),
        message: e.to_string(),
    };
    let mut reader = decoder.read_info().map_err(decode)?;
    let info = reader.info();
    let (width, height) = (info.width as usize, info.height as usize);
    let (color, depth) = (info.color_type, info.bit_depth);
    let bits = match (color, depth) {
        (png::ColorType::Grayscale, png::BitDepth::Eight) => 8,
        (png::ColorType::Grayscale, png::BitDepth::Sixteen) => 16,
        _ => {
            return Err(TextureError::Format {
                path: path.into(),
                what: describe(color, depth),
            })
        }
    };
    if width.saturating_mul(height) > MAX_TEXTURE_TEXELS {
        return Err(TextureError::TooLarge {
            path: path.into(),
            width,
            height,
        });
    }
    let mut buf = vec![0u8; reader.output_buffer_size()];
    let frame = reader.next_frame(&mut buf).map_err(decode)?;
    let stride = frame.line_size;
    let mut values = Vec::with_capacity(width * height);
    for row in buf.chunks(stride).take(height) {
        if bits == 8 {
            values.extend(row[..width].iter().map(|&v| u16::from(v) * 257));
        } else {
            values.extend(
                row[..2 * width]
                    .chunks_exact(2)
                    .map(|b| u16::from_be_bytes([b[0], b[1]])),
            );
        }
    }
    Ok(TextureImage {
        width,
        height,
        bits,
        values,
    })
}

/// Writes a 16-bit grey PNG (row-major `values`).
pub fn write_texture(
    path: &Path,
    width: usize,
    height: usize,
    values: &[u16],
) -> Result<(), TextureError> {
    let err = |message: String| TextureError::Write {
        path: path.into(),
        message,
    };
    if values.len() != width * height {
        return Err(err(format!(
            "{} values for a {width}x{height} texture",
            values.len()
        )));
    }
    let file = File::create(path).map_err(|e| err(format!("cannot create: {e}")))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), width as u32, height as u32);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Sixteen);
    let mut writer = encoder.write_header().map_err(|e| err(e.to_string()))?;
    let bytes: Vec<u8> = values.iter().flat_map(|v| v.to_be_bytes()).collect();
    writer
        .write_image_data(&bytes)
        .map_err(|e| err(e.to_string()))?;
    writer.finish().map_err(|e| err(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sixteen_bits_round_trip_and_eight_bits_scale_to_full_range() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.png");
        let values: Vec<u16> = vec![0, 1, 257, 40000, 65534, 65535];
        write_texture(&p, 3, 2, &values).unwrap();
        let t = read_texture(&p).unwrap();
        assert_eq!((t.width, t.height, t.bits), (3, 2, 16));
        assert_eq!(t.values, values);
        let p8 = dir.path().join("t8.png");
        crate::io::png_out::write_gray_png(&p8, 2, 1, &[0, 255]).unwrap();
        let t8 = read_texture(&p8).unwrap();
        assert_eq!((t8.bits, t8.values.clone()), (8, vec![0, 65535]));
        assert!(write_texture(&p, 4, 2, &values).is_err());
    }

    #[test]
    fn colour_and_odd_depths_are_refused_by_name() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("rgb.png");
        let file = File::create(&p).unwrap();
        let mut e = png::Encoder::new(std::io::BufWriter::new(file), 1, 1);
        e.set_color(png::ColorType::Rgb);
        e.set_depth(png::BitDepth::Eight);
        e.write_header()
            .unwrap()
            .write_image_data(&[1, 2, 3])
            .unwrap();
        let msg = read_texture(&p).unwrap_err().to_string();
        assert!(
            msg.contains("rgb.png") && msg.contains("8-bit RGB"),
            "{msg}"
        );
        let junk = dir.path().join("junk.png");
        std::fs::write(&junk, b"not a png").unwrap();
        let msg = read_texture(&junk).unwrap_err().to_string();
        assert!(
            msg.contains("junk.png") && msg.contains("not a PNG"),
            "{msg}"
        );
    }
}
