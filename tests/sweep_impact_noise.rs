//! The noise that the sweep's impact SNR divides by (`engaged_alpha_noise_rad_s2`) is measurement
//! noise: measured through the real pipeline on the seed-camera rig, it must follow what corner
//! quantisation does — shrink with the pixel scale (a nearer camera, a finer sensor) and grow with
//! the differentiator's noise gain (1/h² for the seed's double `numpy.gradient`). The dwell σ_α
//! that the SNR used before failed all three: a still marker's corners often never change between
//! frames, so 0.3 m/120 fps/4K, 0.4 m/120 fps/1080p and 0.4 m/120 fps/4K had the same value
//! (0.0373 rad/s², the resolvable truth's band-limiting ripple next to the motion), 0.3 m/120
//! fps/1080p 80× more (edge pixels flickering at the threshold), and 120 fps less than 30 fps.
#![cfg(feature = "opencv-detector")]

use geneva_vision::budget::report::ENGAGED_PHASES;
use geneva_vision::estimate::Differentiator;
use geneva_vision::pipeline::run::{run, RunOptions};
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

/// The sweep's noise at one point, and the number of engaged frames it is a σ over.
fn noise(distance_m: f64, fps: f64, width_px: i64, height_px: i64) -> (f64, usize) {
    let sc = point(distance_m, fps, width_px, height_px);
    let m = PipelineEvaluator.evaluate(&sc, sc.seed).unwrap();
    assert_eq!(m.frames_detected, m.frames_total, "every frame detected");
    let n = m.engaged_alpha_noise_rad_s2;
    assert!(
        n.is_finite() && n > 0.0,
        "{distance_m} m, {fps} fps, {width_px}: {n}"
    );
    let options = RunOptions {
        plots: false,
        write_files: false,
        ..RunOptions::default()
    };
    let out = run(&sc, Path::new("."), &options, &|_, _| {}).unwrap();
    let engaged = ENGAGED_PHASES
        .iter()
        .map(|p| out.budget.phases[*p].alpha.n)
        .sum();
    (n, engaged)
}

/// The band a ratio of two noise σ may take around its expected value: three standard errors
/// of the ratio's logarithm. A σ estimated from n_eff independent samples has a relative standard
/// error of 1/√(2 n_eff) (normal samples; corner quantisation errors are bounded, lighter-tailed
/// than normal, so this errs wide). The seed's double `numpy.gradient` makes α̂_k of θ̂_{k−2..k+2}:
/// samples five apart share nothing, so n_eff = n/5 (conservative: nearer samples are only
/// partly correlated). The two σ are of different footage, so their log errors add in
/// quadrature (a correlation between them would only narrow the truth's spread).
fn band(expected: f64, n_a: usize, n_b: usize) -> (f64, f64) {
    let rel_se = |n: usize| (2.0 * n as f64 / 5.0).sqrt().recip();
    let se_log = rel_se(n_a).hypot(rel_se(n_b));
    (
        expected * (-3.0 * se_log).exp(),
        expected * (3.0 * se_log).exp(),
    )
}

#[test]
fn impact_noise_follows_the_pixel_scale_and_the_noise_gain() {
    let (near_1080p, n_near) = noise(0.3, 120.0, 1920, 1080);
    let (far_1080p, n_far) = noise(0.4, 120.0, 1920, 1080);
    let (far_4k, n_4k) = noise(0.4, 120.0, 3840, 2160);
    let (far_1080p_30, n_30) = noise(0.4, 30.0, 1920, 1080);
    eprintln!(
        "σ_α engaged: 0.3 m 1080p {near_1080p:.4} ({n_near} frames), 0.4 m 1080p {far_1080p:.4} \
         ({n_far}), 0.4 m 4K {far_4k:.4} ({n_4k}) (all 120 fps), 0.4 m 1080p 30 fps \
         {far_1080p_30:.4} ({n_30}) rad/s²"
    );
    let check = |what: &str, ratio: f64, expected: f64, n_a: usize, n_b: usize| {
        let (lo, hi) = band(expected, n_a, n_b);
        assert!(
            (lo..=hi).contains(&ratio),
            "{what}: {ratio:.3}, expected {expected:.3} within ({lo:.3}, {hi:.3})"
        );
    };
    // Twice the pixels across the same field of view: half the quantisation step, so half the
    // angle noise at the same radius in mm.
    check("4K / 1080p", far_4k / far_1080p, 0.5, n_4k, n_far);
    // 0.3 m has 4/3 the pixels per mm of 0.4 m: the same pixel error is 3/4 the angle.
    check("0.3 m / 0.4 m", near_1080p / far_1080p, 0.75, n_near, n_far);
    assert!(
        near_1080p < far_1080p,
        "0.3 m {near_1080p:.4} not below 0.4 m {far_1080p:.4}"
    );
    // The seed differentiator's noise gain (analytic) from 30 to 120 fps.
    let gain = |fps: f64| Differentiator::Seed.noise_gain(1.0 / fps).alpha_per_rad;
    check(
        "120 / 30 fps",
        far_1080p / far_1080p_30,
        gain(120.0) / gain(30.0),
        n_far,
        n_30,
    );
}
