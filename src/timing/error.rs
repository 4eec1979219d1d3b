//! The error type of the timing module: every variant names the frame, line or field at fault.

use thiserror::Error;

/// Everything that can go wrong parsing, validating, generating or fitting frame times.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum TimingError {
    /// A timestamp is NaN or infinite.
    #[error("frame {frame}: timestamp {value_s} s is not a finite number")]
    NotFinite { frame: usize, value_s: f64 },
    /// A timestamp equals its predecessor.
    #[error("frame {frame}: timestamp {value_s} s repeats frame {} ({previous_s} s); timestamps must strictly increase", frame - 1)]
    Repeated {
        frame: usize,
        previous_s: f64,
        value_s: f64,
    },
    /// A timestamp is earlier than its predecessor.
    #[error("frame {frame}: timestamp {value_s} s goes backwards from frame {} ({previous_s} s); timestamps must strictly increase", frame - 1)]
    Backwards {
        frame: usize,
        previous_s: f64,
        value_s: f64,
    },
    /// A line of a log could not be understood; `line` is 1-based.
    #[error("{format} line {line}: {message}")]
    Parse {
        format: &'static str,
        line: usize,
        message: String,
    },
    /// The log could not be read (an I/O error) at this 1-based line.
    #[error("cannot read line {line}: {message}")]
    Read { line: usize, message: String },
    /// The log held no frames, or frame numbering has gaps or duplicates.
    #[error("{format}: {message}")]
    Content {
        format: &'static str,
        message: String,
    },
    /// An operation needs more frames than it was given.
    #[error("need at least {needed} frames, got {got}")]
    TooFewFrames { needed: usize, got: usize },
    /// The configuration is invalid (the messages name the fields).
    #[error("invalid frame timing configuration: {0}")]
    InvalidConfig(String),
    /// `kind = "log"` was scheduled without the loaded log.
    #[error("frame_timing.model.kind = \"log\" needs the loaded log timestamps, none were given")]
    MissingLog,
}
