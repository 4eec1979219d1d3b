//! Sim-to-real gap diagnosis (pure: no I/O, no OpenCV, no truth): where the real measurement and
//! the nominal simulation disagree, which effect of the vocabulary explains it, and how far the
//! gap shrinks once that effect is added. Orchestration (running the pipeline on real footage
//! and on simulations) lives in `pipeline::diagnose`.

pub mod align;
pub mod bands;
pub mod camera_warp;
pub mod cells;
pub mod fit;
pub mod fit_noise;
pub mod footing;
pub mod gap;
pub mod holdout;
pub mod image;
pub mod memo;
pub mod moments;
pub mod nominal;
pub mod objectives;
pub mod outcome;
pub mod plan;
pub mod pose_tilt;
pub mod record;
pub mod report;
pub mod runout;
pub mod scoring;
pub mod search;
pub mod sensor_noise;
pub mod shape;
pub mod simulator;
pub mod spectrum;
pub mod trials;
pub mod verdict;
