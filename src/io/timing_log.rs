//! Reading frame-timing logs from disk, streamed line by line (memory flat in the log's length),
//! with the format guessed from the name and the first megabyte.

use crate::timing::{
    fit_vfr_passes, stream_frame_times, LogFormat, Streamed, Timestamps, TimingError, TimingFit,
};
use std::io::Read;
use std::path::Path;

#[derive(Debug, thiserror::Error)]
pub enum TimingLogError {
    #[error("{file}: cannot read")]
    Read {
        file: String,
        source: std::io::Error,
    },
    #[error("{file}")]
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
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
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

/// Bytes from the start of a log that the format is guessed from.
const GUESS_PREFIX_BYTES: u64 = 1 << 20;

fn open(path: &Path) -> Result<std::io::BufReader<std::fs::File>, TimingLogError> {
    std::fs::File::open(path)
        .map(std::io::BufReader::new)
        .map_err(|source| TimingLogError::Read {
            file: path.display().to_string(),
            source,
        })
}

/// The given format, or the one guessed from the file's name and its first megabyte.
fn format_of(path: &Path, format: Option<LogFormat>) -> Result<LogFormat, TimingLogError> {
    if let Some(f) = format {
        return Ok(f);
    }
    let mut prefix = Vec::new();
    open(path)?
        .take(GUESS_PREFIX_BYTES)
        .read_to_end(&mut prefix)
        .map_err(|source| TimingLogError::Read {
            file: path.display().to_string(),
            source,
        })?;
    Ok(guess_format(path, &String::from_utf8_lossy(&prefix)))
}

/// Streams the frame times of the log at `path` through `each` (see
/// [`crate::timing::stream_frame_times`]): the file is read line by line, never whole.
pub fn stream_timing_log(
    path: &Path,
    format: LogFormat,
    each: &mut dyn FnMut(f64) -> Result<(), TimingError>,
) -> Result<Streamed, TimingLogError> {
    let reader = open(path)?;
    stream_frame_times(reader, format, each).map_err(|source| TimingLogError::Parse {
        file: path.display().to_string(),
        source,
    })
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
    let format = format_of(path, format)?;
    let mut times = Vec::new();
    let streamed = stream_timing_log(path, format, &mut |t| {
        times.push(t);
        Ok(())
    })?;
    let parse = |source| TimingLogError::Parse {
        file: path.display().to_string(),
        source,
    };
    let first = usize::try_from(streamed.first_frame).map_err(|_| {
        parse(TimingError::Content {
            format: format.name(),
            message: format!("first frame number {} is too large", streamed.first_frame),
        })
    })?;
    Ok((first, Timestamps::new(times).map_err(parse)?))
}

/// Fits the VFR model to the log at `path` in constant memory, whatever its length: the file
/// is streamed three times (see [`fit_vfr_passes`]).
pub fn fit_timing_log(path: &Path, format: Option<LogFormat>) -> Result<TimingFit, TimingLogError> {
    let format = format_of(path, format)?;
    fit_vfr_passes(|each| {
        stream_timing_log(path, format, each)
            .map(|_| ())
            .map_err(FitLogError::Log)
    })
    .map_err(|e: FitLogError| match e {
        FitLogError::Log(e) => e,
        FitLogError::Fit(source) => TimingLogError::Parse {
            file: path.display().to_string(),
            source,
        },
    })
}

/// A fit's own error, or one of reading its log.
enum FitLogError {
    Log(TimingLogError),
    Fit(TimingError),
}

impl From<TimingError> for FitLogError {
    fn from(e: TimingError) -> Self {
        FitLogError::Fit(e)
    }
}

impl From<TimingLogError> for FitLogError {
    fn from(e: TimingLogError) -> Self {
        FitLogError::Log(e)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Regression: a spreadsheet's UTF-8 byte order mark made the header a time
    /// ("time '\u{feff}frame' is not a number"). Every format, read from a file with its format
    /// guessed, gives the same times with and without one.
    #[test]
    fn a_byte_order_mark_is_accepted_in_every_timing_format() {
        let logs = [
            (
                "a.csv",
                "frame,t_s\n0,0.0\n1,0.0333\n2,0.0667\n".to_string(),
            ),
            (
                "b.csv",
                "frame,0.0\nframe,0.0333\nframe,0.0667\n".to_string(),
            ),
            ("c.csv", "0.0\n0.0333\n0.0667\n".to_string()),
            (
                "d.json",
                "{\"frames\": [{\"pts_time\": \"0.0\"}, {\"pts_time\": \"0.0333\"}, \
                 {\"pts_time\": \"0.0667\"}]}\n"
                    .to_string(),
            ),
            (
                "e.log",
                (0..3)
                    .map(|n| {
                        format!(
                            "[Parsed_showinfo_0 @ 0x1] n:{n} pts:{} pts_time:{:.4} duration:1\n",
                            n * 1000,
                            [0.0, 0.0333, 0.0667][n]
                        )
                    })
                    .collect(),
            ),
        ];
        let dir = tempfile::tempdir().unwrap();
        for (name, text) in logs {
            let plain = dir.path().join(name);
            let bom = dir.path().join(format!("bom-{name}"));
            std::fs::write(&plain, &text).unwrap();
            std::fs::write(&bom, format!("\u{feff}{text}")).unwrap();
            let a = read_timing_log(&plain, None).unwrap();
            let b = read_timing_log(&bom, None).unwrap_or_else(|e| panic!("{name}: {e}"));
            assert_eq!(a.as_slice(), b.as_slice(), "{name}");
            assert_eq!(b.len(), 3, "{name}");
        }
    }

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
        let msg = crate::errors::full(&read_timing_log(&bad, None).unwrap_err());
        assert!(msg.contains("bad.csv") && msg.contains("frame 1"), "{msg}");
        assert!(read_timing_log(&dir.path().join("none"), None).is_err());
    }
}
