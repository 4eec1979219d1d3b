//! Scene composition: the driven disc with its ArUco marker (and an optional static reference
//! marker) seen through the camera, as render layers and as ground truth at any instant.
//!
//! World frame (metres, see [`crate::camera`]): disc plane z = 0, origin at the nominal rotation
//! centre, x right and y down in the untilted image. Angles on the disc are measured from +x
//! towards +y, i.e. clockwise as seen in the image. Every pixel coordinate is in OpenCV's
//! convention (centre of pixel (i, j) at (i, j)).

pub mod appearance;
pub mod compose;
pub mod config;
pub mod geometry;
pub mod marker_levels;
pub mod tessellate;

pub use appearance::{AppearanceConfig, LoadedAppearance, MarkerTexels};
pub use compose::{AnimatedScene, BoundingBox, Scene, SceneError, WheelPose, TOLERANCE_PX};
pub use config::{MarkerConfig, ReferenceMarkerConfig, SceneConfig};
pub use geometry::{black_rectangles, CellRect, PlacedMarker};
pub use marker_levels::MarkerLevelAt;

#[cfg(test)]
mod tests;
#[cfg(test)]
mod tests_appearance;
#[cfg(test)]
mod tests_render;
