//! End-to-end tests of the synthetic pipeline (render → OpenCV detection → estimation → budget)
//! and of `analyze` on rendered frames.
#![cfg(feature = "opencv-detector")]

mod common;

use common::detections;
use geneva_vision::pipeline::analyze::{analyze, AnalyzeOptions, Source};
use geneva_vision::pipeline::frames::FramePath;
use geneva_vision::pipeline::render_job::{render_job, RenderJob};
use geneva_vision::pipeline::rig::Rig;
use geneva_vision::pipeline::run::{run, RunOptions};
use geneva_vision::scenario::{self, Scenario};
use std::path::Path;

fn scenario_from(text: &str) -> Scenario {
    scenario::from_str(text, Path::new("test.toml")).unwrap()
}

/// The seed's internal drive at 1080p, noiseless and blur-free, default (geometric) estimator:
/// every frame's angle error stays under the generalised half-pixel bound δθ = √2·0.5 px / r.
#[test]
fn noiseless_seed_internal_1080p_angle_error_under_the_half_pixel_bound() {
    let s = scenario_from(
        r#"
extend = "seed-internal-4k"
name = "seed-internal-1080p-noiseless"
duration_s = 6.0
[camera]
width_px = 1920
height_px = 1080
[camera.focal]
kind = "image_scale"
mm_per_px = 0.39
[effects.pixel_noise]
enabled = false
[effects.motion_blur]
enabled = false
[estimator]
rotation_centre = "geometric"
"#,
    );
    let dir = tempfile::tempdir().unwrap();
    let out = run(
        &s,
        dir.path(),
        &RunOptions {
            plots: false,
            ..RunOptions::default()
        },
        &|_, _| {},
    )
    .unwrap();
    assert_eq!(
        out.budget.frames.detected, out.budget.frames.total,
        "every frame detected"
    );
    let bound = &out.budget.bounds["centre"];
    let centre = out.signals.iter().find(|e| e.signal == "centre").unwrap();
    let worst = centre
        .theta_err_rad
        .iter()
        .fold(0.0f64, |m, e| m.max(e.abs()));
    assert!(
        bound.theta_exceedance.exceeded == 0,
        "angle error above δθ = {:.3e} rad in {} of {} frames (worst {worst:.3e})",
        bound.half_pixel.theta_rad,
        bound.theta_exceedance.exceeded,
        bound.theta_exceedance.frames
    );
    assert!(worst > 0.0, "a real measurement has some error");
}

/// With the seed's own estimator (truncated bisector centre, numpy.gradient twice) the run
/// completes and reports on 4.5 s (a whole Geneva cycle); the budget has every phase (their
/// frames adding up to the whole) and
/// the seed's half-pixel bound numbers, recomputed here from the run's own frame times:
/// δθ = √2·0.5 px / r, δθ/h and δθ/h² with h the shortest frame interval, and their doubles.
#[test]
fn seed_settings_run_completes_and_reports() {
    let s = scenario_from("extend = \"fast\"\nname = \"fast-seed\"\nduration_s = 4.5\n[estimator]\nrotation_centre = \"seed\"\nmarker_centre = \"corner_mean\"\ndifferentiator = { kind = \"seed\" }\n");
    let dir = tempfile::tempdir().unwrap();
    let out = run(&s, dir.path(), &RunOptions::default(), &|_, _| {}).unwrap();
    for f in [
        "tracks.csv",
        "kinematics.csv",
        "budget.json",
        "measured_vs_true_time.png",
    ] {
        assert!(dir.path().join(f).is_file(), "{f} written");
    }
    let b = &out.budget;
    assert_eq!(b.frames.total, out.detections.len());
    // Every phase of the Geneva cycle, each with frames, adding up to the whole.
    let phases: Vec<&str> = b.phases.keys().map(String::as_str).collect();
    assert_eq!(phases, ["drive", "dwell", "entry", "exit"]);
    assert!(b.phases.values().all(|p| p.theta.n > 0), "{phases:?}");
    let in_phases: usize = b.phases.values().map(|p| p.theta.n).sum();
    assert_eq!(in_phases, b.theta.n);
    // The seed's bound, recomputed from the frame times of this run.
    let t = &out.truth.t_s;
    let h_min = t
        .windows(2)
        .map(|w| w[1] - w[0])
        .fold(f64::INFINITY, f64::min);
    assert!(!b.bounds.is_empty());
    for (signal, bound) in &b.bounds {
        let hp = &bound.half_pixel;
        let close = |a: f64, e: f64| (a - e).abs() <= 1e-12 * e.abs();
        assert_eq!(hp.position_error_px, 0.5, "{signal}");
        assert!(
            close(hp.h_min_s, h_min),
            "{signal}: {} vs {h_min}",
            hp.h_min_s
        );
        let dtheta = std::f64::consts::SQRT_2 * 0.5 / hp.radius_px;
        assert!(close(hp.theta_rad, dtheta), "{signal}: {hp:?}");
        assert!(
            close(hp.seed_omega_rad_s, dtheta / h_min),
            "{signal}: {hp:?}"
        );
        assert!(
            close(hp.seed_alpha_rad_s2, dtheta / (h_min * h_min)),
            "{signal}"
        );
        assert!(
            close(hp.seed_omega_doubled_rad_s, 2.0 * dtheta / h_min),
            "{signal}"
        );
        assert!(
            close(hp.seed_alpha_doubled_rad_s2, 2.0 * dtheta / (h_min * h_min)),
            "{signal}"
        );
        let counted = &bound.theta_exceedance;
        assert!(
            counted.frames > 0 && counted.exceeded <= counted.frames,
            "{signal}"
        );
    }
    // The file says what the struct does.
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(dir.path().join("budget.json")).unwrap())
            .unwrap();
    for phase in ["dwell", "entry", "drive", "exit"] {
        let p = &b.phases[phase];
        for (q, rms) in [
            ("theta", p.theta.rms),
            ("omega", p.omega.rms),
            ("alpha", p.alpha.rms),
        ] {
            let written = json["phases"][phase][q]["rms"].as_f64().unwrap();
            assert!((written - rms).abs() <= 1e-12 * rms.abs(), "{phase} {q}");
        }
    }
    assert_eq!(
        json["frames"]["total"].as_u64(),
        Some(b.frames.total as u64)
    );
}

/// ROI detection gives exactly the corners of full-frame detection, on 200+ rendered frames of
/// several scenarios (blur, noise, motion blur, tilt, sub-pixel refinement).
#[test]
fn roi_detection_equals_full_frame_detection_on_rendered_frames() {
    let variants = [
        "extend = \"fast\"\nduration_s = 2.4\n",
        "extend = \"fast\"\nduration_s = 2.4\nseed = 11\n[detector]\ncorner_refinement_method = \"subpix\"\n[effects.optical_blur]\nsigma_px = 1.2\n",
        "extend = \"fast\"\nduration_s = 2.4\nseed = 5\n[effects.motion_blur]\nenabled = true\nexposure_s = 0.01\n[camera.perspective_tilt]\nenabled = true\ntilt_x_deg = 12.0\ntilt_y_deg = -8.0\n",
    ];
    let mut compared = 0;
    for v in variants {
        let rig = Rig::new(&scenario_from(v)).unwrap();
        let n = rig.frame_times.len();
        let roi = detections(&rig, 0..n, true, 2);
        let full = detections(&rig, 0..n, false, 2);
        assert_eq!((roi.len(), full.len()), (n, n), "{v}");
        for (a, b) in roi.iter().zip(&full) {
            assert_eq!(a.corners_px, b.corners_px, "frame {} of {v}", a.frame);
            assert!(a.corners_px.is_some(), "frame {} detected", a.frame);
            // Equal corners prove nothing if the ROI run fell back to (or never left) the whole
            // frame: the window comes from the true marker position and these configurations
            // are ROI-exact, so every frame must have been detected in its window.
            assert_eq!(a.path, FramePath::Roi, "frame {} of {v}", a.frame);
            assert_eq!(b.path, FramePath::FullFrame, "frame {} of {v}", b.frame);
        }
        compared += n;
    }
    assert!(compared >= 200, "{compared} frames compared");
}

/// Same inputs and seed → identical detections whatever the thread count.
#[test]
fn detections_do_not_depend_on_thread_count() {
    let rig = Rig::new(&scenario_from("extend = \"fast\"\nduration_s = 1.0\n")).unwrap();
    let n = rig.frame_times.len();
    assert_eq!(
        detections(&rig, 0..n, true, 1),
        detections(&rig, 0..n, true, 4)
    );
}

/// `analyze --frames` on the PNG frames `render` wrote gives the same tracks and kinematics as
/// `run` computed in one pass.
#[test]
fn analyze_frames_written_by_render_matches_run() {
    let s = scenario::load_builtin("fast").unwrap();
    let dir = tempfile::tempdir().unwrap();
    let frames = dir.path().join("frames");
    render_job(
        &s,
        &frames,
        &RenderJob {
            png: true,
            ..RenderJob::default()
        },
        &|_, _| {},
    )
    .unwrap();
    let ran = run(
        &s,
        &dir.path().join("run"),
        &RunOptions {
            plots: false,
            ..RunOptions::default()
        },
        &|_, _| {},
    )
    .unwrap();
    let options = AnalyzeOptions::from_scenario(&s, -1.0);
    let source = Source::Frames {
        dir: frames.clone(),
        timestamps: frames.join("timestamps.csv"),
    };
    let analysed = analyze(&source, &options, &dir.path().join("analyze"), &|_, _| {}).unwrap();
    let run_corners: Vec<_> = ran.detections.iter().map(|d| d.corners_px).collect();
    let an_corners: Vec<_> = analysed.tracks.iter().map(|r| r.corners_px).collect();
    assert_eq!(run_corners, an_corners);
    for (a, b) in analysed.signals.iter().zip(&ran.signals) {
        assert_eq!(a.signal, b.signal);
        for i in 0..a.omega2_rad_s.len() {
            assert_eq!(
                a.omega2_rad_s[i].to_bits(),
                b.omega2_rad_s[i].to_bits(),
                "{} ω frame {i}",
                a.signal
            );
            assert_eq!(
                a.alpha2_rad_s2[i].to_bits(),
                b.alpha2_rad_s2[i].to_bits(),
                "{} α frame {i}",
                a.signal
            );
        }
    }
}

/// A marker that leaves the frame is a clear error naming the frame, before any work.
#[test]
fn marker_leaving_the_frame_is_an_error_naming_the_frame() {
    let s = scenario_from("extend = \"fast\"\n[camera]\nwidth_px = 500\n");
    let msg = match Rig::new(&s) {
        Ok(_) => panic!("accepted a marker outside a 500 px wide frame"),
        Err(e) => e.to_string(),
    };
    assert!(
        msg.contains("frame 14 (t = 0.4667 s)") && msg.contains("leaves the image"),
        "{msg}"
    );
}
