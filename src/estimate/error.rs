//! Errors of the estimation stage; each names the offending frame, field or signal.

use thiserror::Error;

#[derive(Debug, Clone, PartialEq, Error)]
pub enum EstimateError {
    #[error("{what} has {got} entries, expected {expected} (one per frame)")]
    LengthMismatch {
        what: &'static str,
        got: usize,
        expected: usize,
    },
    #[error("too few detected frames for {what}: {got}, need at least {need}")]
    TooFewFrames {
        what: &'static str,
        got: usize,
        need: usize,
    },
    #[error("non-finite {what} at frame {frame}")]
    NonFinite { what: &'static str, frame: usize },
    #[error(
        "timestamps must strictly increase: frame {frame} is not after the previous detected frame"
    )]
    NonIncreasingTime { frame: usize },
    #[error("degenerate geometry for the rotation centre: {0}")]
    Degenerate(String),
    #[error(
        "arc too short for a circle fit: {span_deg:.3} deg covered, need at least {min_deg} deg"
    )]
    ArcTooShort { span_deg: f64, min_deg: f64 },
    #[error("invalid differentiator settings: {0}")]
    InvalidDifferentiator(String),
}
