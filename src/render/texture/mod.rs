//! Textured layers: a layer whose radiance varies over it, as a partition of the layer's area
//! into pieces of constant radiance — the texels of one or two textures clipped to their
//! regions, and uniform pieces — drawn exactly: a pixel's value is the area-weighted mean of the
//! pieces its square covers (what [`super::raster`] computes for uniform polygons).
//!
//! Geometry lives in a *plane* (the wheel's frame, metres) and reaches the image through a
//! [`PlaneMap`] (a pinhole camera looking at the plane, lens distortion and camera vibration
//! included) per exposure sample. What does not depend on the pose — which grid edges lie inside
//! their regions, where the region boundaries cross the grid lines — is built once
//! ([`TextureMesh::new`], `build`).
//!
//! Method (see `raster::textured`): the partition is drawn as its *jump network* — every edge of
//! the arrangement carries the difference of the radiances on its two sides (the boundary of
//! each piece, weighted by the piece's radiance, summed: shared edges merge), rasterised with the
//! integer signed-area accumulation of the uniform layers, the weights being integers (16-bit
//! radiance). The prefix sum along a row then gives Σ radiance × exact area per pixel, in
//! integers, whatever the window; a window only visits the texels whose image can reach it.

pub(crate) mod build;
mod map;

pub use build::{GridSpec, LayerContent, MeshError, TextureMesh};
pub use map::PlaneMap;

use std::sync::Arc;

/// Radiance units of the integer weights: radiance 1 is this many units (16-bit samples).
pub const RADIANCE_UNITS: i64 = 65535;

/// A grey texture: `values` row-major, radiance = value / [`RADIANCE_UNITS`].
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Texture {
    pub width: usize,
    pub height: usize,
    pub values: Vec<u16>,
}

impl Texture {
    /// The value of texel (i, j), `None` outside the texture.
    #[inline]
    pub fn get(&self, i: i64, j: i64) -> Option<u16> {
        if i < 0 || j < 0 || i >= self.width as i64 || j >= self.height as i64 {
            return None;
        }
        Some(self.values[j as usize * self.width + i as usize])
    }

    /// The radiance of texel (i, j), clamped to the texture's edge outside it.
    #[inline]
    pub fn radiance_clamped(&self, i: i64, j: i64) -> f32 {
        let i = i.clamp(0, self.width as i64 - 1) as usize;
        let j = j.clamp(0, self.height as i64 - 1) as usize;
        radiance_of(self.values[j * self.width + i])
    }
}

/// Linear radiance of a 16-bit texture value (the one conversion every renderer uses).
#[inline]
pub fn radiance_of(value: u16) -> f32 {
    (value as f64 / RADIANCE_UNITS as f64) as f32
}

/// A radiance in [0, 1] as a 16-bit value (rounded): the weight of a uniform piece.
pub fn value_of(radiance: f64) -> u16 {
    (radiance.clamp(0.0, 1.0) * RADIANCE_UNITS as f64).round() as u16
}

/// The marker's level at one instant (`scene.appearance.marker_levels`): its radiance r, paper
/// and ink alike, textured or uniform, is drawn as gain·r + offset, clamped to [0, 1]. A glossy
/// toner that reflects the lamp at some angles of the wheel changes the ink's level this way.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LevelMap {
    pub gain: f64,
    pub offset: f64,
}

impl LevelMap {
    /// The mapped radiance.
    #[inline]
    pub fn radiance(&self, r: f64) -> f64 {
        (self.gain * r + self.offset).clamp(0.0, 1.0)
    }

    /// The mapped 16-bit value (the weight the rasteriser deposits).
    #[inline]
    pub fn value(&self, v: u16) -> u16 {
        value_of(self.radiance(v as f64 / RADIANCE_UNITS as f64))
    }
}

/// The static background as a texture in the image: texel (x, y) is camera pixel (x, y);
/// outside the frame (the optical blur's margin) the nearest edge pixel's value.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BackgroundTexture(pub Texture);

impl BackgroundTexture {
    /// Radiance of pixel (x, y), edge-clamped.
    #[inline]
    pub fn at(&self, x: i64, y: i64) -> f32 {
        self.0.radiance_clamped(x, y)
    }

    /// Row `y`, columns `x0 .. x0 + out.len()`, into `out`.
    pub fn row_into(&self, x0: i64, y: i64, out: &mut [f32]) {
        let t = &self.0;
        let yy = y.clamp(0, t.height as i64 - 1) as usize;
        let row = &t.values[yy * t.width..][..t.width];
        let last = t.width as i64 - 1;
        for (k, o) in out.iter_mut().enumerate() {
            let x = (x0 + k as i64).clamp(0, last) as usize;
            *o = radiance_of(row[x]);
        }
    }
}

/// A textured layer as one snapshot sees it: the pose-independent mesh and the plane's map to
/// the image at this instant.
#[derive(Debug, Clone)]
pub struct TexturedFill {
    pub mesh: Arc<TextureMesh>,
    pub map: PlaneMap,
    /// The uniform piece (the marker's paper) as an image polygon, when the layer has one: a
    /// later layer (the ink) drawn over the layer nests inside it (see `raster::nesting`).
    pub core_px: Option<crate::render::shapes::Polygon>,
    /// The marker's level at this instant (applies to the paper part, texture or uniform).
    pub paper_level: Option<LevelMap>,
}

impl TexturedFill {
    /// The layer's radiance at plane point `p` (see [`TextureMesh::radiance_at`]), the paper's
    /// level applied.
    pub fn radiance_at(&self, p: glam::DVec2, bilinear: bool) -> Option<f32> {
        self.mesh
            .radiance_with(p, bilinear, self.paper_level.as_ref())
    }

    /// The uniform paper's radiance at this instant, when the paper is uniform.
    pub fn paper_radiance(&self) -> Option<f32> {
        let r = self.mesh.paper_radiance()?;
        Some(match &self.paper_level {
            Some(l) => l.radiance(r as f64) as f32,
            None => r,
        })
    }
}

impl PartialEq for TexturedFill {
    fn eq(&self, other: &Self) -> bool {
        Arc::ptr_eq(&self.mesh, &other.mesh)
            && self.map == other.map
            && self.paper_level == other.paper_level
    }
}

#[cfg(test)]
mod tests;
