//! The VFR fit recovers the parameters of synthetic schedules, within tolerances derived from
//! the number of frames (least-squares standard errors, binomial drop counts).

use proptest::prelude::*;

use super::*;

/// Allowed deviation: `K` standard errors (plus a rounding floor).
const K: f64 = 5.0;

fn check_recovery(fps: f64, v: &VfrModel, seed: u64) -> Result<(), TestCaseError> {
    check_recovery_over(fps, v, seed, 20.0)
}

pub(super) fn check_recovery_over(
    fps: f64,
    v: &VfrModel,
    seed: u64,
    duration_s: f64,
) -> Result<(), TestCaseError> {
    let c = FrameTimingConfig {
        fps,
        model: TimingModel::Vfr(v.clone()),
        ..FrameTimingConfig::default()
    };
    let ts = c.schedule(duration_s, seed, None).unwrap();
    let fit = fit_vfr(&ts).unwrap();
    let n = ts.len() as f64 - 1.0;
    let sigma = v.jitter_s;
    let interval = 1.0 / v.actual_fps(fps);
    let first = if v.first_interval_s == 0.0 {
        interval
    } else {
        v.first_interval_s
    };
    let floor = 1e-9;
    // Slope of a line over n equally spaced points: sd σ·√(12/n³) (drops only widen the span).
    let fitted_interval = 1.0 / fit.fps;
    prop_assert!(
        (fitted_interval - interval).abs() <= K * sigma * (12.0 / n.powi(3)).sqrt() + floor * 1e-3,
        "interval {fitted_interval} vs {interval}"
    );
    // Intercept at the start of the range: sd ≈ 2σ/√n.
    prop_assert!(
        (fit.first_interval_s - first).abs() <= K * 2.0 * sigma / n.sqrt() + floor,
        "first {} vs {first}",
        fit.first_interval_s
    );
    // Alternation coefficient h = a/2 has sd σ/√n, so a has 2σ/√n.
    prop_assert!(
        (fit.pair_alternation_s - v.pair_alternation_s).abs() <= K * 2.0 * sigma / n.sqrt() + floor,
        "alternation {} vs {}",
        fit.pair_alternation_s,
        v.pair_alternation_s
    );
    // Residual σ: relative sd 1/√(2n); truncation at 4σ shrinks σ by < 0.1 %.
    prop_assert!(
        (fit.jitter_s - sigma).abs() <= sigma * (K / (2.0 * n).sqrt() + 0.002) + floor,
        "jitter {} vs {sigma}",
        fit.jitter_s
    );
    // Drops: binomial over the slots spanned.
    let slots = n + fit.dropped_frames as f64;
    let p = v.drop_probability;
    prop_assert!(
        (fit.drop_probability - p).abs() <= K * (p * (1.0 - p) / slots).sqrt() + 2.0 / slots,
        "drop {} vs {p}",
        fit.drop_probability
    );
    // The fitted config regenerates a valid schedule of the same kind.
    prop_assert!(fit.config.schedule(1.0, seed, None).is_ok());
    Ok(())
}

/// The seed phone's order of magnitude: 50 µs jitter, 0.1 ms alternation, 2 % drops.
pub(super) fn phone_like() -> VfrModel {
    VfrModel {
        jitter_s: 5e-5,
        pair_alternation_s: 1e-4,
        first_interval_s: 0.055,
        drop_probability: 0.02,
        rate_error_ppm: -4500.0,
    }
}

#[test]
fn fit_recovers_phone_like_parameters() {
    let v = phone_like();
    check_recovery(30.0, &v, 11).unwrap();
    let fit = fit_vfr(
        &FrameTimingConfig {
            fps: 30.0,
            model: TimingModel::Vfr(v),
            ..FrameTimingConfig::default()
        }
        .schedule(20.0, 11, None)
        .unwrap(),
    )
    .unwrap();
    let text = fit.to_string();
    assert!(
        text.contains("rate               29.86") && text.contains("first interval     55.0"),
        "{text}"
    );
}

#[test]
fn fit_of_exact_constant_rate_is_exact() {
    let ts = timebase(100, 50.0).unwrap();
    let fit = fit_vfr(&ts).unwrap();
    assert!((fit.fps - 50.0).abs() < 1e-9);
    assert!((fit.first_interval_s - 0.02).abs() < 1e-12);
    assert!(fit.jitter_s < 1e-12 && fit.pair_alternation_s.abs() < 1e-12);
    assert_eq!(fit.dropped_frames, 0);
    assert!(matches!(
        fit_vfr(&timebase(4, 50.0).unwrap()),
        Err(TimingError::TooFewFrames { needed: 5, got: 4 })
    ));
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(64))]

    #[test]
    fn fit_recovers_known_parameters(
        fps in 20.0f64..120.0,
        ppm in -20_000.0f64..20_000.0,
        jitter_frac in 0.0f64..0.01,
        alt_frac in 0.0f64..0.1,
        first_frac in prop_oneof![Just(0.0), 0.6f64..3.0],
        drop in prop_oneof![Just(0.0), 0.0f64..0.1],
        seed in any::<u64>(),
    ) {
        let interval = 1.0 / (fps * (1.0 + ppm * 1e-6));
        let v = VfrModel {
            jitter_s: jitter_frac * interval,
            pair_alternation_s: alt_frac * interval,
            first_interval_s: first_frac * interval,
            drop_probability: drop,
            rate_error_ppm: ppm,
        };
        check_recovery(fps, &v, seed)?;
    }
}

/// A run of 4 drops in a schedule whose intervals alternate by ±9 % (a span of 5 intervals less
/// the alternation) is 5 slots, not 4: the slot unit is the interval without its alternation.
/// Found by `fit_recovers_known_parameters` (with the median single interval as the unit, the
/// fitted interval was 0.05013 s for 0.05).
#[test]
fn a_long_run_of_drops_under_a_pair_alternation_keeps_its_slots() {
    let v = VfrModel {
        jitter_s: 0.0,
        pair_alternation_s: 0.09241080387287948 / 20.0,
        first_interval_s: 0.0,
        drop_probability: 0.09307909483372419,
        rate_error_ppm: 0.0,
    };
    check_recovery(20.0, &v, 4633079331913310281).unwrap();
}
