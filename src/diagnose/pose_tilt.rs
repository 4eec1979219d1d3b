//! The camera tilt the real marker corners show, read by calibrate's pose fit through the
//! nominal camera: the perspective-tilt candidate's start.
//!
//! The fit objective of a tilt (Σ z² over shape, side and radius statistics) is nearly even in
//! the tilt: foreshortening is second order in the angle, only the keystone across the image is
//! first order. A search from (0°, 0°) therefore finds a mirror tilt as readily as the real one:
//! a (−22°, −28°) tilt was fitted as (35.1°, 7.4°), a (−8°, 15°) one as (−14.9°, 13.8°), each
//! leaving significant cells. The pose fit works on the corners themselves, where the keystone
//! fixes the sign, so the search starts next to the right minimum.

use crate::calibrate::{fit_geometry, FootageStats, FrameObservation};
use crate::diagnose::record::Record;
use crate::scenario::Scenario;

/// A tilt read off the corners, degrees, with the pose fit's 95 % half-widths.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PoseTilt {
    pub tilt_x_deg: f64,
    pub tilt_y_deg: f64,
    pub u95_x_deg: f64,
    pub u95_y_deg: f64,
}

/// The tilt of `record`'s detected marker corners through `nominal`'s camera (its focal length,
/// distance and lens; its own tilt is replaced by the fitted one). `None` when the corners do
/// not give one: fewer than 8 distinct poses, or no pose fit.
pub fn pose_tilt(nominal: &Scenario, record: &Record) -> Option<PoseTilt> {
    let frames: Vec<FrameObservation> = record
        .frames
        .iter()
        .enumerate()
        .map(|(k, f)| FrameObservation {
            frame: k,
            t_s: f.t_s,
            corners_px: f
                .corners_px
                .filter(|c| c.iter().flatten().all(|v| v.is_finite())),
            ..Default::default()
        })
        .collect();
    let stats = FootageStats {
        width_px: nominal.camera.width_px as usize,
        height_px: nominal.camera.height_px as usize,
        frames,
        ..Default::default()
    };
    let g = fit_geometry(nominal, &stats, false, &mut Vec::new()).ok()?;
    let t = g.tilt;
    let finite = t.tilt_x_deg.value.is_finite() && t.tilt_y_deg.value.is_finite();
    (t.fitted && finite).then_some(PoseTilt {
        tilt_x_deg: t.tilt_x_deg.value,
        tilt_y_deg: t.tilt_y_deg.value,
        u95_x_deg: t.tilt_x_deg.u95,
        u95_y_deg: t.tilt_y_deg.u95,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::camera::Camera;
    use crate::diagnose::record::FrameRecord;
    use crate::mechanism::Mechanism;
    use crate::scene::{Scene, WheelPose};

    /// 6 s of the `fast` rig filmed through a camera tilted by (`tx`, `ty`) degrees, as OpenCV
    /// would give the corners without refinement: whole pixels.
    fn footage(tx: f64, ty: f64) -> (Scenario, Record) {
        let mut s = crate::scenario::load_any("fast").unwrap();
        s.duration_s = 6.0;
        let mut truth = s.clone();
        truth.camera.perspective_tilt.enabled = true;
        truth.camera.perspective_tilt.tilt_x_deg = tx;
        truth.camera.perspective_tilt.tilt_y_deg = ty;
        let mut dynamics = truth.dynamics.clone();
        dynamics.enabled = false;
        let mech = Mechanism::new(&truth.mechanism, &truth.drive_speed, &dynamics, 7.0).unwrap();
        let scene = Scene::new(&truth.scene, Camera::new(&truth.camera).unwrap()).unwrap();
        let frames = (0..180)
            .map(|k| {
                let t_s = k as f64 / 30.0;
                let c = scene.marker_corners_px_at(&WheelPose {
                    theta2_rad: mech.ideal(t_s).theta2_rad,
                    centre_offset_m: [0.0, 0.0],
                });
                FrameRecord {
                    t_s,
                    corners_px: Some(c.map(|p| p.map(f64::round))),
                    reference_px: None,
                    image: None,
                }
            })
            .collect();
        s.camera.perspective_tilt.enabled = false;
        let record = Record {
            frames,
            has_images: false,
            has_reference: false,
        };
        (s, record)
    }

    /// The tilts the objective's search had mirrored are read with their signs, within 2°.
    #[test]
    fn the_corners_give_the_tilt_with_its_sign() {
        for (tx, ty) in [(-22.0, -28.0), (-8.0, 15.0), (12.0, -5.0)] {
            let (nominal, record) = footage(tx, ty);
            let p = pose_tilt(&nominal, &record).unwrap();
            assert!(
                (p.tilt_x_deg - tx).abs() < 2.0 && (p.tilt_y_deg - ty).abs() < 2.0,
                "({tx}, {ty}): {p:?}"
            );
        }
    }

    /// A square camera reads as (nearly) no tilt, and too few poses as none.
    #[test]
    fn a_square_camera_reads_no_tilt_and_a_short_track_none() {
        let (nominal, record) = footage(0.0, 0.0);
        let p = pose_tilt(&nominal, &record).unwrap();
        assert!(
            p.tilt_x_deg.abs() < 1.0 && p.tilt_y_deg.abs() < 1.0,
            "{p:?}"
        );
        let short = Record {
            frames: record.frames[..3].to_vec(),
            ..record
        };
        assert!(pose_tilt(&nominal, &short).is_none());
    }
}
