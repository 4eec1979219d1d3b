//! Region-of-interest geometry for exact ROI detection (pure maths, no OpenCV).
//!
//! Why a margin makes ROI detection exact: every per-pixel decision of the ArUco candidate
//! search (adaptive threshold, contours, polygon fit, candidate grouping) depends only on pixels
//! within a bounded distance of the marker; outside that zone the window border changes the
//! threshold (BORDER_REPLICATE) and cuts contours. The margin below covers that distance.

use super::config::{CornerRefinement, DetectorConfig};

/// A detection window inside a frame: top-left `x0_px, y0_px`, size `width_px × height_px`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct RoiWindow {
    pub x0_px: i32,
    pub y0_px: i32,
    pub width_px: i32,
    pub height_px: i32,
}

/// Whether a configuration allows exact ROI detection, and if not, why.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RoiExactness {
    Exact,
    /// ArUco3 builds an image pyramid whose scale depends on the image size.
    NotExactAruco3,
    /// Contour refinement fits lines in float arithmetic on absolute coordinates, so the last
    /// bits depend on where the image origin is.
    NotExactContourRefinement,
    /// AprilTag quad detection thresholds in tiles anchored at the image origin and fits quads in
    /// float arithmetic on absolute coordinates.
    NotExactAprilTag,
}

/// Whether ROI detection can reproduce full-frame corners bit for bit under `cfg`.
pub fn roi_exactness(cfg: &DetectorConfig) -> RoiExactness {
    if cfg.use_aruco3_detection {
        return RoiExactness::NotExactAruco3;
    }
    match cfg.corner_refinement_method {
        CornerRefinement::None | CornerRefinement::Subpix => RoiExactness::Exact,
        CornerRefinement::Contour => RoiExactness::NotExactContourRefinement,
        CornerRefinement::Apriltag => RoiExactness::NotExactAprilTag,
    }
}

/// Distance a marker whose bounding box has perimeter `perimeter_px` must keep from any window
/// edge that is not a frame edge so that the window reproduces the full-frame candidates that
/// decide its corners:
/// * half the largest adaptive-threshold window (beyond it the threshold is the frame's);
/// * the reach of a candidate that can be grouped with the marker: OpenCV merges two candidates
///   when their mean squared corner distance is below (`min_marker_distance_rate` × the
///   smaller contour's point count)², so each corner of a grouped candidate lies within
///   2 · rate · N of a marker corner, and N ≤ the bounding-box perimeter (an 8-connected
///   convex contour has Σ max(|dx|, |dy|) ≤ Σ (|dx| + |dy|) points);
/// * how far that candidate's contour may stray from its quad (the polygon tolerance,
///   `polygonal_approx_accuracy_rate` × its point count, at most the perimeter of a box grown
///   by the corner reach on every side);
/// * the border-distance rule and 2 px for the contour's 8-neighbourhood.
///
/// Chains of groupings (a candidate grouped with a grouped candidate) are not bounded by this;
/// `tests/detect_roi.rs` checks ROI against full-frame detection on hundreds of rendered frames.
pub fn required_margin_px(cfg: &DetectorConfig, perimeter_px: f64) -> f64 {
    let half_window = cfg
        .threshold_window_sizes_px()
        .into_iter()
        .max()
        .unwrap_or(3)
        / 2;
    let corner_reach = 2.0 * cfg.min_marker_distance_rate * perimeter_px;
    let candidate_perimeter = perimeter_px + 8.0 * corner_reach;
    let stray = corner_reach + cfg.polygonal_approx_accuracy_rate * candidate_perimeter;
    f64::from(half_window) + stray.ceil() + f64::from(cfg.min_distance_to_border_px.max(0)) + 2.0
}

/// The window around a predicted marker bounding box `(x_min, y_min, x_max, y_max)` px, grown by
/// [`required_margin_px`] for a marker of that size plus `cfg.roi.margin_px` of allowance for
/// prediction error, clamped to the frame. `None` when the box is not finite or misses the frame.
pub fn roi_window(
    cfg: &DetectorConfig,
    predicted_bbox_px: (f64, f64, f64, f64),
    frame_width_px: usize,
    frame_height_px: usize,
) -> Option<RoiWindow> {
    let (x_min, y_min, x_max, y_max) = predicted_bbox_px;
    if ![x_min, y_min, x_max, y_max].iter().all(|v| v.is_finite()) || x_max < x_min || y_max < y_min
    {
        return None;
    }
    let perimeter_px = 2.0 * ((x_max - x_min) + (y_max - y_min));
    let margin = required_margin_px(cfg, perimeter_px) + f64::from(cfg.roi.margin_px);
    let (w, h) = (frame_width_px as f64, frame_height_px as f64);
    let x0 = (x_min - margin).floor().max(0.0);
    let y0 = (y_min - margin).floor().max(0.0);
    let x1 = (x_max + margin).ceil().min(w - 1.0);
    let y1 = (y_max + margin).ceil().min(h - 1.0);
    if x1 < x0 || y1 < y0 {
        return None;
    }
    Some(RoiWindow {
        x0_px: x0 as i32,
        y0_px: y0 as i32,
        width_px: (x1 - x0) as i32 + 1,
        height_px: (y1 - y0) as i32 + 1,
    })
}

/// True when the quad with absolute corners `corners_px` keeps [`required_margin_px`] from every
/// window edge that is not also a frame edge (edges on the frame border behave as in the frame).
pub fn corners_inside_exact_zone(
    cfg: &DetectorConfig,
    window: RoiWindow,
    corners_px: &[[f64; 2]; 4],
    frame_width_px: usize,
    frame_height_px: usize,
) -> bool {
    let mut perimeter_px = 0.0;
    for i in 0..4 {
        let (a, b) = (corners_px[i], corners_px[(i + 1) % 4]);
        perimeter_px += (a[0] - b[0]).hypot(a[1] - b[1]);
    }
    let need = required_margin_px(cfg, perimeter_px);
    let x_lo = f64::from(window.x0_px);
    let y_lo = f64::from(window.y0_px);
    let x_hi = f64::from(window.x0_px + window.width_px - 1);
    let y_hi = f64::from(window.y0_px + window.height_px - 1);
    let left_is_frame = window.x0_px == 0;
    let top_is_frame = window.y0_px == 0;
    let right_is_frame = (window.x0_px + window.width_px) as usize >= frame_width_px;
    let bottom_is_frame = (window.y0_px + window.height_px) as usize >= frame_height_px;
    corners_px.iter().all(|p| {
        (left_is_frame || p[0] - x_lo >= need)
            && (top_is_frame || p[1] - y_lo >= need)
            && (right_is_frame || x_hi - p[0] >= need)
            && (bottom_is_frame || y_hi - p[1] >= need)
    })
}

/// OpenCV compares contour lengths with `(unsigned)(rate × max(cols, rows))`; this returns the
/// rate that gives the same integer limit on a window of largest dimension `window_max_dim_px`.
pub fn window_perimeter_rate(rate: f64, frame_max_dim_px: usize, window_max_dim_px: usize) -> f64 {
    let limit = (rate * frame_max_dim_px as f64).floor();
    (limit + 0.5) / window_max_dim_px as f64
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn window_contains_box_plus_required_margin_and_is_clamped() {
        let cfg = DetectorConfig::default();
        let w = roi_window(&cfg, (1000.0, 500.0, 1165.0, 662.0), 3840, 2160).unwrap();
        let need = required_margin_px(&cfg, 2.0 * (165.0 + 162.0));
        assert!(need >= 11.0 + 3.0);
        assert!(f64::from(w.x0_px) <= 1000.0 - need && f64::from(w.y0_px) <= 500.0 - need);
        assert!(f64::from(w.x0_px + w.width_px - 1) >= 1165.0 + need);
        let w = roi_window(&cfg, (5.0, 5.0, 50.0, 50.0), 100, 80).unwrap();
        assert_eq!((w.x0_px, w.y0_px, w.width_px, w.height_px), (0, 0, 100, 80));
        assert!(roi_window(&cfg, (f64::NAN, 0.0, 1.0, 1.0), 100, 80).is_none());
        assert!(roi_window(&cfg, (500.0, 500.0, 600.0, 600.0), 100, 80).is_none());
    }

    #[test]
    fn exact_zone_ignores_frame_edges_only() {
        let cfg = DetectorConfig::default();
        let corners = [[2.0, 2.0], [40.0, 2.0], [40.0, 40.0], [2.0, 40.0]];
        let at_frame_corner = RoiWindow {
            x0_px: 0,
            y0_px: 0,
            width_px: 200,
            height_px: 200,
        };
        assert!(corners_inside_exact_zone(
            &cfg,
            at_frame_corner,
            &corners,
            1000,
            1000
        ));
        let inner = RoiWindow {
            x0_px: 1,
            y0_px: 0,
            width_px: 200,
            height_px: 200,
        };
        assert!(!corners_inside_exact_zone(
            &cfg, inner, &corners, 1000, 1000
        ));
    }

    #[test]
    fn perimeter_rate_reproduces_integer_limit() {
        for (rate, frame, window) in [
            (0.03, 3840usize, 400usize),
            (4.0, 3840, 257),
            (0.03, 33, 1000),
        ] {
            let limit = (rate * frame as f64) as u32;
            let r = window_perimeter_rate(rate, frame, window);
            assert_eq!((r * window as f64) as u32, limit);
        }
    }

    #[test]
    fn contour_apriltag_and_aruco3_are_not_exact() {
        let mut cfg = DetectorConfig::default();
        assert_eq!(roi_exactness(&cfg), RoiExactness::Exact);
        cfg.corner_refinement_method = CornerRefinement::Contour;
        assert_eq!(roi_exactness(&cfg), RoiExactness::NotExactContourRefinement);
        cfg.corner_refinement_method = CornerRefinement::Subpix;
        cfg.use_aruco3_detection = true;
        assert_eq!(roi_exactness(&cfg), RoiExactness::NotExactAruco3);
    }
}
