//! The interface between scene composition and the rasteriser: what is visible at one instant,
//! as filled polygons in image coordinates.
//!
//! Architecture invariant: every coordinate here is in pixels, OpenCV convention (the centre of
//! pixel (i, j) is at (i, j); pixel (i, j) covers [i − 0.5, i + 0.5] × [j − 0.5, j + 0.5]).

use super::texture::{BackgroundTexture, TexturedFill};
use glam::DVec2;
use std::sync::Arc;

/// A closed polygon in image pixels (OpenCV convention); either winding.
#[derive(Debug, Clone, PartialEq)]
pub struct Polygon {
    pub vertices_px: Vec<DVec2>,
}

/// Polygons of one uniform radiance. Polygons inside one layer never overlap (they may share
/// edges), so their coverages add exactly — this is what keeps adjacent marker cells free of
/// seams (no conflation artefacts).
///
/// A textured layer (`texture` set) takes its coverage and radiance from its pieces instead
/// (`render::texture`); its `polygons` are its outline, which tells the exposure sampling how
/// far the layer moves and the independent renderer where it lies, and its `radiance` is not
/// used.
#[derive(Debug, Clone, PartialEq)]
pub struct Layer {
    /// Linear radiance in [0, 1] (0 = black ink, 1 = white paper under nominal lighting).
    pub radiance: f32,
    pub polygons: Vec<Polygon>,
    pub texture: Option<TexturedFill>,
}

/// Everything visible at one instant: layers are painted in order over the background
/// (later layers over earlier ones, with area-coverage "over" compositing).
#[derive(Debug, Clone, PartialEq)]
pub struct SceneSnapshot {
    pub background_radiance: f32,
    /// The background as a texture in the image (it replaces `background_radiance`).
    pub background: Option<Arc<BackgroundTexture>>,
    pub layers: Vec<Layer>,
}

/// A scene that can be looked at any instant (the renderer samples it at row times and within
/// exposure windows). Implementations are pure and thread-safe.
pub trait SceneAt: Sync {
    /// The visible scene at time `t_s` (seconds since the start of the scenario).
    fn snapshot(&self, t_s: f64) -> SceneSnapshot;
}
