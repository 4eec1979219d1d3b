//! Streaming readers of timing logs: each format is read one line (or one JSON frame) at a time
//! from any `BufRead` and handed on as validated frame times, so the memory a log needs does not
//! grow with its length (a line is at most [`MAX_LINE_BYTES`]; showinfo frames may come out of
//! order within [`REORDER_WINDOW`] frames). The text parsers of [`super::parse`] and the
//! multi-pass VFR fit of a file are both built on these.

use std::collections::BTreeMap;
use std::io::BufRead;

use serde::de::{self, DeserializeSeed, IgnoredAny, MapAccess, SeqAccess, Visitor};

use super::error::TimingError;
use super::format::LogFormat;
use super::timestamps::check_next;

/// Longest line accepted, bytes (a showinfo frame line is about 300 bytes).
pub const MAX_LINE_BYTES: usize = 1 << 20;

/// How far out of order showinfo frame numbers may arrive (frames held back at most).
pub const REORDER_WINDOW: usize = 256;

/// What a streamed log held besides its times.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Streamed {
    /// Frames handed on.
    pub frames: usize,
    /// Number of the first frame (`frame,t_s` CSVs of a part of a recording; else 0).
    pub first_frame: u64,
}

/// Calls `each` with every frame time of the log, in frame order, after checking that it is
/// finite and later than the one before (the checks of [`super::Timestamps::new`]).
pub fn stream_frame_times<R: BufRead>(
    mut reader: R,
    format: LogFormat,
    each: &mut dyn FnMut(f64) -> Result<(), TimingError>,
) -> Result<Streamed, TimingError> {
    // A UTF-8 byte order mark (spreadsheets write one) is not part of the first record.
    if reader
        .fill_buf()
        .is_ok_and(|b| b.starts_with(b"\xEF\xBB\xBF"))
    {
        reader.consume(3);
    }
    let mut checked = Checked {
        each,
        count: 0,
        previous_s: 0.0,
    };
    let first_frame = match format {
        LogFormat::Showinfo => showinfo(reader, false, &mut checked)?,
        LogFormat::ShowinfoPts => showinfo(reader, true, &mut checked)?,
        LogFormat::FfprobeCsv => ffprobe_csv(reader, &mut checked)?,
        LogFormat::FfprobeJson => ffprobe_json(reader, &mut checked)?,
        LogFormat::FramesCsv => frames_csv(reader, &mut checked)?,
    };
    Ok(Streamed {
        frames: checked.count,
        first_frame,
    })
}

/// The per-frame checks of `Timestamps::new`, applied as frames stream past.
struct Checked<'a> {
    each: &'a mut dyn FnMut(f64) -> Result<(), TimingError>,
    count: usize,
    previous_s: f64,
}

impl Checked<'_> {
    fn push(&mut self, value_s: f64) -> Result<(), TimingError> {
        let previous_s = (self.count > 0).then_some(self.previous_s);
        check_next(self.count, previous_s, value_s)?;
        (self.each)(value_s)?;
        self.previous_s = value_s;
        self.count += 1;
        Ok(())
    }
}

/// One record of a log: its 1-based line, its text, and whether the file ends inside it (no
/// end of line after it: a log cut there may have cut its last number too).
struct Record<'a> {
    line: usize,
    text: &'a str,
    cut: bool,
}

/// Feeds `f` the records of a log split at `\n`, `\r\n` and bare `\r` (ffmpeg's progress lines
/// end in `\r`), numbered in `\n`s as an editor shows them; bytes that are not UTF-8 (stray
/// metadata of logs written on Windows) are replaced, they never matter for frame lines.
fn for_each_record<R: BufRead>(
    mut reader: R,
    format: &'static str,
    mut f: impl FnMut(Record) -> Result<(), TimingError>,
) -> Result<(), TimingError> {
    let mut buf = Vec::new();
    let mut line = 0usize;
    loop {
        buf.clear();
        line += 1;
        let terminated = read_line_bounded(&mut reader, &mut buf, format, line)?;
        if buf.is_empty() && !terminated {
            return Ok(());
        }
        let text = String::from_utf8_lossy(&buf);
        let mut parts = text.split('\r').peekable();
        while let Some(part) = parts.next() {
            // Only the record the file ends in is cut; a `\r` ends the ones before it.
            let cut = !terminated && parts.peek().is_none();
            f(Record {
                line,
                text: part,
                cut,
            })?;
        }
        if !terminated {
            return Ok(());
        }
    }
}

/// Reads up to and excluding the next `\n` into `buf`; true if a `\n` ended it.
fn read_line_bounded<R: BufRead>(
    reader: &mut R,
    buf: &mut Vec<u8>,
    format: &'static str,
    line: usize,
) -> Result<bool, TimingError> {
    loop {
        let available = match reader.fill_buf() {
            Ok(b) => b,
            Err(e) if e.kind() == std::io::ErrorKind::Interrupted => continue,
            Err(e) => {
                return Err(TimingError::Read {
                    line,
                    message: e.to_string(),
                })
            }
        };
        if available.is_empty() {
            return Ok(false);
        }
        let (chunk, found) = match available.iter().position(|&b| b == b'\n') {
            Some(i) => (&available[..i], true),
            None => (available, false),
        };
        if buf.len() + chunk.len() > MAX_LINE_BYTES {
            return Err(TimingError::Parse {
                format,
                line,
                message: format!("line longer than {MAX_LINE_BYTES} bytes"),
            });
        }
        buf.extend_from_slice(chunk);
        let used = chunk.len() + usize::from(found);
        reader.consume(used);
        if found {
            return Ok(true);
        }
    }
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

/// `a/b` with b ≠ 0 and a/b > 0, as seconds.
fn parse_ratio(text: &str) -> Option<f64> {
    let (a, b) = text.split_once('/')?;
    let (a, b): (f64, f64) = (a.trim().parse().ok()?, b.trim().parse().ok()?);
    let r = a / b;
    (r.is_finite() && r > 0.0).then_some(r)
}

/// Puts showinfo frames back in `n` order: each frame number exactly once, from 0, held back
/// at most [`REORDER_WINDOW`] frames.
struct Reorder {
    format: &'static str,
    next: u64,
    pending: BTreeMap<u64, (f64, usize)>,
}

impl Reorder {
    fn add(&mut self, n: u64, t: f64, line: usize, out: &mut Checked) -> Result<(), TimingError> {
        if n < self.next || self.pending.contains_key(&n) {
            return Err(TimingError::Content {
                format: self.format,
                message: format!("frame {n} appears more than once (again on line {line})"),
            });
        }
        self.pending.insert(n, (t, line));
        self.release(out)?;
        if self.pending.len() > REORDER_WINDOW {
            return Err(self.missing());
        }
        Ok(())
    }

    fn release(&mut self, out: &mut Checked) -> Result<(), TimingError> {
        while let Some((t, _)) = self.pending.remove(&self.next) {
            out.push(t)?;
            self.next += 1;
        }
        Ok(())
    }

    fn missing(&self) -> TimingError {
        let (n, (_, line)) = self
            .pending
            .iter()
            .next()
            .map(|(n, v)| (*n, *v))
            .unwrap_or((self.next, (0.0, 0)));
        TimingError::Content {
            format: self.format,
            message: format!(
                "frame {} is missing (next frame present is {n}, line {line})",
                self.next
            ),
        }
    }

    fn finish(self, out: &Checked) -> Result<(), TimingError> {
        if !self.pending.is_empty() {
            return Err(self.missing());
        }
        if out.count == 0 {
            return Err(TimingError::Content {
                format: self.format,
                message: "no frame lines found".into(),
            });
        }
        Ok(())
    }
}

/// ffmpeg showinfo: frame lines look like
/// `[Parsed_showinfo_0 @ 0x..] n:  12 pts: 36162 pts_time:0.4018 pos: ...`, possibly preceded
/// on the same line by a `frame= ... speed=..` progress record; `pts_time:1` may have no decimal
/// point. ffmpeg always prints more fields after the time, so a frame line that ends right after
/// it was cut, and its number may be too.
fn showinfo<R: BufRead>(reader: R, exact_pts: bool, out: &mut Checked) -> Result<u64, TimingError> {
    let format = if exact_pts {
        "showinfo_pts"
    } else {
        "showinfo"
    };
    let mut time_base_s: Option<f64> = None;
    let mut order = Reorder {
        format,
        next: 0,
        pending: BTreeMap::new(),
    };
    for_each_record(reader, format, |record| {
        let line = record.line;
        let mut rest = record.text;
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
            let Some(after_n) = body.strip_prefix("n:") else {
                continue; // config / colour / side-data lines of the filter
            };
            let n_text = first_token(after_n);
            let n: u64 = n_text
                .parse()
                .map_err(|_| parse_err(format!("frame number `n:{n_text}` is not an integer")))?;
            let key = if exact_pts { "pts:" } else { "pts_time:" };
            let after = after_key(body, key)
                .ok_or_else(|| parse_err(format!("frame n:{n} has no {key} field")))?;
            let value_text = first_token(after);
            if after.len() == value_text.len() {
                return Err(parse_err(format!(
                    "frame n:{n}: the line ends right after {key}{value_text} (ffmpeg prints \
                     more fields after it): the log is cut and the number may be too"
                )));
            }
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
            order.add(n, t, line, out)?;
        }
        Ok(())
    })?;
    order.finish(out)?;
    Ok(0)
}

/// The error for a frame on the line a file ends in without an end of line: tools end every
/// line, so the log was cut there and its last number may be cut too (`0.29` of `0.2934`).
fn cut_line(format: &'static str, line: usize, value: &str) -> TimingError {
    TimingError::Parse {
        format,
        line,
        message: format!(
            "the file ends inside this line, after `{value}` (no end of line): the log was cut \
             and the number may be too; end the line if it is complete"
        ),
    }
}

/// ffprobe CSV: a number per line (`csv=p=0`) or `frame,<number>[,...]` (`csv=p=1`); with
/// several entries requested the first value is the frame time. Lines of other sections
/// (`side_data,...`) and blank lines are skipped.
fn ffprobe_csv<R: BufRead>(reader: R, out: &mut Checked) -> Result<u64, TimingError> {
    const FORMAT: &str = "ffprobe_csv";
    for_each_record(reader, FORMAT, |record| {
        let text = record.text.trim();
        if text.is_empty() {
            return Ok(());
        }
        let mut fields = text.split(',').map(str::trim);
        let first = fields.next().unwrap_or("");
        let value = if first == "frame" {
            fields.next().unwrap_or("")
        } else if first.starts_with(|c: char| c.is_ascii_alphabetic()) && first != "N/A" {
            return Ok(());
        } else {
            first
        };
        let t: f64 = value.parse().map_err(|_| TimingError::Parse {
            format: FORMAT,
            line: record.line,
            message: format!("frame {}: time `{value}` is not a number", out.count),
        })?;
        if record.cut {
            return Err(cut_line(FORMAT, record.line, text));
        }
        out.push(t)
    })?;
    if out.count == 0 {
        return Err(TimingError::Content {
            format: FORMAT,
            message: "no frames found".into(),
        });
    }
    Ok(0)
}

/// Our CSV: header `frame,t_s` (required), rows `index,seconds`, consecutive indices in order
/// from any first frame (a part of a recording is numbered from where it starts).
fn frames_csv<R: BufRead>(reader: R, out: &mut Checked) -> Result<u64, TimingError> {
    const FORMAT: &str = "frames_csv";
    let parse_err = |line: usize, message: String| TimingError::Parse {
        format: FORMAT,
        line,
        message,
    };
    let mut header_seen = false;
    let mut first_frame: Option<u64> = None;
    for_each_record(reader, FORMAT, |record| {
        let (line, row) = (record.line, record.text);
        if row.trim().is_empty() {
            return Ok(());
        }
        if !header_seen {
            let cols: Vec<&str> = row.split(',').map(str::trim).collect();
            if cols != ["frame", "t_s"] {
                return Err(parse_err(
                    line,
                    format!("header must be `frame,t_s`, got `{}`", row.trim()),
                ));
            }
            header_seen = true;
            return Ok(());
        }
        let mut fields = row.split(',').map(str::trim);
        let (Some(n_text), Some(t_text), None) = (fields.next(), fields.next(), fields.next())
        else {
            return Err(parse_err(
                line,
                format!("expected 2 fields `frame,t_s`, got `{}`", row.trim()),
            ));
        };
        let n: u64 = n_text
            .parse()
            .map_err(|_| parse_err(line, format!("frame `{n_text}` is not an integer")))?;
        let t: f64 = t_text
            .parse()
            .map_err(|_| parse_err(line, format!("frame {n}: t_s `{t_text}` is not a number")))?;
        let first = *first_frame.get_or_insert(n);
        let expected = first.checked_add(out.count as u64);
        if Some(n) != expected {
            let expected = expected.map_or("none (past the largest frame number)".into(), |e| {
                e.to_string()
            });
            return Err(parse_err(
                line,
                format!("frame index {n} out of order, expected {expected}"),
            ));
        }
        if record.cut {
            return Err(cut_line(FORMAT, line, row.trim()));
        }
        out.push(t)
    })?;
    if !header_seen {
        return Err(TimingError::Content {
            format: FORMAT,
            message: "empty file".into(),
        });
    }
    first_frame.ok_or_else(|| TimingError::Content {
        format: FORMAT,
        message: "no frame rows".into(),
    })
}

/// ffprobe JSON: `{"frames": [{"pts_time": "0.033", ...}, ...]}`; `best_effort_timestamp_time`
/// is used when `pts_time` is absent; non-video frames (`media_type` ≠ `video`) are skipped.
/// Read element by element: a frame's error carries the line it is on.
fn ffprobe_json<R: BufRead>(reader: R, out: &mut Checked) -> Result<u64, TimingError> {
    const FORMAT: &str = "ffprobe_json";
    let mut stopped: Option<TimingError> = None;
    let mut de = serde_json::Deserializer::from_reader(reader);
    let result = JsonRoot {
        out,
        stopped: &mut stopped,
        found: false,
    }
    .deserialize(&mut de)
    .and_then(|found| de.end().map(|_| found));
    match (result, stopped) {
        (Err(e), Some(typed)) => Err(match typed {
            TimingError::Content { message, .. } => TimingError::Parse {
                format: FORMAT,
                line: e.line(),
                message,
            },
            other => other,
        }),
        (Err(e), None) => Err(TimingError::Parse {
            format: FORMAT,
            line: e.line(),
            message: e.to_string(),
        }),
        (Ok(false), _) => Err(TimingError::Content {
            format: FORMAT,
            message: "no `frames` array at the top level".into(),
        }),
        (Ok(true), _) if out.count == 0 => Err(TimingError::Content {
            format: FORMAT,
            message: "no video frames found".into(),
        }),
        (Ok(true), _) => Ok(0),
    }
}

struct JsonRoot<'a, 'b> {
    out: &'a mut Checked<'b>,
    stopped: &'a mut Option<TimingError>,
    found: bool,
}

impl<'de> DeserializeSeed<'de> for JsonRoot<'_, '_> {
    /// Whether a `frames` array was found.
    type Value = bool;
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<bool, D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de> Visitor<'de> for JsonRoot<'_, '_> {
    type Value = bool;
    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("an ffprobe object with a `frames` array")
    }
    fn visit_map<A: MapAccess<'de>>(mut self, mut map: A) -> Result<bool, A::Error> {
        while let Some(key) = map.next_key::<String>()? {
            if key == "frames" && !self.found {
                map.next_value_seed(JsonFrames {
                    out: &mut *self.out,
                    stopped: &mut *self.stopped,
                })?;
                self.found = true;
            } else {
                map.next_value::<IgnoredAny>()?;
            }
        }
        Ok(self.found)
    }
}

struct JsonFrames<'a, 'b> {
    out: &'a mut Checked<'b>,
    stopped: &'a mut Option<TimingError>,
}

impl<'de> DeserializeSeed<'de> for JsonFrames<'_, '_> {
    type Value = ();
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_seq(self)
    }
}

impl<'de> Visitor<'de> for JsonFrames<'_, '_> {
    type Value = ();
    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("an array of frames")
    }
    fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<(), A::Error> {
        let mut index = 0usize;
        while seq
            .next_element_seed(JsonFrame {
                index,
                out: &mut *self.out,
                stopped: &mut *self.stopped,
            })?
            .is_some()
        {
            index += 1;
        }
        Ok(())
    }
}

/// One element of ffprobe's `frames` array, handed on before its closing brace is read so an
/// error names the line the frame ends on (other keys are skipped).
struct JsonFrame<'a, 'b> {
    index: usize,
    out: &'a mut Checked<'b>,
    stopped: &'a mut Option<TimingError>,
}

impl<'de> DeserializeSeed<'de> for JsonFrame<'_, '_> {
    type Value = ();
    fn deserialize<D: de::Deserializer<'de>>(self, d: D) -> Result<(), D::Error> {
        d.deserialize_map(self)
    }
}

impl<'de> Visitor<'de> for JsonFrame<'_, '_> {
    type Value = ();
    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a frame object")
    }
    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<(), A::Error> {
        let mut media_type: Option<String> = None;
        let mut pts_time: Option<serde_json::Value> = None;
        let mut best_effort: Option<serde_json::Value> = None;
        while let Some(key) = map.next_key::<String>()? {
            match key.as_str() {
                "media_type" => media_type = Some(map.next_value()?),
                "pts_time" => pts_time = Some(map.next_value()?),
                "best_effort_timestamp_time" => best_effort = Some(map.next_value()?),
                _ => {
                    map.next_value::<IgnoredAny>()?;
                }
            }
        }
        let frame = FrameFields {
            media_type,
            pts_time,
            best_effort,
        };
        if let Err(e) = json_frame(self.index, &frame, self.out) {
            let message = e.to_string();
            *self.stopped = Some(e);
            return Err(de::Error::custom(message));
        }
        Ok(())
    }
}

struct FrameFields {
    media_type: Option<String>,
    pts_time: Option<serde_json::Value>,
    best_effort: Option<serde_json::Value>,
}

fn json_frame(i: usize, frame: &FrameFields, out: &mut Checked) -> Result<(), TimingError> {
    let content = |message: String| TimingError::Content {
        format: "ffprobe_json",
        message,
    };
    if frame.media_type.as_deref().is_some_and(|k| k != "video") {
        return Ok(());
    }
    let value = frame
        .pts_time
        .as_ref()
        .or(frame.best_effort.as_ref())
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
    out.push(t)
}
