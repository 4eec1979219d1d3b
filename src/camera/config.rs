//! Camera configuration (the `[camera]` scenario section) and its field-level validation.

use serde::{Deserialize, Serialize};

use crate::validation::{join, Problems};

/// How the focal length is given; all three describe the same pinhole model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum FocalConfig {
    /// Physical lens and sensor: focal_px = focal_length_mm · width_px / sensor_width_mm.
    Physical {
        /// Lens focal length, mm, in [0.5, 5000].
        focal_length_mm: f64,
        /// Sensor width matching `width_px`, mm, in [0.1, 200].
        sensor_width_mm: f64,
    },
    /// Horizontal field of view: focal_px = width_px / (2 · tan(hfov_deg / 2)).
    FieldOfView {
        /// Horizontal field of view, degrees, in [0.01, 175].
        hfov_deg: f64,
    },
    /// Image scale at the disc plane at `distance_m` (untilted): focal_px = 1000 · distance_m / mm_per_px.
    ImageScale {
        /// Millimetres on the disc plane per pixel, in [1e-4, 1000] (seed rig: 0.195).
        mm_per_px: f64,
    },
}

impl Default for FocalConfig {
    fn default() -> Self {
        FocalConfig::ImageScale { mm_per_px: 0.195 }
    }
}

/// Camera rotated about its own axes while still looking at the rotation centre (which stays
/// at `rotation_centre_px`) from the same distance to the disc plane.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct PerspectiveTiltConfig {
    /// Apply the tilt. Default false.
    pub enabled: bool,
    /// Rotation about the camera x axis (image rows), degrees, in [-80, 80]. Default 0.
    /// Right-handed about the camera's x (right) axis: positive turns the optical axis towards
    /// the image top, so the lower half of the image is nearer to the camera.
    pub tilt_x_deg: f64,
    /// Rotation about the camera y axis (image columns), degrees, in [-80, 80]. Default 0.
    /// Right-handed about the camera's y (down) axis: positive turns the optical axis towards
    /// the image right, so the left half of the image is nearer. Applied after `tilt_x_deg`
    /// (camera-to-world R = Rx·Ry).
    pub tilt_y_deg: f64,
}

impl Default for PerspectiveTiltConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            tilt_x_deg: 0.0,
            tilt_y_deg: 0.0,
        }
    }
}

/// Brown–Conrady lens distortion with OpenCV's formula on normalised image coordinates.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct LensDistortionConfig {
    /// Apply the distortion. Default false.
    pub enabled: bool,
    /// Radial coefficient of r², dimensionless, in [-2, 2]. Default 0.
    pub k1: f64,
    /// Radial coefficient of r⁴, dimensionless, in [-2, 2]. Default 0.
    pub k2: f64,
    /// Radial coefficient of r⁶, dimensionless, in [-2, 2]. Default 0.
    pub k3: f64,
    /// First tangential coefficient, dimensionless, in [-0.1, 0.1]. Default 0.
    pub p1: f64,
    /// Second tangential coefficient, dimensionless, in [-0.1, 0.1]. Default 0.
    pub p2: f64,
}

impl Default for LensDistortionConfig {
    fn default() -> Self {
        Self {
            enabled: false,
            k1: 0.0,
            k2: 0.0,
            k3: 0.0,
            p1: 0.0,
            p2: 0.0,
        }
    }
}

/// The camera: resolution, focal length, distance to the disc plane and placement.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct CameraConfig {
    /// Image width, px, in [16, 20000]. Default 3840.
    pub width_px: u32,
    /// Image height, px, in [16, 20000]. Default 2160.
    pub height_px: u32,
    /// Focal length as `physical`, `field_of_view` or `image_scale` (`kind = ...`).
    /// Default `image_scale` with mm_per_px = 0.195 (the seed rig).
    pub focal: FocalConfig,
    /// Perpendicular distance from the camera centre to the disc plane, m, in [0.001, 100]. Default 0.30.
    pub distance_m: f64,
    /// Principal point [x, y], px (OpenCV convention). Default: image centre ((W−1)/2, (H−1)/2).
    pub principal_point_px: Option<[f64; 2]>,
    /// Where the rotation centre appears in the image [x, y], px (OpenCV convention), realised
    /// by a lateral camera offset. Default: image centre ((W−1)/2, (H−1)/2).
    pub rotation_centre_px: Option<[f64; 2]>,
    /// Optional perspective tilt. Default disabled.
    pub perspective_tilt: PerspectiveTiltConfig,
    /// Optional lens distortion. Default disabled.
    pub lens_distortion: LensDistortionConfig,
}

impl Default for CameraConfig {
    fn default() -> Self {
        Self {
            width_px: 3840,
            height_px: 2160,
            focal: FocalConfig::default(),
            distance_m: 0.30,
            principal_point_px: None,
            rotation_centre_px: None,
            perspective_tilt: PerspectiveTiltConfig::default(),
            lens_distortion: LensDistortionConfig::default(),
        }
    }
}

impl CameraConfig {
    /// The image centre in OpenCV's convention, ((W−1)/2, (H−1)/2).
    pub fn image_centre_px(&self) -> [f64; 2] {
        [
            (self.width_px as f64 - 1.0) / 2.0,
            (self.height_px as f64 - 1.0) / 2.0,
        ]
    }

    /// Field-level checks; geometry that only fails in combination is caught by `Camera::new`.
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        problems.range(join(path, "width_px"), self.width_px as f64, 16.0, 20000.0);
        problems.range(
            join(path, "height_px"),
            self.height_px as f64,
            16.0,
            20000.0,
        );
        let focal = join(path, "focal");
        match &self.focal {
            FocalConfig::Physical {
                focal_length_mm,
                sensor_width_mm,
            } => {
                // Lenses from a phone's 0.5 mm to a 5 m telescope; sensors up to large format.
                problems.range(
                    join(&focal, "focal_length_mm"),
                    *focal_length_mm,
                    0.5,
                    5000.0,
                );
                problems.range(
                    join(&focal, "sensor_width_mm"),
                    *sensor_width_mm,
                    0.1,
                    200.0,
                );
            }
            FocalConfig::FieldOfView { hfov_deg } => {
                problems.range(join(&focal, "hfov_deg"), *hfov_deg, 0.01, 175.0);
            }
            FocalConfig::ImageScale { mm_per_px } => {
                problems.range(join(&focal, "mm_per_px"), *mm_per_px, 1e-4, 1e3)
            }
        }
        problems.range(join(path, "distance_m"), self.distance_m, 0.001, 100.0);
        for (name, p) in [
            ("principal_point_px", self.principal_point_px),
            ("rotation_centre_px", self.rotation_centre_px),
        ] {
            if let Some([x, y]) = p {
                let f = join(path, name);
                problems.range(format!("{f}[0]"), x, -0.5, self.width_px as f64 - 0.5);
                problems.range(format!("{f}[1]"), y, -0.5, self.height_px as f64 - 0.5);
            }
        }
        let tilt = join(path, "perspective_tilt");
        problems.range(
            join(&tilt, "tilt_x_deg"),
            self.perspective_tilt.tilt_x_deg,
            -80.0,
            80.0,
        );
        problems.range(
            join(&tilt, "tilt_y_deg"),
            self.perspective_tilt.tilt_y_deg,
            -80.0,
            80.0,
        );
        let d = &self.lens_distortion;
        let dp = join(path, "lens_distortion");
        for (name, v) in [("k1", d.k1), ("k2", d.k2), ("k3", d.k3)] {
            problems.range(join(&dp, name), v, -2.0, 2.0);
        }
        for (name, v) in [("p1", d.p1), ("p2", d.p2)] {
            problems.range(join(&dp, name), v, -0.1, 0.1);
        }
    }
}
