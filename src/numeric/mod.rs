//! Numerics shared by the whole crate, each written once: angles, robust statistics,
//! distributions and special functions, one-dimensional minimisation and dense linear algebra.
//!
//! Pure functions of their arguments, no I/O and no OpenCV (built and tested with
//! `--no-default-features`). Distributions and special functions come from `statrs`, linear
//! algebra from `nalgebra`; what is written here is what those crates do not offer, or the
//! small pieces (a median, an angle wrap) whose exact convention the callers rely on.

pub mod angle;
pub mod dist;
pub mod linalg;
pub mod minimize;
pub mod robust;
