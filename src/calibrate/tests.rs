//! The pure fits on synthetic observations with a known truth (the round trip through the
//! renderer and the detector is in `tests/calibrate_roundtrip.rs`).

use super::*;
use crate::mechanism::kinematics::{Geneva, GenevaKind};
use crate::mechanism::DriveSpeedConfig;
use crate::rng;
use crate::scenario::Scenario;
use rand_distr::{Distribution, Normal};

/// Marker-angle track of a constant-speed crank: φ = A + θ2(θ10 + ω t) − θ2(θ10), with noise.
#[allow(clippy::too_many_arguments)]
fn track(
    kind: GenevaKind,
    slots: u32,
    th0: f64,
    w: f64,
    a: f64,
    noise: f64,
    n: usize,
    fps: f64,
) -> Vec<(f64, f64)> {
    let g = Geneva::new(kind, slots);
    let mut r = rng::stream(5, rng::Stream::MonteCarlo, 0);
    let d = Normal::new(0.0, noise.max(1e-300)).unwrap();
    (0..n)
        .map(|k| {
            let t = k as f64 / fps;
            let phi = a + g.wheel_angle_abs_rad(th0 + w * t) - g.wheel_angle_abs_rad(th0);
            (t, phi + if noise > 0.0 { d.sample(&mut r) } else { 0.0 })
        })
        .collect()
}

#[test]
fn motion_fit_recovers_phase_speed_and_angle_within_its_uncertainty() {
    for &(kind, slots, th0, w) in &[
        (GenevaKind::Internal, 4, -2.9, -1.55),
        (GenevaKind::External, 4, 0.4, 3.1),
        (GenevaKind::External, 6, -1.0, -2.2),
        (GenevaKind::Internal, 5, 2.0, 0.9),
    ] {
        let a = 0.7;
        let input = MotionInput {
            kind,
            slots,
            track: track(kind, slots, th0, w, a, 2e-4, 240, 30.0),
            dense: Vec::new(),
            centre_angle_u95_rad: 0.0,
        };
        let mut notes = Vec::new();
        let m = fit_motion(&input, &mut notes).unwrap();
        assert!(
            m.omega1_rad_s.covers(w) && (m.omega1_rad_s.value - w).abs() < 0.01,
            "{kind:?} {slots}: ω {} vs {w}",
            m.omega1_rad_s
        );
        let dth = crate::numeric::angle::wrap_pi(m.theta1_start_rad.value - th0);
        assert!(
            dth.abs() <= m.theta1_start_rad.u95 && dth.abs() < 0.02,
            "{kind:?}: θ1 {} vs {th0}",
            m.theta1_start_rad
        );
        assert!(
            (m.angle_first_deg.value - a.to_degrees()).abs() <= m.angle_first_deg.u95.max(0.01),
            "{kind:?}: A {} vs {}",
            m.angle_first_deg,
            a.to_degrees()
        );
        assert!(
            m.polynomial.is_none(),
            "{kind:?}: constant speed taken for a polynomial"
        );
        assert!(m.engagements >= 1);
    }
}

#[test]
fn motion_fit_resolves_the_per_engagement_polynomial() {
    let g = Geneva::new(GenevaKind::Internal, 4);
    let (end, mid, th0) = (-1.55, -1.25, -2.5);
    let crank = crate::mechanism::CrankMotion::new(
        &DriveSpeedConfig::PolynomialPerEngagement {
            end_rad_s: end,
            mid_rad_s: mid,
        },
        &g,
        th0,
    )
    .unwrap();
    let w0 = g.wheel_angle_abs_rad(crank.state(0.0).theta1_rad);
    let tr: Vec<(f64, f64)> = (0..300)
        .map(|k| {
            let t = k as f64 / 30.0;
            (
                t,
                0.2 + g.wheel_angle_abs_rad(crank.state(t).theta1_rad) - w0,
            )
        })
        .collect();
    let mut notes = Vec::new();
    let m = fit_motion(
        &MotionInput {
            kind: GenevaKind::Internal,
            slots: 4,
            track: tr,
            dense: Vec::new(),
            centre_angle_u95_rad: 0.0,
        },
        &mut notes,
    )
    .unwrap();
    let (e, mi) = m.polynomial.expect("resolved");
    assert!(
        (e.value - end).abs() < 0.01 && (mi.value - mid).abs() < 0.01,
        "{e} {mi}"
    );
}

#[test]
fn a_wheel_that_does_not_turn_is_an_error_naming_the_motion() {
    let input = MotionInput {
        kind: GenevaKind::Internal,
        slots: 4,
        track: (0..50).map(|k| (k as f64 / 30.0, 0.3)).collect(),
        dense: Vec::new(),
        centre_angle_u95_rad: 0.0,
    };
    let e = fit_motion(&input, &mut Vec::new()).unwrap_err();
    assert!(e.to_string().contains("single-frame"), "{e}");
}

/// Corners of every pose of a marker turning with `track` on the disc, seen by the project's
/// camera (optionally tilted): the truth for the pose fit.
fn posed(
    base: &Scenario,
    tilt: Option<(f64, f64)>,
    centre: [f64; 2],
    tr: &[(f64, f64)],
) -> Vec<FrameObservation> {
    let mut cfg = base.camera.clone();
    cfg.rotation_centre_px = Some(centre);
    if let Some((tx, ty)) = tilt {
        cfg.perspective_tilt.enabled = true;
        cfg.perspective_tilt.tilt_x_deg = tx;
        cfg.perspective_tilt.tilt_y_deg = ty;
    }
    let cam = crate::camera::Camera::new(&cfg).unwrap();
    let m = &base.scene.marker;
    tr.iter()
        .enumerate()
        .map(|(k, &(t, phi))| {
            let placed = crate::scene::PlacedMarker::new(
                glam::DVec2::new(phi.cos(), phi.sin()) * (m.radius_mm * 1e-3),
                phi + m.orientation_deg.to_radians(),
                m.size_mm * 1e-3,
                m.white_margin_mm * 1e-3,
            );
            let c = placed.corners_m().map(|w| cam.project(w).to_array());
            FrameObservation {
                frame: k,
                t_s: t,
                corners_px: Some(c),
                refined_px: Some(c),
                ..Default::default()
            }
        })
        .collect()
}

fn rig_base() -> Scenario {
    let mut base = Scenario::default();
    base.camera.width_px = 1600;
    base.camera.height_px = 900;
    base.camera.focal = crate::camera::FocalConfig::ImageScale { mm_per_px: 0.25 };
    base.scene.marker.size_mm = 32.0;
    base.scene.marker.radius_mm = 95.0;
    base.scene.marker.orientation_deg = 17.0;
    base
}

#[test]
fn geometry_recovers_scale_centre_radius_and_orientation() {
    let base = rig_base();
    let c = [812.3, 455.8];
    let tr = track(GenevaKind::External, 4, -0.6, 2.5, 0.4, 0.0, 120, 30.0);
    let stats = FootageStats {
        width_px: 1600,
        height_px: 900,
        frames: posed(&base, None, c, &tr),
        ..Default::default()
    };
    let g = fit_geometry(&base, &stats, false, &mut Vec::new()).unwrap();
    assert!((g.mm_per_px.value - 0.25).abs() < 1e-7, "{}", g.mm_per_px);
    let [cx, cy] = g.centre_px.unwrap();
    assert!(
        (cx.value - c[0]).abs() < 1e-4 && (cy.value - c[1]).abs() < 1e-4,
        "{cx} {cy}"
    );
    assert!((g.radius_mm.value - 95.0).abs() < 1e-4, "{}", g.radius_mm);
    assert!(
        (g.orientation_deg.value - 17.0).abs() < 1e-4,
        "{}",
        g.orientation_deg
    );
    assert!((g.angle_first_deg.value - 0.4f64.to_degrees()).abs() < 1e-4);
    assert!(!g.tilt.significant, "{:?}", g.tilt);
    assert!(g.from_edges && g.rms_residual_px < 1e-6);
}

#[test]
fn a_tilted_camera_is_recovered_by_the_pose_fit() {
    let base = rig_base();
    let c = [760.0, 470.0];
    let tr = track(GenevaKind::Internal, 4, -2.0, -2.0, 0.0, 0.0, 90, 30.0);
    // Corner noise of edge-fitted corners, a few hundredths of a pixel.
    let mut r = rng::stream(9, rng::Stream::MonteCarlo, 1);
    let d = Normal::new(0.0, 0.02).unwrap();
    let mut frames = posed(&base, Some((4.0, -3.0)), c, &tr);
    for f in &mut frames {
        let noisy = f
            .refined_px
            .unwrap()
            .map(|p| [p[0] + d.sample(&mut r), p[1] + d.sample(&mut r)]);
        f.refined_px = Some(noisy);
        f.corners_px = Some(noisy);
    }
    let stats = FootageStats {
        width_px: 1600,
        height_px: 900,
        frames,
        ..Default::default()
    };
    let g = fit_geometry(&base, &stats, false, &mut Vec::new()).unwrap();
    assert!(g.tilt.significant, "{:?}", g.tilt);
    assert!(
        g.tilt.tilt_x_deg.covers(4.0) && g.tilt.tilt_y_deg.covers(-3.0),
        "{:?}",
        g.tilt
    );
    assert!(
        (g.tilt.tilt_x_deg.value - 4.0).abs() < 0.2 && (g.tilt.tilt_y_deg.value + 3.0).abs() < 0.2
    );
    let [cx, cy] = g.centre_px.unwrap();
    assert!(cx.covers(c[0]) && cy.covers(c[1]), "{cx} {cy}");
    assert!(g.mm_per_px.covers(0.25), "{}", g.mm_per_px);
    assert!(g.radius_mm.covers(95.0), "{}", g.radius_mm);
}

#[test]
fn fitted_intervals_print_two_significant_digits_and_map_through_functions() {
    let f = Fitted::new(0.195123, 0.000412);
    assert_eq!(f.to_string(), "0.19512 ± 0.00041");
    assert!(f.covers(0.1953) && !f.covers(0.196));
    let g = Fitted::new(2.0, 0.1).map(|x| x * x);
    assert!((g.value - 4.0).abs() < 1e-12 && (g.u95 - 0.41).abs() < 1e-9);
}

#[test]
fn a_base_time_longer_than_the_footages_frame_interval_is_capped_there() {
    use super::output::{capped_time_note, capped_to_frame_interval, footage_frame_interval_s};
    let mut base = Scenario::default();
    assert!(base.effects.motion_blur.enabled && base.effects.motion_blur.exposure_s == 0.004);
    // 30 fps footage: the default 4 ms exposure fits.
    assert!(capped_to_frame_interval(&base, 1.0 / 30.0).is_empty());
    // 480 fps slow motion: 2.083 ms between frames.
    let capped = capped_to_frame_interval(&base, 1.0 / 480.0);
    assert_eq!(capped.len(), 1);
    assert_eq!(capped[0].field, "effects.motion_blur.exposure_s");
    assert_eq!((capped[0].base_s, capped[0].capped_s), (0.004, 0.002083));
    let note = capped_time_note(&capped[0]);
    assert!(
        note.contains("0.004 s") && note.contains("capped at 0.002083 s"),
        "{note}"
    );
    // A readout is capped only when it is on; an interval that is none caps nothing.
    base.effects.rolling_shutter.readout_s = 0.03;
    assert_eq!(capped_to_frame_interval(&base, 1.0 / 60.0).len(), 0);
    base.effects.rolling_shutter.enabled = true;
    let capped = capped_to_frame_interval(&base, 1.0 / 60.0);
    assert_eq!(capped.len(), 1);
    assert_eq!(capped[0].field, "effects.rolling_shutter.readout_s");
    assert_eq!(capped[0].capped_s, 0.016666);
    assert!(capped_to_frame_interval(&base, 0.0).is_empty());
    assert!(capped_to_frame_interval(&base, f64::NAN).is_empty());
    // The footage's interval: the shorter of its median interval and its mean rate's. A phone's
    // variable rate can put the median below the mean rate's interval, and the validator
    // bounds the exposure by the log's median.
    let times: Vec<f64> = (0..20)
        .map(|k| k as f64 * 0.0020 + if k > 15 { 0.01 } else { 0.0 })
        .collect();
    let interval = footage_frame_interval_s(&times, 480.0).unwrap();
    assert!((interval - 0.0020).abs() < 1e-12, "{interval}");
    assert_eq!(
        footage_frame_interval_s(&times[..1], 480.0),
        Some(1.0 / 480.0)
    );
    assert_eq!(footage_frame_interval_s(&times[..1], 0.0), None);
    // What is written passes the validator, on a timing log at that median interval; the
    // base's values did not.
    let dir = tempfile::tempdir().unwrap();
    let ts = crate::timing::Timestamps::new(times.clone()).unwrap();
    let log = dir.path().join("t.csv");
    std::fs::write(&log, crate::timing::to_frames_csv(&ts)).unwrap();
    base.effects.rolling_shutter.enabled = false;
    let write = |exposure_s: f64| {
        let path = dir.path().join("s.toml");
        std::fs::write(
            &path,
            format!(
                "name = \"s\"\nframe_timing.fps = 480.0\neffects.motion_blur.exposure_s = {exposure_s}\n\
                 [frame_timing.model]\nkind = \"log\"\nfile = \"t.csv\"\nformat = \"frames_csv\"\n"
            ),
        )
        .unwrap();
        crate::scenario::load(&path)
    };
    assert!(write(0.004).is_err());
    for c in capped_to_frame_interval(&base, interval) {
        base.effects.motion_blur.exposure_s = c.capped_s;
    }
    assert_eq!(base.effects.motion_blur.exposure_s, 0.002);
    let loaded = write(base.effects.motion_blur.exposure_s);
    assert!(loaded.is_ok(), "{loaded:?}");
    // One interval at the mean rate (2.083 ms) would have been refused against the median.
    assert!(write(0.002083).is_err());
}
