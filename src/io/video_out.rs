//! Writing rendered frames as an MP4 that keeps the variable frame timestamps.
//!
//! Frames are staged as PNG files in a temporary folder beside the output (memory stays flat),
//! and the video is encoded there and renamed into place when complete;
//! `finish` runs ffmpeg's concat demuxer with each frame's duration, which gives every frame its
//! own presentation time (no resampling to a constant rate), and encodes H.264 with lossless luma
//! (`-qp 0`) in a 90 kHz track timescale (timestamps exact to 11 µs, like phone footage).

use super::png_out::write_gray_png;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::process::Command;

#[derive(Debug, thiserror::Error)]
pub enum VideoOutError {
    #[error("{file}: {message}")]
    Io { file: PathBuf, message: String },
    #[error("{file}: ffmpeg is not installed (Debian package `ffmpeg`: apt-get install ffmpeg)")]
    NoFfmpeg { file: PathBuf },
    #[error("{file}: ffmpeg failed: {stderr}")]
    Ffmpeg { file: PathBuf, stderr: String },
    #[error("{file}: {given} frames given for {expected} timestamps")]
    FrameCount {
        file: PathBuf,
        given: usize,
        expected: usize,
    },
}

pub struct VideoWriter {
    path: PathBuf,
    staging: PathBuf,
    width: usize,
    height: usize,
    times_s: Vec<f64>,
    written: usize,
}

impl VideoWriter {
    pub fn create(
        path: &Path,
        width: usize,
        height: usize,
        times_s: &[f64],
    ) -> Result<Self, VideoOutError> {
        let io = |m: String| VideoOutError::Io {
            file: path.to_path_buf(),
            message: m,
        };
        let staging = path.with_extension("frames.tmp");
        std::fs::create_dir_all(&staging)
            .map_err(|e| io(format!("cannot create {}: {e}", staging.display())))?;
        Ok(Self {
            path: path.to_path_buf(),
            staging,
            width,
            height,
            times_s: times_s.to_vec(),
            written: 0,
        })
    }

    pub fn write_frame(&mut self, gray: &[u8]) -> Result<(), VideoOutError> {
        let p = self.staging.join(format!("{:06}.png", self.written));
        write_gray_png(&p, self.width as u32, self.height as u32, gray).map_err(|e| {
            VideoOutError::Io {
                file: self.path.clone(),
                message: e.to_string(),
            }
        })?;
        self.written += 1;
        Ok(())
    }

    /// Encodes the staged frames and removes the staging folder. Returns the video path.
    pub fn finish(self) -> Result<PathBuf, VideoOutError> {
        let file = self.path.clone();
        if self.written != self.times_s.len() {
            return Err(VideoOutError::FrameCount {
                file,
                given: self.written,
                expected: self.times_s.len(),
            });
        }
        let io = |m: String| VideoOutError::Io {
            file: file.clone(),
            message: m,
        };
        let list_path = self.staging.join("frames.txt");
        let mut list = String::from("ffconcat version 1.0\n");
        let n = self.times_s.len();
        for (i, t) in self.times_s.iter().enumerate() {
            // The last frame's duration repeats the previous interval (the concat demuxer needs one).
            let d = if i + 1 < n {
                self.times_s[i + 1] - t
            } else if n > 1 {
                t - self.times_s[n - 2]
            } else {
                1.0 / 30.0
            };
            // `framerate 90000` gives each still a 1/90000 time base, so durations are not
            // rounded to the image demuxer's default 1/25 s.
            list.push_str(&format!(
                "file '{:06}.png'\noption framerate 90000\nduration {:.9}\n",
                i, d
            ));
        }
        std::fs::File::create(&list_path)
            .and_then(|mut f| f.write_all(list.as_bytes()))
            .map_err(|e| io(format!("cannot write {}: {e}", list_path.display())))?;
        let start = self.times_s.first().copied().unwrap_or(0.0);
        // Encoded inside the staging folder (beside the output, same file system) and renamed
        // into place when complete: a failed encode (disk full, killed) leaves any earlier
        // video at `file` as it was, never a half-written one.
        let encoded = self.staging.join(format!(
            "encoded.{}",
            file.extension().and_then(|e| e.to_str()).unwrap_or("mp4")
        ));
        let output = Command::new("ffmpeg")
            .args(["-y", "-v", "error", "-f", "concat", "-safe", "0", "-i"])
            .arg(&list_path)
            .args([
                "-fps_mode",
                "passthrough",
                "-c:v",
                "libx264",
                "-qp",
                "0",
                "-pix_fmt",
                "yuv420p",
            ])
            .args(["-video_track_timescale", "90000", "-output_ts_offset"])
            .arg(format!("{start:.9}"))
            .arg(&encoded)
            .output();
        let result = match output {
            Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
                Err(VideoOutError::NoFfmpeg { file })
            }
            Err(e) => Err(io(e.to_string())),
            Ok(o) if !o.status.success() => Err(VideoOutError::Ffmpeg {
                file,
                stderr: String::from_utf8_lossy(&o.stderr).trim().to_string(),
            }),
            Ok(_) => std::fs::rename(&encoded, &file)
                .map(|_| file.clone())
                .map_err(|e| io(format!("cannot move the encoded video into place: {e}"))),
        };
        let _ = std::fs::remove_dir_all(&self.staging);
        result
    }
}

/// A writer dropped before `finish` (a frame that could not be written: a full disk, a render
/// error) leaves no staged frames behind.
impl Drop for VideoWriter {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.staging);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// `render --video` on a full disk left `F.frames.tmp/` behind: a writer given up before
    /// `finish` removes its staged frames.
    #[test]
    fn a_writer_given_up_leaves_no_staged_frames() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("v.mp4");
        let mut w = VideoWriter::create(&path, 4, 4, &[0.0, 0.04, 0.08]).unwrap();
        w.write_frame(&[0u8; 16]).unwrap();
        let staging = path.with_extension("frames.tmp");
        assert!(staging.join("000000.png").is_file());
        drop(w);
        assert!(!staging.exists());
        assert!(!path.exists());
    }

    /// Regression: with the disk full, ffmpeg wrote over a good video in place and left an
    /// unplayable one. A failed encode (here: 3×3 px, which H.264 in 4:2:0 refuses; or no ffmpeg)
    /// leaves the earlier file untouched and no staging folder behind.
    #[test]
    fn a_failed_encode_leaves_the_earlier_video_untouched() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("old.mp4");
        std::fs::write(&path, b"an earlier, good video").unwrap();
        let mut w = VideoWriter::create(&path, 3, 3, &[0.0, 0.04]).unwrap();
        w.write_frame(&[0u8; 9]).unwrap();
        w.write_frame(&[255u8; 9]).unwrap();
        let err = w.finish().unwrap_err();
        assert!(
            matches!(
                err,
                VideoOutError::Ffmpeg { .. } | VideoOutError::NoFfmpeg { .. }
            ),
            "{err}"
        );
        assert_eq!(std::fs::read(&path).unwrap(), b"an earlier, good video");
        let left: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name())
            .collect();
        assert_eq!(left, vec![std::ffi::OsString::from("old.mp4")]);
    }
}
