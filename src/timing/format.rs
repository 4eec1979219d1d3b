//! The timing-log formats the toolkit reads, by the tool that writes each.

use serde::{Deserialize, Serialize};

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
