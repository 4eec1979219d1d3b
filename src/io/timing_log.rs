//! Reading frame-timing logs from disk, with the format guessed from name and content.

use crate::timing::{load_from_text, LogFormat, Timestamps, TimingError};
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum TimingLogError {
    #[error("{file}: cannot read: {source}")]
    Read {
        file: String,
        source: std::io::Error,
    },
    #[error("{file}: {source}")]
    Parse { file: String, source: TimingError },
}

/// Guesses the format: `.json` → ffprobe JSON; a `frame,t_s` header → our CSV; text containing
/// `pts_time:` → showinfo; otherwise ffprobe CSV.
pub fn guess_format(path: &Path, text: &str) -> LogFormat {
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    if ext == "json" || text.trim_start().starts_with('{') {
        LogFormat::FfprobeJson
    } else if text
        .lines()
        .next()
        .map(|l| l.trim().starts_with("frame,t_s"))
        .unwrap_or(false)
    {
        LogFormat::FramesCsv
    } else if text.contains("pts_time:") {
        LogFormat::Showinfo
    } else {
        LogFormat::FfprobeCsv
    }
}

/// Reads and parses a timing log; `format` None means guess.
pub fn read_timing_log(
    path: &Path,
    format: Option<LogFormat>,
) -> Result<Timestamps, TimingLogError> {
    read_frame_timestamps(path, format).map(|(_, ts)| ts)
}

/// Reads the timestamps of a frame sequence and the number of its first frame: a `frame,t_s`
/// CSV may start at any frame (a part of a recording); every other log starts at frame 0.
pub fn read_frame_timestamps(
    path: &Path,
    format: Option<LogFormat>,
) -> Result<(usize, Timestamps), TimingLogError> {
    let file = path.display().to_string();
    let bytes = std::fs::read(path).map_err(|source| TimingLogError::Read {
        file: file.clone(),
        source,
    })?;
    // Logs written on Windows may contain stray non-UTF-8 bytes in metadata lines; they never
    // matter for frame lines, so decode lossily.
    let text = String::from_utf8_lossy(&bytes);
    let format = format.unwrap_or_else(|| guess_format(path, &text));
    let parsed = match format {
        LogFormat::FramesCsv => {
            crate::timing::parse_frames_csv_numbered(&text).map(|(first, ts)| (first as usize, ts))
        }
        other => load_from_text(other, &text).map(|ts| (0, ts)),
    };
    parsed.map_err(|source| TimingLogError::Parse { file, source })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guesses_formats() {
        assert_eq!(
            guess_format(Path::new("a.json"), "{}"),
            LogFormat::FfprobeJson
        );
        assert_eq!(
            guess_format(Path::new("a.csv"), "frame,t_s\n0,0\n"),
            LogFormat::FramesCsv
        );
        assert_eq!(
            guess_format(Path::new("a.log"), "x n: 0 pts: 0 pts_time:0 y"),
            LogFormat::Showinfo
        );
        assert_eq!(
            guess_format(Path::new("a.txt"), "0.0\n0.033\n"),
            LogFormat::FfprobeCsv
        );
    }

    #[test]
    fn reads_a_real_log_and_names_the_file_on_errors() {
        let p = Path::new(concat!(
            env!("CARGO_MANIFEST_DIR"),
            "/data/phone-frame-timing/model_test1.showinfo.log"
        ));
        assert_eq!(read_timing_log(p, None).unwrap().len(), 58);
        let dir = tempfile::tempdir().unwrap();
        let bad = dir.path().join("bad.csv");
        std::fs::write(&bad, "frame,t_s\n0,0.1\n1,0.05\n").unwrap();
        let msg = read_timing_log(&bad, None).unwrap_err().to_string();
        assert!(msg.contains("bad.csv") && msg.contains("frame 1"), "{msg}");
        assert!(read_timing_log(&dir.path().join("none"), None).is_err());
    }
}
