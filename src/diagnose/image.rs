//! Image statistics of one frame around the detected marker, for the diagnosis (the same
//! function on real and simulated frames): levels and noise of ink, paper and surround, the
//! blur of each outer side, and blockiness of the marker's neighbourhood.

use crate::detect::GrayView;
use crate::diagnose::record::{FrameImage, SideEdge};
use crate::estimate::Corners;
use crate::imagestats::{self, EdgeOptions, LevelOptions, MarkerLayout};
use crate::scenario::Scenario;

/// Edge fits on at most 800 pixels per side: the σ of a sharp edge is then known to a few
/// hundredths of a pixel; the four fits are still the costliest part of a simulated measurement.
const EDGE_OPTIONS: EdgeOptions = EdgeOptions {
    sigma_hint_px: 2.5,
    half_width_px: None,
    max_samples: 800,
    min_samples: 40,
    sharpening: None,
};

/// Frames measured for image statistics: at most about [`IMAGE_FRAMES`] of them, every
/// `stride`-th by frame index (the same frames of real and simulated footage). The statistics are
/// per-phase means, which this many frames pin down far below the model tolerance, and the edge
/// fits are the costliest part of a simulated measurement.
pub const IMAGE_FRAMES: usize = 60;

/// Whether frame `index` of `frames` gets image statistics.
pub fn measures_image(index: usize, frames: usize) -> bool {
    index % frames.div_ceil(IMAGE_FRAMES).max(1) == 0
}

/// The printed layout of the scenario's moving marker.
pub fn marker_layout(s: &Scenario) -> Result<MarkerLayout, imagestats::StatsError> {
    let m = &s.scene.marker;
    MarkerLayout::new(
        m.dictionary,
        m.id,
        m.border_bits,
        Some(m.white_margin_mm / m.size_mm),
    )
}

/// Statistics of `view` around the marker at `corners` (fields the frame does not allow are
/// `None`).
pub fn frame_image(view: GrayView<'_>, corners: &Corners, layout: &MarkerLayout) -> FrameImage {
    let mut out = FrameImage::default();
    let options = LevelOptions::default();
    if let Ok(regions) = imagestats::marker_regions(&view, corners, layout, &options) {
        let stats = |pixels: &[(i64, i64)], what: &str| {
            imagestats::region_stats(&view, pixels, what, options.min_pixels).ok()
        };
        if let Some(ink) = stats(&regions.ink, "ink") {
            out.ink_dn = Some(ink.trimmed_mean_dn);
            out.noise_ink_dn = Some(ink.noise_sigma_dn);
        }
        if let Some(paper) = stats(&regions.paper, "paper") {
            out.paper_dn = Some(paper.trimmed_mean_dn);
            out.noise_paper_dn = Some(paper.noise_sigma_dn);
        }
        out.background_dn = stats(&regions.surround, "surround").map(|s| s.trimmed_mean_dn);
        out.blockiness = imagestats::flat_region_blockiness(&view, &regions);
    }
    let edges = imagestats::outer_edge_profiles(&view, corners, layout, &EDGE_OPTIONS);
    for (slot, e) in out.edges.iter_mut().zip(&edges) {
        *slot = e
            .as_ref()
            .ok()
            .filter(|p| p.sigma_px.is_finite())
            .map(|p| SideEdge {
                sigma_px: p.sigma_px,
                normal: p.normal,
            });
    }
    let fitted: Vec<imagestats::EdgeProfile> = edges
        .into_iter()
        .filter_map(|e| e.ok())
        .filter(|p| p.sigma_px.is_finite() && p.offset_px.is_finite())
        .collect();
    out.refined_corners_px = imagestats::refined_corners(&fitted, layout.side_cells())
        .filter(|c| c.iter().flatten().all(|v| v.is_finite()));
    out
}
