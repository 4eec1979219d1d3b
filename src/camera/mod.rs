//! Pinhole camera looking at the disc plane: configuration, validation and projection.
//!
//! World frame (metres): the disc plane is z = 0, the origin is the nominal rotation centre,
//! x points right and y down in the image of an untilted camera, z points away from the camera
//! (right-handed, same axes as OpenCV's camera frame when untilted). Image coordinates follow
//! OpenCV's pixel convention: the centre of pixel (i, j) is at (i, j).

pub mod config;
pub mod distortion;
pub mod model;

pub use config::{CameraConfig, FocalConfig, LensDistortionConfig, PerspectiveTiltConfig};
pub use distortion::{distort_normalised, undistort_normalised};
pub use model::{Camera, CameraError};

#[cfg(test)]
mod tests;
