//! Where a synthetic run's measurement meets its truth: the estimate mapped into the wheel's
//! convention with the *true* geometry, errors against the resolvable truth (the headline) and
//! against the raw truth, the aliasing part, per-signal and per-phase statistics, and the
//! analytic bounds. The pipeline supplies the truths; nothing here looks at a rig.

use super::bounds::{LinearWeights, SEED_POSITION_ERROR_PX};
use super::compare::{to_wheel_convention, SignalErrors, TruthSeries};
use super::report::{
    bounds_report, mechanism_departure, phased_stats, signal_budget, BoundsInput, Budget,
    FrameCounts,
};
use super::resolvable::ResolvableInfo;
use super::stats::ErrorStats;
use crate::estimate::angle::screen_angle_rad;
use crate::estimate::{Estimate, Signal};
use std::collections::BTreeMap;

/// The true image geometry at the first frame: the rotation centre, each signal's point (in
/// [`Signal::ALL`] order; the fused signal is aligned to the centre) and the sense of θ2 on
/// screen (+1: counter-clockwise).
#[derive(Debug, Clone, PartialEq)]
pub struct TrueGeometry {
    pub centre_px: [f64; 2],
    pub points_px: Vec<[f64; 2]>,
    pub screen_sign: f64,
}

/// The truths a run is judged against, per frame (all with the frames' phases).
#[derive(Debug, Clone, Copy)]
pub struct Truths<'a> {
    /// The actual motion at the frame timestamps.
    pub raw: &'a TruthSeries,
    /// The ideal kinematics at the frame timestamps.
    pub ideal: &'a TruthSeries,
    /// What the frames can resolve (NaN where undefined).
    pub resolvable: &'a TruthSeries,
    /// The raw truth band-limited at the timestamps: raw − this is the aliasing part.
    pub band_limited: &'a TruthSeries,
    /// θ2 averaged over each frame's exposure of the marker (what each frame shows).
    pub frame_theta2_rad: &'a [f64],
    pub info: &'a ResolvableInfo,
}

/// Each signal's measurement in the wheel convention with its errors against both truths.
pub fn signal_errors(
    est: &Estimate,
    geometry: &TrueGeometry,
    raw: &TruthSeries,
    resolvable: &TruthSeries,
) -> Vec<SignalErrors> {
    est.signals
        .iter()
        .map(|s| {
            let p = geometry.points_px[s.signal.index()];
            to_wheel_convention(
                s.signal.name(),
                [&s.theta_rad, &s.omega_rad_s, &s.alpha_rad_s2],
                geometry.screen_sign,
                screen_angle_rad(p, geometry.centre_px),
                raw,
                resolvable,
            )
        })
        .collect()
}

fn difference(a: &[f64], b: &[f64]) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x - y).collect()
}

/// The detection part of one signal's errors: θ̂ − θ̄ and ω̂ − D(θ̄), α̂ − D(θ̄), with θ̄ what each
/// frame shows and D the signal's own (λ-fixed, hence linear) differentiator on the estimate's
/// time base — the differentiator's bias and the timebase error cancel, what detection adds stays.
fn detection_errors(
    series: &crate::estimate::SignalSeries,
    errors: &SignalErrors,
    t_used_s: &[f64],
    frame_theta2_rad: &[f64],
) -> [Vec<f64>; 3] {
    let n = errors.theta2_rad.len();
    let used: Vec<usize> = (0..n)
        .filter(|&k| errors.theta2_rad[k].is_finite() && frame_theta2_rad[k].is_finite())
        .collect();
    let mut out = [vec![f64::NAN; n], vec![f64::NAN; n], vec![f64::NAN; n]];
    let t: Vec<f64> = used.iter().map(|&k| t_used_s[k]).collect();
    let th: Vec<f64> = used.iter().map(|&k| frame_theta2_rad[k]).collect();
    let Ok(d) = series.differentiator.differentiate(&t, &th) else {
        return out;
    };
    for (i, &k) in used.iter().enumerate() {
        out[0][k] = errors.theta2_rad[k] - frame_theta2_rad[k];
        out[1][k] = errors.omega2_rad_s[k] - d.omega_rad_s[i];
        out[2][k] = errors.alpha2_rad_s2[k] - d.alpha_rad_s2[i];
    }
    out
}

/// The error budget of one run: fused signal at the top (against the resolvable truth), the raw
/// truth's errors and the aliasing part beside it, every signal inside, bounds per signal.
pub fn build_budget(
    scenario: &str,
    est: &Estimate,
    signals: &[SignalErrors],
    truths: &Truths<'_>,
    geometry: &TrueGeometry,
    frames: FrameCounts,
) -> Budget {
    let raw = truths.raw;
    let intervals: Vec<f64> = est.t_used_s.windows(2).map(|w| w[1] - w[0]).collect();
    let h_min = intervals.iter().copied().fold(f64::INFINITY, f64::min);
    let h_mean = if intervals.is_empty() {
        1.0 / 30.0
    } else {
        intervals.iter().sum::<f64>() / intervals.len() as f64
    };
    let timebase_error_std_s = ErrorStats::of(&difference(&est.t_used_s, &raw.t_s)).std;
    // What timestamp errors cost depends on the motion the frames resolve.
    let omega_rms_true = ErrorStats::of(&truths.resolvable.omega2_rad_s).rms;
    let mut per_signal = BTreeMap::new();
    let mut bounds = BTreeMap::new();
    for (series, errors) in est.signals.iter().zip(signals) {
        per_signal.insert(
            errors.signal.clone(),
            signal_budget(errors, truths.resolvable, raw),
        );
        let p = geometry.points_px[series.signal.index()];
        let c = geometry.centre_px;
        let radius_px = ((p[0] - c[0]).powi(2) + (p[1] - c[1]).powi(2)).sqrt();
        let differentiator = series.differentiator.clone();
        let weights = LinearWeights::probe(
            |tt, th| match differentiator.differentiate(tt, th) {
                Ok(d) => (d.omega_rad_s, d.alpha_rad_s2),
                Err(_) => (vec![f64::NAN; tt.len()], vec![f64::NAN; tt.len()]),
            },
            h_mean,
            12,
        );
        let detection = detection_errors(series, errors, &est.t_used_s, truths.frame_theta2_rad);
        bounds.insert(
            errors.signal.clone(),
            bounds_report(&BoundsInput {
                errors,
                detection: [&detection[0], &detection[1], &detection[2]],
                phase: &raw.phase,
                radius_px,
                position_error_px: SEED_POSITION_ERROR_PX,
                h_min_s: h_min,
                weights: &weights,
                omega_rms_true_rad_s: omega_rms_true,
                timebase_error_std_s,
            }),
        );
    }
    let bl = truths.band_limited;
    let aliasing = phased_stats(
        [
            &difference(&raw.theta2_rad, &bl.theta2_rad),
            &difference(&raw.omega2_rad_s, &bl.omega2_rad_s),
            &difference(&raw.alpha2_rad_s2, &bl.alpha2_rad_s2),
        ],
        raw,
    );
    let fused = &per_signal[Signal::Fused.name()];
    Budget {
        scenario: scenario.to_string(),
        seeds: 1,
        errors_against: super::report::ERRORS_AGAINST.to_string(),
        frames,
        theta: fused.overall.theta,
        omega: fused.overall.omega,
        alpha: fused.overall.alpha,
        relative: fused.overall.relative.clone(),
        phases: fused.phases.clone(),
        raw: fused.raw.clone(),
        aliasing,
        resolvable: truths.info.clone(),
        mechanism: mechanism_departure(raw, truths.ideal),
        signals: per_signal,
        bounds,
    }
}
