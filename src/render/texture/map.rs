//! The map from a textured layer's plane to the image at one instant: a pinhole camera looking
//! at the plane (a 3×3 homography to camera coordinates), Brown–Conrady distortion in OpenCV's
//! formula, the focal length and principal point, then the camera vibration's image transform.

use crate::camera::distortion::{distort_normalised, undistort_normalised};
use crate::camera::LensDistortionConfig;
use crate::render::raster::RigidTransform;
use glam::{DMat3, DVec2, DVec3};

/// Plane point (metres) → image pixel (OpenCV convention).
#[derive(Debug, Clone, PartialEq)]
pub struct PlaneMap {
    /// Plane (x, y, 1) → camera frame (x right, y down, z forward), metres.
    pub plane_to_camera: DMat3,
    pub lens: Option<LensDistortionConfig>,
    pub focal_px: f64,
    pub principal_point_px: DVec2,
    /// Image-space transform applied last (camera vibration).
    pub transform: Option<RigidTransform>,
}

impl PlaneMap {
    /// The image of plane point `p`.
    #[inline]
    pub fn to_image(&self, p: DVec2) -> DVec2 {
        let c = self.plane_to_camera * DVec3::new(p.x, p.y, 1.0);
        let n = DVec2::new(c.x / c.z, c.y / c.z);
        let n = match &self.lens {
            Some(d) => distort_normalised(d, n),
            None => n,
        };
        let px = self.principal_point_px + self.focal_px * n;
        match &self.transform {
            Some(t) => t.apply(px),
            None => px,
        }
    }

    /// The plane point imaged at pixel `px`; `None` where the ray misses the plane in front of
    /// the camera or the distortion cannot be inverted.
    pub fn to_plane(&self, px: DVec2) -> Option<DVec2> {
        self.inverse().to_plane(px)
    }

    /// The map from the image back to the plane, its homography inverted once (for many
    /// pixels).
    pub fn inverse(&self) -> ImageToPlane<'_> {
        ImageToPlane {
            map: self,
            camera_to_plane: self.plane_to_camera.inverse(),
        }
    }

    /// +1 when the map keeps the plane's orientation at `p` (x right, y down to x right, y
    /// down), −1 when it mirrors it.
    pub fn orientation_at(&self, p: DVec2) -> i64 {
        let h = 1e-4;
        let o = self.to_image(p);
        let a = self.to_image(p + DVec2::new(h, 0.0)) - o;
        let b = self.to_image(p + DVec2::new(0.0, h)) - o;
        if a.perp_dot(b) >= 0.0 {
            1
        } else {
            -1
        }
    }
}

/// Image pixel → plane point: [`PlaneMap`] inverted.
#[derive(Debug, Clone)]
pub struct ImageToPlane<'a> {
    map: &'a PlaneMap,
    camera_to_plane: DMat3,
}

impl ImageToPlane<'_> {
    /// [`PlaneMap::to_plane`].
    pub fn to_plane(&self, px: DVec2) -> Option<DVec2> {
        let m = self.map;
        let px = match &m.transform {
            Some(t) => {
                let (s, c) = t.rotation_rad.sin_cos();
                let d = px - t.translation_px - t.centre_px;
                t.centre_px + DVec2::new(c * d.x + s * d.y, -s * d.x + c * d.y)
            }
            None => px,
        };
        let distorted = (px - m.principal_point_px) / m.focal_px;
        let n = match &m.lens {
            Some(d) => undistort_normalised(d, distorted)?,
            None => distorted,
        };
        let q = self.camera_to_plane * DVec3::new(n.x, n.y, 1.0);
        if !q.is_finite() || q.z.abs() < 1e-300 {
            return None;
        }
        // The ray's points are λ·(n, 1) with λ > 0 in front of the camera: λ = 1/q.z.
        (q.z > 0.0).then(|| DVec2::new(q.x / q.z, q.y / q.z))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn map(lens: bool, transform: bool) -> PlaneMap {
        let tilt = DMat3::from_rotation_x(0.2) * DMat3::from_rotation_y(-0.1);
        // A plane 0.3 m in front of a tilted camera.
        let r = tilt.transpose();
        let origin = DVec3::new(0.01, -0.02, 0.3);
        PlaneMap {
            plane_to_camera: DMat3::from_cols(r.x_axis, r.y_axis, origin),
            lens: lens.then(|| LensDistortionConfig {
                enabled: true,
                k1: -0.1,
                k2: 0.03,
                p1: 0.001,
                ..Default::default()
            }),
            focal_px: 1500.0,
            principal_point_px: DVec2::new(640.0, 360.0),
            transform: transform.then_some(RigidTransform {
                centre_px: DVec2::new(600.0, 300.0),
                rotation_rad: 0.01,
                translation_px: DVec2::new(0.4, -0.7),
            }),
        }
    }

    #[test]
    fn to_plane_inverts_to_image() {
        for (lens, transform) in [(false, false), (true, false), (true, true)] {
            let m = map(lens, transform);
            for p in [
                DVec2::new(0.0, 0.0),
                DVec2::new(0.05, -0.03),
                DVec2::new(-0.1, 0.08),
            ] {
                let back = m.to_plane(m.to_image(p)).unwrap();
                assert!(
                    (back - p).length() < 1e-12,
                    "{lens} {transform}: {p} → {back}"
                );
            }
            assert_eq!(m.orientation_at(DVec2::ZERO), 1);
        }
    }
}
