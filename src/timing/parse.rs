//! Parsers turning the text of timing logs (ffmpeg showinfo, ffprobe CSV/JSON, our `frame,t_s`
//! CSV) into validated [`Timestamps`], on top of the streaming readers of [`super::stream`].
//! No file I/O: callers pass the text.

use super::error::TimingError;
use super::format::LogFormat;
use super::stream::stream_frame_times;
use super::timestamps::Timestamps;

/// Parses `text` written in `format` into frame times (seconds, as the log gives them).
pub fn load_from_text(format: LogFormat, text: &str) -> Result<Timestamps, TimingError> {
    load_numbered(format, text).map(|(_, ts)| ts)
}

/// The frame times of `text` and the number of its first frame (see [`stream_frame_times`]).
fn load_numbered(format: LogFormat, text: &str) -> Result<(u64, Timestamps), TimingError> {
    let mut times = Vec::new();
    let streamed = stream_frame_times(text.as_bytes(), format, &mut |t| {
        times.push(t);
        Ok(())
    })?;
    Ok((streamed.first_frame, Timestamps::new(times)?))
}

/// ffmpeg showinfo: the `n:` and `pts_time:` fields of each frame line, frames put in `n`
/// order; a frame line cut after its time is an error naming the line.
pub fn parse_showinfo(text: &str) -> Result<Timestamps, TimingError> {
    load_from_text(LogFormat::Showinfo, text)
}

/// Like [`parse_showinfo`] but computes each time as `pts × time_base` from the filter's
/// `config in time_base: a/b` line. ffmpeg prints `pts_time` with 6 significant digits, which
/// rounds by up to 50 µs beyond 10 s; the integer `pts` is exact.
pub fn parse_showinfo_pts(text: &str) -> Result<Timestamps, TimingError> {
    load_from_text(LogFormat::ShowinfoPts, text)
}

/// ffprobe CSV: a number per line (`csv=p=0`) or `frame,<number>[,...]` (`csv=p=1`).
pub fn parse_ffprobe_csv(text: &str) -> Result<Timestamps, TimingError> {
    load_from_text(LogFormat::FfprobeCsv, text)
}

/// ffprobe JSON: `{"frames": [{"pts_time": "0.033", ...}, ...]}`.
pub fn parse_ffprobe_json(text: &str) -> Result<Timestamps, TimingError> {
    load_from_text(LogFormat::FfprobeJson, text)
}

/// Our CSV: header `frame,t_s` (required), rows `index,seconds`, consecutive indices in order.
pub fn parse_frames_csv(text: &str) -> Result<Timestamps, TimingError> {
    load_from_text(LogFormat::FramesCsv, text)
}

/// [`parse_frames_csv`] that also returns the first frame's number: a part of a recording
/// (`geneva render --frames 5..10`) is numbered from where it starts, consecutively.
pub fn parse_frames_csv_numbered(text: &str) -> Result<(u64, Timestamps), TimingError> {
    load_numbered(LogFormat::FramesCsv, text)
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
