//! Marker detection: the `[detector]` config (pure, always compiled), detector input/output
//! types, ROI window geometry, and the OpenCV ArUco detector (feature `opencv-detector`).

mod config;
mod roi;
mod types;

#[cfg(feature = "opencv-detector")]
mod opencv_aruco;

pub use config::{parse_dictionary, CornerRefinement, DetectorConfig, DictionaryInfo, RoiConfig};
pub use roi::{
    corners_inside_exact_zone, required_margin_px, roi_exactness, roi_window,
    window_perimeter_rate, RoiExactness, RoiWindow,
};
pub use types::{corners_bbox_px, Detection, GrayView};

#[cfg(all(feature = "opencv-detector", not(opencv_aruco_objdetect)))]
pub use opencv_aruco::opencv_parameters;
#[cfg(feature = "opencv-detector")]
pub use opencv_aruco::{ArucoDetector, DetectError, DetectionPath, MarkerObservation, RoiFallback};
