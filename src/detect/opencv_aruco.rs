//! OpenCV ArUco detection (feature `opencv-detector`): full-frame detection and ROI detection
//! that returns exactly the full-frame corners or falls back to the full frame.
//!
//! ROI exactness (OpenCV 4.6 contrib `aruco::detectMarkers`): the window is detected with
//! refinement off and the perimeter limits rescaled to the window size; the marker must keep
//! [`required_margin_px`] from every window edge that is not a frame edge; SUBPIX refinement then
//! runs `cornerSubPix` on the *full* frame with the same starting corners and criteria that
//! `detectMarkers` uses, so the float arithmetic sees the same absolute coordinates. CONTOUR and
//! APRILTAG refinement and ArUco3 mode are not translation-exact (see [`RoiExactness`]) and fall
//! back to the full frame. With OpenCV ≥ 4.7 (`objdetect::ArucoDetector`) the ROI path is not
//! verified and always falls back.

use super::config::{parse_dictionary, CornerRefinement, DetectorConfig};
#[cfg(doc)]
use super::roi::required_margin_px;
use super::roi::{
    corners_inside_exact_zone, roi_exactness, roi_window, window_perimeter_rate, RoiExactness,
};
use super::types::{Detection, GrayView};
use crate::validation::Problems;
use opencv::core::{Mat, Point2f, Vector};

#[derive(Debug, thiserror::Error)]
pub enum DetectError {
    #[error("invalid detector config: {0}")]
    Config(String),
    #[error("image is {width}x{height} px but holds {got} bytes (expected {expected})")]
    ImageSize {
        width: usize,
        height: usize,
        expected: usize,
        got: usize,
    },
    #[error("OpenCV")]
    OpenCv(#[from] opencv::Error),
}

/// Why a ROI request was answered from the full frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RoiFallback {
    /// The configuration cannot be made exact in a window.
    NotExact(RoiExactness),
    /// OpenCV ≥ 4.7: the window path is not verified against this detector version.
    UnverifiedOpenCvVersion,
    /// The predicted box is not finite or lies outside the frame.
    NoWindow,
    /// The marker was not (or more than once) found in the window.
    NotFoundInWindow,
    /// The marker came too close to a window edge for the window to be exact.
    NearWindowEdge,
}

/// How a [`MarkerObservation`] was obtained.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DetectionPath {
    FullFrame,
    Roi,
    RoiFallback(RoiFallback),
}

/// The tracked marker in one frame: `None` when it was not detected (never interpolated).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MarkerObservation {
    pub detection: Option<Detection>,
    pub path: DetectionPath,
}

/// An ArUco detector for one [`DetectorConfig`]. OpenCV objects are built per call: the 4.6
/// `detectMarkers` writes into its parameters, so sharing them across threads would race.
#[derive(Debug, Clone)]
pub struct ArucoDetector {
    cfg: DetectorConfig,
    dictionary_code: i32,
}

fn check_image(image: &GrayView<'_>) -> Result<(), DetectError> {
    let expected = image.width * image.height;
    if image.width == 0
        || image.height == 0
        || image.data.len() != expected
        || image.width > i32::MAX as usize
        || image.height > i32::MAX as usize
    {
        return Err(DetectError::ImageSize {
            width: image.width,
            height: image.height,
            expected,
            got: image.data.len(),
        });
    }
    Ok(())
}

impl ArucoDetector {
    pub fn new(cfg: &DetectorConfig) -> Result<Self, DetectError> {
        let mut problems = Problems::new();
        cfg.validate("detector", &mut problems);
        if !problems.is_empty() {
            let text: Vec<String> = problems.iter().map(|p| p.to_string()).collect();
            return Err(DetectError::Config(text.join("; ")));
        }
        let dictionary_code = parse_dictionary(&cfg.dictionary)
            .map(|d| d.opencv_code)
            .unwrap_or(0);
        Ok(Self {
            cfg: cfg.clone(),
            dictionary_code,
        })
    }

    pub fn config(&self) -> &DetectorConfig {
        &self.cfg
    }

    /// All markers in `image`, corners in absolute pixels (`origin_px` added), OpenCV order.
    pub fn detect(&self, image: GrayView<'_>) -> Result<Vec<Detection>, DetectError> {
        check_image(&image)?;
        let mat =
            Mat::new_rows_cols_with_data(image.height as i32, image.width as i32, image.data)?;
        let raw = backend::detect(&mat, self.dictionary_code, &self.cfg)?;
        Ok(raw
            .into_iter()
            .map(|(id, c)| to_detection(id, &c, image.origin_px))
            .collect())
    }

    /// The marker `marker_id` in a full frame (`frame.origin_px` is ignored). With ROI enabled
    /// and a predicted bounding box `(x_min, y_min, x_max, y_max)` px, detects in a window and
    /// guarantees the corners full-frame detection would give, falling back when it cannot.
    pub fn detect_marker(
        &self,
        frame: GrayView<'_>,
        marker_id: i32,
        predicted_bbox_px: Option<(f64, f64, f64, f64)>,
    ) -> Result<MarkerObservation, DetectError> {
        let frame = GrayView {
            origin_px: (0, 0),
            ..frame
        };
        let Some(bbox) = predicted_bbox_px.filter(|_| self.cfg.roi.enabled) else {
            return self.full_frame_marker(frame, marker_id, DetectionPath::FullFrame);
        };
        let fallback =
            |reason| self.full_frame_marker(frame, marker_id, DetectionPath::RoiFallback(reason));
        if cfg!(opencv_aruco_objdetect) {
            return fallback(RoiFallback::UnverifiedOpenCvVersion);
        }
        let exactness = roi_exactness(&self.cfg);
        if exactness != RoiExactness::Exact {
            return fallback(RoiFallback::NotExact(exactness));
        }
        check_image(&frame)?;
        let Some(win) = roi_window(&self.cfg, bbox, frame.width, frame.height) else {
            return fallback(RoiFallback::NoWindow);
        };
        let (x0, y0) = (win.x0_px as usize, win.y0_px as usize);
        let (ww, wh) = (win.width_px as usize, win.height_px as usize);
        let mut pixels = Vec::with_capacity(ww * wh);
        for row in frame.data.chunks_exact(frame.width).skip(y0).take(wh) {
            pixels.extend_from_slice(&row[x0..x0 + ww]);
        }
        let frame_max = frame.width.max(frame.height);
        let window_max = ww.max(wh);
        let mut wcfg = self.cfg.clone();
        wcfg.corner_refinement_method = CornerRefinement::None;
        wcfg.min_marker_perimeter_rate =
            window_perimeter_rate(self.cfg.min_marker_perimeter_rate, frame_max, window_max);
        wcfg.max_marker_perimeter_rate =
            window_perimeter_rate(self.cfg.max_marker_perimeter_rate, frame_max, window_max);
        let wmat = Mat::new_rows_cols_with_data(wh as i32, ww as i32, &pixels)?;
        let found: Vec<_> = backend::detect(&wmat, self.dictionary_code, &wcfg)?
            .into_iter()
            .filter(|(id, _)| *id == marker_id)
            .collect();
        let [(id, corners)] = found.as_slice() else {
            return fallback(RoiFallback::NotFoundInWindow);
        };
        let mut det = to_detection(*id, corners, (win.x0_px, win.y0_px));
        if !corners_inside_exact_zone(&self.cfg, win, &det.corners_px, frame.width, frame.height) {
            return fallback(RoiFallback::NearWindowEdge);
        }
        if self.cfg.corner_refinement_method == CornerRefinement::Subpix {
            // Integer contour corners shift exactly, so this is the call detectMarkers makes.
            let mut pts: Vector<Point2f> = det
                .corners_px
                .iter()
                .map(|p| Point2f::new(p[0] as f32, p[1] as f32))
                .collect();
            let full =
                Mat::new_rows_cols_with_data(frame.height as i32, frame.width as i32, frame.data)?;
            backend::subpix(&full, &mut pts, &self.cfg)?;
            for (i, p) in pts.iter().enumerate() {
                det.corners_px[i] = [f64::from(p.x), f64::from(p.y)];
            }
        }
        Ok(MarkerObservation {
            detection: Some(det),
            path: DetectionPath::Roi,
        })
    }

    fn full_frame_marker(
        &self,
        frame: GrayView<'_>,
        marker_id: i32,
        path: DetectionPath,
    ) -> Result<MarkerObservation, DetectError> {
        let detection = self.detect(frame)?.into_iter().find(|d| d.id == marker_id);
        Ok(MarkerObservation { detection, path })
    }
}

fn to_detection(id: i32, corners: &[Point2f; 4], origin_px: (i32, i32)) -> Detection {
    let (ox, oy) = (f64::from(origin_px.0), f64::from(origin_px.1));
    // f32 → f64 plus an integer origin is exact, so absolute corners keep every bit.
    Detection {
        id,
        corners_px: corners.map(|p| [f64::from(p.x) + ox, f64::from(p.y) + oy]),
    }
}

/// Sets every `DetectorParameters` field from a [`DetectorConfig`]: the same setters exist on the
/// 4.6 `aruco` and the 4.7+ `objdetect` parameter types, which share no trait.
macro_rules! set_detector_parameters {
    ($p:ident, $cfg:ident) => {{
        $p.set_adaptive_thresh_win_size_min($cfg.adaptive_thresh_win_size_min_px);
        $p.set_adaptive_thresh_win_size_max($cfg.adaptive_thresh_win_size_max_px);
        $p.set_adaptive_thresh_win_size_step($cfg.adaptive_thresh_win_size_step_px);
        $p.set_adaptive_thresh_constant($cfg.adaptive_thresh_constant_dn);
        $p.set_min_marker_perimeter_rate($cfg.min_marker_perimeter_rate);
        $p.set_max_marker_perimeter_rate($cfg.max_marker_perimeter_rate);
        $p.set_polygonal_approx_accuracy_rate($cfg.polygonal_approx_accuracy_rate);
        $p.set_min_corner_distance_rate($cfg.min_corner_distance_rate);
        $p.set_min_distance_to_border($cfg.min_distance_to_border_px);
        $p.set_min_marker_distance_rate($cfg.min_marker_distance_rate);
        $p.set_corner_refinement_method($cfg.corner_refinement_method.opencv_code());
        $p.set_corner_refinement_win_size($cfg.corner_refinement_win_size_px);
        $p.set_corner_refinement_max_iterations($cfg.corner_refinement_max_iterations);
        $p.set_corner_refinement_min_accuracy($cfg.corner_refinement_min_accuracy_px);
        $p.set_marker_border_bits($cfg.marker_border_bits);
        $p.set_perspective_remove_pixel_per_cell($cfg.perspective_remove_pixel_per_cell_px);
        $p.set_perspective_remove_ignored_margin_per_cell(
            $cfg.perspective_remove_ignored_margin_per_cell,
        );
        $p.set_max_erroneous_bits_in_border_rate($cfg.max_erroneous_bits_in_border_rate);
        $p.set_min_otsu_std_dev($cfg.min_otsu_std_dev_dn);
        $p.set_error_correction_rate($cfg.error_correction_rate);
        $p.set_april_tag_quad_decimate($cfg.april_tag_quad_decimate);
        $p.set_april_tag_quad_sigma($cfg.april_tag_quad_sigma_px);
        $p.set_april_tag_min_cluster_pixels($cfg.april_tag_min_cluster_pixels);
        $p.set_april_tag_max_nmaxima($cfg.april_tag_max_nmaxima);
        $p.set_april_tag_critical_rad($cfg.april_tag_critical_rad);
        $p.set_april_tag_max_line_fit_mse($cfg.april_tag_max_line_fit_mse_px2);
        $p.set_april_tag_min_white_black_diff($cfg.april_tag_min_white_black_diff_dn);
        $p.set_april_tag_deglitch(i32::from($cfg.april_tag_deglitch));
        $p.set_detect_inverted_marker($cfg.detect_inverted_marker);
        $p.set_use_aruco3_detection($cfg.use_aruco3_detection);
        $p.set_min_side_length_canonical_img($cfg.min_side_length_canonical_img_px);
        $p.set_min_marker_length_ratio_original_img($cfg.min_marker_length_ratio_original_img);
    }};
}

/// OpenCV 4.6 contrib `aruco` API.
#[cfg(not(opencv_aruco_objdetect))]
mod backend {
    use super::super::config::DetectorConfig;
    use opencv::aruco::{self, DetectorParametersTrait};
    use opencv::core::{Point2f, Size, TermCriteria, TermCriteria_Type, ToInputArray, Vector};

    pub fn parameters(
        cfg: &DetectorConfig,
    ) -> opencv::Result<opencv::core::Ptr<aruco::DetectorParameters>> {
        let mut p = aruco::DetectorParameters::create()?;
        set_detector_parameters!(p, cfg);
        Ok(p)
    }

    pub fn detect(
        image: &impl ToInputArray,
        dictionary_code: i32,
        cfg: &DetectorConfig,
    ) -> opencv::Result<Vec<(i32, [Point2f; 4])>> {
        let dictionary = aruco::get_predefined_dictionary_i32(dictionary_code)?;
        let params = parameters(cfg)?;
        let mut corners: Vector<Vector<Point2f>> = Vector::new();
        let mut ids: Vector<i32> = Vector::new();
        let mut rejected: Vector<Vector<Point2f>> = Vector::new();
        aruco::detect_markers(
            image,
            &dictionary,
            &mut corners,
            &mut ids,
            &params,
            &mut rejected,
        )?;
        let mut out = Vec::with_capacity(ids.len());
        for (id, c) in ids.iter().zip(corners.iter()) {
            // detectMarkers always returns four corners per marker.
            out.push((id, [c.get(0)?, c.get(1)?, c.get(2)?, c.get(3)?]));
        }
        Ok(out)
    }

    /// The `cornerSubPix` call `detectMarkers` makes for CORNER_REFINE_SUBPIX.
    pub fn subpix(
        image: &impl ToInputArray,
        pts: &mut Vector<Point2f>,
        cfg: &DetectorConfig,
    ) -> opencv::Result<()> {
        let w = cfg.corner_refinement_win_size_px;
        let criteria = TermCriteria::new(
            TermCriteria_Type::COUNT as i32 | TermCriteria_Type::EPS as i32,
            cfg.corner_refinement_max_iterations,
            cfg.corner_refinement_min_accuracy_px,
        )?;
        opencv::imgproc::corner_sub_pix(image, pts, Size::new(w, w), Size::new(-1, -1), criteria)
    }
}

/// OpenCV ≥ 4.7 `objdetect::ArucoDetector` API. Not compiled or tested here (OpenCV 4.6); needs
/// the opencv crate's `objdetect` feature. ROI detection falls back to full frame on this path.
#[cfg(opencv_aruco_objdetect)]
mod backend {
    use super::super::config::DetectorConfig;
    use opencv::core::{Point2f, ToInputArray, Vector};
    use opencv::objdetect::{self, DetectorParametersTrait};
    use opencv::prelude::*;

    pub fn detect(
        image: &impl ToInputArray,
        dictionary_code: i32,
        cfg: &DetectorConfig,
    ) -> opencv::Result<Vec<(i32, [Point2f; 4])>> {
        let dictionary = objdetect::get_predefined_dictionary_i32(dictionary_code)?;
        let mut p = objdetect::DetectorParameters::default()?;
        set_detector_parameters!(p, cfg);
        let refine = objdetect::RefineParameters::new_def()?;
        let detector = objdetect::ArucoDetector::new(&dictionary, &p, refine)?;
        let mut corners: Vector<Vector<Point2f>> = Vector::new();
        let mut ids: Vector<i32> = Vector::new();
        let mut rejected: Vector<Vector<Point2f>> = Vector::new();
        detector.detect_markers(image, &mut corners, &mut ids, &mut rejected)?;
        let mut out = Vec::with_capacity(ids.len());
        for (id, c) in ids.iter().zip(corners.iter()) {
            out.push((id, [c.get(0)?, c.get(1)?, c.get(2)?, c.get(3)?]));
        }
        Ok(out)
    }

    pub fn subpix(
        _: &impl ToInputArray,
        _: &mut Vector<Point2f>,
        _: &DetectorConfig,
    ) -> opencv::Result<()> {
        // Unreachable: the ROI path falls back to full frame on OpenCV >= 4.7.
        Ok(())
    }
}

#[cfg(not(opencv_aruco_objdetect))]
pub use backend::parameters as opencv_parameters;
