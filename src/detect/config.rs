//! `[detector]` scenario section: which ArUco dictionary and marker to track, every OpenCV 4.6
//! `aruco::DetectorParameters` field (snake_case, unit-suffixed, OpenCV's defaults), and the
//! region-of-interest option. Compiles without OpenCV so scenarios load in the pure core.

use crate::validation::{join, Problems};
use serde::{Deserialize, Serialize};

/// OpenCV's `cornerRefinementMethod`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum CornerRefinement {
    /// `CORNER_REFINE_NONE`: corners are contour pixels (centre of the outermost dark pixel).
    #[default]
    None,
    /// `CORNER_REFINE_SUBPIX`: `cornerSubPix` on the grey image.
    Subpix,
    /// `CORNER_REFINE_CONTOUR`: line fits through the contour points.
    Contour,
    /// `CORNER_REFINE_APRILTAG`: AprilTag 2 quad detection replaces the ArUco candidate search.
    Apriltag,
}

impl CornerRefinement {
    /// OpenCV's integer code for the method.
    pub fn opencv_code(self) -> i32 {
        match self {
            CornerRefinement::None => 0,
            CornerRefinement::Subpix => 1,
            CornerRefinement::Contour => 2,
            CornerRefinement::Apriltag => 3,
        }
    }
}

/// Region-of-interest detection: detect in a window around the predicted marker instead of the
/// whole frame; the detector guarantees the same corners as full-frame detection or falls back.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct RoiConfig {
    /// Use ROI detection when a predicted bounding box is available. Default: true (it returns
    /// exactly the corners full-frame detection returns, and falls back to the full frame when
    /// it cannot guarantee that).
    pub enabled: bool,
    /// Allowance for prediction error, px: added around the predicted bounding box on top of the
    /// minimum margin that keeps ROI results exact (threshold window, reach of a candidate that
    /// can be grouped with the marker, border distance). Default: 32.
    pub margin_px: u32,
}

impl Default for RoiConfig {
    fn default() -> Self {
        Self {
            enabled: true,
            margin_px: 32,
        }
    }
}

impl RoiConfig {
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        problems.range(
            join(path, "margin_px"),
            f64::from(self.margin_px),
            0.0,
            10_000.0,
        );
    }
}

/// `[detector]`: ArUco detection settings. Parameter defaults are OpenCV 4.6's
/// `DetectorParameters` defaults (the seed study used them: no corner refinement).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct DetectorConfig {
    /// ArUco dictionary, e.g. "4x4_50" or OpenCV's "DICT_4X4_50"; also "aruco_original",
    /// "apriltag_36h11" etc. Default: "4x4_50".
    pub dictionary: String,
    /// Id of the marker on the moving (driven) disc. Default: 0.
    pub marker_id: i32,
    /// Id of an optional fixed reference marker (camera-motion check). Default: none.
    pub reference_marker_id: Option<i32>,
    /// Region-of-interest detection. Default: disabled, margin 32 px.
    pub roi: RoiConfig,
    /// `adaptiveThreshWinSizeMin`, px. Default: 3.
    pub adaptive_thresh_win_size_min_px: i32,
    /// `adaptiveThreshWinSizeMax`, px. Default: 23.
    pub adaptive_thresh_win_size_max_px: i32,
    /// `adaptiveThreshWinSizeStep`, px. Default: 10.
    pub adaptive_thresh_win_size_step_px: i32,
    /// `adaptiveThreshConstant`, grey levels subtracted from the local mean. Default: 7.
    pub adaptive_thresh_constant_dn: f64,
    /// `minMarkerPerimeterRate`, marker perimeter / largest image dimension. Default: 0.03.
    pub min_marker_perimeter_rate: f64,
    /// `maxMarkerPerimeterRate`, marker perimeter / largest image dimension. Default: 4.
    pub max_marker_perimeter_rate: f64,
    /// `polygonalApproxAccuracyRate`, polygon approximation tolerance / contour length. Default: 0.03.
    pub polygonal_approx_accuracy_rate: f64,
    /// `minCornerDistanceRate`, smallest corner distance / perimeter. Default: 0.05.
    pub min_corner_distance_rate: f64,
    /// `minDistanceToBorder`, px from the image border. Default: 3.
    pub min_distance_to_border_px: i32,
    /// `minMarkerDistanceRate`, mean corner distance / perimeter below which two candidates
    /// merge. Default: 0.05.
    pub min_marker_distance_rate: f64,
    /// `cornerRefinementMethod`: "none" | "subpix" | "contour" | "apriltag". Default: "none".
    pub corner_refinement_method: CornerRefinement,
    /// `cornerRefinementWinSize`, half window, px. Default: 5.
    pub corner_refinement_win_size_px: i32,
    /// `cornerRefinementMaxIterations`. Default: 30.
    pub corner_refinement_max_iterations: i32,
    /// `cornerRefinementMinAccuracy`, px (stop when a step is smaller). Default: 0.1.
    pub corner_refinement_min_accuracy_px: f64,
    /// `markerBorderBits`, border width in cells. Default: 1.
    pub marker_border_bits: i32,
    /// `perspectiveRemovePixelPerCell`, px per cell in the rectified marker. Default: 4.
    pub perspective_remove_pixel_per_cell_px: i32,
    /// `perspectiveRemoveIgnoredMarginPerCell`, fraction of a cell ignored at its edge. Default: 0.13.
    pub perspective_remove_ignored_margin_per_cell: f64,
    /// `maxErroneousBitsInBorderRate`, fraction of border bits allowed wrong. Default: 0.35.
    pub max_erroneous_bits_in_border_rate: f64,
    /// `minOtsuStdDev`, grey levels; below it a cell image is treated as uniform. Default: 5.
    pub min_otsu_std_dev_dn: f64,
    /// `errorCorrectionRate`, fraction of the dictionary's correction capacity used. Default: 0.6.
    pub error_correction_rate: f64,
    /// `aprilTagQuadDecimate`, image decimation factor (0: none). Default: 0.
    pub april_tag_quad_decimate: f32,
    /// `aprilTagQuadSigma`, Gaussian blur sigma, px (0: none). Default: 0.
    pub april_tag_quad_sigma_px: f32,
    /// `aprilTagMinClusterPixels`, px. Default: 5.
    pub april_tag_min_cluster_pixels: i32,
    /// `aprilTagMaxNmaxima`, corner candidates tried per quad. Default: 10.
    pub april_tag_max_nmaxima: i32,
    /// `aprilTagCriticalRad`, rad; quads with a corner angle closer to 0 or π are rejected.
    /// Default: 10° = 0.17453292.
    pub april_tag_critical_rad: f32,
    /// `aprilTagMaxLineFitMse`, px². Default: 10.
    pub april_tag_max_line_fit_mse_px2: f32,
    /// `aprilTagMinWhiteBlackDiff`, grey levels. Default: 5.
    pub april_tag_min_white_black_diff_dn: i32,
    /// `aprilTagDeglitch`. Default: false.
    pub april_tag_deglitch: bool,
    /// `detectInvertedMarker`: also detect white-on-black markers. Default: false.
    pub detect_inverted_marker: bool,
    /// `useAruco3Detection`: image-pyramid detection (forces subpix refinement). Default: false.
    pub use_aruco3_detection: bool,
    /// `minSideLengthCanonicalImg`, px (ArUco3 only). Default: 32.
    pub min_side_length_canonical_img_px: i32,
    /// `minMarkerLengthRatioOriginalImg`, marker side / largest image dimension (ArUco3 only).
    /// Default: 0.
    pub min_marker_length_ratio_original_img: f32,
}

impl Default for DetectorConfig {
    fn default() -> Self {
        Self {
            dictionary: "4x4_50".to_string(),
            marker_id: 0,
            reference_marker_id: None,
            roi: RoiConfig::default(),
            adaptive_thresh_win_size_min_px: 3,
            adaptive_thresh_win_size_max_px: 23,
            adaptive_thresh_win_size_step_px: 10,
            adaptive_thresh_constant_dn: 7.0,
            min_marker_perimeter_rate: 0.03,
            max_marker_perimeter_rate: 4.0,
            polygonal_approx_accuracy_rate: 0.03,
            min_corner_distance_rate: 0.05,
            min_distance_to_border_px: 3,
            min_marker_distance_rate: 0.05,
            corner_refinement_method: CornerRefinement::None,
            corner_refinement_win_size_px: 5,
            corner_refinement_max_iterations: 30,
            corner_refinement_min_accuracy_px: 0.1,
            marker_border_bits: 1,
            perspective_remove_pixel_per_cell_px: 4,
            perspective_remove_ignored_margin_per_cell: 0.13,
            max_erroneous_bits_in_border_rate: 0.35,
            min_otsu_std_dev_dn: 5.0,
            error_correction_rate: 0.6,
            april_tag_quad_decimate: 0.0,
            april_tag_quad_sigma_px: 0.0,
            april_tag_min_cluster_pixels: 5,
            april_tag_max_nmaxima: 10,
            april_tag_critical_rad: (10.0 * std::f64::consts::PI / 180.0) as f32,
            april_tag_max_line_fit_mse_px2: 10.0,
            april_tag_min_white_black_diff_dn: 5,
            april_tag_deglitch: false,
            detect_inverted_marker: false,
            use_aruco3_detection: false,
            min_side_length_canonical_img_px: 32,
            min_marker_length_ratio_original_img: 0.0,
        }
    }
}

/// A predefined dictionary: OpenCV's `PREDEFINED_DICTIONARY_NAME` code and its marker count.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct DictionaryInfo {
    pub opencv_code: i32,
    pub marker_count: i32,
}

/// Parses "4x4_50", "DICT_4X4_50", "aruco_original", "apriltag_36h11" (case-insensitive).
pub fn parse_dictionary(name: &str) -> Option<DictionaryInfo> {
    let lower = name.trim().to_ascii_lowercase();
    let short = lower.strip_prefix("dict_").unwrap_or(&lower);
    let named = [
        ("aruco_original", 16, 1024),
        ("apriltag_16h5", 17, 30),
        ("apriltag_25h9", 18, 35),
        ("apriltag_36h10", 19, 2320),
        ("apriltag_36h11", 20, 587),
    ];
    if let Some(&(_, code, count)) = named.iter().find(|(n, _, _)| *n == short) {
        return Some(DictionaryInfo {
            opencv_code: code,
            marker_count: count,
        });
    }
    let (bits, count) = short.split_once('_')?;
    let size: i32 = match bits {
        "4x4" => 0,
        "5x5" => 1,
        "6x6" => 2,
        "7x7" => 3,
        _ => return None,
    };
    let (slot, marker_count) = match count {
        "50" => (0, 50),
        "100" => (1, 100),
        "250" => (2, 250),
        "1000" => (3, 1000),
        _ => return None,
    };
    Some(DictionaryInfo {
        opencv_code: size * 4 + slot,
        marker_count,
    })
}

impl DetectorConfig {
    /// Adaptive threshold window sizes OpenCV 4.6 uses, in order (even sizes are bumped to odd).
    pub fn threshold_window_sizes_px(&self) -> Vec<i32> {
        let (lo, hi, step) = (
            self.adaptive_thresh_win_size_min_px,
            self.adaptive_thresh_win_size_max_px,
            self.adaptive_thresh_win_size_step_px,
        );
        if lo < 3 || hi < lo || step <= 0 {
            return Vec::new();
        }
        let n = (hi - lo) / step + 1;
        (0..n)
            .map(|i| lo + i * step)
            .map(|w| if w % 2 == 0 { w + 1 } else { w })
            .collect()
    }

    pub fn validate(&self, path: &str, problems: &mut Problems) {
        let f = |name: &str| join(path, name);
        match parse_dictionary(&self.dictionary) {
            None => problems.push(
                f("dictionary"),
                format!(
                    "unknown dictionary {:?}; expected NxN_COUNT with N in 4..=7 and COUNT in \
                     50|100|250|1000 (or DICT_ prefix), aruco_original, apriltag_16h5|25h9|36h10|36h11",
                    self.dictionary
                ),
            ),
            Some(info) => {
                let hi = f64::from(info.marker_count - 1);
                problems.range(f("marker_id"), f64::from(self.marker_id), 0.0, hi);
                if let Some(r) = self.reference_marker_id {
                    problems.range(f("reference_marker_id"), f64::from(r), 0.0, hi);
                    if r == self.marker_id {
                        problems.push(f("reference_marker_id"), "must differ from marker_id");
                    }
                }
            }
        }
        self.roi.validate(&f("roi"), problems);
        let int = |p: &mut Problems, name: &str, v: i32, lo: f64, hi: f64| {
            p.range(f(name), f64::from(v), lo, hi)
        };
        int(
            problems,
            "adaptive_thresh_win_size_min_px",
            self.adaptive_thresh_win_size_min_px,
            3.0,
            255.0,
        );
        int(
            problems,
            "adaptive_thresh_win_size_max_px",
            self.adaptive_thresh_win_size_max_px,
            3.0,
            255.0,
        );
        if self.adaptive_thresh_win_size_max_px < self.adaptive_thresh_win_size_min_px {
            problems.push(
                f("adaptive_thresh_win_size_max_px"),
                format!(
                    "must be >= adaptive_thresh_win_size_min_px ({}), got {}",
                    self.adaptive_thresh_win_size_min_px, self.adaptive_thresh_win_size_max_px
                ),
            );
        }
        int(
            problems,
            "adaptive_thresh_win_size_step_px",
            self.adaptive_thresh_win_size_step_px,
            1.0,
            255.0,
        );
        problems.range(
            f("adaptive_thresh_constant_dn"),
            self.adaptive_thresh_constant_dn,
            -255.0,
            255.0,
        );
        problems.range(
            f("min_marker_perimeter_rate"),
            self.min_marker_perimeter_rate,
            1e-6,
            4.0,
        );
        problems.range(
            f("max_marker_perimeter_rate"),
            self.max_marker_perimeter_rate,
            1e-6,
            16.0,
        );
        if self.max_marker_perimeter_rate < self.min_marker_perimeter_rate {
            problems.push(
                f("max_marker_perimeter_rate"),
                format!(
                    "must be >= min_marker_perimeter_rate ({}), got {}",
                    crate::validation::short(self.min_marker_perimeter_rate),
                    crate::validation::short(self.max_marker_perimeter_rate)
                ),
            );
        }
        problems.range(
            f("polygonal_approx_accuracy_rate"),
            self.polygonal_approx_accuracy_rate,
            1e-6,
            1.0,
        );
        problems.range(
            f("min_corner_distance_rate"),
            self.min_corner_distance_rate,
            0.0,
            1.0,
        );
        int(
            problems,
            "min_distance_to_border_px",
            self.min_distance_to_border_px,
            0.0,
            10_000.0,
        );
        problems.range(
            f("min_marker_distance_rate"),
            self.min_marker_distance_rate,
            0.0,
            1.0,
        );
        int(
            problems,
            "corner_refinement_win_size_px",
            self.corner_refinement_win_size_px,
            1.0,
            100.0,
        );
        int(
            problems,
            "corner_refinement_max_iterations",
            self.corner_refinement_max_iterations,
            1.0,
            10_000.0,
        );
        problems.range(
            f("corner_refinement_min_accuracy_px"),
            self.corner_refinement_min_accuracy_px,
            1e-9,
            10.0,
        );
        int(
            problems,
            "marker_border_bits",
            self.marker_border_bits,
            1.0,
            8.0,
        );
        int(
            problems,
            "perspective_remove_pixel_per_cell_px",
            self.perspective_remove_pixel_per_cell_px,
            1.0,
            100.0,
        );
        problems.range(
            f("perspective_remove_ignored_margin_per_cell"),
            self.perspective_remove_ignored_margin_per_cell,
            0.0,
            0.49,
        );
        problems.range(
            f("max_erroneous_bits_in_border_rate"),
            self.max_erroneous_bits_in_border_rate,
            0.0,
            1.0,
        );
        problems.range(
            f("min_otsu_std_dev_dn"),
            self.min_otsu_std_dev_dn,
            0.0,
            255.0,
        );
        problems.range(
            f("error_correction_rate"),
            self.error_correction_rate,
            0.0,
            1.0,
        );
        problems.range(
            f("april_tag_quad_decimate"),
            f64::from(self.april_tag_quad_decimate),
            0.0,
            16.0,
        );
        problems.range(
            f("april_tag_quad_sigma_px"),
            f64::from(self.april_tag_quad_sigma_px),
            0.0,
            20.0,
        );
        int(
            problems,
            "april_tag_min_cluster_pixels",
            self.april_tag_min_cluster_pixels,
            0.0,
            1e7,
        );
        int(
            problems,
            "april_tag_max_nmaxima",
            self.april_tag_max_nmaxima,
            1.0,
            100.0,
        );
        problems.range(
            f("april_tag_critical_rad"),
            f64::from(self.april_tag_critical_rad),
            0.0,
            std::f64::consts::FRAC_PI_2,
        );
        problems.range(
            f("april_tag_max_line_fit_mse_px2"),
            f64::from(self.april_tag_max_line_fit_mse_px2),
            0.0,
            1e6,
        );
        int(
            problems,
            "april_tag_min_white_black_diff_dn",
            self.april_tag_min_white_black_diff_dn,
            0.0,
            255.0,
        );
        int(
            problems,
            "min_side_length_canonical_img_px",
            self.min_side_length_canonical_img_px,
            0.0,
            10_000.0,
        );
        if self.use_aruco3_detection
            && self.min_side_length_canonical_img_px == 0
            && self.marker_border_bits != 1
        {
            problems.push(
                f("min_side_length_canonical_img_px"),
                "must be > 0 when use_aruco3_detection is on and marker_border_bits != 1",
            );
        }
        problems.range(
            f("min_marker_length_ratio_original_img"),
            f64::from(self.min_marker_length_ratio_original_img),
            0.0,
            1.0,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_valid() {
        let mut p = Problems::new();
        DetectorConfig::default().validate("detector", &mut p);
        assert!(p.is_empty(), "{:?}", p);
    }

    #[test]
    fn dictionary_names_map_to_opencv_codes() {
        // Codes from OpenCV's PREDEFINED_DICTIONARY_NAME enum.
        assert_eq!(parse_dictionary("4x4_50").unwrap().opencv_code, 0);
        assert_eq!(parse_dictionary("DICT_4X4_50").unwrap().opencv_code, 0);
        assert_eq!(parse_dictionary("DICT_5X5_250").unwrap().opencv_code, 6);
        assert_eq!(parse_dictionary("7x7_1000").unwrap().opencv_code, 15);
        assert_eq!(
            parse_dictionary("DICT_ARUCO_ORIGINAL").unwrap().opencv_code,
            16
        );
        assert_eq!(
            parse_dictionary("DICT_APRILTAG_36h11").unwrap().opencv_code,
            20
        );
        assert_eq!(
            parse_dictionary("apriltag_36h11").unwrap().marker_count,
            587
        );
        assert!(parse_dictionary("3x3_50").is_none());
        assert!(parse_dictionary("4x4_51").is_none());
    }

    #[test]
    fn toml_section_round_trips_and_rejects_unknown_fields() {
        let cfg: DetectorConfig = toml::from_str(
            "dictionary = \"DICT_6X6_250\"\nmarker_id = 7\ncorner_refinement_method = \"subpix\"\n\
             [roi]\nenabled = true\nmargin_px = 40\n",
        )
        .unwrap();
        assert_eq!(cfg.corner_refinement_method, CornerRefinement::Subpix);
        assert_eq!(
            cfg.roi,
            RoiConfig {
                enabled: true,
                margin_px: 40
            }
        );
        assert_eq!(cfg.adaptive_thresh_win_size_max_px, 23);
        let back: DetectorConfig = toml::from_str(&toml::to_string(&cfg).unwrap()).unwrap();
        assert_eq!(back, cfg);
        assert!(toml::from_str::<DetectorConfig>("adaptiveThreshWinSizeMin = 3").is_err());
        assert!(toml::from_str::<DetectorConfig>("corner_refinement_method = \"bogus\"").is_err());
    }

    #[test]
    fn invalid_fields_are_named_with_ranges() {
        let cfg = DetectorConfig {
            dictionary: "4x4_50".into(),
            marker_id: 50,
            reference_marker_id: Some(50),
            adaptive_thresh_win_size_min_px: 30,
            adaptive_thresh_win_size_max_px: 23,
            error_correction_rate: 1.5,
            ..DetectorConfig::default()
        };
        let mut p = Problems::new();
        cfg.validate("detector", &mut p);
        let msgs: Vec<String> = p.iter().map(|x| x.to_string()).collect();
        assert!(
            msgs.contains(&"detector.marker_id: must be in [0, 49], got 50".to_string()),
            "{msgs:?}"
        );
        assert!(msgs
            .iter()
            .any(|m| m.starts_with("detector.reference_marker_id: must differ")));
        assert!(msgs
            .iter()
            .any(|m| m.starts_with("detector.adaptive_thresh_win_size_max_px: must be >=")));
        assert!(msgs
            .contains(&"detector.error_correction_rate: must be in [0, 1], got 1.5".to_string()));
        let mut p = Problems::new();
        DetectorConfig {
            dictionary: "bogus".into(),
            ..DetectorConfig::default()
        }
        .validate("d", &mut p);
        assert_eq!(p.iter().next().unwrap().field, "d.dictionary");
    }

    #[test]
    fn threshold_windows_match_opencv_rule() {
        let c = DetectorConfig::default();
        assert_eq!(c.threshold_window_sizes_px(), vec![3, 13, 23]);
        let c = DetectorConfig {
            adaptive_thresh_win_size_min_px: 4,
            adaptive_thresh_win_size_max_px: 20,
            adaptive_thresh_win_size_step_px: 8,
            ..DetectorConfig::default()
        };
        assert_eq!(c.threshold_window_sizes_px(), vec![5, 13, 21]);
    }
}
