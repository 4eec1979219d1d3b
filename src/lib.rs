//! geneva-vision: validates camera-based motion measurement of Geneva drives with synthetic
//! data and a known truth.
//!
//! Data flows one way (see ARCHITECTURE.md):
//! scenario → mechanism (truth) → timing + camera → render → detect → estimate → budget → report.
//!
//! The pure core (everything except [`detect`]'s OpenCV part and [`io`]) does no I/O and does not
//! link OpenCV.

pub mod budget;
pub mod calibrate;
pub mod camera;
pub mod detect;
pub mod diagnose;
pub mod errors;
pub mod estimate;
pub mod fuzz;
pub mod imagestats;
pub mod io;
pub mod marker;
pub mod mechanism;
pub mod numeric;
pub mod pipeline;
pub mod plot;
pub mod render;
pub mod rng;
pub mod scenario;
pub mod scene;
pub mod shard;
pub mod sweep;
pub mod timing;
pub mod validation;

#[cfg(test)]
pub mod proptest_utils;
