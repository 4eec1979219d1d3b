//! Impact detectability: can an impact (a sudden change of ω) be seen in the measured α trace?
//!
//! An impact changes ω by Δω over a duration τ: a ramp in ω, i.e. an α pulse of height Δω/τ and
//! width τ. θ(t) is then piecewise quadratic (during the ramp) and linear (after it). We sample
//! that θ at uniform frame times (interval h), run the differentiator in use, and take the peak
//! |α̂|. Because the frames may fall anywhere relative to the impact, we repeat for several
//! sub-frame phases of the impact start and keep the *smallest* peak (worst case).
//!
//! SNR = peak |α̂| / σ_α, where σ_α is the standard deviation of the α detection error (α̂ − D(θ̄):
//! the differentiator D applied to what the frames show cancels its own bias, what detection adds
//! stays) over the engaged frames, where the pin drives the wheel and an impact can happen (the
//! sweep's `engaged_alpha_noise_rad_s2`; `budget::report::ENGAGED_PHASES` says why not the
//! dwell). Detectable when SNR ≥ `min_snr` (default 3).
//!
//! The peak is the differentiator's response to the impact alone, computed, not measured: the
//! differentiator is linear, so the response to (motion + impact + detection noise) is the sum of
//! the three responses, and the impact's part depends only on the differentiator and the frame
//! interval. The camera enters through the noise.
//!
//! Why this metric: a person (or a threshold detector) looking at an α trace sees an impact as a
//! spike that stands out of the noise band. The band is ±k·σ_α; the spike's height is exactly the
//! differentiator's response to the impact. Both pass through the same linear filter, so a wider
//! smoothing window lowers the noise band *and* the spike — the ratio, not either one, decides.

use crate::estimate::{Differentiator, EstimateError};

/// Sub-frame phases of the impact start that are tried (fractions of h: 0, 1/8, …, 7/8).
pub const PHASES: usize = 8;

/// The detectability of one impact for one camera/differentiator setup.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Detectability {
    /// Worst-case (over phase) peak |α̂| of the impact response, rad/s².
    pub peak_alpha_rad_s2: f64,
    /// α noise σ that the spike must beat (engaged detection noise), rad/s².
    pub noise_alpha_rad_s2: f64,
    /// peak / noise.
    pub snr: f64,
    /// snr ≥ min_snr.
    pub detectable: bool,
}

/// θ(t) of an impact starting at `t0_s`: 0 before, Δω(t−t0)²/(2τ) during, linear after.
/// τ = 0 is an ideal step in ω.
pub fn impact_theta_rad(t_s: f64, t0_s: f64, delta_omega_rad_s: f64, duration_s: f64) -> f64 {
    let dt = t_s - t0_s;
    if dt <= 0.0 {
        0.0
    } else if dt < duration_s {
        delta_omega_rad_s * dt * dt / (2.0 * duration_s)
    } else {
        delta_omega_rad_s * (dt - duration_s / 2.0)
    }
}

/// Frames either side of the impact: enough for the widest stencil to see flat data at the edges.
fn half_frames(diff: &Differentiator, h_s: f64, duration_s: f64) -> usize {
    let stencil = match diff {
        Differentiator::SavitzkyGolay {
            window_frames,
            window_s,
            ..
        } => match window_s {
            Some(w) => (w / h_s).ceil() as usize,
            None => *window_frames,
        },
        _ => 3,
    };
    // The Kalman smoother's response decays over tens of frames; 40 covers it.
    40 + 2 * stencil + (duration_s / h_s).ceil() as usize
}

/// Frame times around an impact at sub-frame `phase` (0..1), and the index of the impact frame.
pub fn impact_series(
    h_s: f64,
    delta_omega_rad_s: f64,
    duration_s: f64,
    phase: f64,
    half: usize,
) -> (Vec<f64>, Vec<f64>, usize) {
    let n = 2 * half + 1;
    let t: Vec<f64> = (0..n).map(|i| i as f64 * h_s).collect();
    let t0 = (half as f64 + phase) * h_s;
    let theta = t
        .iter()
        .map(|&ti| impact_theta_rad(ti, t0, delta_omega_rad_s, duration_s))
        .collect();
    (t, theta, half)
}

/// Worst-case (over [`PHASES`] sub-frame phases) peak |α̂| response to the impact, rad/s².
/// The peak is taken near the impact only (the series' edges are not part of the response).
/// A Kalman smoother must have its λ fixed: the response depends on it.
pub fn peak_alpha_response(
    diff: &Differentiator,
    h_s: f64,
    delta_omega_rad_s: f64,
    duration_s: f64,
) -> Result<f64, EstimateError> {
    if !(h_s.is_finite() && h_s > 0.0 && duration_s.is_finite() && duration_s >= 0.0) {
        return Err(EstimateError::InvalidDifferentiator(format!(
            "impact response needs h_s > 0 and duration_s >= 0, got {h_s}, {duration_s}"
        )));
    }
    if matches!(
        diff,
        Differentiator::KalmanRts {
            lambda_per_s6: None
        }
    ) {
        // λ chosen on a noiseless impact series would be huge and the SNR wildly optimistic.
        return Err(EstimateError::InvalidDifferentiator(
            "kalman_rts with automatic lambda_per_s6: fix λ (Differentiator::resolved on a real \
             series) before computing impact detectability"
                .into(),
        ));
    }
    let half = half_frames(diff, h_s, duration_s);
    let reach = half / 2;
    let mut worst = f64::INFINITY;
    for k in 0..PHASES {
        let phase = k as f64 / PHASES as f64;
        let (t, theta, centre) = impact_series(h_s, delta_omega_rad_s, duration_s, phase, half);
        let d = diff.differentiate(&t, &theta)?;
        let peak = d.alpha_rad_s2[centre - reach..=centre + reach]
            .iter()
            .fold(0.0_f64, |m, a| m.max(a.abs()));
        worst = worst.min(peak);
    }
    Ok(worst)
}

/// SNR of the impact against the α noise `noise_alpha_rad_s2`, and the verdict.
pub fn detectability(
    diff: &Differentiator,
    h_s: f64,
    delta_omega_rad_s: f64,
    duration_s: f64,
    noise_alpha_rad_s2: f64,
    min_snr: f64,
) -> Result<Detectability, EstimateError> {
    let peak = peak_alpha_response(diff, h_s, delta_omega_rad_s, duration_s)?;
    let snr = if noise_alpha_rad_s2 > 0.0 {
        peak / noise_alpha_rad_s2
    } else if peak > 0.0 {
        f64::INFINITY
    } else {
        0.0
    };
    Ok(Detectability {
        peak_alpha_rad_s2: peak,
        noise_alpha_rad_s2,
        snr,
        detectable: snr >= min_snr,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand_distr::{Distribution, Normal};

    const H: f64 = 1.0 / 30.0;

    fn sg(window_frames: usize) -> Differentiator {
        Differentiator::SavitzkyGolay {
            window_frames,
            window_s: None,
            order: 2,
        }
    }

    #[test]
    fn theta_is_continuous_with_the_right_slopes() {
        let (dw, tau, t0) = (0.2, 0.01, 1.0);
        assert_eq!(impact_theta_rad(0.5, t0, dw, tau), 0.0);
        let at_end = impact_theta_rad(t0 + tau, t0, dw, tau);
        assert!((at_end - dw * tau / 2.0).abs() < 1e-15);
        let eps = 1e-6;
        let slope_after = (impact_theta_rad(t0 + 2.0, t0, dw, tau)
            - impact_theta_rad(t0 + 1.0, t0, dw, tau))
            / 1.0;
        assert!((slope_after - dw).abs() < 1e-12);
        let jump = impact_theta_rad(t0 + tau + eps, t0, dw, tau)
            - impact_theta_rad(t0 + tau - eps, t0, dw, tau);
        assert!(jump.abs() < 3.0 * dw * eps);
    }

    #[test]
    fn snr_scales_linearly_with_delta_omega() {
        for diff in [Differentiator::Central3, Differentiator::Seed, sg(9)] {
            let a = detectability(&diff, H, 0.05, 0.002, 0.1, 3.0).unwrap();
            let b = detectability(&diff, H, 0.15, 0.002, 0.1, 3.0).unwrap();
            assert!(a.snr > 0.0);
            assert!((b.snr / a.snr - 3.0).abs() < 1e-9, "{diff:?}: {a:?} {b:?}");
        }
    }

    #[test]
    fn longer_impacts_give_smaller_peaks_beyond_one_frame() {
        for diff in [Differentiator::Central3, Differentiator::Seed, sg(7)] {
            let peaks: Vec<f64> = [2.0, 4.0, 8.0, 16.0]
                .iter()
                .map(|k| peak_alpha_response(&diff, H, 0.05, k * H).unwrap())
                .collect();
            for w in peaks.windows(2) {
                assert!(w[1] < w[0], "{diff:?}: {peaks:?}");
            }
            // Far beyond the stencil the estimate follows the true α pulse Δω/τ.
            let tau = 40.0 * H;
            let p = peak_alpha_response(&diff, H, 0.05, tau).unwrap();
            assert!((p / (0.05 / tau) - 1.0).abs() < 0.1, "{diff:?}: {p}");
        }
    }

    #[test]
    fn smoother_differentiator_lowers_peak_and_noise() {
        let c3 = Differentiator::Central3;
        let wide = sg(21);
        let peak_c3 = peak_alpha_response(&c3, H, 0.05, 0.002).unwrap();
        let peak_sg = peak_alpha_response(&wide, H, 0.05, 0.002).unwrap();
        assert!(peak_sg < peak_c3, "{peak_sg} vs {peak_c3}");
        let g_c3 = c3.noise_gain(H).alpha_per_rad;
        let g_sg = wide.noise_gain(H).alpha_per_rad;
        assert!(g_sg < g_c3, "{g_sg} vs {g_c3}");
    }

    /// Monte Carlo check of the metric's meaning: add Gaussian angle noise σ_θ to the worst-phase
    /// impact, differentiate, and look for a sample above 3σ_α near the impact. σ_α is measured on
    /// noise alone (a dwell), as in a real run; Δω is scaled so the metric says SNR = 5 or 1.
    fn detection_rate(diff: &Differentiator, target_snr: f64, trials: u64) -> f64 {
        let sigma_theta = 1e-3;
        let half = half_frames(diff, H, 0.002);
        // Noise σ_α measured from pure-noise series.
        let normal = Normal::new(0.0, sigma_theta).unwrap();
        let t: Vec<f64> = (0..2 * half + 1).map(|i| i as f64 * H).collect();
        let mut noise_alpha = Vec::new();
        for s in 0..50 {
            let mut rng = crate::rng::stream(99, crate::rng::Stream::MonteCarlo, s);
            let th: Vec<f64> = t.iter().map(|_| normal.sample(&mut rng)).collect();
            let d = diff.differentiate(&t, &th).unwrap();
            noise_alpha.extend_from_slice(&d.alpha_rad_s2[10..t.len() - 10]);
        }
        let sigma_alpha = crate::budget::ErrorStats::of(&noise_alpha).rms;
        let unit = detectability(diff, H, 1.0, 0.002, sigma_alpha, 3.0).unwrap();
        let dw = target_snr / unit.snr;
        let check = detectability(diff, H, dw, 0.002, sigma_alpha, 3.0).unwrap();
        assert!((check.snr - target_snr).abs() < 1e-9);
        // Worst phase, found the same way the metric does.
        let phase = (0..PHASES)
            .map(|k| k as f64 / PHASES as f64)
            .min_by(|a, b| {
                let pa = |p: f64| {
                    let (t, th, c) = impact_series(H, dw, 0.002, p, half);
                    let d = diff.differentiate(&t, &th).unwrap();
                    d.alpha_rad_s2[c - 3..=c + 3]
                        .iter()
                        .fold(0.0_f64, |m, x| m.max(x.abs()))
                };
                pa(*a).total_cmp(&pa(*b))
            })
            .unwrap();
        let (t, clean, centre) = impact_series(H, dw, 0.002, phase, half);
        let mut found = 0;
        for trial in 0..trials {
            let mut rng = crate::rng::stream(7, crate::rng::Stream::MonteCarlo, trial);
            let th: Vec<f64> = clean.iter().map(|c| c + normal.sample(&mut rng)).collect();
            let d = diff.differentiate(&t, &th).unwrap();
            // "Near the impact": the frames the spike occupies (±2 around the impact frame).
            let hit = d.alpha_rad_s2[centre - 2..=centre + 2]
                .iter()
                .any(|a| a.abs() > 3.0 * sigma_alpha);
            if hit {
                found += 1;
            }
        }
        found as f64 / trials as f64
    }

    #[test]
    fn monte_carlo_agrees_with_the_metric() {
        for diff in [Differentiator::Central3, sg(5)] {
            let strong = detection_rate(&diff, 5.0, 400);
            let weak = detection_rate(&diff, 1.0, 400);
            assert!(strong > 0.9, "{diff:?}: SNR 5 found in {strong}");
            assert!(weak < 0.5, "{diff:?}: SNR 1 found in {weak}");
        }
    }

    #[test]
    fn kalman_needs_a_fixed_lambda_and_then_responds() {
        let auto = Differentiator::KalmanRts {
            lambda_per_s6: None,
        };
        assert!(peak_alpha_response(&auto, H, 0.05, 0.002).is_err());
        let fixed = Differentiator::KalmanRts {
            lambda_per_s6: Some(1e6),
        };
        let a = peak_alpha_response(&fixed, H, 0.05, 0.002).unwrap();
        let b = peak_alpha_response(&fixed, H, 0.10, 0.002).unwrap();
        assert!(a > 0.0 && ((b / a) - 2.0).abs() < 1e-6, "{a} {b}");
    }

    #[test]
    fn bad_interval_is_an_error() {
        assert!(peak_alpha_response(&Differentiator::Central3, 0.0, 0.05, 0.002).is_err());
        assert!(peak_alpha_response(&Differentiator::Central3, H, 0.05, -1.0).is_err());
    }
}
