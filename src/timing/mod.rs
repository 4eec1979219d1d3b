//! Frame timing: when each frame is taken. Parsers for real timing logs, summary statistics,
//! the configurable frame-time models (constant, VFR, log), deterministic schedules and the fit
//! of the VFR model to a real log.

mod config;
mod error;
pub(crate) mod fit;
mod format;
mod parse;
mod schedule;
pub(crate) mod stats;
pub use stats::median_interval_s;
mod stream;
mod timestamps;

#[cfg(test)]
mod tests_fit;
#[cfg(test)]
mod tests_parse;
#[cfg(test)]
mod tests_real_logs;
#[cfg(test)]
mod tests_schedule;
#[cfg(test)]
mod tests_stream;

pub use config::{FrameTimingConfig, LogModel, TimestampMark, TimingModel, VfrModel};
pub use error::TimingError;
pub use fit::{fit_vfr, fit_vfr_passes, TimingFit, MEDIAN_SAMPLE};
pub use format::LogFormat;
pub use parse::{
    load_from_text, parse_ffprobe_csv, parse_ffprobe_json, parse_frames_csv,
    parse_frames_csv_numbered, parse_showinfo, parse_showinfo_pts, to_frames_csv,
};
pub use schedule::JITTER_TRUNCATION_SIGMA;
pub use stats::{TimingStats, DROP_THRESHOLD};
pub use stream::{stream_frame_times, Streamed, MAX_LINE_BYTES, REORDER_WINDOW};
pub use timestamps::{timebase, Timestamps};
