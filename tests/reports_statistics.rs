//! Statistical checks of the pipeline's error budget on small synthetic scenarios:
//! - with pixel noise as the only random effect, the white-noise prediction of the ω2/α2 error
//!   σ from the measured angle noise (`bounds.<signal>.statistical`) matches at 0.5 mm/px within
//!   a tolerance derived from the number of frames, but in general is only an upper bound: the
//!   detection error is mostly corner quantisation, correlated from frame to frame;
//! - cornerSubPix makes the corner errors correlated from frame to frame, and the white-noise
//!   prediction then overestimates the derivative noise several times (pinned finding);
//! - with pixel noise, blur and quantisation only, the angle error against the half-pixel bound:
//!   the seed's estimator does NOT stay under it (its rotation centre), the geometric fit does.

#![cfg(feature = "opencv-detector")]

use geneva_vision::budget::report::{BoundsReport, Budget};
use geneva_vision::pipeline::run::{run, RunOptions};
use geneva_vision::scenario::{load_any, with_overrides};
use rand::Rng;
use std::path::Path;
use toml::Value;

/// `fast` with lighting off (pixel noise, optical blur and quantisation are what remains;
/// motion blur is already off there), 4 s, plus `extra`. The differentiator is the 3-point
/// central difference: the white-noise prediction is about a stencil without smoothing bias (a
/// smoother such as the default `kalman_rts` adds its bias at the phase boundaries to the
/// measured σ).
fn budget(seed: u64, mm_per_px: f64, extra: &[(&str, Value)]) -> Budget {
    let base = load_any("fast").unwrap();
    let mut o: Vec<(String, Value)> = vec![
        (
            "estimator.differentiator".into(),
            Value::Table(toml::toml! { kind = "central3" }),
        ),
        ("effects.lighting.enabled".into(), Value::Boolean(false)),
        ("effects.pixel_noise.enabled".into(), Value::Boolean(true)),
        ("duration_s".into(), Value::Float(4.0)),
        ("seed".into(), Value::Integer(seed as i64)),
        ("camera.focal.mm_per_px".into(), Value::Float(mm_per_px)),
    ];
    o.extend(extra.iter().map(|(a, b)| (a.to_string(), b.clone())));
    let s = with_overrides(&base, &o, Path::new("reports_statistics")).unwrap();
    let options = RunOptions {
        write_files: false,
        plots: false,
        ..RunOptions::default()
    };
    run(&s, Path::new(""), &options, &|_, _| {}).unwrap().budget
}

/// Standard errors of ln(measured/predicted) for ω and α when the angle error is white noise
/// over `n` frames (the null hypothesis the prediction rests on). The measured σ_ω of the
/// central difference ω_i = (θ_{i+1} − θ_{i−1})/2h has autocorrelations ρ(0) = 1, ρ(±2) = −1/2
/// (Σρ² = 3/2); the prediction scales the measured σ_θ (Σρ² = 1), which is correlated with it
/// (cross-correlations ±1/√2 at lags ±1: Σρ² = 1). With Var(ln s) = Σρ²/(2n) and
/// Cov(ln s_x, ln s_y) = Σρ_xy²/(2n): Var(ln r_ω) = (3/2 + 1 − 2)/(2n) = 1/(4n). For
/// α_i = (θ_{i+1} − 2θ_i + θ_{i−1})/h²: ρ(±1) = −2/3, ρ(±2) = 1/6 (Σρ² = 35/18), cross
/// −2/√6 at lag 0 and 1/√6 at ±1 (Σρ² = 1): Var(ln r_α) = (35/18 − 1)/(2n) = 17/(36n).
fn white_noise_se(n: f64) -> (f64, f64) {
    ((0.25 / n).sqrt(), (17.0 / 36.0 / n).sqrt())
}

fn ratios(b: &BoundsReport) -> (f64, f64) {
    (
        b.measured_omega_std_rad_s / b.statistical.sigma_omega_rad_s,
        b.measured_alpha_std_rad_s2 / b.statistical.sigma_alpha_rad_s2,
    )
}

/// Random variants (seed, image scale) with pixel noise on. Finding (see the module report):
/// the measured σ does NOT match the white-noise prediction in general — measured/predicted
/// ranges from about 0.37 to 0.98 over 0.40–0.60 mm/px — because the detection error is
/// dominated by corner quantisation (contour pixels, no refinement), a deterministic function
/// of the marker's sub-pixel pose: constant through a dwell and slowly varying, so it inflates
/// the θ error σ (which the prediction scales) more than the derivatives. What holds is that the
/// prediction is an upper bound: measured/predicted ≤ exp(3·SE) with SE the ratio's sampling
/// error under white noise ([`white_noise_se`]: 4.6 % for ω, 6.3 % for α at 120 frames), and the
/// same order of magnitude (> 0.3).
#[test]
fn pixel_noise_only_prediction_is_an_upper_bound() {
    let mut rng =
        geneva_vision::rng::stream(2024, geneva_vision::rng::Stream::MonteCarlo, u64::MAX);
    for _ in 0..4 {
        let seed = rng.gen_range(1..10_000u64);
        let mm_per_px = rng.gen_range(0.4..0.6);
        let b = budget(seed, mm_per_px, &[]);
        let n = b.frames.detected as f64;
        let (se_w, se_a) = white_noise_se(n);
        for signal in ["centre", "fused"] {
            let (w, a) = ratios(&b.bounds[signal]);
            for (q, r, se) in [("ω", w, se_w), ("α", a, se_a)] {
                let high = (3.0 * se).exp();
                assert!(
                    r < high && r > 0.3,
                    "seed {seed}, {mm_per_px:.3} mm/px, {signal}: {q} measured/predicted {r:.3}, allowed (0.3, {high:.3})"
                );
            }
        }
    }
}

/// At the `fast` scale (0.5 mm/px) the prediction comes closest, but it is still an upper bound,
/// not a match: over 8 seeds the mean measured/predicted ratio (measured 0.92 for ω and 0.93 for
/// α) lies further below 1 than white noise allows for a mean of 8 seeds (3·SE/√8 ≈ 5 % for ω),
/// the mark of the correlated quantisation part; yet within one seed's white-noise band (3·SE),
/// and no seed exceeds the upper bound.
#[test]
fn prediction_is_a_close_upper_bound_at_the_fast_scale() {
    let seeds = 8;
    let (mut sum_w, mut sum_a, mut n) = (0.0, 0.0, 0.0);
    for seed in 1..=seeds {
        let b = budget(seed, 0.5, &[]);
        n = b.frames.detected as f64;
        let (se_w, se_a) = white_noise_se(n);
        let (w, a) = ratios(&b.bounds["centre"]);
        assert!(
            w.ln() < 3.0 * se_w && a.ln() < 3.0 * se_a,
            "seed {seed}: ω {w:.3}, α {a:.3} over the white-noise bound"
        );
        sum_w += w.ln();
        sum_a += a.ln();
    }
    let (mean_w, mean_a) = (sum_w / seeds as f64, sum_a / seeds as f64);
    let (se_w, se_a) = white_noise_se(n);
    let k = (seeds as f64).sqrt();
    assert!(
        mean_w < -3.0 * se_w / k && mean_a < -3.0 * se_a / k,
        "mean ln ratio ω {mean_w:.3}, α {mean_a:.3}: no longer below the white-noise band of a mean"
    );
    assert!(
        mean_w > -3.0 * se_w && mean_a > -3.0 * se_a,
        "mean ln ratio ω {mean_w:.3}, α {mean_a:.3}: further than one seed's white-noise band"
    );
}

/// Why: quantisation, not noise, is the detection error at these scales. Same seed with and
/// without pixel noise (common random numbers: the same placement and frames), so
/// σ²(on) = σ²(off) + the noise's part. "Dominates" is the definition tested: the noise's
/// part of the ω error variance, 1 − σ²(off)/σ²(on), is below one half. And noise does not
/// lower the error beyond what one seed's white-noise sampling allows (ratio ≥ exp(−3·SE)).
#[test]
fn quantisation_not_pixel_noise_dominates_the_detection_error() {
    for mm_per_px in [0.44, 0.52, 0.58] {
        let on = budget(5, mm_per_px, &[]);
        let off = budget(
            5,
            mm_per_px,
            &[("effects.pixel_noise.enabled", Value::Boolean(false))],
        );
        let (a, b) = (
            on.bounds["centre"].measured_omega_std_rad_s,
            off.bounds["centre"].measured_omega_std_rad_s,
        );
        let noise_part = 1.0 - (b * b) / (a * a);
        assert!(
            noise_part < 0.5,
            "{mm_per_px} mm/px: pixel noise holds {:.0} % of the ω error variance (σ {a:.3e} \
             with noise, {b:.3e} without)",
            100.0 * noise_part
        );
        let (se_w, _) = white_noise_se(on.frames.detected as f64);
        assert!(
            a / b > (-3.0 * se_w).exp(),
            "{mm_per_px} mm/px: noise lowered the ω error σ from {b:.3e} to {a:.3e}"
        );
    }
}

/// Finding: with cornerSubPix the corner errors are smooth functions of the marker's
/// sub-pixel position (correlated from frame to frame), so differentiation amplifies them far
/// less than white noise — measured σ is below the white-noise band of one seed (derived from
/// its sampling error; measured: under half the prediction).
#[test]
fn subpix_errors_are_correlated_so_the_white_noise_prediction_overestimates() {
    let b = budget(
        3,
        0.5,
        &[(
            "detector.corner_refinement_method",
            Value::String("subpix".into()),
        )],
    );
    // White noise would put the ratios within exp(±3·SE) of 1 (SE the sampling error of one
    // seed's σ ratio); correlated errors put them below that band (measured: under half).
    let (se_w, se_a) = white_noise_se(b.frames.detected as f64);
    for signal in ["centre", "fused"] {
        let (w, a) = ratios(&b.bounds[signal]);
        assert!(
            w < (-3.0 * se_w).exp() && a < (-3.0 * se_a).exp(),
            "{signal}: ω ratio {w:.3}, α ratio {a:.3}: within the white-noise band"
        );
    }
}

/// The generalised half-pixel bound on θ with pixel noise, blur and quantisation only. With the
/// seed's estimator (truncated perpendicular-bisector rotation centre, numpy.gradient) the
/// per-frame angle error does NOT stay under δθ in ≥ 99 % of frames: the wrong rotation centre
/// puts most frames over it (measured 94–95 % of frames over at 0.5 mm/px, pinned here as
/// > 80 %). The same frames with the geometric circle fit stay under it in ≥ 99 % of frames.
#[test]
fn half_pixel_angle_bound_fails_with_the_seed_centre_and_holds_with_the_geometric_fit() {
    let seed_estimator = [
        ("estimator.rotation_centre", Value::String("seed".into())),
        (
            "estimator.marker_centre",
            Value::String("corner_mean".into()),
        ),
        (
            "estimator.differentiator",
            Value::Table(toml::toml! { kind = "seed" }),
        ),
    ];
    let seed_b = budget(11, 0.5, &seed_estimator);
    let geo = [
        seed_estimator[0].clone(),
        seed_estimator[1].clone(),
        seed_estimator[2].clone(),
        (
            "estimator.rotation_centre",
            Value::String("geometric".into()),
        ),
    ];
    let geo_b = budget(11, 0.5, &geo);
    let over_seed = seed_b.bounds["centre"].theta_exceedance.fraction;
    let over_geo = geo_b.bounds["centre"].theta_exceedance.fraction;
    assert!(
        over_seed > 0.8,
        "seed centre: {over_seed:.3} of frames over δθ (expected most)"
    );
    assert!(
        over_geo <= 0.01,
        "geometric centre: {over_geo:.3} of frames over δθ"
    );
}
