//! Pure parsers turning timing logs (ffmpeg showinfo, ffprobe CSV/JSON, our `frame,t_s` CSV)
//! into validated [`Timestamps`]. No file I/O: callers pass the text.

use serde::{Deserialize, Serialize};

use super::error::TimingError;
use super::timestamps::Timestamps;

/// Which tool wrote a timing log.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum LogFormat {
    /// `ffmpeg -vf showinfo` stderr (the `n:` and `pts_time:` fields of each frame line).
    Showinfo,
    /// The same log, but times from the exact integer `pts:` × the `time_base` of the filter's
    /// `config in time_base:` line (`pts_time` is printed to 6 significant digits only).
    ShowinfoPts,
    /// `ffprobe -show_entries frame=pts_time -of csv=p=0` (or `frame,<t>` lines with `p=1`).
    FfprobeCsv,
    /// `ffprobe -show_entries frame=pts_time -of json`.
    FfprobeJson,
    /// Our own CSV: header `frame,t_s`, then one `index,seconds` row per frame, index from 0.
    FramesCsv,
}

impl LogFormat {
    pub fn name(self) -> &'static str {
        match self {
            LogFormat::Showinfo => "showinfo",
            LogFormat::ShowinfoPts => "showinfo_pts",
            LogFormat::FfprobeCsv => "ffprobe_csv",
            LogFormat::FfprobeJson => "ffprobe_json",
            LogFormat::FramesCsv => "frames_csv",
        }
    }
}

/// Parses `text` written in `format` into frame times (seconds, as the log gives them).
pub fn load_from_text(format: LogFormat, text: &str) -> Result<Timestamps, TimingError> {
    match format {
        LogFormat::Showinfo => parse_showinfo(text),
        LogFormat::ShowinfoPts => parse_showinfo_pts(text),
        LogFormat::FfprobeCsv => parse_ffprobe_csv(text),
        LogFormat::FfprobeJson => parse_ffprobe_json(text),
        LogFormat::FramesCsv => parse_frames_csv(text),
    }
}

const SHOWINFO: &str = "showinfo";

/// Records of a log split at `\n`, `\r\n` and bare `\r` (ffmpeg's progress lines end in `\r`),
/// each paired with its 1-based line number counted in `\n`s as an editor would show it.
fn records(text: &str) -> impl Iterator<Item = (usize, &str)> {
    let mut line = 1usize;
    text.split('\n').flat_map(move |physical| {
        let this_line = line;
        line += 1;
        physical.split('\r').map(move |r| (this_line, r))
    })
}

/// The text after `key` (which must start a whitespace-separated token) with leading blanks
/// removed, so `n:   5` and `n:5` both yield `5 ...`.
fn after_key<'a>(s: &'a str, key: &str) -> Option<&'a str> {
    let mut from = 0;
    while let Some(pos) = s[from..].find(key) {
        let at = from + pos;
        let token_start = at == 0 || s[..at].ends_with(|c: char| c.is_whitespace() || c == ']');
        if token_start {
            return Some(s[at + key.len()..].trim_start());
        }
        from = at + key.len();
    }
    None
}

fn first_token(s: &str) -> &str {
    s.split_whitespace().next().unwrap_or("")
}

/// ffmpeg showinfo: frame lines look like
/// `[Parsed_showinfo_0 @ 0x..] n:  12 pts: 36162 pts_time:0.4018 ...`, possibly preceded on the
/// same line by a `frame= ... speed=..` progress record; `pts_time:1` may have no decimal point.
pub fn parse_showinfo(text: &str) -> Result<Timestamps, TimingError> {
    showinfo(text, SHOWINFO, false)
}

/// Like [`parse_showinfo`] but computes each time as `pts × time_base` from the filter's
/// `config in time_base: a/b` line. ffmpeg prints `pts_time` with 6 significant digits, which
/// rounds by up to 50 µs beyond 10 s; the integer `pts` is exact.
pub fn parse_showinfo_pts(text: &str) -> Result<Timestamps, TimingError> {
    showinfo(text, SHOWINFO_PTS, true)
}

const SHOWINFO_PTS: &str = "showinfo_pts";

fn showinfo(text: &str, format: &'static str, exact_pts: bool) -> Result<Timestamps, TimingError> {
    let mut frames: Vec<(u64, f64, usize)> = Vec::new();
    let mut time_base_s: Option<f64> = None;
    for (line, record) in records(text) {
        let mut rest = record;
        while let Some(pos) = rest.find("[Parsed_showinfo") {
            let segment = &rest[pos..];
            let Some(close) = segment.find(']') else {
                break;
            };
            let body = segment[close + 1..].trim_start();
            rest = &segment[close + 1..];
            let parse_err = |message: String| TimingError::Parse {
                format,
                line,
                message,
            };
            if let Some(tb) = body.strip_prefix("config in time_base:") {
                let tb = first_token(tb).trim_end_matches(',');
                time_base_s = parse_ratio(tb);
                if time_base_s.is_none() && exact_pts {
                    return Err(parse_err(format!(
                        "time_base `{tb}` is not a ratio a/b > 0"
                    )));
                }
            }
            if !body.starts_with("n:") {
                continue; // config / colour / side-data lines of the filter
            }
            let n_text = first_token(&body[2..]);
            let n: u64 = n_text
                .parse()
                .map_err(|_| parse_err(format!("frame number `n:{n_text}` is not an integer")))?;
            let key = if exact_pts { "pts:" } else { "pts_time:" };
            let value_text = after_key(body, key)
                .map(first_token)
                .ok_or_else(|| parse_err(format!("frame n:{n} has no {key} field")))?;
            let t = if exact_pts {
                let tb = time_base_s.ok_or_else(|| {
                    parse_err(format!(
                        "frame n:{n} comes before any `config in time_base:` line"
                    ))
                })?;
                let pts: i64 = value_text.parse().map_err(|_| {
                    parse_err(format!("frame n:{n}: pts `{value_text}` is not an integer"))
                })?;
                pts as f64 * tb
            } else {
                value_text.parse::<f64>().map_err(|_| {
                    parse_err(format!(
                        "frame n:{n}: pts_time `{value_text}` is not a number"
                    ))
                })?
            };
            if !t.is_finite() {
                return Err(parse_err(format!(
                    "frame n:{n}: time `{value_text}` is not finite"
                )));
            }
            frames.push((n, t, line));
        }
    }
    ordered_by_index(format, frames)
}

/// `a/b` with b ≠ 0 and a/b > 0, as seconds.
fn parse_ratio(text: &str) -> Option<f64> {
    let (a, b) = text.split_once('/')?;
    let (a, b): (f64, f64) = (a.trim().parse().ok()?, b.trim().parse().ok()?);
    let r = a / b;
    (r.is_finite() && r > 0.0).then_some(r)
}

/// Sorts `(index, time, line)` by index and insists the indices are exactly `0..N`, each once.
fn ordered_by_index(
    format: &'static str,
    mut frames: Vec<(u64, f64, usize)>,
) -> Result<Timestamps, TimingError> {
    if frames.is_empty() {
        return Err(TimingError::Content {
            format,
            message: "no frame lines found".into(),
        });
    }
    frames.sort_by_key(|f| f.0);
    for (expected, &(n, _, line)) in frames.iter().enumerate() {
        let expected = expected as u64;
        if n != expected {
            let message = if n < expected {
                format!("frame {n} appears more than once (again on line {line})")
            } else {
                format!("frame {expected} is missing (next frame present is {n}, line {line})")
            };
            return Err(TimingError::Content { format, message });
        }
    }
    Timestamps::new(frames.into_iter().map(|f| f.1).collect())
}

const FFPROBE_CSV: &str = "ffprobe_csv";

/// ffprobe CSV: a number per line (`csv=p=0`) or `frame,<number>[,...]` (`csv=p=1`); with
/// several entries requested the first value is the frame time. Lines of other sections
/// (`side_data,...`) and blank lines are skipped.
pub fn parse_ffprobe_csv(text: &str) -> Result<Timestamps, TimingError> {
    let mut times = Vec::new();
    for (line, record) in records(text) {
        let record = record.trim();
        if record.is_empty() {
            continue;
        }
        let mut fields = record.split(',').map(str::trim);
        let first = fields.next().unwrap_or("");
        let value = if first == "frame" {
            fields.next().unwrap_or("")
        } else if first.starts_with(|c: char| c.is_ascii_alphabetic()) && first != "N/A" {
            continue;
        } else {
            first
        };
        let t: f64 = value.parse().map_err(|_| TimingError::Parse {
            format: FFPROBE_CSV,
            line,
            message: format!("frame {}: time `{value}` is not a number", times.len()),
        })?;
        times.push(t);
    }
    if times.is_empty() {
        return Err(TimingError::Content {
            format: FFPROBE_CSV,
            message: "no frames found".into(),
        });
    }
    Timestamps::new(times)
}

const FFPROBE_JSON: &str = "ffprobe_json";

/// ffprobe JSON: `{"frames": [{"pts_time": "0.033", ...}, ...]}`; `best_effort_timestamp_time`
/// is used when `pts_time` is absent; non-video frames (`media_type` ≠ `video`) are skipped.
pub fn parse_ffprobe_json(text: &str) -> Result<Timestamps, TimingError> {
    let content = |message: String| TimingError::Content {
        format: FFPROBE_JSON,
        message,
    };
    let root: serde_json::Value = serde_json::from_str(text).map_err(|e| TimingError::Parse {
        format: FFPROBE_JSON,
        line: e.line(),
        message: e.to_string(),
    })?;
    let frames = root
        .get("frames")
        .and_then(|f| f.as_array())
        .ok_or_else(|| content("no `frames` array at the top level".into()))?;
    let mut times = Vec::new();
    for (i, frame) in frames.iter().enumerate() {
        if let Some(kind) = frame.get("media_type").and_then(|m| m.as_str()) {
            if kind != "video" {
                continue;
            }
        }
        let value = frame
            .get("pts_time")
            .or_else(|| frame.get("best_effort_timestamp_time"))
            .ok_or_else(|| {
                content(format!(
                    "frames[{i}] has neither pts_time nor best_effort_timestamp_time"
                ))
            })?;
        let t = match value {
            serde_json::Value::String(s) => s.trim().parse::<f64>().ok(),
            serde_json::Value::Number(n) => n.as_f64(),
            _ => None,
        }
        .ok_or_else(|| content(format!("frames[{i}]: time {value} is not a number")))?;
        times.push(t);
    }
    if times.is_empty() {
        return Err(content("no video frames found".into()));
    }
    Timestamps::new(times)
}

const FRAMES_CSV: &str = "frames_csv";

/// Our CSV: header `frame,t_s` (required), rows `index,seconds`, consecutive indices in order.
pub fn parse_frames_csv(text: &str) -> Result<Timestamps, TimingError> {
    parse_frames_csv_numbered(text).map(|(_, ts)| ts)
}

/// [`parse_frames_csv`] that also returns the first frame's number: a part of a recording
/// (`geneva render --frames 5..10`) is numbered from where it starts, consecutively.
pub fn parse_frames_csv_numbered(text: &str) -> Result<(u64, Timestamps), TimingError> {
    let mut rows = records(text).filter(|(_, r)| !r.trim().is_empty());
    let parse_err = |line: usize, message: String| TimingError::Parse {
        format: FRAMES_CSV,
        line,
        message,
    };
    let (line, header) = rows.next().ok_or_else(|| TimingError::Content {
        format: FRAMES_CSV,
        message: "empty file".into(),
    })?;
    let cols: Vec<&str> = header.split(',').map(str::trim).collect();
    if cols != ["frame", "t_s"] {
        return Err(parse_err(
            line,
            format!("header must be `frame,t_s`, got `{}`", header.trim()),
        ));
    }
    let mut frames = Vec::new();
    let mut first_frame: Option<u64> = None;
    for (line, row) in rows {
        let fields: Vec<&str> = row.split(',').map(str::trim).collect();
        if fields.len() != 2 {
            return Err(parse_err(
                line,
                format!("expected 2 fields `frame,t_s`, got `{}`", row.trim()),
            ));
        }
        let n: u64 = fields[0]
            .parse()
            .map_err(|_| parse_err(line, format!("frame `{}` is not an integer", fields[0])))?;
        let t: f64 = fields[1].parse().map_err(|_| {
            parse_err(
                line,
                format!("frame {n}: t_s `{}` is not a number", fields[1]),
            )
        })?;
        let first = *first_frame.get_or_insert(n);
        let expected = first + frames.len() as u64;
        if n != expected {
            return Err(parse_err(
                line,
                format!("frame index {n} out of order, expected {expected}"),
            ));
        }
        frames.push(t);
    }
    match first_frame {
        Some(first) => Ok((first, Timestamps::new(frames)?)),
        None => Err(TimingError::Content {
            format: FRAMES_CSV,
            message: "no frame rows".into(),
        }),
    }
}

/// Writes timestamps in our `frame,t_s` format (round-trips through [`parse_frames_csv`]).
pub fn to_frames_csv(ts: &Timestamps) -> String {
    let mut out = String::from("frame,t_s\n");
    for (k, t) in ts.as_slice().iter().enumerate() {
        // `{:?}` prints the shortest representation that parses back to the same f64.
        out.push_str(&format!("{k},{t:?}\n"));
    }
    out
}
