//! Numerics shared by the whole crate, each written once: angles, robust statistics and
//! one-dimensional minimisation.
//!
//! Pure functions of their arguments, no I/O and no OpenCV (built and tested with
//! `--no-default-features`).

pub mod angle;
pub mod minimize;
pub mod robust;
