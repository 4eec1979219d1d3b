//! The synthetic rig: a scenario's mechanism, camera, scene, render settings and frame times,
//! built once and shared read-only by every frame.

use crate::camera::{Camera, CameraError};
use crate::estimate::angle::screen_angle_rad;
use crate::mechanism::{Mechanism, MechanismError, MotionSample};
use crate::render::{PixelRect, RenderSettings};
use crate::scenario::Scenario;
use crate::scene::{AnimatedScene, Scene, SceneError, WheelPose};
use crate::timing::{Timestamps, TimingError};

#[derive(Debug, thiserror::Error)]
pub enum RigError {
    #[error("mechanism: {0}")]
    Mechanism(#[from] MechanismError),
    #[error("camera: {0}")]
    Camera(#[from] CameraError),
    #[error("scene: {0}")]
    Scene(#[from] SceneError),
    #[error("frame timing: {0}")]
    Timing(#[from] TimingError),
    #[error(
        "frame {frame} (t = {t_s:.4} s): the marker leaves the image (its paper spans x {x0:.1}..{x1:.1}, y {y0:.1}..{y1:.1} px in a {w}x{h} frame); move the camera or the marker"
    )]
    MarkerLeavesFrame {
        frame: usize,
        t_s: f64,
        x0: f64,
        x1: f64,
        y0: f64,
        y1: f64,
        w: usize,
        h: usize,
    },
}

/// Everything needed to render and judge any frame of a scenario.
pub struct Rig {
    pub scenario: Scenario,
    pub mechanism: Mechanism,
    pub scene: Scene,
    pub settings: RenderSettings,
    pub frame_times: Timestamps,
    /// +1 when the wheel's θ2 grows counter-clockwise on screen, −1 when clockwise.
    pub screen_sign: f64,
}

fn pose_of(s: &MotionSample) -> WheelPose {
    WheelPose {
        theta2_rad: s.theta2_rad,
        centre_offset_m: s.centre_offset_m,
    }
}

impl Rig {
    pub fn new(scenario: &Scenario) -> Result<Rig, RigError> {
        let mechanism = Mechanism::new(
            &scenario.mechanism,
            &scenario.drive_speed,
            &scenario.dynamics,
            scenario.duration_s,
        )?;
        let camera = Camera::new(&scenario.camera)?;
        let scene = Scene::new(&scenario.scene, camera)?;
        let settings = RenderSettings {
            width_px: scenario.camera.width_px as usize,
            height_px: scenario.camera.height_px as usize,
            effects: scenario.effects.clone(),
            seed: scenario.seed,
        };
        let frame_times = scenario.frame_times()?;
        let centre = scene.rotation_centre_px_at(&WheelPose {
            theta2_rad: 0.0,
            centre_offset_m: [0.0, 0.0],
        });
        let at = |th: f64| {
            let p = scene.marker_centre_px_at(&WheelPose {
                theta2_rad: th,
                centre_offset_m: [0.0, 0.0],
            });
            screen_angle_rad([p.x, p.y], [centre.x, centre.y])
        };
        let d = at(1e-3) - at(0.0);
        let screen_sign = if d >= 0.0 { 1.0 } else { -1.0 };
        let rig = Rig {
            scenario: scenario.clone(),
            mechanism,
            scene,
            settings,
            frame_times,
            screen_sign,
        };
        rig.check_marker_in_frame()?;
        Ok(rig)
    }

    pub fn pose(&self, t_s: f64) -> WheelPose {
        pose_of(&self.mechanism.actual(t_s))
    }

    /// The scene driven by the actual motion, for the renderer.
    pub fn animated(&self) -> AnimatedScene<impl Fn(f64) -> WheelPose + Sync + '_> {
        let mechanism = &self.mechanism;
        self.scene
            .clone()
            .animate(move |t| pose_of(&mechanism.actual(t)))
    }

    pub fn frame_rect(&self) -> PixelRect {
        self.settings.frame_rect()
    }

    /// The marker's paper bounding box over the frame's exposure and readout (px, OpenCV).
    pub fn marker_bbox_px(&self, t_s: f64) -> (f64, f64, f64, f64) {
        let fx = &self.settings.effects;
        let exposure = if fx.motion_blur.enabled {
            fx.motion_blur.exposure_s
        } else {
            0.0
        };
        let readout = if fx.rolling_shutter.enabled {
            fx.rolling_shutter.readout_s
        } else {
            0.0
        };
        let mut b = (
            f64::INFINITY,
            f64::INFINITY,
            f64::NEG_INFINITY,
            f64::NEG_INFINITY,
        );
        for dt in [
            -exposure / 2.0,
            0.0,
            exposure / 2.0,
            readout - exposure / 2.0,
            readout,
            readout + exposure / 2.0,
        ] {
            let bb = self.scene.marker_bbox_px_at(&self.pose(t_s + dt));
            b = (
                b.0.min(bb.min_px.x),
                b.1.min(bb.min_px.y),
                b.2.max(bb.max_px.x),
                b.3.max(bb.max_px.y),
            );
        }
        b
    }

    /// Rejects scenarios whose marker leaves the image at some frame (names the first frame).
    fn check_marker_in_frame(&self) -> Result<(), RigError> {
        let (w, h) = (self.settings.width_px, self.settings.height_px);
        for (frame, &t_s) in self.frame_times.as_slice().iter().enumerate() {
            let (x0, y0, x1, y1) = self.marker_bbox_px(t_s);
            if x0 < -0.5 || y0 < -0.5 || x1 > w as f64 - 0.5 || y1 > h as f64 - 0.5 {
                return Err(RigError::MarkerLeavesFrame {
                    frame,
                    t_s,
                    x0,
                    x1,
                    y0,
                    y1,
                    w,
                    h,
                });
            }
        }
        Ok(())
    }
}
