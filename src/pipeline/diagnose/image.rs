//! Image statistics of one frame around the detected marker, for the diagnosis (the same
//! function on real and simulated frames): levels and noise of ink, paper and surround, the
//! blur of each outer side, and blockiness of the marker's neighbourhood.

use crate::detect::GrayView;
use crate::diagnose::record::{FrameImage, SideEdge};
use crate::estimate::Corners;
use crate::imagestats::{self, EdgeOptions, LevelOptions, MarkerLayout, MarkerRegions};
use crate::scenario::Scenario;

/// Edge fits on at most 800 pixels per side: the σ of a sharp edge is then known to a few
/// hundredths of a pixel, and a frame's four fits cost about a millisecond.
const EDGE_OPTIONS: EdgeOptions = EdgeOptions {
    sigma_hint_px: 2.5,
    half_width_px: None,
    max_samples: 800,
    min_samples: 40,
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

/// Blockiness of flat regions: the mean absolute difference between horizontally or vertically
/// adjacent pixels that straddle an 8-px block boundary (on the absolute grid), divided by the
/// same over pairs that do not, counting only pairs inside one flat region (ink, paper or
/// surround, away from every edge). Edges of the marker never enter, so an uncompressed frame
/// gives 1 up to noise wherever the marker sits; JPEG's block boundaries raise it. `None` with
/// fewer than 50 pairs of either kind.
pub fn flat_blockiness(view: &GrayView<'_>, regions: &MarkerRegions) -> Option<f64> {
    let (ox, oy) = (view.origin_px.0 as i64, view.origin_px.1 as i64);
    let value = |x: i64, y: i64| -> Option<f64> {
        let (lx, ly) = (x - ox, y - oy);
        if lx < 0 || ly < 0 || lx >= view.width as i64 || ly >= view.height as i64 {
            return None;
        }
        view.data
            .get(ly as usize * view.width + lx as usize)
            .map(|v| *v as f64)
    };
    let (mut on, mut n_on, mut off, mut n_off) = (0.0, 0usize, 0.0, 0usize);
    for pixels in [&regions.ink, &regions.paper, &regions.surround] {
        let set: std::collections::HashSet<(i64, i64)> = pixels.iter().copied().collect();
        for &(x, y) in pixels.iter() {
            for (dx, dy, coord) in [(1i64, 0i64, x + 1), (0, 1, y + 1)] {
                if !set.contains(&(x + dx, y + dy)) {
                    continue;
                }
                let (Some(a), Some(b)) = (value(x, y), value(x + dx, y + dy)) else {
                    continue;
                };
                if coord.rem_euclid(8) == 0 {
                    on += (a - b).abs();
                    n_on += 1;
                } else {
                    off += (a - b).abs();
                    n_off += 1;
                }
            }
        }
    }
    if n_on < 50 || n_off < 50 {
        return None;
    }
    let (m_on, m_off) = (on / n_on as f64, off / n_off as f64);
    // A frame without noise has no differences at all: no blocks to see.
    Some(if m_off > 1e-9 {
        m_on / m_off
    } else if m_on > 1e-9 {
        f64::INFINITY
    } else {
        1.0
    })
    .filter(|v| v.is_finite())
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
        out.blockiness = flat_blockiness(&view, &regions);
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
