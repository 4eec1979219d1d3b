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
    /// The simulated pin went through a slot wall: the contact cannot hold the wheel, and
    /// whatever follows would be made up.
    #[error(
        "dynamics: the pin went {depth_mm:.2} mm into a slot wall at t = {t_s:.4} s (the contact \
         model holds up to {limit_mm:.2} mm): the rattle grew until the wheel broke through. A \
         dynamics.contact_restitution near 1 lets the crank pump energy into the rattle; lower \
         it, or raise dynamics.contact_stiffness_n_m"
    )]
    WallBreakthrough {
        t_s: f64,
        depth_mm: f64,
        limit_mm: f64,
    },
}
