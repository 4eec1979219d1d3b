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

    /// The renderer's time of a frame with timestamp `t_s`: the centre of its first row's
    /// exposure (`frame_timing.timestamp_marks` says which instant the timestamp marks).
    pub fn render_time_s(&self, t_s: f64) -> f64 {
        let fx = &self.settings.effects;
        t_s + self
            .scenario
            .frame_timing
            .timestamp_marks
            .to_first_row_centre_s(
                fx.motion_blur.exposure_or_zero_s(),
                fx.rolling_shutter.readout_or_zero_s(),
            )
    }

    /// The marker's paper bounding box over the exposure and readout of the frame with
    /// timestamp `t_s` (px, OpenCV).
    pub fn marker_bbox_px(&self, t_s: f64) -> (f64, f64, f64, f64) {
        let fx = &self.settings.effects;
        let exposure = fx.motion_blur.exposure_or_zero_s();
        let readout = fx.rolling_shutter.readout_or_zero_s();
        let t_s = self.render_time_s(t_s);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::frame::render_linear;
    use crate::render::shapes::{SceneAt, SceneSnapshot};
    use crate::render::FrameRequest;

    /// A uniform image that turns from black to white at `on_s`: each row's value is the
    /// fraction of its exposure after `on_s`, so the image shows when every row was exposed.
    struct Flash {
        on_s: f64,
    }

    impl SceneAt for Flash {
        fn snapshot(&self, t_s: f64) -> SceneSnapshot {
            SceneSnapshot {
                background_radiance: if t_s >= self.on_s { 1.0 } else { 0.0 },
                layers: vec![],
            }
        }
    }

    /// What `frame_timing.timestamp_marks` means, read off rendered rows: with exposure E and
    /// readout R, a frame stamped T is exposed from T on in its first row under
    /// `first_row_exposure_start` (Android's sensor timestamp), around T in its first row under
    /// `first_row_exposure_centre`, and around T in its middle row under
    /// `middle_row_exposure_centre`.
    #[test]
    fn timestamp_marks_the_documented_instant_of_the_frame() {
        let (exposure, readout, t) = (0.008, 0.02, 0.5);
        for (mark, row, exposed_from) in [
            ("first_row_exposure_start", 0usize, t),
            ("first_row_exposure_centre", 0, t - exposure / 2.0),
            ("middle_row_exposure_centre", 360, t - exposure / 2.0),
        ] {
            let text = format!(
                "extend = \"fast\"\n[frame_timing]\ntimestamp_marks = \"{mark}\"\n\
                 [effects.motion_blur]\nenabled = true\nexposure_s = {exposure}\nsamples = 64\n\
                 [effects.rolling_shutter]\nenabled = true\nreadout_s = {readout}\n"
            );
            let s = crate::scenario::from_str(&text, std::path::Path::new("t.toml")).unwrap();
            let rig = Rig::new(&s).unwrap();
            let rect = PixelRect::new(0, row as i64, 4, 1);
            let value_with_flash_at = |on_s: f64| {
                let frame = FrameRequest {
                    index: 0,
                    t_s: rig.render_time_s(t),
                    window: rect,
                };
                render_linear(&Flash { on_s }, &rig.settings, &frame, &rect).data[0] as f64
            };
            // The row is dark for a flash at the end of its exposure, white for one at its start,
            // half white for one in the middle (64 samples: exact to 1/64).
            let tol = 1.0 / 64.0 + 1e-6;
            assert!(
                value_with_flash_at(exposed_from + exposure + 1e-6) < tol,
                "{mark}"
            );
            assert!(
                value_with_flash_at(exposed_from - 1e-6) > 1.0 - tol,
                "{mark}"
            );
            let half = value_with_flash_at(exposed_from + exposure / 2.0);
            assert!((half - 0.5).abs() <= tol, "{mark}: {half}");
        }
    }
}
