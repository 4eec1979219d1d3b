//! The video codec effect's round trip through ffmpeg: grey frames in, the bitstream held in
//! memory, grey frames back out, each in frame order. The arguments come from
//! [`VideoCodecConfig`]; this module only runs the processes.
//!
//! Why two processes and a held bitstream: the encoder looks ahead (B-frames, rate control), so
//! a frame comes out only after later ones went in. Encoding the whole clip first and decoding it
//! after keeps every pipe drained by its own thread and never waits on a frame not yet written.
//! The bitstream of a phone clip is a few MB.

use crate::render::effects::VideoCodecConfig;
use std::io::{Read, Write};
use std::process::{Child, ChildStdin, ChildStdout, Command, Stdio};
use std::thread::JoinHandle;

#[derive(Debug, thiserror::Error)]
pub enum CodecError {
    #[error(
        "effects.video_codec needs ffmpeg with libx264 and libx265 (Debian package `ffmpeg`: \
         apt-get install ffmpeg)"
    )]
    NoFfmpeg,
    #[error("effects.video_codec: the {stage} failed{}: {stderr}", frame.map(|f| format!(" at frame {f}")).unwrap_or_default())]
    Ffmpeg {
        stage: &'static str,
        frame: Option<usize>,
        stderr: String,
    },
    #[error("effects.video_codec: frame {frame} has {got} pixels, expected {expected}")]
    FrameSize {
        frame: usize,
        got: usize,
        expected: usize,
    },
    #[error("effects.video_codec: {decoded} frames decoded from {encoded} encoded")]
    FrameCount { encoded: usize, decoded: usize },
}

fn spawn(args: &[String], stage: &'static str) -> Result<Child, CodecError> {
    Command::new("ffmpeg")
        .args(args)
        .stdin(Stdio::piped())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .map_err(|e| match e.kind() {
            std::io::ErrorKind::NotFound => CodecError::NoFfmpeg,
            _ => CodecError::Ffmpeg {
                stage,
                frame: None,
                stderr: e.to_string(),
            },
        })
}

fn drain<R: Read + Send + 'static>(mut r: R) -> JoinHandle<Vec<u8>> {
    std::thread::spawn(move || {
        let mut bytes = Vec::new();
        let _ = r.read_to_end(&mut bytes);
        bytes
    })
}

fn text(handle: JoinHandle<Vec<u8>>) -> String {
    let bytes = handle.join().unwrap_or_default();
    String::from_utf8_lossy(&bytes).trim().to_string()
}

/// Frames going into the encoder, in frame order.
pub struct Encoder {
    cfg: VideoCodecConfig,
    frame_len: usize,
    child: Child,
    stdin: Option<ChildStdin>,
    stdout: Option<JoinHandle<Vec<u8>>>,
    stderr: Option<JoinHandle<Vec<u8>>>,
    written: usize,
}

/// A clip's bitstream and what decoding it needs.
pub struct Encoded {
    cfg: VideoCodecConfig,
    frame_len: usize,
    frames: usize,
    bitstream: Vec<u8>,
}

impl Encoder {
    /// Starts encoding `width_px` × `height_px` grey frames at `nominal_fps`.
    pub fn start(
        cfg: &VideoCodecConfig,
        width_px: usize,
        height_px: usize,
        nominal_fps: f64,
    ) -> Result<Self, CodecError> {
        let mut child = spawn(
            &cfg.encoder_args(width_px, height_px, nominal_fps),
            "encoder",
        )?;
        let stdin = child.stdin.take();
        let stdout = child.stdout.take().map(drain);
        let stderr = child.stderr.take().map(drain);
        Ok(Self {
            cfg: cfg.clone(),
            frame_len: width_px * height_px,
            child,
            stdin,
            stdout,
            stderr,
            written: 0,
        })
    }

    /// Hands the next frame (row-major grey, the size given to `start`) to the encoder.
    pub fn write_frame(&mut self, gray: &[u8]) -> Result<(), CodecError> {
        let frame = self.written;
        if gray.len() != self.frame_len {
            return Err(CodecError::FrameSize {
                frame,
                got: gray.len(),
                expected: self.frame_len,
            });
        }
        let ok = self
            .stdin
            .as_mut()
            .is_some_and(|s| s.write_all(gray).is_ok());
        if !ok {
            // The encoder stopped reading: its own message says why.
            self.stdin = None;
            let _ = self.child.wait();
            return Err(CodecError::Ffmpeg {
                stage: "encoder",
                frame: Some(frame),
                stderr: self.stderr.take().map(text).unwrap_or_default(),
            });
        }
        self.written += 1;
        Ok(())
    }

    /// Ends the clip and returns its bitstream.
    pub fn finish(mut self) -> Result<Encoded, CodecError> {
        drop(self.stdin.take());
        let status = self.child.wait();
        let bitstream = self
            .stdout
            .take()
            .map(|h| h.join().unwrap_or_default())
            .unwrap_or_default();
        let stderr = self.stderr.take().map(text).unwrap_or_default();
        if !matches!(status, Ok(s) if s.success()) || (self.written > 0 && bitstream.is_empty()) {
            return Err(CodecError::Ffmpeg {
                stage: "encoder",
                frame: None,
                stderr,
            });
        }
        Ok(Encoded {
            cfg: self.cfg.clone(),
            frame_len: self.frame_len,
            frames: self.written,
            bitstream,
        })
    }
}

impl Drop for Encoder {
    fn drop(&mut self) {
        drop(self.stdin.take());
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

impl Encoded {
    /// The bitstream's size, bytes.
    pub fn bytes(&self) -> usize {
        self.bitstream.len()
    }

    /// Frames encoded.
    pub fn frames(&self) -> usize {
        self.frames
    }

    /// Starts decoding; frames come back in order from [`Decoder::next_frame`].
    pub fn decode(&self) -> Result<Decoder, CodecError> {
        let mut child = spawn(&self.cfg.decoder_args(), "decoder")?;
        let feed = child.stdin.take().map(|mut stdin| {
            let bytes = self.bitstream.clone();
            std::thread::spawn(move || {
                let _ = stdin.write_all(&bytes);
            })
        });
        let stdout = child.stdout.take();
        let stderr = child.stderr.take().map(drain);
        Ok(Decoder {
            frame_len: self.frame_len,
            expected: self.frames,
            decoded: 0,
            child,
            stdout,
            feed,
            stderr,
        })
    }
}

/// Frames coming out of the decoder, in frame order.
pub struct Decoder {
    frame_len: usize,
    expected: usize,
    decoded: usize,
    child: Child,
    stdout: Option<ChildStdout>,
    feed: Option<JoinHandle<()>>,
    stderr: Option<JoinHandle<Vec<u8>>>,
}

impl Decoder {
    /// The next decoded frame, or `None` after the last one the encoder was given. A clip that
    /// decodes to another number of frames is an error, never a shorter run.
    pub fn next_frame(&mut self) -> Result<Option<Vec<u8>>, CodecError> {
        if self.decoded == self.expected {
            return self.finish().map(|_| None);
        }
        let mut frame = vec![0u8; self.frame_len];
        let read = self
            .stdout
            .as_mut()
            .map(|s| s.read_exact(&mut frame).is_ok())
            .unwrap_or(false);
        if !read {
            let decoded = self.decoded;
            let stderr = self.close();
            return Err(if stderr.is_empty() {
                CodecError::FrameCount {
                    encoded: self.expected,
                    decoded,
                }
            } else {
                CodecError::Ffmpeg {
                    stage: "decoder",
                    frame: Some(decoded),
                    stderr,
                }
            });
        }
        self.decoded += 1;
        Ok(Some(frame))
    }

    /// After the expected frames: nothing more may come out, and the decoder must succeed.
    fn finish(&mut self) -> Result<(), CodecError> {
        let mut rest = Vec::new();
        if let Some(s) = self.stdout.as_mut() {
            let _ = s.read_to_end(&mut rest);
        }
        let status = self.child.wait();
        let stderr = self.close();
        if !rest.is_empty() {
            return Err(CodecError::FrameCount {
                encoded: self.expected,
                decoded: self.expected + rest.len().div_ceil(self.frame_len.max(1)),
            });
        }
        match status {
            Ok(s) if s.success() => Ok(()),
            _ => Err(CodecError::Ffmpeg {
                stage: "decoder",
                frame: None,
                stderr,
            }),
        }
    }

    fn close(&mut self) -> String {
        self.stdout = None;
        let _ = self.child.kill();
        let _ = self.child.wait();
        if let Some(f) = self.feed.take() {
            let _ = f.join();
        }
        self.stderr.take().map(text).unwrap_or_default()
    }
}

impl Drop for Decoder {
    fn drop(&mut self) {
        self.close();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::effects::VideoCodec;

    /// A textured, moving test clip: a bright square sliding over a gradient with fine detail.
    fn clip(w: usize, h: usize, n: usize) -> Vec<Vec<u8>> {
        (0..n)
            .map(|k| {
                (0..w * h)
                    .map(|i| {
                        let (x, y) = (i % w, i / w);
                        let inside = (x + 2 * k) % w < w / 3 && y > h / 4 && y < 3 * h / 4;
                        let base = 40 + (x * 120 / w) as u32 + ((x * 7 + y * 13) % 9) as u32;
                        if inside {
                            210
                        } else {
                            base as u8
                        }
                    })
                    .collect()
            })
            .collect()
    }

    fn round_trip(cfg: &VideoCodecConfig, frames: &[Vec<u8>], w: usize, h: usize) -> Vec<Vec<u8>> {
        let mut enc = Encoder::start(cfg, w, h, 30.0).unwrap();
        for f in frames {
            enc.write_frame(f).unwrap();
        }
        let encoded = enc.finish().unwrap();
        let mut dec = encoded.decode().unwrap();
        let mut out = Vec::new();
        while let Some(f) = dec.next_frame().unwrap() {
            out.push(f);
        }
        out
    }

    fn rms_dn(a: &[u8], b: &[u8]) -> f64 {
        let s: f64 = a
            .iter()
            .zip(b)
            .map(|(&x, &y)| (x as f64 - y as f64).powi(2))
            .sum();
        (s / a.len() as f64).sqrt()
    }

    #[test]
    fn every_frame_comes_back_in_order_bit_identical_on_a_second_run() {
        let (w, h, n) = (64, 48, 12);
        let frames = clip(w, h, n);
        for codec in [VideoCodec::H264, VideoCodec::Hevc] {
            let cfg = VideoCodecConfig {
                enabled: true,
                codec,
                gop_frames: 5,
                ..Default::default()
            };
            let a = round_trip(&cfg, &frames, w, h);
            assert_eq!(a.len(), n, "{codec:?}");
            assert_eq!(a, round_trip(&cfg, &frames, w, h), "{codec:?}");
            // Each decoded frame is nearest its own source frame: the order is kept.
            for (k, f) in a.iter().enumerate() {
                let own = rms_dn(f, &frames[k]);
                for (j, g) in frames.iter().enumerate().filter(|(j, _)| *j != k) {
                    assert!(own < rms_dn(f, g), "{codec:?} frame {k} is nearer {j}");
                }
            }
        }
    }

    #[test]
    fn a_lower_bitrate_loses_more_and_a_low_crf_almost_nothing() {
        let (w, h, n) = (64, 48, 10);
        let frames = clip(w, h, n);
        let err = |cfg: VideoCodecConfig| {
            let out = round_trip(&cfg, &frames, w, h);
            out.iter()
                .zip(&frames)
                .map(|(a, b)| rms_dn(a, b))
                .sum::<f64>()
                / n as f64
        };
        let at = |bps: f64| VideoCodecConfig {
            enabled: true,
            bitrate_bps: Some(bps),
            ..Default::default()
        };
        let (low, high) = (err(at(2e4)), err(at(2e6)));
        assert!(
            low > 2.0 * high,
            "20 kbit/s {low} DN against 2 Mbit/s {high} DN"
        );
        // Requantising to the 16–235 luma range and back costs under half a DN RMS.
        let near_lossless = err(VideoCodecConfig {
            enabled: true,
            crf: 0.0,
            ..Default::default()
        });
        assert!(near_lossless < 0.5, "crf 0 lost {near_lossless} DN RMS");
    }

    #[test]
    fn a_frame_of_the_wrong_size_is_refused_naming_it() {
        let cfg = VideoCodecConfig {
            enabled: true,
            ..Default::default()
        };
        let mut enc = Encoder::start(&cfg, 16, 16, 30.0).unwrap();
        enc.write_frame(&[0; 256]).unwrap();
        let e = enc.write_frame(&[0; 255]).unwrap_err();
        assert!(e.to_string().contains("frame 1 has 255 pixels"), "{e}");
    }
}
