//! Video frame input through the ffmpeg command-line tools: `ffprobe` for size, display
//! rotation and per-frame timestamps; `ffmpeg` decoding to raw 8-bit grey, streamed one frame at
//! a time so a 4K video never sits in memory.
//!
//! Integrity: the probe compares what the container promises (frame count, duration) with the
//! frames that decode, so a truncated file is reported with its last good frame, and lists every
//! frame whose size or pixel format differs from the stream's (ffmpeg would silently rescale it).

use std::io::Read;
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdout, Command, Stdio};

#[derive(Debug, thiserror::Error)]
pub enum VideoError {
    #[error("`{tool}` not found on PATH; install it (Debian/Ubuntu: apt-get install {package})")]
    ToolMissing {
        tool: &'static str,
        package: &'static str,
    },
    #[error("{path}: cannot run {tool}")]
    Spawn {
        path: PathBuf,
        tool: &'static str,
        source: std::io::Error,
    },
    #[error("{path}: cannot open")]
    Open {
        path: PathBuf,
        source: std::io::Error,
    },
    #[error("{path}: is a directory, not a video")]
    NotAFile { path: PathBuf },
    #[error("{path}: ffprobe failed (corrupt or not a video?): {stderr}")]
    Probe { path: PathBuf, stderr: String },
    #[error("{path}: unexpected ffprobe output: {message}")]
    ProbeOutput { path: PathBuf, message: String },
    #[error(
        "{path}: frame {frame}: timestamp {t_s} s is not after the previous frame's {previous_s} s"
    )]
    TimestampsNotIncreasing {
        path: PathBuf,
        frame: usize,
        t_s: f64,
        previous_s: f64,
    },
    #[error("{path}: frame {frame}: no pts_time or best_effort_timestamp_time")]
    MissingTimestamp { path: PathBuf, frame: usize },
    #[error("{path}: stream truncated: read {frames_read} of {frames_expected} frames{detail}")]
    Truncated {
        path: PathBuf,
        frames_read: usize,
        frames_expected: usize,
        detail: String,
    },
    #[error("{path}: ffmpeg decoded more frames than ffprobe listed ({frames_expected})")]
    ExtraFrames {
        path: PathBuf,
        frames_expected: usize,
    },
    #[error("{path}: frame {frame}: read error")]
    Read {
        path: PathBuf,
        frame: usize,
        source: std::io::Error,
    },
}

/// What ffprobe says about the first video stream.
#[derive(Debug, Clone, PartialEq)]
pub struct VideoInfo {
    /// Size of decoded frames as ffmpeg delivers them (display rotation applied), px.
    pub width_px: usize,
    pub height_px: usize,
    /// Size as stored in the stream, before rotation, px.
    pub coded_width_px: usize,
    pub coded_height_px: usize,
    /// Display rotation from the stream's display matrix (or legacy `rotate` tag), degrees,
    /// normalised to 0, 90, 180 or 270.
    pub rotation_deg: i32,
    /// Per-frame presentation time, s (pts_time, falling back to best_effort_timestamp_time).
    pub timestamps_s: Vec<f64>,
    /// The stream's pixel format (`yuv420p`, ...), when ffprobe names it.
    pub pix_fmt: Option<String>,
    /// Frame count the container's index promises (`nb_frames`), when it states one.
    pub container_frames: Option<usize>,
    /// Duration the container states for the video stream (else for the file), s.
    pub container_duration_s: Option<f64>,
    /// Frames whose coded size or pixel format differs from the stream's, with the difference.
    pub odd_frames: Vec<(usize, String)>,
    /// What ffprobe printed on stderr while succeeding (e.g. "partial file").
    pub probe_warnings: String,
    /// How the stream was coded, as far as the container tells.
    pub coding: StreamCoding,
}

/// The coding of the video stream as ffprobe reports it.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct StreamCoding {
    /// `codec_name` (`h264`, `hevc`, `mjpeg`, …).
    pub codec_name: Option<String>,
    /// The video stream's `bit_rate`, bit/s.
    pub stream_bit_rate_bps: Option<f64>,
    /// The file's `bit_rate` (all its streams), bit/s.
    pub file_bit_rate_bps: Option<f64>,
    /// Each decoded frame's picture type in order: `I`, `P`, `B`, or `?` when not stated.
    pub picture_types: String,
}

/// A video whose container promises more than decodes.
#[derive(Debug, Clone, PartialEq)]
pub struct Truncation {
    /// Frames that decode.
    pub decoded: usize,
    /// Frames the container lists (`nb_frames`), when it states a count.
    pub container_frames: Option<usize>,
    /// The container's duration and where the decodable frames end, s.
    pub container_duration_s: Option<f64>,
    /// The last frame that decodes and its time, if any does.
    pub last_good: Option<(usize, f64)>,
}

impl std::fmt::Display for Truncation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match (self.container_frames, self.container_duration_s) {
            (Some(n), _) if n > self.decoded => write!(
                f,
                "the container lists {n} frames but only {} decode",
                self.decoded
            )?,
            (_, Some(d)) => write!(
                f,
                "the container lasts {d:.3} s but the {} decodable frames end earlier",
                self.decoded
            )?,
            _ => write!(f, "{} frames decode", self.decoded)?,
        }
        match self.last_good {
            Some((k, t)) => write!(f, "; last good frame {k} at t = {t:.3} s"),
            None => write!(f, "; no frame decodes"),
        }
    }
}

impl VideoInfo {
    pub fn frame_count(&self) -> usize {
        self.timestamps_s.len()
    }

    /// Truncation: fewer decodable frames than the container lists, or (without a count) the
    /// frames end more than three median intervals (at least 0.25 s) before its duration.
    pub fn truncation(&self) -> Option<Truncation> {
        let decoded = self.frame_count();
        let last_good = self.timestamps_s.last().map(|&t| (decoded - 1, t));
        let short_by_count = self.container_frames.is_some_and(|n| n > decoded);
        let short_by_time = self.container_frames.is_none()
            && match (self.container_duration_s, self.timestamps_s.first()) {
                (Some(d), Some(&t0)) => {
                    let mut intervals: Vec<f64> =
                        self.timestamps_s.windows(2).map(|w| w[1] - w[0]).collect();
                    intervals.sort_by(f64::total_cmp);
                    let typical = intervals.get(intervals.len() / 2).copied().unwrap_or(0.0);
                    let end = last_good.map_or(t0, |(_, t)| t);
                    t0 + d - end > (3.0 * typical).max(0.25)
                }
                (Some(d), None) => d > 0.0,
                _ => false,
            };
        (short_by_count || short_by_time).then_some(Truncation {
            decoded,
            container_frames: self.container_frames,
            container_duration_s: self.container_duration_s,
            last_good,
        })
    }
}

fn spawn_error(path: &Path, tool: &'static str, e: std::io::Error) -> VideoError {
    if e.kind() == std::io::ErrorKind::NotFound {
        VideoError::ToolMissing {
            tool,
            package: "ffmpeg",
        }
    } else {
        VideoError::Spawn {
            path: path.into(),
            tool,
            source: e,
        }
    }
}

/// Largest frame side accepted from a container, px (16K video is 15,360).
pub const MAX_SIDE_PX: usize = 1 << 15;
/// Largest frame accepted from a container, px (16K × 8K).
pub const MAX_FRAME_PIXELS: usize = 1 << 27;

/// Runs ffprobe on `path` (decodes every frame to list timestamps). A command reads one video
/// several times (alignment, statistics, the re-render check), and the probe decodes it whole
/// each time, as long as ffmpeg's own decode: so the answer is kept for the process, keyed by
/// the file's identity (path, length, modification time), and a file changed since is probed
/// again. Failures are not kept.
pub fn probe(path: &Path) -> Result<VideoInfo, VideoError> {
    use std::collections::HashMap;
    use std::sync::{Mutex, OnceLock};
    type Key = (PathBuf, u64, Option<std::time::SystemTime>);
    static PROBED: OnceLock<Mutex<HashMap<Key, VideoInfo>>> = OnceLock::new();
    let key = std::fs::metadata(path)
        .ok()
        .filter(|m| m.is_file())
        .map(|m| {
            let name = std::fs::canonicalize(path).unwrap_or_else(|_| path.to_path_buf());
            (name, m.len(), m.modified().ok())
        });
    let cache = PROBED.get_or_init(Mutex::default);
    if let Some(info) = key.as_ref().and_then(|k| {
        cache
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .get(k)
            .cloned()
    }) {
        return Ok(info);
    }
    let info = probe_with(path, "ffprobe")?;
    if let Some(k) = key {
        cache
            .lock()
            .unwrap_or_else(|poisoned| poisoned.into_inner())
            .insert(k, info.clone());
    }
    Ok(info)
}

/// [`probe`] with an explicit ffprobe executable (tests use a missing one).
pub fn probe_with(path: &Path, ffprobe: &str) -> Result<VideoInfo, VideoError> {
    let meta = std::fs::metadata(path).map_err(|source| VideoError::Open {
        path: path.into(),
        source,
    })?;
    if meta.is_dir() {
        return Err(VideoError::NotAFile { path: path.into() });
    }
    // One decoding thread, as ffprobe's default: with frame threads (`-threads 0`, twice as
    // fast) a stream cut short lists one frame fewer than ffmpeg then decodes from it, and the
    // two must agree (`tests/analyze_integrity.rs`, the truncated video).
    let out = Command::new(ffprobe)
        .args(["-v", "error", "-select_streams", "v:0", "-show_entries"])
        .arg(
            "stream=width,height,pix_fmt,nb_frames,duration,codec_name,bit_rate:stream_tags=rotate\
             :stream_side_data=rotation:format=duration,bit_rate:frame=pts_time,\
             best_effort_timestamp_time,width,height,pix_fmt,pict_type",
        )
        .args(["-of", "json"])
        .arg(path)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| spawn_error(path, "ffprobe", e))?;
    if !out.status.success() {
        // ffprobe starts its message with the file name, which ours states already.
        let stderr = String::from_utf8_lossy(&out.stderr);
        let stderr = stderr.trim();
        let named = format!("{}: ", path.display());
        return Err(VideoError::Probe {
            path: path.into(),
            stderr: stderr.strip_prefix(&named).unwrap_or(stderr).into(),
        });
    }
    let mut info = parse_probe_json(path, &String::from_utf8_lossy(&out.stdout))?;
    info.probe_warnings = String::from_utf8_lossy(&out.stderr).trim().to_string();
    Ok(info)
}

/// Parses ffprobe's JSON (split out so it is testable without ffprobe).
pub fn parse_probe_json(path: &Path, json: &str) -> Result<VideoInfo, VideoError> {
    let bad = |message: String| VideoError::ProbeOutput {
        path: path.into(),
        message,
    };
    let v: serde_json::Value =
        serde_json::from_str(json).map_err(|e| bad(crate::errors::full(&e)))?;
    let stream = v["streams"]
        .get(0)
        .ok_or_else(|| bad("no video stream".into()))?;
    let dim = |k: &str| {
        stream[k]
            .as_u64()
            .filter(|&d| d > 0)
            .ok_or_else(|| bad(format!("no stream {k}")))
    };
    let (coded_w, coded_h) = (dim("width")? as usize, dim("height")? as usize);
    // Refused before any frame buffer is sized from them (a damaged header of 10¹² px).
    if coded_w > MAX_SIDE_PX || coded_h > MAX_SIDE_PX || coded_w * coded_h > MAX_FRAME_PIXELS {
        return Err(bad(format!(
            "stream size {coded_w}x{coded_h} px is beyond any camera (at most {MAX_SIDE_PX} px a \
             side and {MAX_FRAME_PIXELS} px a frame)"
        )));
    }
    let side_rotation = stream["side_data_list"]
        .as_array()
        .and_then(|l| l.iter().find_map(|s| s["rotation"].as_f64()));
    let tag_rotation = stream["tags"]["rotate"]
        .as_str()
        .and_then(|s| s.trim().parse::<f64>().ok());
    let rotation = side_rotation.or(tag_rotation).unwrap_or(0.0);
    let rotation_deg = ((rotation.round() as i64).rem_euclid(360)) as i32;
    if rotation_deg % 90 != 0 {
        return Err(bad(format!(
            "display rotation {rotation} deg is not a multiple of 90"
        )));
    }
    let (width_px, height_px) = if rotation_deg % 180 == 90 {
        (coded_h, coded_w)
    } else {
        (coded_w, coded_h)
    };
    let pix_fmt = stream["pix_fmt"].as_str().map(str::to_string);
    let number = |x: &serde_json::Value| -> Option<f64> {
        x.as_str()
            .and_then(|s| s.trim().parse::<f64>().ok())
            .or_else(|| x.as_f64())
            .filter(|v| v.is_finite() && *v >= 0.0)
    };
    let container_frames = number(&stream["nb_frames"])
        .filter(|&n| n >= 1.0 && n.fract() == 0.0 && n < 1e12)
        .map(|n| n as usize);
    let container_duration_s = number(&stream["duration"])
        .or_else(|| number(&v["format"]["duration"]))
        .filter(|&d| d > 0.0);
    let empty = Vec::new();
    let frames = v["frames"].as_array().unwrap_or(&empty);
    let mut timestamps_s = Vec::with_capacity(frames.len());
    let mut odd_frames = Vec::new();
    let coding = StreamCoding {
        codec_name: stream["codec_name"].as_str().map(str::to_string),
        stream_bit_rate_bps: number(&stream["bit_rate"]).filter(|&b| b > 0.0),
        file_bit_rate_bps: number(&v["format"]["bit_rate"]).filter(|&b| b > 0.0),
        picture_types: frames
            .iter()
            .map(|f| match f["pict_type"].as_str() {
                Some("I") => 'I',
                Some("P") => 'P',
                Some("B") => 'B',
                _ => '?',
            })
            .collect(),
    };
    for (i, f) in frames.iter().enumerate() {
        if let Some(reason) = odd_frame(f, (coded_w, coded_h), pix_fmt.as_deref()) {
            odd_frames.push((i, reason));
        }
        push_timestamp(&mut timestamps_s, f, path, i)?;
    }
    Ok(VideoInfo {
        width_px,
        height_px,
        coded_width_px: coded_w,
        coded_height_px: coded_h,
        rotation_deg,
        timestamps_s,
        pix_fmt,
        container_frames,
        container_duration_s,
        odd_frames,
        probe_warnings: String::new(),
        coding,
    })
}

/// Why a probed frame differs from its stream (size or pixel format), if it does.
fn odd_frame(
    f: &serde_json::Value,
    (coded_w, coded_h): (usize, usize),
    stream_fmt: Option<&str>,
) -> Option<String> {
    if let (Some(w), Some(h)) = (f["width"].as_u64(), f["height"].as_u64()) {
        if (w, h) != (coded_w as u64, coded_h as u64) {
            return Some(format!(
                "decodes as {w}x{h} px, the stream is {coded_w}x{coded_h} px"
            ));
        }
    }
    match (f["pix_fmt"].as_str(), stream_fmt) {
        (Some(fmt), Some(stream)) if fmt != stream => {
            Some(format!("pixel format {fmt}, the stream's is {stream}"))
        }
        _ => None,
    }
}

/// Appends frame `i`'s timestamp, which must be finite and after the previous one.
fn push_timestamp(
    timestamps_s: &mut Vec<f64>,
    f: &serde_json::Value,
    path: &Path,
    i: usize,
) -> Result<(), VideoError> {
    let t = ["pts_time", "best_effort_timestamp_time"]
        .iter()
        .find_map(|k| f[*k].as_str().and_then(|s| s.parse::<f64>().ok()))
        .filter(|t| t.is_finite())
        .ok_or(VideoError::MissingTimestamp {
            path: path.into(),
            frame: i,
        })?;
    if let Some(&prev) = timestamps_s.last() {
        if t <= prev {
            return Err(VideoError::TimestampsNotIncreasing {
                path: path.into(),
                frame: i,
                t_s: t,
                previous_s: prev,
            });
        }
    }
    timestamps_s.push(t);
    Ok(())
}

/// One decoded frame: index from 0, timestamp from ffprobe, 8-bit grey pixels (row-major).
#[derive(Debug, Clone, PartialEq)]
pub struct VideoFrame {
    pub index: usize,
    pub t_s: f64,
    pub data: Vec<u8>,
}

/// Streams decoded grey frames from `ffmpeg -i FILE -f rawvideo -pix_fmt gray -`.
pub struct VideoFrames {
    path: PathBuf,
    info: VideoInfo,
    child: Child,
    stdout: ChildStdout,
    next_index: usize,
    done: bool,
}

impl VideoFrames {
    /// Probes `path` and starts ffmpeg. Frames come out display-rotated (ffmpeg's default), so
    /// their size is `info().width_px × height_px`.
    pub fn open(path: &Path) -> Result<Self, VideoError> {
        let info = probe(path)?;
        Self::start(path, info)
    }

    /// Starts ffmpeg on `path`, expecting the frames `info` lists.
    fn start(path: &Path, info: VideoInfo) -> Result<Self, VideoError> {
        let mut child = Command::new("ffmpeg")
            .args(["-v", "error", "-nostdin", "-i"])
            .arg(path)
            // passthrough: one output frame per decoded frame, no duplication or dropping to a
            // constant rate, so frame i matches ffprobe's timestamp i.
            .args([
                "-map",
                "0:v:0",
                "-fps_mode",
                "passthrough",
                "-f",
                "rawvideo",
                "-pix_fmt",
                "gray",
                "-",
            ])
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped())
            .spawn()
            .map_err(|e| spawn_error(path, "ffmpeg", e))?;
        let Some(stdout) = child.stdout.take() else {
            let _ = child.kill();
            return Err(spawn_error(
                path,
                "ffmpeg",
                std::io::Error::other("no pipe to ffmpeg's standard output"),
            ));
        };
        Ok(Self {
            path: path.into(),
            info,
            child,
            stdout,
            next_index: 0,
            done: false,
        })
    }

    pub fn info(&self) -> &VideoInfo {
        &self.info
    }

    fn stderr_text(&mut self) -> String {
        let mut s = String::new();
        if let Some(mut e) = self.child.stderr.take() {
            let _ = e.read_to_string(&mut s);
        }
        s.trim().to_string()
    }

    /// The next frame, `Ok(None)` after the last one. Errors on a short or failed decode.
    pub fn next_frame(&mut self) -> Result<Option<VideoFrame>, VideoError> {
        if self.done {
            return Ok(None);
        }
        let size = self.info.width_px * self.info.height_px;
        let mut data = vec![0u8; size];
        let mut filled = 0;
        while filled < size {
            match self.stdout.read(&mut data[filled..]) {
                Ok(0) => break,
                Ok(n) => filled += n,
                Err(e) if e.kind() == std::io::ErrorKind::Interrupted => {}
                Err(source) => {
                    return Err(VideoError::Read {
                        path: self.path.clone(),
                        frame: self.next_index,
                        source,
                    })
                }
            }
        }
        let expected = self.info.frame_count();
        if filled == 0 {
            self.done = true;
            let status = self.child.wait().ok();
            let stderr = self.stderr_text();
            if self.next_index < expected || status.is_some_and(|s| !s.success()) {
                return Err(VideoError::Truncated {
                    path: self.path.clone(),
                    frames_read: self.next_index,
                    frames_expected: expected,
                    detail: if stderr.is_empty() {
                        String::new()
                    } else {
                        format!(" (ffmpeg: {stderr})")
                    },
                });
            }
            return Ok(None);
        }
        if filled < size {
            self.done = true;
            let _ = self.child.wait();
            return Err(VideoError::Truncated {
                path: self.path.clone(),
                frames_read: self.next_index,
                frames_expected: expected,
                detail: format!(
                    "; frame {} ends after {filled} of {size} bytes",
                    self.next_index
                ),
            });
        }
        if self.next_index >= expected {
            self.done = true;
            let _ = self.child.kill();
            let _ = self.child.wait();
            return Err(VideoError::ExtraFrames {
                path: self.path.clone(),
                frames_expected: expected,
            });
        }
        let frame = VideoFrame {
            index: self.next_index,
            t_s: self.info.timestamps_s[self.next_index],
            data,
        };
        self.next_index += 1;
        Ok(Some(frame))
    }
}

impl Drop for VideoFrames {
    fn drop(&mut self) {
        if !self.done {
            let _ = self.child.kill();
        }
        let _ = self.child.wait();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ffmpeg(args: &[&str]) {
        let ok = Command::new("ffmpeg")
            .args(["-v", "error", "-y"])
            .args(args)
            .status()
            .unwrap()
            .success();
        assert!(ok, "ffmpeg {args:?}");
    }

    #[test]
    fn tiny_video_streams_all_frames_with_timestamps() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.mkv");
        let ps = p.to_str().unwrap();
        ffmpeg(&[
            "-f",
            "lavfi",
            "-i",
            "testsrc=size=64x48:rate=10",
            "-frames:v",
            "5",
            "-c:v",
            "ffv1",
            ps,
        ]);
        let mut v = VideoFrames::open(&p).unwrap();
        assert_eq!(
            (v.info().width_px, v.info().height_px, v.info().rotation_deg),
            (64, 48, 0)
        );
        let mut n = 0;
        while let Some(f) = v.next_frame().unwrap() {
            assert_eq!(f.index, n);
            assert!((f.t_s - n as f64 * 0.1).abs() < 1e-3, "{}", f.t_s);
            assert_eq!(f.data.len(), 64 * 48);
            n += 1;
        }
        assert_eq!(n, 5);
        assert!(v.next_frame().unwrap().is_none());
    }

    /// The probe is kept for the process, but a file replaced since (another length or time)
    /// is probed again: never the old file's frames for the new one.
    #[test]
    fn a_video_replaced_after_its_probe_is_probed_again() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.mkv");
        let ps = p.to_str().unwrap();
        let make = |frames: &str, size: &str| {
            ffmpeg(&[
                "-f",
                "lavfi",
                "-i",
                &format!("testsrc=size={size}:rate=10"),
                "-frames:v",
                frames,
                "-c:v",
                "ffv1",
                ps,
            ])
        };
        make("4", "64x48");
        let first = probe(&p).unwrap();
        assert_eq!(probe(&p).unwrap(), first);
        assert_eq!((first.width_px, first.timestamps_s.len()), (64, 4));
        make("7", "80x60");
        let second = probe(&p).unwrap();
        assert_eq!((second.width_px, second.timestamps_s.len()), (80, 7));
    }

    #[test]
    fn rotated_video_reports_display_size() {
        let dir = tempfile::tempdir().unwrap();
        let plain = dir.path().join("plain.mp4");
        let ps = plain.to_str().unwrap();
        ffmpeg(&[
            "-f",
            "lavfi",
            "-i",
            "testsrc=size=64x48:rate=10",
            "-frames:v",
            "3",
            "-c:v",
            "mpeg4",
            ps,
        ]);
        // ffmpeg 5.1 turns the legacy rotate tag into a display matrix only when stream-copying.
        let p = dir.path().join("r.mp4");
        ffmpeg(&[
            "-i",
            ps,
            "-c",
            "copy",
            "-metadata:s:v:0",
            "rotate=90",
            p.to_str().unwrap(),
        ]);
        let mut v = VideoFrames::open(&p).unwrap();
        assert_eq!(v.info().rotation_deg % 180, 90);
        assert_eq!((v.info().width_px, v.info().height_px), (48, 64));
        assert_eq!(
            (v.info().coded_width_px, v.info().coded_height_px),
            (64, 48)
        );
        let mut upright = VideoFrames::open(&plain).unwrap();
        let mut n = 0;
        while let Some(f) = v.next_frame().unwrap() {
            let u = upright.next_frame().unwrap().unwrap();
            // Same bitstream, so the rotated frame is an exact quarter turn of the upright one.
            let cw: Vec<u8> = (0..64)
                .flat_map(|r| (0..48).map(move |c| (r, c)))
                .map(|(r, c)| u.data[(47 - c) * 64 + r])
                .collect();
            let ccw: Vec<u8> = (0..64)
                .flat_map(|r| (0..48).map(move |c| (r, c)))
                .map(|(r, c)| u.data[c * 64 + (63 - r)])
                .collect();
            assert!(
                f.data == cw || f.data == ccw,
                "frame {n} is not a rotation of the upright frame"
            );
            n += 1;
        }
        assert_eq!(n, 3);
    }

    #[test]
    fn corrupt_file_is_an_error_naming_it() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("junk.mp4");
        let mut rng = crate::rng::stream(1, crate::rng::Stream::PixelNoise, 0);
        let bytes: Vec<u8> = (0..4096).map(|_| rand::Rng::gen(&mut rng)).collect();
        std::fs::write(&p, bytes).unwrap();
        let e = VideoFrames::open(&p).err().expect("corrupt file must fail");
        assert!(e.to_string().contains("junk.mp4"), "{e}");
    }

    #[test]
    fn missing_tool_names_the_package() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("x.mp4");
        std::fs::write(&p, b"x").unwrap();
        let e = probe_with(&p, "ffprobe-definitely-missing").unwrap_err();
        assert!(matches!(e, VideoError::ToolMissing { .. }));
        assert!(e.to_string().contains("apt-get install ffmpeg"));
    }

    #[test]
    fn missing_files_and_directories_are_errors_before_ffprobe_runs() {
        let dir = tempfile::tempdir().unwrap();
        let e = probe(&dir.path().join("none.mp4")).unwrap_err();
        assert!(matches!(e, VideoError::Open { .. }), "{e}");
        let e = probe(dir.path()).unwrap_err();
        assert!(matches!(e, VideoError::NotAFile { .. }), "{e}");
    }

    #[test]
    fn frames_of_another_size_or_format_and_short_containers_are_listed() {
        let json = r#"{"streams":[{"width":8,"height":4,"pix_fmt":"yuv420p","nb_frames":"5"}],
            "frames":[{"pts_time":"0.0","width":8,"height":4,"pix_fmt":"yuv420p"},
                      {"pts_time":"0.1","width":4,"height":2,"pix_fmt":"yuv420p"},
                      {"pts_time":"0.2","width":8,"height":4,"pix_fmt":"gray"}]}"#;
        let info = parse_probe_json(Path::new("v.mp4"), json).unwrap();
        assert_eq!(info.odd_frames.len(), 2);
        assert_eq!(info.odd_frames[0].0, 1);
        assert!(
            info.odd_frames[0].1.contains("4x2"),
            "{:?}",
            info.odd_frames
        );
        assert_eq!(info.odd_frames[1].0, 2);
        assert!(
            info.odd_frames[1].1.contains("gray"),
            "{:?}",
            info.odd_frames
        );
        let t = info.truncation().expect("5 listed, 3 decode");
        assert_eq!((t.decoded, t.last_good), (3, Some((2, 0.2))));
        // Without a count, the stated duration decides: 2 s promised, frames end at 0.2 s.
        let json = r#"{"streams":[{"width":8,"height":4}],"format":{"duration":"2.0"},
            "frames":[{"pts_time":"0.0"},{"pts_time":"0.1"},{"pts_time":"0.2"}]}"#;
        let info = parse_probe_json(Path::new("v.mkv"), json).unwrap();
        assert!(info.truncation().is_some());
        // A duration one frame past the last timestamp is a complete file.
        let json = r#"{"streams":[{"width":8,"height":4}],"format":{"duration":"0.3"},
            "frames":[{"pts_time":"0.0"},{"pts_time":"0.1"},{"pts_time":"0.2"}]}"#;
        let info = parse_probe_json(Path::new("v.mkv"), json).unwrap();
        assert!(info.truncation().is_none());
    }

    #[test]
    fn backwards_and_missing_timestamps_are_errors() {
        let json = r#"{"streams":[{"width":4,"height":2}],"frames":[{"pts_time":"0.0"},{"pts_time":"0.1"},{"pts_time":"0.05"}]}"#;
        let e = parse_probe_json(Path::new("v.mp4"), json).unwrap_err();
        assert!(
            matches!(e, VideoError::TimestampsNotIncreasing { frame: 2, .. }),
            "{e}"
        );
        let json = r#"{"streams":[{"width":4,"height":2,"side_data_list":[{"rotation":-90}]}],"frames":[{"pts_time":"N/A","best_effort_timestamp_time":"0.5"},{}]}"#;
        let e = parse_probe_json(Path::new("v.mp4"), json).unwrap_err();
        assert!(
            matches!(e, VideoError::MissingTimestamp { frame: 1, .. }),
            "{e}"
        );
        let json = r#"{"streams":[{"width":4,"height":2,"side_data_list":[{"rotation":-90}]}],"frames":[{"pts_time":"N/A","best_effort_timestamp_time":"0.5"}]}"#;
        let info = parse_probe_json(Path::new("v.mp4"), json).unwrap();
        assert_eq!(
            (
                info.width_px,
                info.height_px,
                info.rotation_deg,
                info.timestamps_s.clone()
            ),
            (2, 4, 270, vec![0.5])
        );
    }

    #[test]
    fn fewer_frames_than_listed_is_truncation_with_count() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("t.mkv");
        ffmpeg(&[
            "-f",
            "lavfi",
            "-i",
            "testsrc=size=64x48:rate=10",
            "-frames:v",
            "5",
            "-c:v",
            "ffv1",
            p.to_str().unwrap(),
        ]);
        let mut info = probe(&p).unwrap();
        info.timestamps_s.extend([0.5, 0.6]);
        let mut v = VideoFrames::start(&p, info).unwrap();
        for _ in 0..5 {
            assert!(v.next_frame().unwrap().is_some());
        }
        let e = v.next_frame().unwrap_err();
        assert!(
            matches!(
                e,
                VideoError::Truncated {
                    frames_read: 5,
                    frames_expected: 7,
                    ..
                }
            ),
            "{e}"
        );
        assert!(e.to_string().contains("read 5 of 7 frames"));
    }

    #[test]
    fn truncated_file_never_yields_unlisted_frames() {
        let dir = tempfile::tempdir().unwrap();
        let good = dir.path().join("g.mkv");
        ffmpeg(&[
            "-f",
            "lavfi",
            "-i",
            "testsrc=size=64x48:rate=10",
            "-frames:v",
            "20",
            "-c:v",
            "ffv1",
            good.to_str().unwrap(),
        ]);
        let bytes = std::fs::read(&good).unwrap();
        let cut = dir.path().join("cut.mkv");
        std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
        // ffprobe lists only the frames it can decode, so truncation shows as fewer frames or an
        // error; either way no panic and never more frames than listed.
        match VideoFrames::open(&cut) {
            Err(e) => assert!(e.to_string().contains("cut.mkv")),
            Ok(mut v) => {
                let listed = v.info().frame_count();
                assert!(listed < 20);
                // The container's duration (2 s) outlasts the decodable frames.
                let t = v.info().truncation().expect("truncation reported");
                assert_eq!(t.decoded, listed);
                let mut n = 0;
                loop {
                    match v.next_frame() {
                        Ok(Some(_)) => n += 1,
                        Ok(None) => break,
                        Err(e) => {
                            assert!(e.to_string().contains("cut.mkv"));
                            break;
                        }
                    }
                }
                assert!(n <= listed);
            }
        }
    }
}
