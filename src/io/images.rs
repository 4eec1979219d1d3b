//! Still-image frame input: PNG/JPEG files decoded to 8-bit grey the way OpenCV's `cvtColor`
//! would, their headers (size and pixel format, read without decoding, so a sequence can be
//! checked for consistency first), and directory listings in natural name order (frame2 before
//! frame10).
//!
//! Bounded work: an image larger than [`MAX_IMAGE_PIXELS`] is refused from its header, before
//! any pixel buffer is allocated.

use std::cmp::Ordering;
use std::fs::File;
use std::io::{BufReader, Read};
use std::path::{Path, PathBuf};

/// An owned 8-bit grey image, row-major, no padding.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct GrayImage {
    pub width: usize,
    pub height: usize,
    pub data: Vec<u8>,
}

#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    #[error("{path}")]
    Io {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: cannot decode image: {message}")]
    Decode { path: PathBuf, message: String },
    #[error("{path}: unsupported image: {what}")]
    Unsupported { path: PathBuf, what: String },
    #[error("{path}: empty file (0 bytes)")]
    Empty { path: PathBuf },
    #[error("{path}: image of {width}x{height} px exceeds the limit of {MAX_IMAGE_PIXELS} pixels")]
    TooLarge {
        path: PathBuf,
        width: usize,
        height: usize,
    },
}

/// Largest image accepted (2^28 px, e.g. 16384x16384): far above any camera frame, small enough
/// that decoding one never allocates more than about 2 GB (16-bit RGBA).
pub const MAX_IMAGE_PIXELS: usize = 1 << 28;

/// Container and sample layout of an image file, as its header states them.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct PixelFormat {
    pub jpeg: bool,
    /// Samples per pixel after palette expansion (1 grey, 2 grey+alpha, 3 RGB, 4 RGBA).
    pub channels: u8,
    pub bits: u8,
}

impl std::fmt::Display for PixelFormat {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let layout = match self.channels {
            1 => "grey",
            2 => "grey+alpha",
            3 => "RGB",
            4 => "RGBA",
            _ => "CMYK",
        };
        let kind = if self.jpeg { "JPEG" } else { "PNG" };
        write!(f, "{}-bit {layout} {kind}", self.bits)
    }
}

/// Size and pixel format of an image file, from its header.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct ImageHeader {
    pub width: usize,
    pub height: usize,
    pub format: PixelFormat,
}

impl ImageError {
    /// The message without the file name (for lists that name the file already).
    pub fn reason(&self) -> String {
        match self {
            ImageError::Io { source, .. } => source.to_string(),
            ImageError::Decode { message, .. } => format!("cannot decode image: {message}"),
            ImageError::Unsupported { what, .. } => format!("unsupported image: {what}"),
            ImageError::Empty { .. } => "empty file (0 bytes)".into(),
            ImageError::TooLarge { width, height, .. } => format!(
                "image of {width}x{height} px exceeds the limit of {MAX_IMAGE_PIXELS} pixels"
            ),
        }
    }
}

/// OpenCV's fixed-point RGB→grey (`cvtColor`, 8-bit): weights 0.299/0.587/0.114 scaled by 2^14
/// (4899, 9617, 1868, summing to 16384) with round-half-up descaling.
pub fn rgb_to_gray(r: u8, g: u8, b: u8) -> u8 {
    const R2Y: u32 = 4899;
    const G2Y: u32 = 9617;
    const B2Y: u32 = 1868;
    ((u32::from(r) * R2Y + u32::from(g) * G2Y + u32::from(b) * B2Y + (1 << 13)) >> 14) as u8
}

/// 16-bit sample to 8 bits, rounded (65535 → 255).
fn to_u8(v: u16) -> u8 {
    ((u32::from(v) * 255 + 32767) / 65535) as u8
}

/// Channels in a decoded buffer and which of them are colour (grey+alpha: 2, RGBA: 4).
fn samples_to_gray(samples: &[u16], channels: usize, path: &Path) -> Result<Vec<u8>, ImageError> {
    let px = |c: &[u16]| match channels {
        1 | 2 => to_u8(c[0]),
        _ => rgb_to_gray(to_u8(c[0]), to_u8(c[1]), to_u8(c[2])),
    };
    if !(1..=4).contains(&channels) {
        return Err(ImageError::Unsupported {
            path: path.into(),
            what: format!("{channels} channels"),
        });
    }
    Ok(samples.chunks_exact(channels).map(px).collect())
}

/// Reads a PNG (1–16 bit, grey/grey+alpha/RGB/RGBA/palette) or JPEG (grey/RGB) as 8-bit grey.
/// 16-bit samples are rounded to 8 bits before the colour conversion; alpha is ignored, as
/// `cvtColor(..., COLOR_RGBA2GRAY)` does.
pub fn read_gray(path: &Path) -> Result<GrayImage, ImageError> {
    if sniff(path)? {
        read_jpeg(path)
    } else {
        read_png(path)
    }
}

/// Size and pixel format from the header only (no pixel is decoded).
pub fn read_header(path: &Path) -> Result<ImageHeader, ImageError> {
    let header = if sniff(path)? {
        let mut decoder = jpeg_decoder::Decoder::new(BufReader::new(open(path)?));
        decoder.read_info().map_err(|e| ImageError::Decode {
            path: path.into(),
            message: e.to_string(),
        })?;
        let info = decoder.info().ok_or_else(|| ImageError::Decode {
            path: path.into(),
            message: "no header".into(),
        })?;
        let (channels, bits) = match info.pixel_format {
            jpeg_decoder::PixelFormat::L8 => (1, 8),
            jpeg_decoder::PixelFormat::L16 => (1, 16),
            jpeg_decoder::PixelFormat::RGB24 => (3, 8),
            jpeg_decoder::PixelFormat::CMYK32 => (5, 8),
        };
        ImageHeader {
            width: usize::from(info.width),
            height: usize::from(info.height),
            format: PixelFormat {
                jpeg: true,
                channels,
                bits,
            },
        }
    } else {
        let mut decoder = png::Decoder::new(BufReader::new(open(path)?));
        decoder.set_transformations(png::Transformations::EXPAND);
        let reader = decoder.read_info().map_err(|e| ImageError::Decode {
            path: path.into(),
            message: e.to_string(),
        })?;
        let (color, depth) = reader.output_color_type();
        ImageHeader {
            width: reader.info().width as usize,
            height: reader.info().height as usize,
            format: PixelFormat {
                jpeg: false,
                channels: color.samples() as u8,
                bits: if depth == png::BitDepth::Sixteen {
                    16
                } else {
                    8
                },
            },
        }
    };
    check_size(path, header.width, header.height)?;
    Ok(header)
}

fn open(path: &Path) -> Result<File, ImageError> {
    File::open(path).map_err(|source| ImageError::Io {
        path: path.into(),
        source,
    })
}

/// Reads the magic bytes: `Ok(true)` for JPEG, `Ok(false)` for PNG, else an error naming why.
fn sniff(path: &Path) -> Result<bool, ImageError> {
    let io = |source| ImageError::Io {
        path: path.into(),
        source,
    };
    let mut magic = [0u8; 8];
    let mut file = open(path)?;
    let mut n = 0;
    // `read` may return fewer bytes than asked; fill the magic from a short file as far as it goes.
    while n < magic.len() {
        match file.read(&mut magic[n..]).map_err(io)? {
            0 => break,
            k => n += k,
        }
    }
    if n == 0 {
        Err(ImageError::Empty { path: path.into() })
    } else if n >= 8 && magic == *b"\x89PNG\r\n\x1a\n" {
        Ok(false)
    } else if n >= 2 && magic[..2] == [0xFF, 0xD8] {
        Ok(true)
    } else {
        Err(ImageError::Unsupported {
            path: path.into(),
            what: "not a PNG or JPEG file".into(),
        })
    }
}

fn check_size(path: &Path, width: usize, height: usize) -> Result<(), ImageError> {
    if width.saturating_mul(height) > MAX_IMAGE_PIXELS {
        return Err(ImageError::TooLarge {
            path: path.into(),
            width,
            height,
        });
    }
    Ok(())
}

fn read_png(path: &Path) -> Result<GrayImage, ImageError> {
    let decode = |e: png::DecodingError| ImageError::Decode {
        path: path.into(),
        message: e.to_string(),
    };
    let file = File::open(path).map_err(|source| ImageError::Io {
        path: path.into(),
        source,
    })?;
    let mut decoder = png::Decoder::new(BufReader::new(file));
    // EXPAND: palettes → RGB, 1/2/4-bit → 8-bit, tRNS → alpha; 16-bit stays 16-bit.
    decoder.set_transformations(png::Transformations::EXPAND);
    let mut reader = decoder.read_info().map_err(decode)?;
    check_size(
        path,
        reader.info().width as usize,
        reader.info().height as usize,
    )?;
    let mut buf = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buf).map_err(decode)?;
    let bytes = &buf[..info.buffer_size()];
    let channels = info.color_type.samples();
    let samples: Vec<u16> = match info.bit_depth {
        png::BitDepth::Sixteen => bytes
            .chunks_exact(2)
            .map(|b| u16::from_be_bytes([b[0], b[1]]))
            .collect(),
        // 8-bit samples widened so one conversion path serves both depths (257 × v maps back to v).
        _ => bytes.iter().map(|&b| u16::from(b) * 257).collect(),
    };
    let data = samples_to_gray(&samples, channels, path)?;
    Ok(GrayImage {
        width: info.width as usize,
        height: info.height as usize,
        data,
    })
}

fn read_jpeg(path: &Path) -> Result<GrayImage, ImageError> {
    let file = File::open(path).map_err(|source| ImageError::Io {
        path: path.into(),
        source,
    })?;
    let mut decoder = jpeg_decoder::Decoder::new(BufReader::new(file));
    decoder.read_info().map_err(|e| ImageError::Decode {
        path: path.into(),
        message: e.to_string(),
    })?;
    if let Some(info) = decoder.info() {
        check_size(path, usize::from(info.width), usize::from(info.height))?;
    }
    let pixels = decoder.decode().map_err(|e| ImageError::Decode {
        path: path.into(),
        message: e.to_string(),
    })?;
    let info = decoder.info().ok_or_else(|| ImageError::Decode {
        path: path.into(),
        message: "no header".into(),
    })?;
    let data = match info.pixel_format {
        jpeg_decoder::PixelFormat::L8 => pixels,
        jpeg_decoder::PixelFormat::RGB24 => pixels
            .chunks_exact(3)
            .map(|c| rgb_to_gray(c[0], c[1], c[2]))
            .collect(),
        jpeg_decoder::PixelFormat::L16 => pixels
            .chunks_exact(2)
            .map(|b| to_u8(u16::from_be_bytes([b[0], b[1]])))
            .collect(),
        jpeg_decoder::PixelFormat::CMYK32 => {
            return Err(ImageError::Unsupported {
                path: path.into(),
                what: "CMYK JPEG".into(),
            })
        }
    };
    let (width, height) = (usize::from(info.width), usize::from(info.height));
    if data.len() != width * height {
        return Err(ImageError::Decode {
            path: path.into(),
            message: "pixel count does not match size".into(),
        });
    }
    Ok(GrayImage {
        width,
        height,
        data,
    })
}

/// Compares names with digit runs taken as numbers: "frame2" < "frame10" < "frame010b".
pub fn natural_cmp(a: &str, b: &str) -> Ordering {
    let (mut a, mut b) = (a.as_bytes(), b.as_bytes());
    loop {
        match (a.first(), b.first()) {
            (None, None) => return Ordering::Equal,
            (None, _) => return Ordering::Less,
            (_, None) => return Ordering::Greater,
            (Some(x), Some(y)) if x.is_ascii_digit() && y.is_ascii_digit() => {
                let la = a.iter().take_while(|c| c.is_ascii_digit()).count();
                let lb = b.iter().take_while(|c| c.is_ascii_digit()).count();
                let (da, db) = (&a[..la], &b[..lb]);
                let ta = trim_zeros(da);
                let tb = trim_zeros(db);
                // Numeric value first (length of the significant digits, then digits), then
                // fewer leading zeros first so the order is total and deterministic.
                let ord = ta.len().cmp(&tb.len()).then(ta.cmp(tb)).then(la.cmp(&lb));
                if ord != Ordering::Equal {
                    return ord;
                }
                a = &a[la..];
                b = &b[lb..];
            }
            (Some(x), Some(y)) => {
                if x != y {
                    return x.cmp(y);
                }
                a = &a[1..];
                b = &b[1..];
            }
        }
    }
}

fn trim_zeros(d: &[u8]) -> &[u8] {
    let z = d.iter().take_while(|&&c| c == b'0').count();
    &d[z..]
}

/// The PNG/JPEG files (by extension, case-insensitive) directly inside `dir`, in natural name order.
pub fn list_image_files(dir: &Path) -> Result<Vec<PathBuf>, ImageError> {
    let io = |source| ImageError::Io {
        path: dir.into(),
        source,
    };
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(io)? {
        let path = entry.map_err(io)?.path();
        let ext = path
            .extension()
            .and_then(|e| e.to_str())
            .unwrap_or("")
            .to_ascii_lowercase();
        if path.is_file() && matches!(ext.as_str(), "png" | "jpg" | "jpeg") {
            files.push(path);
        }
    }
    files.sort_by(|x, y| {
        let nx = x
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let ny = y
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        natural_cmp(&nx, &ny)
    });
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn write_png(
        path: &Path,
        w: u32,
        h: u32,
        color: png::ColorType,
        depth: png::BitDepth,
        data: &[u8],
    ) {
        let file = File::create(path).unwrap();
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), w, h);
        enc.set_color(color);
        enc.set_depth(depth);
        enc.write_header().unwrap().write_image_data(data).unwrap();
    }

    #[test]
    fn gray_weights_match_opencv_fixed_point() {
        // Independent reference: round(0.299 r + 0.587 g + 0.114 b) agrees with OpenCV except at
        // exact halves; check pure channels and white.
        assert_eq!(rgb_to_gray(255, 255, 255), 255);
        assert_eq!(rgb_to_gray(0, 0, 0), 0);
        assert_eq!(rgb_to_gray(255, 0, 0), 76); // 255·4899/16384 = 76.25
        assert_eq!(rgb_to_gray(0, 255, 0), 150); // 149.68
        assert_eq!(rgb_to_gray(0, 0, 255), 29); // 29.07
        for (r, g, b) in [(10u8, 200u8, 30u8), (123, 45, 67), (250, 1, 128)] {
            let f = 0.299 * f64::from(r) + 0.587 * f64::from(g) + 0.114 * f64::from(b);
            assert!((f64::from(rgb_to_gray(r, g, b)) - f).abs() <= 0.51);
        }
    }

    #[test]
    fn png_depths_and_colour_types_decode_to_gray() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("g8.png");
        write_png(
            &p,
            3,
            2,
            png::ColorType::Grayscale,
            png::BitDepth::Eight,
            &[0, 1, 2, 100, 200, 255],
        );
        let img = read_gray(&p).unwrap();
        assert_eq!(
            (img.width, img.height, img.data.clone()),
            (3, 2, vec![0, 1, 2, 100, 200, 255])
        );

        let p = dir.path().join("rgb8.png");
        write_png(
            &p,
            2,
            1,
            png::ColorType::Rgb,
            png::BitDepth::Eight,
            &[255, 0, 0, 10, 200, 30],
        );
        assert_eq!(
            read_gray(&p).unwrap().data,
            vec![76, rgb_to_gray(10, 200, 30)]
        );

        let p = dir.path().join("rgba8.png");
        write_png(
            &p,
            1,
            1,
            png::ColorType::Rgba,
            png::BitDepth::Eight,
            &[0, 255, 0, 7],
        );
        assert_eq!(read_gray(&p).unwrap().data, vec![150]);

        let p = dir.path().join("g16.png");
        let v: [u16; 3] = [0, 0x8080, 0xFFFF];
        let bytes: Vec<u8> = v.iter().flat_map(|x| x.to_be_bytes()).collect();
        write_png(
            &p,
            3,
            1,
            png::ColorType::Grayscale,
            png::BitDepth::Sixteen,
            &bytes,
        );
        assert_eq!(read_gray(&p).unwrap().data, vec![0, 128, 255]);

        let p = dir.path().join("rgb16.png");
        let bytes: Vec<u8> = [0xFFFFu16, 0, 0]
            .iter()
            .flat_map(|x| x.to_be_bytes())
            .collect();
        write_png(
            &p,
            1,
            1,
            png::ColorType::Rgb,
            png::BitDepth::Sixteen,
            &bytes,
        );
        assert_eq!(read_gray(&p).unwrap().data, vec![76]);
    }

    #[test]
    fn jpeg_gray_round_trips_approximately() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.jpg");
        let data: Vec<u8> = (0..16 * 16)
            .map(|i| if (i % 16) < 8 { 40 } else { 210 })
            .collect();
        jpeg_encoder::Encoder::new_file(&p, 100)
            .unwrap()
            .encode(&data, 16, 16, jpeg_encoder::ColorType::Luma)
            .unwrap();
        let img = read_gray(&p).unwrap();
        assert_eq!((img.width, img.height), (16, 16));
        let max_err = img
            .data
            .iter()
            .zip(&data)
            .map(|(a, b)| (i32::from(*a) - i32::from(*b)).abs())
            .max();
        assert!(max_err.unwrap() <= 12, "{max_err:?}");
    }

    #[test]
    fn corrupt_and_foreign_files_are_errors_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("bad.png");
        std::fs::write(&p, b"\x89PNG\r\n\x1a\n garbage garbage").unwrap();
        let e = read_gray(&p).unwrap_err().to_string();
        assert!(e.contains("bad.png"), "{e}");
        let p = dir.path().join("bad.jpg");
        std::fs::write(&p, [0xFF, 0xD8, 1, 2, 3, 4]).unwrap();
        assert!(read_gray(&p).unwrap_err().to_string().contains("bad.jpg"));
        let p = dir.path().join("x.txt");
        std::fs::write(&p, b"hello").unwrap();
        assert!(matches!(read_gray(&p), Err(ImageError::Unsupported { .. })));
        assert!(matches!(
            read_gray(&dir.path().join("missing.png")),
            Err(ImageError::Io { .. })
        ));
    }

    #[test]
    fn headers_give_size_and_pixel_format_without_decoding() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("g.png");
        write_png(
            &p,
            3,
            2,
            png::ColorType::Grayscale,
            png::BitDepth::Eight,
            &[0; 6],
        );
        let h = read_header(&p).unwrap();
        assert_eq!((h.width, h.height), (3, 2));
        assert_eq!(h.format.to_string(), "8-bit grey PNG");
        let p = dir.path().join("p.png");
        // A 1-bit palette image expands to 8-bit RGB, as the decoder delivers it.
        let file = File::create(&p).unwrap();
        let mut enc = png::Encoder::new(std::io::BufWriter::new(file), 8, 1);
        enc.set_color(png::ColorType::Indexed);
        enc.set_depth(png::BitDepth::One);
        enc.set_palette(vec![0, 0, 0, 255, 255, 255]);
        enc.write_header()
            .unwrap()
            .write_image_data(&[0b1010_1010])
            .unwrap();
        assert_eq!(read_header(&p).unwrap().format.to_string(), "8-bit RGB PNG");
        let p = dir.path().join("a.jpg");
        jpeg_encoder::Encoder::new_file(&p, 90)
            .unwrap()
            .encode(&[0u8; 8 * 8 * 3], 8, 8, jpeg_encoder::ColorType::Rgb)
            .unwrap();
        let h = read_header(&p).unwrap();
        assert_eq!((h.width, h.height, h.format.jpeg), (8, 8, true));
        assert_eq!(h.format.to_string(), "8-bit RGB JPEG");
    }

    #[test]
    fn empty_and_oversized_images_are_refused_before_decoding() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("zero.png");
        std::fs::write(&p, b"").unwrap();
        let e = read_gray(&p).unwrap_err();
        assert!(matches!(e, ImageError::Empty { .. }), "{e}");
        assert_eq!(e.reason(), "empty file (0 bytes)");
        assert!(matches!(read_header(&p), Err(ImageError::Empty { .. })));
        assert!(check_size(&p, 16384, 16384).is_ok());
        let e = check_size(&p, 100_000, 100_000).unwrap_err().to_string();
        assert!(e.contains("zero.png") && e.contains("100000x100000"), "{e}");
    }

    #[test]
    fn directory_listing_is_natural_order() {
        let dir = tempfile::tempdir().unwrap();
        for n in [
            "frame10.png",
            "frame2.PNG",
            "frame1.jpg",
            "notes.txt",
            "frame02b.jpeg",
        ] {
            std::fs::write(dir.path().join(n), b"x").unwrap();
        }
        std::fs::create_dir(dir.path().join("sub.png")).unwrap();
        let names: Vec<String> = list_image_files(dir.path())
            .unwrap()
            .iter()
            .map(|p| p.file_name().unwrap().to_string_lossy().into_owned())
            .collect();
        assert_eq!(
            names,
            vec!["frame1.jpg", "frame2.PNG", "frame02b.jpeg", "frame10.png"]
        );
        assert_eq!(natural_cmp("a2", "a10"), Ordering::Less);
        assert_eq!(natural_cmp("a02", "a2"), Ordering::Greater);
        assert_eq!(natural_cmp("a", "a1"), Ordering::Less);
    }

    #[test]
    fn png_sequence_reads_in_frame_order() {
        let dir = tempfile::tempdir().unwrap();
        for k in [10u8, 2, 1] {
            let data: Vec<u8> = (0..12).map(|i| k * 10 + i).collect();
            let p = dir.path().join(format!("frame{k}.png"));
            write_png(
                &p,
                4,
                3,
                png::ColorType::Grayscale,
                png::BitDepth::Eight,
                &data,
            );
        }
        let first: Vec<u8> = list_image_files(dir.path())
            .unwrap()
            .iter()
            .map(|p| read_gray(p).unwrap().data[0])
            .collect();
        assert_eq!(first, vec![10, 20, 100]);
    }
}
