//! 8-bit greyscale PNG writing (rendered frames).

use std::path::Path;

#[derive(Debug, thiserror::Error)]
#[error("{file}: {message}")]
pub struct PngError {
    pub file: String,
    pub message: String,
}

/// Writes a row-major 8-bit grey image.
pub fn write_gray_png(path: &Path, width: u32, height: u32, data: &[u8]) -> Result<(), PngError> {
    let err = |m: String| PngError {
        file: path.display().to_string(),
        message: m,
    };
    if data.len() != (width as usize) * (height as usize) {
        return Err(err(format!(
            "{} bytes for a {width}x{height} image",
            data.len()
        )));
    }
    let file = std::fs::File::create(path).map_err(|e| err(format!("cannot create: {e}")))?;
    let mut encoder = png::Encoder::new(std::io::BufWriter::new(file), width, height);
    encoder.set_color(png::ColorType::Grayscale);
    encoder.set_depth(png::BitDepth::Eight);
    // Frames are written once and read by detection; fast compression keeps rendering I/O-light.
    encoder.set_compression(png::Compression::Fast);
    let mut writer = encoder.write_header().map_err(|e| err(e.to_string()))?;
    writer
        .write_image_data(data)
        .map_err(|e| err(e.to_string()))?;
    writer.finish().map_err(|e| err(e.to_string()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("f.png");
        let data: Vec<u8> = (0..12u8).collect();
        write_gray_png(&p, 4, 3, &data).unwrap();
        let mut reader = png::Decoder::new(std::fs::File::open(&p).unwrap())
            .read_info()
            .unwrap();
        let mut buf = vec![0; reader.output_buffer_size()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (4, 3));
        assert_eq!(&buf[..12], &data[..]);
        assert!(write_gray_png(&p, 5, 3, &data).is_err());
    }
}
