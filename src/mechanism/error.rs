//! Errors of the mechanism module (configuration, drive tables, run set-up).

use thiserror::Error;

#[derive(Debug, Clone, PartialEq, Error)]
pub enum MechanismError {
    /// One or more fields failed validation; the message lists `field: problem` pairs.
    #[error("invalid mechanism configuration: {0}")]
    InvalidConfig(String),
    /// A drive-speed table (CSV text) could not be parsed; `line` is 1-based.
    #[error("drive_speed table line {line}: {message}")]
    DriveTable { line: usize, message: String },
    /// The simulated duration must be finite and positive.
    #[error("duration_s must be finite and > 0, got {0}")]
    Duration(f64),
}
