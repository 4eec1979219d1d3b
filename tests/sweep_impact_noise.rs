//! The noise that the sweep's impact SNR divides by (`engaged_alpha_noise_rad_s2`) is measurement
//! noise: measured through the real pipeline on the seed-camera rig, it must follow what corner
//! quantisation does — shrink with the pixel scale (a nearer camera, a finer sensor) and grow with
//! the differentiator's noise gain (1/h² for the seed's double `numpy.gradient`). The dwell σ_α
//! that the SNR used before failed all three: a still marker's corners often never change between
//! frames, so 0.3 m/120 fps/4K, 0.4 m/120 fps/1080p and 0.4 m/120 fps/4K had the same value
//! (0.0373 rad/s², the resolvable truth's band-limiting ripple next to the motion), 0.3 m/120
//! fps/1080p 80× more (edge pixels flickering at the threshold), and 120 fps less than 30 fps.
#![cfg(feature = "opencv-detector")]

use geneva_vision::estimate::Differentiator;
use geneva_vision::pipeline::sweep_eval::PipelineEvaluator;
use geneva_vision::scenario::{self, Scenario};
use geneva_vision::sweep::Evaluator;
use std::path::{Path, PathBuf};

fn base_path() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/sweeps/seed-camera-base.toml")
}

fn point(distance_m: f64, fps: f64, width_px: i64, height_px: i64) -> Scenario {
    let base = scenario::load(&base_path()).unwrap();
    let overrides = vec![
        (
            "camera.distance_m".to_string(),
            toml::Value::Float(distance_m),
        ),
        ("frame_timing.fps".to_string(), toml::Value::Float(fps)),
        (
            "camera.width_px".to_string(),
            toml::Value::Integer(width_px),
        ),
        (
            "camera.height_px".to_string(),
            toml::Value::Integer(height_px),
        ),
    ];
    scenario::with_overrides(&base, &overrides, &base_path()).unwrap()
}

fn noise(distance_m: f64, fps: f64, width_px: i64, height_px: i64) -> f64 {
    let sc = point(distance_m, fps, width_px, height_px);
    let m = PipelineEvaluator.evaluate(&sc, sc.seed).unwrap();
    assert_eq!(m.frames_detected, m.frames_total, "every frame detected");
    let n = m.engaged_alpha_noise_rad_s2;
    assert!(
        n.is_finite() && n > 0.0,
        "{distance_m} m, {fps} fps, {width_px}: {n}"
    );
    n
}

#[test]
fn impact_noise_follows_the_pixel_scale_and_the_noise_gain() {
    let near_1080p = noise(0.3, 120.0, 1920, 1080);
    let far_1080p = noise(0.4, 120.0, 1920, 1080);
    let far_4k = noise(0.4, 120.0, 3840, 2160);
    let far_1080p_30 = noise(0.4, 30.0, 1920, 1080);
    eprintln!(
        "σ_α engaged: 0.3 m 1080p {near_1080p:.4}, 0.4 m 1080p {far_1080p:.4}, 0.4 m 4K \
         {far_4k:.4} (all 120 fps), 0.4 m 1080p 30 fps {far_1080p_30:.4} rad/s²"
    );
    // Twice the pixels across the same field of view: about half the quantisation step.
    let ratio_4k = far_4k / far_1080p;
    assert!(
        (0.3..=0.75).contains(&ratio_4k),
        "4K / 1080p noise {ratio_4k:.3}, expected about 0.5"
    );
    // 0.3 m has 4/3 the pixels per mm of 0.4 m.
    assert!(
        near_1080p < far_1080p,
        "0.3 m {near_1080p:.4} not below 0.4 m {far_1080p:.4}"
    );
    // The seed differentiator's noise gain (analytic) from 30 to 120 fps, within a factor 2.
    let gain = |fps: f64| Differentiator::Seed.noise_gain(1.0 / fps).alpha_per_rad;
    let expected = gain(120.0) / gain(30.0);
    let ratio_fps = far_1080p / far_1080p_30;
    assert!(
        (expected / 2.0..=expected * 2.0).contains(&ratio_fps),
        "120 / 30 fps noise {ratio_fps:.2}, noise gain ratio {expected:.1}"
    );
}
