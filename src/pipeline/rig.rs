//! The synthetic rig: a scenario's mechanism, camera, scene, render settings and frame times,
//! built once and shared read-only by every frame.

use crate::budget::resolvable::{
    median_interval_s, resolvable_truth, FrameInstants, Resolvable, ResolvableFilter, WINDOW_FRAMES,
};
use crate::camera::{Camera, CameraError};
use crate::estimate::angle::screen_angle_rad;
use crate::mechanism::{Mechanism, MechanismError, MotionSample};
use crate::render::{PixelRect, RenderSettings};
use crate::scenario::Scenario;
use crate::scene::{AnimatedScene, Scene, SceneError, WheelPose};
use crate::timing::{Timestamps, TimingError};

#[derive(Debug, thiserror::Error)]
pub enum RigError {
    #[error("mechanism")]
    Mechanism(#[from] MechanismError),
    #[error("camera")]
    Camera(#[from] CameraError),
    #[error("scene")]
    Scene(#[from] SceneError),
    #[error("frame timing")]
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
    /// Times where the actual motion is known, s: everywhere for closed-form motion; with
    /// clearance dynamics from t = 0 (the start of the integration) to beyond the last frame by
    /// the reach of the resolvable-truth filter.
    pub truth_span_s: (f64, f64),
}

fn pose_of(s: &MotionSample) -> WheelPose {
    WheelPose {
        theta2_rad: s.theta2_rad,
        centre_offset_m: s.centre_offset_m,
    }
}

impl Rig {
    pub fn new(scenario: &Scenario) -> Result<Rig, RigError> {
        Self::filmed_at(scenario, scenario.frame_times()?)
    }

    /// The rig of `scenario` filmed at `frame_times` instead of its own frame timing (a real
    /// footage's times, rebased to start at 0 s): the motion is simulated to the last of them.
    pub fn filmed_at(scenario: &Scenario, frame_times: Timestamps) -> Result<Rig, RigError> {
        // The resolvable truth filters the motion around each frame's exposure of the marker:
        // simulate past the end by that reach (the motion up to duration_s is unchanged).
        let fx = &scenario.effects;
        let h = median_interval_s(frame_times.as_slice());
        let reach_s = fx.rolling_shutter.readout_or_zero_s()
            + 1.5 * fx.motion_blur.exposure_or_zero_s()
            + 0.5 * WINDOW_FRAMES * if h.is_finite() { h } else { 0.0 }
            + 0.01;
        let last_s = frame_times.as_slice().last().copied().unwrap_or(0.0);
        let simulated_s = scenario.duration_s.max(last_s) + reach_s;
        let mechanism = Mechanism::new(
            &scenario.mechanism,
            &scenario.drive_speed,
            &scenario.dynamics,
            simulated_s,
        )?;
        let truth_span_s = if mechanism.dynamics().is_some() {
            (0.0, simulated_s)
        } else {
            (f64::NEG_INFINITY, f64::INFINITY)
        };
        let camera = Camera::new(&scenario.camera)?;
        let scene = Scene::new(&scenario.scene, camera)?;
        let settings = RenderSettings {
            width_px: scenario.camera.width_px as usize,
            height_px: scenario.camera.height_px as usize,
            effects: scenario.effects.clone(),
            seed: scenario.seed,
        };
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
            truth_span_s,
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

    /// The centre of the marker's exposure in the frame with timestamp `t_s`: the first row's
    /// exposure centre plus the rolling-shutter delay of the row the marker centre is on.
    pub fn marker_exposure_centre_s(&self, t_s: f64) -> f64 {
        let fx = &self.settings.effects;
        let row0 = self.render_time_s(t_s);
        let readout = fx.rolling_shutter.readout_or_zero_s();
        if readout == 0.0 {
            return row0;
        }
        let y = self.scene.marker_centre_px_at(&self.pose(row0)).y;
        row0 + readout * y / self.settings.height_px as f64
    }

    /// The truth the frames at `timestamps_s` can resolve (see `budget::resolvable`), and the
    /// filter that made it (for plots; none when the frames define no frame rate).
    pub fn resolvable_truth(&self, timestamps_s: &[f64]) -> (Resolvable, Option<ResolvableFilter>) {
        let centres: Vec<f64> = timestamps_s
            .iter()
            .map(|&t| self.marker_exposure_centre_s(t))
            .collect();
        let mechanism = &self.mechanism;
        resolvable_truth(
            &|t| mechanism.actual(t).theta2_rad,
            &FrameInstants {
                timestamps_s,
                marker_centres_s: &centres,
                exposure_s: self.settings.effects.motion_blur.exposure_or_zero_s(),
                truth_span_s: self.truth_span_s,
            },
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
                background: None,
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

#[cfg(test)]
mod resolvable_tests {
    use super::*;
    use std::f64::consts::TAU;

    fn rig(extra: &str) -> Rig {
        let text = format!("extend = \"fast\"\n{extra}");
        Rig::new(&crate::scenario::from_str(&text, std::path::Path::new("t.toml")).unwrap())
            .unwrap()
    }

    fn vibration(freq_hz: f64) -> String {
        format!(
            "[dynamics.disc_vibration]\nenabled = true\n\
             components = [{{ amplitude_rad = 2e-4, frequency_hz = {freq_hz}, phase_rad = 0.4 }}]\n"
        )
    }

    /// A wheel vibration above the Nyquist rate of the 30 fps frames is not resolvable: the
    /// resolvable truth is that of the same rig without it, and the aliasing part is the
    /// vibration itself. One below the Nyquist rate is resolved whole.
    #[test]
    fn wheel_vibration_is_aliasing_above_the_nyquist_rate_and_resolved_below() {
        let plain = rig("");
        let t = plain.frame_times.as_slice().to_vec();
        let (base, _) = plain.resolvable_truth(&t);
        assert_eq!(
            base.info.frames_defined,
            t.len(),
            "closed-form motion: every frame"
        );
        for (freq, resolved) in [(40.0, false), (5.0, true)] {
            let r = rig(&vibration(freq));
            let (res, _) = r.resolvable_truth(&t);
            for (k, &tk) in t.iter().enumerate() {
                let v = 2e-4 * (TAU * freq * tk + 0.4).sin();
                let w = 2e-4 * TAU * freq * (TAU * freq * tk + 0.4).cos();
                let dtheta = res.theta2_rad[k] - base.theta2_rad[k];
                let domega = res.omega2_rad_s[k] - base.omega2_rad_s[k];
                let (want_theta, want_omega) = if resolved { (v, w) } else { (0.0, 0.0) };
                assert!(
                    (dtheta - want_theta).abs() < 2e-3 * 2e-4,
                    "{freq} Hz, frame {k}"
                );
                assert!((domega - want_omega).abs() < 2e-3 * 2e-4 * TAU * freq);
                // Aliasing part: raw minus band-limited, against the plain rig's.
                let raw = r.mechanism.actual(tk).theta2_rad;
                let alias = raw - res.band_limited_theta2_rad[k];
                let base_alias =
                    plain.mechanism.actual(tk).theta2_rad - base.band_limited_theta2_rad[k];
                let want_alias = if resolved { 0.0 } else { v };
                assert!((alias - base_alias - want_alias).abs() < 2e-3 * 2e-4);
            }
        }
    }

    /// The marker is seen at the centre of its own row's exposure: E/2 after an exposure-start
    /// timestamp, plus the readout delay of the marker centre's row.
    #[test]
    fn marker_exposure_centre_follows_the_timestamp_convention_and_the_row() {
        let r = rig(
            "[frame_timing]\ntimestamp_marks = \"first_row_exposure_start\"\n\
             [effects.motion_blur]\nenabled = true\nexposure_s = 0.008\n\
             [effects.rolling_shutter]\nenabled = true\nreadout_s = 0.02\n",
        );
        for &t in &r.frame_times.as_slice()[..10] {
            let y = r.scene.marker_centre_px_at(&r.pose(t + 0.004)).y;
            let want = t + 0.004 + 0.02 * y / 720.0;
            assert!((r.marker_exposure_centre_s(t) - want).abs() < 1e-12);
        }
        let t = r.frame_times.as_slice().to_vec();
        let (res, _) = r.resolvable_truth(&t);
        assert!(res.info.marker_delay_min_s > 0.004 && res.info.marker_delay_max_s < 0.024);
        assert_eq!(res.info.exposure_s, 0.008);
    }
}
