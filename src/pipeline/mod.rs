//! Orchestration: the jobs the CLI runs, composed from the pure core and `io`.
//!
//! Each job takes a validated scenario and an output directory and returns what it computed.
//! Most of it composes the pure core; `diagnose` also holds the diagnosis's candidate fits,
//! which simulate measurements and so need the detector.

#[cfg(feature = "opencv-detector")]
pub mod analyze;
#[cfg(feature = "opencv-detector")]
pub mod calibrate;
#[cfg(feature = "opencv-detector")]
mod calibrate_appearance;
#[cfg(feature = "opencv-detector")]
mod calibrate_levels;
#[cfg(feature = "opencv-detector")]
mod calibrate_noise_levels;
#[cfg(feature = "opencv-detector")]
mod calibrate_overlay;
#[cfg(feature = "opencv-detector")]
pub mod calibrate_printed;
#[cfg(feature = "opencv-detector")]
pub mod calibrate_roundtrip;
#[cfg(feature = "opencv-detector")]
mod calibrate_sharpening;
#[cfg(feature = "opencv-detector")]
mod calibrate_surroundings;
pub mod coded_frames;
#[cfg(feature = "opencv-detector")]
pub mod decompose;
#[cfg(feature = "opencv-detector")]
pub mod defaults_study;
#[cfg(feature = "opencv-detector")]
pub mod diagnose;
pub mod dynamics_report;
#[cfg(feature = "opencv-detector")]
pub mod error_bars;
#[cfg(feature = "opencv-detector")]
pub mod error_bars_check;
#[cfg(feature = "opencv-detector")]
pub mod frames;
pub mod measure;
#[cfg(feature = "opencv-detector")]
pub mod montecarlo;
pub mod plots;
pub mod render_job;
#[cfg(feature = "opencv-detector")]
pub mod reports;
pub mod rig;
#[cfg(feature = "opencv-detector")]
pub mod run;
pub mod scored_cases;
#[cfg(feature = "opencv-detector")]
pub mod selfcheck;
#[cfg(feature = "opencv-detector")]
pub mod sweep_eval;
pub mod truth;
pub mod workload;
