//! The camera model built from a validated [`CameraConfig`]: pose, intrinsics and projection.

use glam::{DMat3, DVec2, DVec3};
use thiserror::Error;

use super::distortion::{distort_normalised, undistort_normalised};
use super::{CameraConfig, FocalConfig, LensDistortionConfig};
use crate::validation::Problems;

/// Why a camera configuration cannot be realised.
#[derive(Debug, Clone, PartialEq, Error)]
pub enum CameraError {
    #[error("invalid camera configuration: {0}")]
    Invalid(String),
    #[error("camera.rotation_centre_px: the rotation centre would be behind or beside the camera under this tilt")]
    RotationCentreBehind,
    #[error("camera.lens_distortion: the distortion cannot be inverted at rotation_centre_px (coefficients too strong)")]
    DistortionNotInvertible,
}

/// A pinhole camera (optionally tilted and distorted) looking at the disc plane z = 0.
#[derive(Debug, Clone, PartialEq)]
pub struct Camera {
    config: CameraConfig,
    focal_px: f64,
    principal_point_px: DVec2,
    rotation_centre_px: DVec2,
    /// Rotation taking world vectors into the camera frame (x right, y down, z forward).
    world_to_camera: DMat3,
    position_m: DVec3,
    distortion: Option<LensDistortionConfig>,
}

impl Camera {
    /// Builds the camera; the rotation centre (world origin) lands exactly on
    /// `rotation_centre_px`, distortion and tilt included.
    pub fn new(config: &CameraConfig) -> Result<Camera, CameraError> {
        let mut problems = Problems::new();
        config.validate("camera", &mut problems);
        if !problems.is_empty() {
            let msg: Vec<String> = problems.iter().map(|p| p.to_string()).collect();
            return Err(CameraError::Invalid(msg.join("; ")));
        }
        let width = config.width_px as f64;
        let focal_px = match config.focal {
            FocalConfig::Physical {
                focal_length_mm,
                sensor_width_mm,
            } => focal_length_mm * width / sensor_width_mm,
            FocalConfig::FieldOfView { hfov_deg } => {
                width / (2.0 * (hfov_deg.to_radians() / 2.0).tan())
            }
            FocalConfig::ImageScale { mm_per_px } => 1000.0 * config.distance_m / mm_per_px,
        };
        let centre = config.image_centre_px();
        let principal_point_px = DVec2::from(config.principal_point_px.unwrap_or(centre));
        let rotation_centre_px = DVec2::from(config.rotation_centre_px.unwrap_or(centre));
        let distortion = config
            .lens_distortion
            .enabled
            .then(|| config.lens_distortion.clone());
        let tilt = &config.perspective_tilt;
        let camera_to_world = if tilt.enabled {
            DMat3::from_rotation_x(tilt.tilt_x_deg.to_radians())
                * DMat3::from_rotation_y(tilt.tilt_y_deg.to_radians())
        } else {
            DMat3::IDENTITY
        };
        // The ray through rotation_centre_px must hit the world origin: undo the distortion,
        // then place the camera on that ray at the configured distance from the plane.
        let distorted = (rotation_centre_px - principal_point_px) / focal_px;
        let normalised = match &distortion {
            Some(d) => {
                undistort_normalised(d, distorted).ok_or(CameraError::DistortionNotInvertible)?
            }
            None => distorted,
        };
        let ray_world = camera_to_world * DVec3::new(normalised.x, normalised.y, 1.0);
        if ray_world.z < 1e-6 * ray_world.length() {
            return Err(CameraError::RotationCentreBehind);
        }
        let position_m = -ray_world * (config.distance_m / ray_world.z);
        Ok(Camera {
            config: config.clone(),
            focal_px,
            principal_point_px,
            rotation_centre_px,
            world_to_camera: camera_to_world.transpose(),
            position_m,
            distortion,
        })
    }

    /// The configuration this camera was built from.
    pub fn config(&self) -> &CameraConfig {
        &self.config
    }

    /// Focal length in pixels (square pixels).
    pub fn focal_px(&self) -> f64 {
        self.focal_px
    }

    /// Nominal image scale at the disc plane: mm on the plane per pixel, untilted, at the
    /// principal point (1000 · distance_m / focal_px).
    pub fn image_scale_mm_per_px(&self) -> f64 {
        1000.0 * self.config.distance_m / self.focal_px
    }

    /// Horizontal field of view, degrees.
    pub fn hfov_deg(&self) -> f64 {
        2.0 * (self.config.width_px as f64 / (2.0 * self.focal_px))
            .atan()
            .to_degrees()
    }

    pub fn width_px(&self) -> u32 {
        self.config.width_px
    }

    pub fn height_px(&self) -> u32 {
        self.config.height_px
    }

    pub fn principal_point_px(&self) -> DVec2 {
        self.principal_point_px
    }

    /// Where the world origin (nominal rotation centre) is imaged, px (OpenCV convention).
    pub fn rotation_centre_px(&self) -> DVec2 {
        self.rotation_centre_px
    }

    /// Camera centre in the world frame, m.
    pub fn position_m(&self) -> DVec3 {
        self.position_m
    }

    /// A world point in the camera frame (x right, y down, z forward), m.
    pub fn to_camera_m(&self, p_world_m: DVec3) -> DVec3 {
        self.world_to_camera * (p_world_m - self.position_m)
    }

    /// Projects a world point to pixels (OpenCV convention). The point must be in front of the
    /// camera (use [`Camera::try_project`] when that is not guaranteed).
    pub fn project(&self, p_world_m: DVec3) -> DVec2 {
        let pc = self.to_camera_m(p_world_m);
        self.project_camera(pc)
    }

    /// Like [`Camera::project`], `None` for points not in front of the camera.
    pub fn try_project(&self, p_world_m: DVec3) -> Option<DVec2> {
        let pc = self.to_camera_m(p_world_m);
        (pc.z > 1e-9).then(|| self.project_camera(pc))
    }

    fn project_camera(&self, pc: DVec3) -> DVec2 {
        let n = DVec2::new(pc.x / pc.z, pc.y / pc.z);
        let n = match &self.distortion {
            Some(d) => distort_normalised(d, n),
            None => n,
        };
        self.principal_point_px + self.focal_px * n
    }

    /// Human-readable description giving both the physical and the image-scale view.
    pub fn describe(&self) -> String {
        let c = &self.config;
        let physical = match c.focal {
            FocalConfig::Physical {
                focal_length_mm,
                sensor_width_mm,
            } => {
                format!("lens {focal_length_mm} mm on a {sensor_width_mm} mm wide sensor")
            }
            _ => "lens given by field of view / image scale".to_string(),
        };
        let tilt = if c.perspective_tilt.enabled {
            format!(
                "tilt x {}°, y {}°",
                c.perspective_tilt.tilt_x_deg, c.perspective_tilt.tilt_y_deg
            )
        } else {
            "no tilt".to_string()
        };
        let dist = match &self.distortion {
            Some(d) => format!(
                "distortion k1 {} k2 {} k3 {} p1 {} p2 {}",
                d.k1, d.k2, d.k3, d.p1, d.p2
            ),
            None => "no distortion".to_string(),
        };
        format!(
            "{}×{} px, {physical}; focal {:.2} px, hfov {:.2}°, distance {:.4} m to the disc plane\n\
             image scale {:.5} mm/px ({:.3} px/mm) at the disc plane; principal point ({:.2}, {:.2}) px; \
             rotation centre at ({:.2}, {:.2}) px; {tilt}; {dist}",
            c.width_px,
            c.height_px,
            self.focal_px,
            self.hfov_deg(),
            c.distance_m,
            self.image_scale_mm_per_px(),
            1.0 / self.image_scale_mm_per_px(),
            self.principal_point_px.x,
            self.principal_point_px.y,
            self.rotation_centre_px.x,
            self.rotation_centre_px.y,
        )
    }
}
