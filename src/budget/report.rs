//! The error budget of one run: statistics per signal and motion phase against the resolvable
//! truth (the headline) and against the raw truth, the aliasing part, the mechanism's own
//! departure from ideal kinematics (a second truth, kept apart), and the analytic bounds with how
//! often they are exceeded. Serialises to `budget.json` (SI units).

use super::bounds::{
    exceedance, half_pixel_bound, predict_noise, Exceedance, HalfPixelBound, LinearWeights,
    NoisePrediction,
};
use super::compare::{SignalErrors, TruthSeries};
use super::resolvable::ResolvableInfo;
use super::stats::{peak_abs, ErrorStats};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

pub const PHASES: [&str; 4] = ["dwell", "entry", "drive", "exit"];

/// What the headline statistics of a budget are measured against (written into `budget.json`).
pub const ERRORS_AGAINST: &str = "resolvable truth: the actual motion averaged over each frame's \
     exposure of the marker and band-limited to the footage's Nyquist rate (ARCHITECTURE.md, \
     \"Resolvable truth\"); `raw` holds the errors against the actual motion at the timestamps, \
     `aliasing` the part of that motion above the Nyquist rate, which no camera at this frame \
     rate can follow";

/// Errors of θ2 (rad), ω2 (rad/s), α2 (rad/s²), absolute and relative to the peak true value.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct QuantityStats {
    pub theta: ErrorStats,
    pub omega: ErrorStats,
    pub alpha: ErrorStats,
    /// Peak |true| value over the frames considered (the scale for `relative`).
    pub peak_true: Peaks,
    /// Statistics divided by the peak true value (dimensionless).
    pub relative: RelativeStats,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Peaks {
    pub theta_rad: f64,
    pub omega_rad_s: f64,
    pub alpha_rad_s2: f64,
}

#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RelativeStats {
    pub theta: ErrorStats,
    pub omega: ErrorStats,
    pub alpha: ErrorStats,
}

/// Statistics overall and per phase.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PhasedStats {
    #[serde(flatten)]
    pub overall: QuantityStats,
    pub phases: BTreeMap<String, QuantityStats>,
}

/// One signal's budget: overall and per phase against the resolvable truth, and the same
/// against the raw truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SignalBudget {
    #[serde(flatten)]
    pub overall: QuantityStats,
    pub phases: BTreeMap<String, QuantityStats>,
    pub raw: PhasedStats,
}

#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FrameCounts {
    pub total: usize,
    pub detected: usize,
}

/// The analytic bounds for one signal and how the measurement compares. The exceedances count
/// the detection part of the errors ([`BoundsInput::detection`]); the measured standard
/// deviations are of the whole error against the resolvable truth.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BoundsReport {
    pub half_pixel: HalfPixelBound,
    /// Per-frame |θ detection error| against δθ.
    pub theta_exceedance: Exceedance,
    /// |ω detection error| against the generalised worst case δθ·Σ|w_ω| and the seed's doubled value.
    pub omega_exceedance: Exceedance,
    pub omega_seed_doubled_exceedance: Exceedance,
    pub alpha_exceedance: Exceedance,
    pub alpha_seed_doubled_exceedance: Exceedance,
    /// Statistical prediction from the measured angle noise and timebase error.
    pub statistical: NoisePrediction,
    /// Measured ω and α error standard deviations beside the prediction.
    pub measured_omega_std_rad_s: f64,
    pub measured_alpha_std_rad_s2: f64,
    /// σ of the difference between the analysis time base and the true frame times.
    pub timebase_error_std_s: f64,
    /// σ of the detection part of α̂ over the engaged frames ([`ENGAGED_PHASES`]): the
    /// measurement noise an impact spike must stand out of ([`super::detectability`]).
    #[serde(default = "nan")]
    pub engaged_detection_alpha_std_rad_s2: f64,
}

/// The phases in which the pin drives the wheel: the only ones where a pin–slot impact can
/// happen. The dwell is no measure of the noise an impact must beat: there the marker stands
/// still, its corners are whole pixels that change only where an edge pixel sits at the
/// threshold (a placement lottery, often no change at all), and the dwell frames next to the
/// motion carry the differentiator's bias and the resolvable truth's band-limiting ripple.
pub const ENGAGED_PHASES: [&str; 3] = ["entry", "drive", "exit"];

fn nan() -> f64 {
    f64::NAN
}

/// The whole budget (fused signal at the top level, every signal inside). The top-level
/// statistics are against the resolvable truth ([`ERRORS_AGAINST`]); `raw` and `aliasing` stand
/// beside them.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Budget {
    pub scenario: String,
    pub seeds: usize,
    /// What `theta`, `omega`, `alpha`, `relative`, `phases` and `signals` are measured against.
    pub errors_against: String,
    pub frames: FrameCounts,
    pub theta: ErrorStats,
    pub omega: ErrorStats,
    pub alpha: ErrorStats,
    pub relative: RelativeStats,
    pub phases: BTreeMap<String, QuantityStats>,
    /// Fused signal against the raw truth (the actual motion at the frame timestamps).
    pub raw: PhasedStats,
    /// The aliasing part: raw truth minus its band-limited version at the timestamps (the
    /// motion above the Nyquist rate), as statistics of a series.
    pub aliasing: PhasedStats,
    /// How the resolvable truth was made.
    pub resolvable: ResolvableInfo,
    pub signals: BTreeMap<String, SignalBudget>,
    /// The actual motion's departure from ideal kinematics, per phase (what the mechanism adds).
    pub mechanism: BTreeMap<String, QuantityStats>,
    pub bounds: BTreeMap<String, BoundsReport>,
}

fn select(values: &[f64], mask: &[bool]) -> Vec<f64> {
    values
        .iter()
        .zip(mask)
        .filter(|(_, m)| **m)
        .map(|(v, _)| *v)
        .collect()
}

/// Statistics of (measured − truth) series restricted to `mask`.
pub fn quantity_stats(
    theta_err: &[f64],
    omega_err: &[f64],
    alpha_err: &[f64],
    truth: &TruthSeries,
    mask: &[bool],
) -> QuantityStats {
    let theta = ErrorStats::of(&select(theta_err, mask));
    let omega = ErrorStats::of(&select(omega_err, mask));
    let alpha = ErrorStats::of(&select(alpha_err, mask));
    // θ2 "peak" is its excursion over the frames considered (an absolute angle has no scale).
    let th = select(&truth.theta2_rad, mask);
    let (lo, hi) = th
        .iter()
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), v| {
            (a.min(*v), b.max(*v))
        });
    let peak_true = Peaks {
        theta_rad: if hi >= lo { hi - lo } else { f64::NAN },
        omega_rad_s: peak_abs(&select(&truth.omega2_rad_s, mask)),
        alpha_rad_s2: peak_abs(&select(&truth.alpha2_rad_s2, mask)),
    };
    let relative = RelativeStats {
        theta: theta.relative_to(peak_true.theta_rad),
        omega: omega.relative_to(peak_true.omega_rad_s),
        alpha: alpha.relative_to(peak_true.alpha_rad_s2),
    };
    QuantityStats {
        theta,
        omega,
        alpha,
        peak_true,
        relative,
    }
}

fn per_phase(
    theta_err: &[f64],
    omega_err: &[f64],
    alpha_err: &[f64],
    truth: &TruthSeries,
) -> BTreeMap<String, QuantityStats> {
    PHASES
        .iter()
        .filter_map(|phase| {
            let mask: Vec<bool> = truth.phase.iter().map(|p| p == phase).collect();
            mask.iter().any(|m| *m).then(|| {
                (
                    phase.to_string(),
                    quantity_stats(theta_err, omega_err, alpha_err, truth, &mask),
                )
            })
        })
        .collect()
}

/// Statistics of the three error series `[θ, ω, α]` overall and per phase of `truth` (which also
/// gives the peaks for the relative statistics).
pub fn phased_stats(errors: [&[f64]; 3], truth: &TruthSeries) -> PhasedStats {
    let all = vec![true; truth.t_s.len()];
    PhasedStats {
        overall: quantity_stats(errors[0], errors[1], errors[2], truth, &all),
        phases: per_phase(errors[0], errors[1], errors[2], truth),
    }
}

/// A signal's budget against the resolvable truth and against the raw truth.
pub fn signal_budget(
    e: &SignalErrors,
    resolvable: &TruthSeries,
    raw: &TruthSeries,
) -> SignalBudget {
    let headline = phased_stats(
        [&e.theta_err_rad, &e.omega_err_rad_s, &e.alpha_err_rad_s2],
        resolvable,
    );
    SignalBudget {
        overall: headline.overall,
        phases: headline.phases,
        raw: phased_stats(
            [
                &e.theta_raw_err_rad,
                &e.omega_raw_err_rad_s,
                &e.alpha_raw_err_rad_s2,
            ],
            raw,
        ),
    }
}

/// The mechanism's departure: actual − ideal, per phase.
pub fn mechanism_departure(
    actual: &TruthSeries,
    ideal: &TruthSeries,
) -> BTreeMap<String, QuantityStats> {
    let d = |a: &[f64], b: &[f64]| a.iter().zip(b).map(|(x, y)| x - y).collect::<Vec<f64>>();
    per_phase(
        &d(&actual.theta2_rad, &ideal.theta2_rad),
        &d(&actual.omega2_rad_s, &ideal.omega2_rad_s),
        &d(&actual.alpha2_rad_s2, &ideal.alpha2_rad_s2),
        actual,
    )
}

/// Inputs of the bounds for one signal.
pub struct BoundsInput<'a> {
    pub errors: &'a SignalErrors,
    /// The detection part of the errors, what the bounds are about: θ̂ − θ̄ with θ̄ the truth
    /// averaged over each frame's exposure of the marker (what the frame shows), and
    /// ω̂ − D(θ̄), α̂ − D(θ̄) with D the signal's own differentiator on the same time base.
    pub detection: [&'a [f64]; 3],
    /// Each frame's motion phase (as the errors).
    pub phase: &'a [&'static str],
    pub radius_px: f64,
    pub position_error_px: f64,
    pub h_min_s: f64,
    pub weights: &'a LinearWeights,
    pub omega_rms_true_rad_s: f64,
    pub timebase_error_std_s: f64,
}

pub fn bounds_report(b: &BoundsInput<'_>) -> BoundsReport {
    let hp = half_pixel_bound(b.position_error_px, b.radius_px, b.h_min_s, b.weights);
    let e = b.errors;
    let [theta, omega, alpha] = b.detection;
    // The position part of the angle noise: the detection θ error's spread (its bias is a
    // constant offset that no derivative sees). It is measured at the true frame times, so it
    // excludes the timebase error, which the prediction adds separately.
    let sigma_perp_px = ErrorStats::of(theta).std * b.radius_px;
    let statistical = predict_noise(
        sigma_perp_px,
        b.radius_px,
        b.weights,
        b.omega_rms_true_rad_s,
        b.timebase_error_std_s,
    );
    BoundsReport {
        theta_exceedance: exceedance(theta, hp.theta_rad),
        omega_exceedance: exceedance(omega, hp.omega_rad_s),
        omega_seed_doubled_exceedance: exceedance(omega, hp.seed_omega_doubled_rad_s),
        alpha_exceedance: exceedance(alpha, hp.alpha_rad_s2),
        alpha_seed_doubled_exceedance: exceedance(alpha, hp.seed_alpha_doubled_rad_s2),
        half_pixel: hp,
        statistical,
        measured_omega_std_rad_s: ErrorStats::of(&e.omega_err_rad_s).std,
        measured_alpha_std_rad_s2: ErrorStats::of(&e.alpha_err_rad_s2).std,
        timebase_error_std_s: b.timebase_error_std_s,
        engaged_detection_alpha_std_rad_s2: engaged_std(alpha, b.phase),
    }
}

/// σ of `values` over the engaged frames ([`ENGAGED_PHASES`]); NaN when there are none.
pub fn engaged_std(values: &[f64], phase: &[&str]) -> f64 {
    let mask: Vec<bool> = phase.iter().map(|p| ENGAGED_PHASES.contains(p)).collect();
    ErrorStats::of(&select(values, &mask)).std
}

#[cfg(test)]
mod tests {
    use super::*;

    fn truth(n: usize) -> TruthSeries {
        TruthSeries {
            t_s: (0..n).map(|i| i as f64 * 0.1).collect(),
            theta2_rad: (0..n).map(|i| i as f64 * 0.01).collect(),
            omega2_rad_s: (0..n).map(|i| if i < n / 2 { 0.0 } else { 0.5 }).collect(),
            alpha2_rad_s2: vec![1.0; n],
            phase: (0..n)
                .map(|i| if i < n / 2 { "dwell" } else { "drive" })
                .collect(),
        }
    }

    #[test]
    fn phases_are_split_and_relative_uses_the_phase_peak() {
        let t = truth(10);
        let e = SignalErrors {
            signal: "centre".into(),
            theta2_rad: vec![0.0; 10],
            omega2_rad_s: vec![0.0; 10],
            alpha2_rad_s2: vec![0.0; 10],
            theta_err_rad: vec![0.001; 10],
            omega_err_rad_s: (0..10).map(|i| if i < 5 { 0.01 } else { 0.05 }).collect(),
            alpha_err_rad_s2: vec![0.2; 10],
            theta_raw_err_rad: vec![0.002; 10],
            omega_raw_err_rad_s: vec![0.3; 10],
            alpha_raw_err_rad_s2: vec![f64::NAN; 10],
        };
        let b = signal_budget(&e, &t, &t);
        assert!((b.raw.phases["dwell"].omega.rms - 0.3).abs() < 1e-12);
        assert_eq!(b.raw.overall.alpha.n, 0);
        assert_eq!(b.phases.len(), 2);
        assert!((b.phases["dwell"].omega.rms - 0.01).abs() < 1e-12);
        assert!((b.phases["drive"].omega.rms - 0.05).abs() < 1e-12);
        assert!((b.phases["drive"].relative.omega.rms - 0.1).abs() < 1e-12);
        assert!(
            b.phases["dwell"].relative.omega.rms.is_nan(),
            "no motion in dwell: no relative scale"
        );
        assert_eq!(b.overall.theta.n, 10);
        let json = serde_json::to_value(&b).unwrap();
        assert!(
            json["theta"]["rms"].is_number()
                && json["phases"]["drive"]["alpha"]["p95"].is_number()
                && json["raw"]["phases"]["drive"]["omega"]["rms"].is_number()
        );
    }

    #[test]
    fn engaged_std_leaves_the_dwell_out() {
        // A huge dwell flicker and a constant in entry must not count; drive and exit do.
        let phase = [
            "dwell", "dwell", "entry", "entry", "drive", "drive", "exit", "exit",
        ];
        let alpha = [50.0, -50.0, 1.0, 1.0, -1.0, -1.0, f64::NAN, 1.0];
        // Engaged values 1, 1, −1, −1, 1: mean 0.2, σ = √(1 − 0.04).
        let s = engaged_std(&alpha, &phase);
        assert!((s - 0.96_f64.sqrt()).abs() < 1e-12, "{s}");
        assert!(engaged_std(&alpha[..2], &phase[..2]).is_nan());
    }

    #[test]
    fn mechanism_departure_is_actual_minus_ideal() {
        let ideal = truth(6);
        let mut actual = ideal.clone();
        actual.alpha2_rad_s2[4] += 30.0;
        let m = mechanism_departure(&actual, &ideal);
        assert_eq!(m["drive"].alpha.max, 30.0);
        assert_eq!(m["dwell"].alpha.max, 0.0);
    }
}
