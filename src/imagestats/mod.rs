//! Image statistics of one 8-bit grey frame around a detected ArUco marker: what the footage
//! says directly about image formation. Pure functions over a [`GrayView`] (a full frame or a
//! window with its absolute origin): no I/O, no OpenCV. Every pixel coordinate is absolute and in
//! OpenCV's convention (the centre of pixel (i, j) is at (i, j)); marker corners are given in
//! OpenCV's order (top-left, top-right, bottom-right, bottom-left as printed).
//!
//! | function | measures |
//! |---|---|
//! | [`marker_levels`] | ink, paper and surround grey levels (median, trimmed mean) and per-frame noise σ of each, from pixels well inside each region |
//! | [`marker_regions`] | the absolute pixels of those regions (for [`temporal_noise`] across frames) |
//! | [`region_stats`] | level and noise of any list of pixels |
//! | [`rigid_motion`] | the image's sub-pixel shift and turn between two frames (a still marker told from one moving by a tenth of a pixel) |
//! | [`temporal_noise`] | noise σ of a static set of pixels from its variation over frames |
//! | [`weak_texture_noise`] | noise σ of one frame's region from its weak-texture patches (Liu, Tanaka & Okutomi 2013; Chen, Zhu & Heng 2015), and whether it is the sensor's white noise or texture |
//! | [`outer_edge_profiles`] | blur σ of each outer side of the black square (erf-type edge model with free levels) with the side's unit normal, fitted edge line and standard errors |
//! | [`inner_edge_profiles`] | the same on the straight boundaries between inner black and white cells |
//! | [`fit_grid_edge`] | the edge fit on any grid line of the marker |
//! | [`refined_corners`] | corners from the intersections of four fitted outer edge lines (sub-pixel, unbiased) |
//! | [`square_fit`] | marker shape: similarity fit to a square (side, RMS residual) and the affine remainder (aspect, shear) |
//! | [`blockiness`] | 8-px grid blockiness (Wang, Sheikh & Bovik 2002) |
//! | [`jpeg_quality`] | JPEG quantiser (IJG quality) estimate by maximum likelihood on block-DCT coefficients (Fan & de Queiroz 2003) |
//!
//! Every result carries the number of pixels or samples it used; a region that is too small or
//! not inside the view gives an error ([`StatsError`]), never a silently wrong value.
//!
//! The marker's printed layout ([`MarkerLayout`]) comes from the dictionary, id and border width;
//! its white margin (in units of the black-square side) is optional: when it is not known the
//! surround of the black square is a material of its own ("surround") with its own level, and
//! only half a cell of it is used.
//!
//! Edge model: a straight edge between materials is an ideal step, blurred by a Gaussian PSF of σ
//! and integrated over the 1×1 pixel box. Along the edge normal, at angle θ to the pixel axes,
//! the box projects to a trapezoid (widths |cos θ| and |sin θ|), so a pixel centred at signed
//! distance x from the edge reads S(x) = E[Φ((x + |cos θ|·U₁ + |sin θ|·U₂)/σ)] with U₁, U₂
//! uniform on (−½, ½), in closed form (see `edge::step_response`). This is exactly what the
//! renderer produces for a straight edge with optical blur, so a rendered frame recovers its σ.

mod censored;
mod edge;
mod grid;
mod jpeg;
mod levels;
mod motion;
mod noise;
mod shape;

#[cfg(test)]
mod tests;

pub use censored::censored_normal_fit;
pub(crate) use edge::step_response;
pub use edge::{
    fit_grid_edge, inner_edge_profiles, outer_edge_profiles, refined_corners, EdgeOptions,
    EdgeProfile, EdgeSharpening, GridEdge,
};
pub use grid::{Homography, MarkerLayout, Material};
pub use jpeg::{
    blockiness, flat_region_blockiness, ijg_luma_table, jpeg_quality, Blockiness, JpegQuality,
};
pub use levels::{
    marker_levels, marker_regions, region_stats, temporal_noise, Clipping, LevelOptions,
    MarkerLevels, MarkerRegions, RegionStats, TemporalNoise, MIN_PILE_FRACTION,
};
pub use motion::{rigid_motion, RigidMotion};
pub use noise::{
    texture_threshold, weak_texture_noise, WeakTextureNoise, WeakTextureOptions,
    MIN_NOISE_DIMS_SHARE, MIN_SELECTED_PER_DIM, WHITE_CONSISTENCY,
};
pub use shape::{square_fit, SquareFit};

use crate::detect::GrayView;
use thiserror::Error;

/// Why a statistic cannot be measured.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum StatsError {
    #[error("marker corners {corners_px:?} are degenerate: {reason}")]
    Degenerate {
        corners_px: [[f64; 2]; 4],
        reason: String,
    },
    #[error("{what} reaches outside the image view (x {x0}..{x1}, y {y0}..{y1})")]
    OutsideView {
        what: String,
        x0: i64,
        y0: i64,
        x1: i64,
        y1: i64,
    },
    #[error("{what}: {got} usable pixels or samples, need at least {need}")]
    TooFew {
        what: String,
        got: usize,
        need: usize,
    },
    #[error("{what}: the fit failed ({reason})")]
    NoFit { what: String, reason: String },
    #[error("invalid input: {0}")]
    Invalid(String),
}

/// Grey level of absolute pixel (x, y) of `view`, if inside it.
pub fn pixel_at(view: &GrayView<'_>, x: i64, y: i64) -> Option<u8> {
    pixel(view, x, y)
}

/// Grey level of absolute pixel (x, y), if inside the view.
#[inline]
pub(crate) fn pixel(view: &GrayView<'_>, x: i64, y: i64) -> Option<u8> {
    let lx = x - view.origin_px.0 as i64;
    let ly = y - view.origin_px.1 as i64;
    if lx < 0 || ly < 0 || lx >= view.width as i64 || ly >= view.height as i64 {
        return None;
    }
    view.data
        .get(ly as usize * view.width + lx as usize)
        .copied()
}

/// Absolute pixel bounds of the view, `(x0, y0, x1, y1)` inclusive.
pub(crate) fn view_bounds(view: &GrayView<'_>) -> (i64, i64, i64, i64) {
    let (ox, oy) = (view.origin_px.0 as i64, view.origin_px.1 as i64);
    (
        ox,
        oy,
        ox + view.width as i64 - 1,
        oy + view.height as i64 - 1,
    )
}

/// Checks that the view's buffer matches its size.
pub(crate) fn check_view(view: &GrayView<'_>) -> Result<(), StatsError> {
    if view.width == 0 || view.height == 0 || view.data.len() < view.width * view.height {
        return Err(StatsError::Invalid(format!(
            "image view of {}×{} px with {} bytes",
            view.width,
            view.height,
            view.data.len()
        )));
    }
    Ok(())
}
