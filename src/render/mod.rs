//! Synthetic camera frames: an exact area-coverage rasteriser ([`raster`]), imaging effects
//! ([`effects`]) and frame rendering with region-of-interest support ([`frame`]).
//!
//! Every effect is a pure function of absolute pixel position, time and the seed, so a region
//! of interest is bit-identical to the same window of the full frame, and frames can be rendered
//! in any order or in parallel.

pub mod effects;
pub mod frame;
pub mod image;
pub mod independent;
pub mod novel;
pub mod raster;
pub mod real_frame;
pub mod shapes;
#[doc(hidden)]
pub mod test_scenes;
pub mod texture;
pub mod tiny_skia_ref;

pub use effects::EffectsConfig;
pub use frame::{render_frame, render_frame_with, FrameBuffers, FrameRequest, RenderSettings};
pub use image::GrayImage;
pub use raster::PixelRect;
