//! The motion nuisance seen through a camera (or a wobbling axis) that bends the measured angle.
//!
//! The motion alignment ([`crate::diagnose::align`]) models the measured angle as σ·θ2 + c: true
//! for a camera square to the disc. A tilted camera (or a lens that distorts away from the
//! rotation centre) sees the marker's circle as an ellipse, and the angle the estimator measures
//! about the fitted centre runs ahead of θ2 on two quadrants and behind it on the other two. On
//! footage that covers a fraction of a wheel turn that warp looks like a different crank speed:
//! in the self-check a 30° tilt made the aligned crank 8.5 % slow, and a candidate trial that
//! switched the tilt on kept that wrong speed, so its simulated α and rolling-shutter cells
//! could not match the real ones and the tilt was never `explained`.
//!
//! The cure is nuisance alignment inside the candidate: the warp of the candidate's camera is
//! computed without rendering (the estimator run on the exact corners the camera projects at the
//! real frame times) and taken out of the real angle before the motion is refitted; the warp
//! depends on the motion only through where the marker is, so two rounds settle it. The rotation
//! centre the estimator measures also moves with the tilt (the centre of an ellipse's arc is not
//! the image of the axis), so the candidate's rotation centre is shifted until the estimator
//! measures, on its exact corners, the centre it measures on the aligned nominal's.
//!
//! An axis runout bends the measured angle too: the wheel centre's wobble moves the marker
//! across its radius, and on footage that covers less than one cycle of the wobble the plain
//! alignment takes much of that for a crank phase and speed. A runout candidate kept that
//! biased motion, its simulated angle residual came out larger than the real one for the same
//! amplitude, and its fit settled at about half the true amplitude (0.5–1.4 mm for 2 mm in
//! the self-check). The exact view therefore moves the wheel centre as the scenario's runout
//! does, and the same realignment takes the runout's warp out before the motion is refitted.
//!
//! A pin–slot clearance bends it as well: the pin crosses the gap before the wheel starts, the
//! wheel bounces at the impacts and lags or runs ahead at exit. The alignment takes the late
//! start for crank phase (55 mrad of crank for 0.5 mm on exact corners, this module's test),
//! and a backlash trial that kept that motion added its own delay to it. The exact view
//! therefore runs the scenario's dynamics (without disc vibration, whose phase is a parameter,
//! not a nuisance) when it has a clearance. (The self-check's 0.5 mm clearance, 12–18 % low
//! before, is still 11–16 % low with the refit: the crank was not the main cause.)

use crate::camera::Camera;
use crate::diagnose::align::{align_motion, apply_motion, MotionAlignment};
use crate::estimate::angle::screen_angle_rad;
use crate::estimate::{estimate, Corners, Differentiator, ReferenceCompensation, Timebase};
use crate::mechanism::effects::axis_runout_offset_m;
use crate::mechanism::Mechanism;
use crate::numeric::angle::wrap_pi as wrap;
use crate::scenario::effects::Effect;
use crate::scenario::Scenario;
use crate::scene::{Scene, WheelPose};

/// Why the nominal's view of its motion could not be computed: a part of the scenario that does
/// not build, or an estimator or a motion alignment that fails on its corners or angles.
#[derive(Debug, thiserror::Error)]
pub enum ViewError {
    #[error("the nominal scenario's camera")]
    NominalCamera(#[source] crate::camera::CameraError),
    #[error("the nominal scenario's scene")]
    NominalScene(#[source] crate::scene::SceneError),
    #[error("the nominal scenario's mechanism")]
    NominalMechanism(#[source] crate::mechanism::MechanismError),
    #[error("the estimator on the camera's view of the exact motion")]
    Estimate(#[source] crate::estimate::EstimateError),
    #[error("aligning the nominal's motion to the measured angle")]
    AlignMotion(#[source] crate::diagnose::align::AlignError),
}

/// Most rounds of motion refits with the warp recomputed for the refitted motion (each round
/// cuts the speed error about fivefold; they stop once the crank start and speed settle).
const MOTION_ROUNDS: usize = 8;
/// Most rounds of rotation-centre shifts (each cuts the centre error about sixfold at a 30°
/// tilt; they stop below [`CENTRE_TOLERANCE_PX`]).
const CENTRE_ROUNDS: usize = 8;
/// A measured centre this close to the target is matched, px.
const CENTRE_TOLERANCE_PX: f64 = 1e-3;
/// Motion refits stop when the speed scale changes by less than this (relative).
const SPEED_TOLERANCE: f64 = 1e-5;

/// +1 when θ2 grows counter-clockwise on screen for this scene.
pub fn screen_sign(scene: &Scene) -> f64 {
    let pose = |th: f64| WheelPose {
        theta2_rad: th,
        centre_offset_m: [0.0, 0.0],
    };
    let c = scene.rotation_centre_px_at(&pose(0.0));
    let at = |th: f64| {
        let p = scene.marker_centre_px_at(&pose(th));
        screen_angle_rad([p.x, p.y], [c.x, c.y])
    };
    if wrap(at(1e-3) - at(0.0)) >= 0.0 {
        1.0
    } else {
        -1.0
    }
}

/// Whether `s`'s camera bends the measured angle away from σ·θ2 + c: a tilt, or a lens
/// distortion, switched on with a non-zero parameter.
pub fn camera_bends_angle(s: &Scenario) -> bool {
    let tilt = &s.camera.perspective_tilt;
    let lens = &s.camera.lens_distortion;
    (tilt.enabled && (tilt.tilt_x_deg != 0.0 || tilt.tilt_y_deg != 0.0))
        || (lens.enabled
            && [lens.k1, lens.k2, lens.k3, lens.p1, lens.p2]
                .iter()
                .any(|v| *v != 0.0))
}

/// Whether `s` states a runout a camera can see (see `AxisRunoutConfig::is_visible`).
pub fn runout_bends_angle(s: &Scenario) -> bool {
    Effect::AxisRunout.is_on(s) && s.dynamics.axis_runout.is_visible()
}

/// Whether `s`'s wheel departs from its kinematic angle through its dynamics: a pin–slot
/// clearance (impacts, bouncing) or low friction (coasting past the index), switched on.
pub fn dynamics_bends_angle(s: &Scenario) -> bool {
    Effect::Backlash.is_on(s)
}

/// Whether the angle `s`'s estimator measures departs from σ·θ2 + c on exact corners: through
/// the camera, the wheel centre's runout, or the wheel's dynamics.
pub fn bends_angle(s: &Scenario) -> bool {
    camera_bends_angle(s) || runout_bends_angle(s) || dynamics_bends_angle(s)
}

/// What `s`'s estimator measures on the exact marker corners of `s`'s motion at `t_s`: the
/// kinematic motion, or the dynamics' when they bend it ([`dynamics_bends_angle`]), the wheel
/// centre moved by `s`'s runout (disc vibration left out: its phase is no nuisance to refit).
pub struct ExactView {
    /// Measured angle minus `screen_sign`·θ2 of the kinematic motion at each time (a constant
    /// for a square camera and no dynamics), rad.
    pub warp_rad: Vec<f64>,
    /// The measured angle itself (screen, unwrapped from the first time), rad.
    pub measured_rad: Vec<f64>,
    /// The rotation centre the estimator fits, px.
    pub centre_px: [f64; 2],
}

/// The wheel angle θ2 of `s`'s motion at each time, kinematic and as the camera sees it: the
/// costly half of an exact view (a dynamics simulation when the dynamics bend the angle, about
/// 75 ms for 6 s of the `fast` rig).
///
/// Architecture invariant: it reads only `s`'s mechanism, drive speed, dynamics and duration.
/// The camera, the rotation centre and the marker's angle on the disc do not move the wheel,
/// so a refit that changes only those reuses it ([`match_measured_centre`], the marker step of
/// [`realign_motion`]).
struct WheelAngles {
    kinematic_rad: Vec<f64>,
    seen_rad: Vec<f64>,
}

fn wheel_angles(s: &Scenario, t_s: &[f64]) -> Result<WheelAngles, ViewError> {
    let mut dynamics = s.dynamics.clone();
    dynamics.enabled = dynamics_bends_angle(s);
    // Runout is applied by the view, from `s`'s own section; disc vibration is not a nuisance.
    // With neither and no dynamics, `actual` is `ideal` exactly.
    dynamics.disc_vibration.enabled = false;
    dynamics.axis_runout.enabled = false;
    let duration_s = t_s.last().copied().unwrap_or(0.0).max(s.duration_s) + 1.0;
    let mech = Mechanism::new(&s.mechanism, &s.drive_speed, &dynamics, duration_s)
        .map_err(ViewError::NominalMechanism)?;
    Ok(WheelAngles {
        kinematic_rad: t_s.iter().map(|&t| mech.ideal(t).theta2_rad).collect(),
        seen_rad: t_s.iter().map(|&t| mech.actual(t).theta2_rad).collect(),
    })
}

/// The estimator on the corners `s`'s camera projects, without rendering or detection.
pub fn exact_view(s: &Scenario, t_s: &[f64], screen_sign: f64) -> Result<ExactView, ViewError> {
    view_of(s, t_s, &wheel_angles(s, t_s)?, screen_sign)
}

/// [`exact_view`] with `s`'s wheel angles already computed.
fn view_of(
    s: &Scenario,
    t_s: &[f64],
    wheel: &WheelAngles,
    screen_sign: f64,
) -> Result<ExactView, ViewError> {
    let camera = Camera::new(&s.camera).map_err(ViewError::NominalCamera)?;
    let scene = Scene::new(&s.scene, camera).map_err(ViewError::NominalScene)?;
    let corners: Vec<Option<Corners>> = t_s
        .iter()
        .zip(&wheel.seen_rad)
        .map(|(&t, &theta2_rad)| {
            Some(scene.marker_corners_px_at(&WheelPose {
                theta2_rad,
                centre_offset_m: axis_runout_offset_m(&s.dynamics.axis_runout, t, theta2_rad),
            }))
        })
        .collect();
    // Only the angle and the centre are used: the cheapest differentiator that cannot fail on
    // noise-free data.
    let mut config = s.estimator.clone();
    config.differentiator = Differentiator::Central3;
    config.reference_compensation = ReferenceCompensation::Off;
    config.timebase = Timebase::Timestamps;
    let est = estimate(&config, t_s, &corners, None).map_err(ViewError::Estimate)?;
    let measured_rad = est.primary_series().theta_rad.clone();
    let warp_rad = measured_rad
        .iter()
        .zip(&wheel.kinematic_rad)
        .map(|(m, th)| m - screen_sign * th)
        .collect();
    Ok(ExactView {
        warp_rad,
        measured_rad,
        centre_px: est.rotation_centre.centre_px,
    })
}

/// `s` with its crank phase and speed refitted to the real angle `theta_rad` at `t_s` (detected
/// frames) with the warp of `s`'s own camera and runout taken out, and the last refit (its speed
/// scale is relative to `s`'s drive; `None` when nothing bends the angle ([`bends_angle`]) and
/// `s` is returned unchanged).
pub fn realign_motion(
    s: &Scenario,
    t_s: &[f64],
    theta_rad: &[f64],
    screen_sign: f64,
) -> Result<(Scenario, Option<Realigned>), ViewError> {
    if !bends_angle(s) {
        return Ok((s.clone(), None));
    }
    let wheel = wheel_angles(s, t_s)?;
    let (out, last, _) = realign_with(s, t_s, theta_rad, screen_sign, wheel)?;
    Ok((out, last))
}

/// [`realign_motion`] of an `s` that bends the angle, from `s`'s wheel angles, returning the
/// result's wheel angles too.
fn realign_with(
    s: &Scenario,
    t_s: &[f64],
    theta_rad: &[f64],
    screen_sign: f64,
    mut wheel: WheelAngles,
) -> Result<(Scenario, Option<Realigned>, WheelAngles), ViewError> {
    let mut out = s.clone();
    let mut speed_scale = 1.0;
    let mut last = None;
    for _ in 0..MOTION_ROUNDS {
        let view = view_of(&out, t_s, &wheel, screen_sign)?;
        let straightened: Vec<f64> = theta_rad
            .iter()
            .zip(&view.warp_rad)
            .map(|(th, w)| th - w)
            .collect();
        let motion =
            align_motion(&out, t_s, &straightened, screen_sign).map_err(ViewError::AlignMotion)?;
        out = apply_motion(&out, &motion);
        wheel = wheel_angles(&out, t_s)?;
        // The refit moves the wheel's phase; put the marker back where the footage sees it
        // (the marker's angle does not move the wheel: `wheel` stays valid).
        let seen = view_of(&out, t_s, &wheel, screen_sign)?;
        let mut offsets: Vec<f64> = theta_rad
            .iter()
            .zip(&seen.measured_rad)
            .map(|(real, exact)| wrap(real - exact))
            .filter(|d| d.is_finite())
            .collect();
        offsets.sort_by(f64::total_cmp);
        if let Some(d) = offsets.get(offsets.len() / 2) {
            let m = &mut out.scene.marker;
            m.angle_on_disc_deg =
                wrap(m.angle_on_disc_deg.to_radians() + screen_sign * d).to_degrees();
        }
        speed_scale *= motion.speed_scale;
        let settled = (motion.speed_scale - 1.0).abs() < SPEED_TOLERANCE;
        last = Some(Realigned {
            motion,
            speed_scale,
        });
        if settled {
            break;
        }
    }
    Ok((out, last, wheel))
}

/// The nuisance a trial that bends the angle ([`bends_angle`]) or varies the crank speed
/// ([`Effect::trial_refits_motion`]) refits: `s`'s rotation centre
/// moved to where the estimator measures `want_centre_px` ([`match_measured_centre`]), its
/// motion and marker angle refitted to the real angle `theta_rad` ([`realign_motion`]), and the
/// centre matched again after the motion moved it. The same as those three calls in turn, with
/// the wheel's angles computed once per motion.
pub fn refit_nuisance(
    s: &Scenario,
    want_centre_px: [f64; 2],
    t_s: &[f64],
    theta_rad: &[f64],
    screen_sign: f64,
) -> Result<Scenario, ViewError> {
    let wheel = wheel_angles(s, t_s)?;
    let centred = centre_at(s, want_centre_px, t_s, &wheel, screen_sign)?;
    if !(bends_angle(&centred) || Effect::DriveSpeed.is_on(&centred)) {
        return centre_at(&centred, want_centre_px, t_s, &wheel, screen_sign);
    }
    // The centre does not move the wheel: `wheel` is `centred`'s.
    let (moved, _, wheel) = realign_with(&centred, t_s, theta_rad, screen_sign, wheel)?;
    centre_at(&moved, want_centre_px, t_s, &wheel, screen_sign)
}

/// The rotation centre the estimator measures on `reference`'s exact corners, px: what
/// [`match_measured_centre`] matches.
pub fn measured_centre_px(
    reference: &Scenario,
    t_s: &[f64],
    screen_sign: f64,
) -> Result<[f64; 2], ViewError> {
    Ok(exact_view(reference, t_s, screen_sign)?.centre_px)
}

/// The motion refit of [`realign_motion`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Realigned {
    /// The last round's alignment (start angle absolute, speed scale relative to the round
    /// before, offset and residual of the straightened angle).
    pub motion: MotionAlignment,
    /// Speed scale of the result relative to the input scenario's drive.
    pub speed_scale: f64,
}

/// `s` with its rotation centre's image moved so that the estimator measures, on `s`'s exact
/// corners, the centre it measures on `reference`'s (the aligned nominal's, matched to the real
/// footage by simulation).
pub fn match_measured_centre(
    s: &Scenario,
    reference: &Scenario,
    t_s: &[f64],
    screen_sign: f64,
) -> Result<Scenario, ViewError> {
    let want = measured_centre_px(reference, t_s, screen_sign)?;
    centre_at(s, want, t_s, &wheel_angles(s, t_s)?, screen_sign)
}

/// `s` with its rotation centre's image moved so that the estimator measures `want` px on its
/// exact corners, `wheel` being `s`'s wheel angles.
fn centre_at(
    s: &Scenario,
    want: [f64; 2],
    t_s: &[f64],
    wheel: &WheelAngles,
    screen_sign: f64,
) -> Result<Scenario, ViewError> {
    let mut out = s.clone();
    // Only the rotation centre's image moves between rounds: the wheel's angles stay.
    for _ in 0..CENTRE_ROUNDS {
        let got = view_of(&out, t_s, wheel, screen_sign)?.centre_px;
        if (got[0] - want[0]).hypot(got[1] - want[1]) < CENTRE_TOLERANCE_PX {
            break;
        }
        let c = out
            .camera
            .rotation_centre_px
            .unwrap_or_else(|| out.camera.image_centre_px());
        out.camera.rotation_centre_px = Some([c[0] + want[0] - got[0], c[1] + want[1] - got[1]]);
    }
    Ok(out)
}

/// RMS about its mean of the change in the measured angle (exact corners, rad) when `effect` is
/// applied to `s` at `values`, at the times `t_s`: how much the effect bends the angle on this
/// rig's geometry, with no rendering and no noise. The mean is left out: the alignment takes a
/// constant offset as the marker's angle.
pub fn angle_bend_rms(
    s: &Scenario,
    effect: Effect,
    values: &[f64],
    t_s: &[f64],
    screen_sign: f64,
) -> Result<f64, ViewError> {
    let before = exact_view(s, t_s, screen_sign)?;
    let mut with = s.clone();
    effect.apply(&mut with, values);
    let after = exact_view(&with, t_s, screen_sign)?;
    let d: Vec<f64> = after
        .measured_rad
        .iter()
        .zip(&before.measured_rad)
        .map(|(a, b)| a - b)
        .filter(|d| d.is_finite())
        .collect();
    if d.is_empty() {
        return Ok(0.0);
    }
    let mean = d.iter().sum::<f64>() / d.len() as f64;
    Ok((d.iter().map(|x| (x - mean) * (x - mean)).sum::<f64>() / d.len() as f64).sqrt())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::align::align_motion;

    fn tilted(deg: f64) -> Scenario {
        let mut s = crate::scenario::load_any("fast").unwrap();
        s.camera.perspective_tilt.enabled = true;
        s.camera.perspective_tilt.tilt_x_deg = deg;
        s.camera.perspective_tilt.tilt_y_deg = 0.6 * deg;
        s
    }

    /// A radial lens is symmetric about its centre: with the wheel axis imaged there (the `fast`
    /// rig) even a k1 of −0.6 bends the measured angle by microradians, far below any
    /// detection noise; with the axis 200 px off the centre the same lens bends it by
    /// milliradians.
    #[test]
    fn a_lens_bends_the_angle_only_off_its_centre() {
        let centred = crate::scenario::load_any("fast").unwrap();
        let t: Vec<f64> = (0..120).map(|k| k as f64 / 30.0).collect();
        let sign = |s: &Scenario| {
            super::screen_sign(&Scene::new(&s.scene, Camera::new(&s.camera).unwrap()).unwrap())
        };
        let bend =
            |s: &Scenario| angle_bend_rms(s, Effect::LensDistortion, &[-0.6], &t, sign(s)).unwrap();
        let at_centre = bend(&centred);
        assert!(at_centre < 2e-5, "{at_centre}");
        let mut off = centred.clone();
        let c = off.camera.image_centre_px();
        off.camera.rotation_centre_px = Some([c[0] + 200.0, c[1] + 60.0]);
        let off_centre = bend(&off);
        assert!(off_centre > 1e-3, "{off_centre}");
        // Nothing applied, nothing bent.
        let none = angle_bend_rms(&off, Effect::LensDistortion, &[0.0], &t, sign(&off)).unwrap();
        assert!(none < 1e-12, "{none}");
    }

    /// The real angle of a tilted camera, measured on exact corners: the plain alignment takes
    /// the warp for a speed error; the realignment through the camera does not.
    #[test]
    fn a_tilted_cameras_warp_is_not_taken_for_a_crank_speed() {
        the_warp_is_not_taken_for_a_crank_speed(tilted(30.0));
    }

    /// The same for a square camera and a wobbling wheel axis: 2 mm at 2 cycles per wheel
    /// revolution (the self-check's strong runout), seen over 3 s.
    #[test]
    fn a_runouts_warp_is_not_taken_for_a_crank_speed() {
        let mut truth = crate::scenario::load_any("fast").unwrap();
        let r = &mut truth.dynamics.axis_runout;
        r.enabled = true;
        r.amplitude_m = 2e-3;
        r.cycles_per_wheel_rev = 2.0;
        r.phase_rad = 0.0;
        assert!(!camera_bends_angle(&truth) && bends_angle(&truth));
        the_warp_is_not_taken_for_a_crank_speed(truth);
    }

    /// `truth` moved (crank start, marker angle, speed ×1.1) and measured on its exact corners:
    /// the plain alignment is off in speed by more than 1 %, the realignment through `truth`'s
    /// own warp within 0.2 %, and the realigned scenario reproduces the measured angle.
    fn the_warp_is_not_taken_for_a_crank_speed(truth: Scenario) {
        let (plain, realigned_scale, _) = realign_moved(&truth, 2e-3);
        assert!(
            (plain.speed_scale - 1.1).abs() > 0.01,
            "the warp should bias the plain fit: {plain:?}"
        );
        assert!(
            (realigned_scale - 1.1).abs() < 2e-3,
            "realigned speed scale {realigned_scale} (plain {})",
            plain.speed_scale
        );
    }

    /// A pin–slot clearance of 0.5 mm (the self-check's strong backlash): the wheel starts late
    /// and bounces, and the plain alignment takes that for crank phase (55 mrad off here); the
    /// realignment through the dynamics finds the crank (1 µrad).
    #[test]
    fn a_clearances_late_start_is_not_taken_for_a_crank_phase() {
        let mut truth = crate::scenario::load_any("fast").unwrap();
        Effect::Backlash.apply(&mut truth, &[0.5]);
        assert!(!camera_bends_angle(&truth) && bends_angle(&truth));
        let (plain, realigned_scale, realigned) = realign_moved(&truth, 2e-3);
        let start = |s: &Scenario| s.mechanism.theta1_start_rad.unwrap_or(f64::NAN);
        let plain_err = (plain.theta1_start_rad - 2.0).abs();
        let realigned_err = (start(&realigned) - 2.0).abs();
        assert!(
            plain_err > 1e-2,
            "the late start should pull the plain fit: {plain:?}"
        );
        assert!(
            realigned_err < 1e-3,
            "realigned start off by {realigned_err} rad, plain {plain_err}"
        );
        assert!(
            (realigned_scale - 1.1).abs() < 1e-3,
            "realigned speed scale {realigned_scale}"
        );
    }

    /// `truth` moved (crank start 2 rad, marker angle +4°, speed ×1.1) and measured on its exact
    /// corners at `frames` frames of 30 fps: its screen sign, the frame times and the angle.
    fn measured_moved(truth: &Scenario, frames: usize) -> (f64, Vec<f64>, Vec<f64>) {
        let sign = super::screen_sign(&{
            let camera = Camera::new(&truth.camera).unwrap();
            Scene::new(&truth.scene, camera).unwrap()
        });
        let t: Vec<f64> = (0..frames).map(|k| k as f64 / 30.0).collect();
        let mut moving = truth.clone();
        moving.mechanism.theta1_start_rad = Some(2.0);
        moving.scene.marker.angle_on_disc_deg += 4.0;
        moving.drive_speed = crate::diagnose::align::scale_drive(&truth.drive_speed, 1.1);
        let theta = exact_view(&moving, &t, sign).unwrap().measured_rad;
        (sign, t, theta)
    }

    /// `truth` moved (crank start 2 rad, marker angle +4°, speed ×1.1) and measured on its exact
    /// corners, aligned plainly and realigned through `truth`'s own bend: the plain alignment,
    /// the realigned speed scale and scenario. The realigned scenario must reproduce the
    /// measured angle within `worst_rad`.
    fn realign_moved(truth: &Scenario, worst_rad: f64) -> (MotionAlignment, f64, Scenario) {
        let (sign, t, theta) = measured_moved(truth, 90);

        let plain = align_motion(truth, &t, &theta, sign).unwrap();
        let (realigned, refit) = realign_motion(truth, &t, &theta, sign).unwrap();
        let omega1 = |s: &Scenario| match &s.drive_speed {
            crate::mechanism::DriveSpeedConfig::Constant { omega1_rad_s } => *omega1_rad_s,
            other => panic!("the test needs a constant drive: {other:?}"),
        };
        let realigned_scale = omega1(&realigned) / omega1(truth);
        let refit_scale = refit.map_or(f64::NAN, |r| r.speed_scale);
        assert!(
            (refit_scale / realigned_scale - 1.0).abs() < 1e-12,
            "{refit_scale}"
        );
        // The marker is put back where the footage sees it: the realigned scenario's exact view
        // is the real angle.
        let seen = exact_view(&realigned, &t, sign).unwrap();
        let worst = seen
            .measured_rad
            .iter()
            .zip(&theta)
            .map(|(a, b)| wrap(a - b).abs())
            .fold(0.0, f64::max);
        assert!(worst < worst_rad, "worst angle misfit {worst} rad");
        (plain, realigned_scale, realigned)
    }

    /// A crank that slows by 15 % in each engagement (the drive-speed probe), moved and measured
    /// on exact corners: the constant-speed nominal's alignment takes the profile for another
    /// crank speed and phase, so the profile's trial on that motion misses the real angle; the
    /// trial's nuisance refit finds the crank and matches it.
    #[test]
    fn a_speed_profiles_trial_refits_the_crank_the_constant_alignment_misread() {
        let mut truth = crate::scenario::load_any("fast").unwrap();
        let mut nominal = truth.clone();
        Effect::DriveSpeed.switch_off(&mut nominal);
        Effect::DriveSpeed.apply(&mut truth, &[-0.15]);
        let end = |s: &Scenario| crate::scenario::effects::mean_crank_speed_rad_s(&s.drive_speed);
        let (sign, t, theta) = measured_moved(&truth, 180);

        let aligned = apply_motion(&nominal, &align_motion(&nominal, &t, &theta, sign).unwrap());
        let mut trial = aligned.clone();
        Effect::DriveSpeed.apply(&mut trial, &[-0.15]);
        let want = measured_centre_px(&aligned, &t, sign).unwrap();
        let refitted = refit_nuisance(&trial, want, &t, &theta, sign).unwrap();
        let misfit = |s: &Scenario| {
            exact_view(s, &t, sign)
                .unwrap()
                .measured_rad
                .iter()
                .zip(&theta)
                .map(|(a, b)| wrap(a - b).abs())
                .fold(0.0, f64::max)
        };
        let (kept, refit) = (misfit(&trial), misfit(&refitted));
        assert!(kept > 1e-2, "the kept motion should miss: {kept} rad");
        assert!(refit < 2e-3, "refitted misfit {refit} rad (kept {kept})");
        let speed_err = end(&refitted) / (1.1 * end(&truth)) - 1.0;
        let kept_err = end(&trial) / (1.1 * end(&truth)) - 1.0;
        assert!(
            speed_err.abs() < 2e-3 && kept_err.abs() > 1e-2,
            "crank speed off by {speed_err} refitted, {kept_err} kept"
        );
    }

    /// [`refit_nuisance`] is the centre match, motion refit and centre match it replaced, bit
    /// for bit, for a trial that refits through its dynamics (a 0.5 mm clearance), through its
    /// camera (a tilt) and one that bends nothing (only the centre moves).
    #[test]
    fn refitting_the_nuisance_at_once_is_the_three_steps_in_turn(
    ) -> Result<(), Box<dyn std::error::Error>> {
        let reference = crate::scenario::load_any("fast")?;
        let mut clearance = reference.clone();
        Effect::Backlash.apply(&mut clearance, &[0.5]);
        let t: Vec<f64> = (0..60).map(|k| k as f64 / 30.0).collect();
        let sign = super::screen_sign(&{
            let camera = Camera::new(&reference.camera)?;
            Scene::new(&reference.scene, camera)?
        });
        for truth in [clearance, tilted(20.0), reference.clone()] {
            let mut moving = truth.clone();
            moving.mechanism.theta1_start_rad = Some(2.0);
            moving.scene.marker.angle_on_disc_deg += 4.0;
            let theta = exact_view(&moving, &t, sign)?.measured_rad;
            let mut trial = truth.clone();
            let c = trial.camera.image_centre_px();
            trial.camera.rotation_centre_px = Some([c[0] + 3.0, c[1] - 2.0]);

            let centred = match_measured_centre(&trial, &reference, &t, sign)?;
            let (moved, _) = realign_motion(&centred, &t, &theta, sign)?;
            let in_turn = match_measured_centre(&moved, &reference, &t, sign)?;
            let want = measured_centre_px(&reference, &t, sign)?;
            let at_once = refit_nuisance(&trial, want, &t, &theta, sign)?;
            assert_eq!(at_once, in_turn);
            assert_ne!(at_once, trial, "the refit moved nothing");
        }
        Ok(())
    }

    /// The registry's [`Effect::bends_the_aligned_angle`] (which trials refit their motion) and
    /// [`bends_angle`] (whether the exact view departs from the kinematic angle) are one idea in
    /// two places: each effect of the vocabulary, switched on at its probe value on the `fast`
    /// rig, bends the exact view exactly when the registry says so.
    #[test]
    fn the_registry_and_the_exact_view_agree_on_what_bends_the_angle() {
        let base = crate::scenario::load_any("fast").unwrap();
        for e in Effect::ALL {
            let mut s = base.clone();
            e.switch_off(&mut s);
            assert!(!bends_angle(&s), "{} switched off", e.name());
            let probe: Vec<f64> = e.params().iter().map(|p| p.probe).collect();
            e.apply(&mut s, &probe);
            assert_eq!(
                bends_angle(&s),
                e.bends_the_aligned_angle(),
                "{} at its probe {probe:?}",
                e.name()
            );
        }
    }

    #[test]
    fn a_square_camera_is_left_alone() {
        let s = crate::scenario::load_any("fast").unwrap();
        assert!(!camera_bends_angle(&s));
        let t: Vec<f64> = (0..20).map(|k| k as f64 / 30.0).collect();
        let theta = vec![0.0; t.len()];
        assert_eq!(realign_motion(&s, &t, &theta, 1.0).unwrap(), (s, None));
    }

    #[test]
    fn the_centre_is_moved_to_where_the_reference_is_measured() {
        let reference = crate::scenario::load_any("fast").unwrap();
        let s = tilted(25.0);
        let t: Vec<f64> = (0..90).map(|k| k as f64 / 30.0).collect();
        let want = exact_view(&reference, &t, 1.0).unwrap().centre_px;
        let before = exact_view(&s, &t, 1.0).unwrap().centre_px;
        let moved = match_measured_centre(&s, &reference, &t, 1.0).unwrap();
        let after = exact_view(&moved, &t, 1.0).unwrap().centre_px;
        let d = |a: [f64; 2], b: [f64; 2]| (a[0] - b[0]).hypot(a[1] - b[1]);
        assert!(
            d(before, want) > 1.0,
            "tilt moves the measured centre: {before:?} {want:?}"
        );
        assert!(d(after, want) < 0.05, "{after:?} vs {want:?}");
    }
}
