//! Error bars on measured samples: each frame's standard uncertainty of θ2, ω2 and α2 against
//! the true motion, from simulations of the rig at the footage's own frame times, and whether a
//! measured feature stands above the detection noise. Pure: numbers in, numbers out.
//!
//! The uncertainty at a frame is the root mean square, over the simulated seeds, of the
//! measured-minus-true error at that frame. It holds the noise and the estimator's own error at
//! that frame (smoothing across an impact is an error too); it does not hold a model error (an
//! effect the rig's model lacks), which is what `diagnose` looks for.

use crate::numeric::robust::mean;

/// One simulated seed's series at the footage's frames, in the analysis's convention (θ2
/// relative to the first detected frame, the analysis's sense of rotation); NaN where the
/// simulated frame has no value.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SeedSeries {
    /// What the pipeline measured: θ2 rad, ω2 rad/s, α2 rad/s².
    pub measured: [Vec<f64>; 3],
    /// Measured minus the true motion, same units.
    pub error: [Vec<f64>; 3],
}

/// A signal's error bars at each frame of the footage.
#[derive(Debug, Clone, PartialEq)]
pub struct SignalBars {
    /// The signal's name (`centre`, `fused`, …).
    pub signal: String,
    /// Standard uncertainty against the true motion: θ2 rad, ω2 rad/s, α2 rad/s² (NaN where
    /// fewer than two seeds had a value).
    pub sigma: [Vec<f64>; 3],
    /// The simulated rig's true motion (fitted to the footage's): θ2 rad (from the first
    /// frame), ω2 rad/s, α2 rad/s².
    pub model: [Vec<f64>; 3],
    /// Standard uncertainty of the ω2 jump from the previous frame against the true jump, rad/s
    /// (NaN at the first frame): errors of neighbouring frames are correlated, so this is not
    /// √2 σ.
    pub omega2_jump_sigma_rad_s: Vec<f64>,
    /// Seeds with a value at each frame.
    pub seeds: Vec<usize>,
}

/// Relative standard error of an RMS taken over `n` independent Gaussian draws:
/// √(Var(s²))/(2σ²) = √(2σ⁴/n)/(2σ²) = 1/√(2n) to first order.
pub fn sigma_relative_se(n: usize) -> f64 {
    if n == 0 {
        f64::INFINITY
    } else {
        1.0 / (2.0 * n as f64).sqrt()
    }
}

fn finite_at(series: &[SeedSeries], pick: impl Fn(&SeedSeries) -> f64) -> Vec<f64> {
    series.iter().map(pick).filter(|v| v.is_finite()).collect()
}

/// The RMS of at least two finite values (one has no spread to speak of), else NaN.
fn rms(v: &[f64]) -> f64 {
    match crate::numeric::robust::rms_finite(v.iter().copied()) {
        (r, n) if n >= 2 => r,
        _ => f64::NAN,
    }
}

/// The error bars of one signal from its simulated seeds (all of one length, the footage's
/// frame count).
pub fn signal_bars(signal: &str, seeds: &[SeedSeries]) -> SignalBars {
    let n = seeds.first().map_or(0, |s| s.measured[0].len());
    let mut bars = SignalBars {
        signal: signal.to_string(),
        sigma: Default::default(),
        model: Default::default(),
        omega2_jump_sigma_rad_s: Vec::with_capacity(n),
        seeds: Vec::with_capacity(n),
    };
    for i in 0..n {
        for q in 0..3 {
            bars.sigma[q].push(rms(&finite_at(seeds, |s| s.error[q][i])));
            bars.model[q].push(mean(&finite_at(seeds, |s| {
                s.measured[q][i] - s.error[q][i]
            })));
        }
        let jump = match i.checked_sub(1) {
            Some(j) => rms(&finite_at(seeds, |s| s.error[1][i] - s.error[1][j])),
            None => f64::NAN,
        };
        bars.omega2_jump_sigma_rad_s.push(jump);
        bars.seeds
            .push(seeds.iter().filter(|s| s.error[0][i].is_finite()).count());
    }
    bars
}

/// Where a measured feature stands beyond the measurement's error: `Some(true)` where the
/// measured value departs from the modelled rig's true motion (`model`) by more than `k_sigma`
/// of its error bar (`sigma`): something the camera resolved (an impact, a vibration) that the
/// model lacks. `Some(false)` where it stays within (possibly detection error), `None` where a
/// value is missing.
pub fn beyond_noise(
    measured: &[f64],
    model: &[f64],
    sigma: &[f64],
    k_sigma: f64,
) -> Vec<Option<bool>> {
    measured
        .iter()
        .zip(model)
        .zip(sigma)
        .map(|((m, e), s)| {
            let d = m - e;
            (d.is_finite() && s.is_finite() && *s > 0.0).then(|| d.abs() > k_sigma * s)
        })
        .collect()
}

/// A measured signal's flags at each frame: its α2, and its ω2 jump from the previous frame,
/// beyond `k_sigma` error bars from the modelled rig's ([`beyond_noise`]).
pub fn feature_flags(
    bars: &SignalBars,
    omega2_rad_s: &[f64],
    alpha2_rad_s2: &[f64],
    k_sigma: f64,
) -> [Vec<Option<bool>>; 2] {
    [
        beyond_noise(alpha2_rad_s2, &bars.model[2], &bars.sigma[2], k_sigma),
        beyond_noise(
            &jumps(omega2_rad_s),
            &jumps(&bars.model[1]),
            &bars.omega2_jump_sigma_rad_s,
            k_sigma,
        ),
    ]
}

/// Frame-to-frame differences `v[i] − v[i−1]` (NaN at the first frame and next to a gap).
pub fn jumps(v: &[f64]) -> Vec<f64> {
    (0..v.len())
        .map(|i| match i.checked_sub(1) {
            Some(j) => v[i] - v[j],
            None => f64::NAN,
        })
        .collect()
}

/// The spread of z-scores (error / σ) over the frames where both are finite: their root mean
/// square (1 when the error bars are right, bias included) and how many frames it rests on.
pub fn z_rms(error: &[f64], sigma: &[f64]) -> (f64, usize) {
    let z: Vec<f64> = error
        .iter()
        .zip(sigma)
        .filter(|(e, s)| e.is_finite() && s.is_finite() && **s > 0.0)
        .map(|(e, s)| e / s)
        .collect();
    let n = z.len();
    if n == 0 {
        return (f64::NAN, 0);
    }
    ((z.iter().map(|x| x * x).sum::<f64>() / n as f64).sqrt(), n)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_distr::{Distribution, Normal};

    fn seed_series(rng: &mut rand_pcg::Pcg64Mcg, n: usize, sd: [f64; 3]) -> SeedSeries {
        let mut s = SeedSeries::default();
        for (q, sd) in sd.into_iter().enumerate() {
            let d = Normal::new(0.0, sd).unwrap();
            s.error[q] = (0..n).map(|_| d.sample(rng)).collect();
            s.measured[q] = s.error[q].iter().map(|e| 1.0 + e).collect();
        }
        s
    }

    #[test]
    fn the_error_bars_of_white_errors_are_their_standard_deviation() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(3);
        let seeds: Vec<SeedSeries> = (0..400)
            .map(|_| seed_series(&mut rng, 5, [1e-3, 0.02, 0.5]))
            .collect();
        let bars = signal_bars("centre", &seeds);
        // 400 draws: the RMS is within 4 standard errors (1/√800 = 3.5 %) of the truth.
        let tol = 4.0 * sigma_relative_se(400);
        for (q, sd) in [1e-3, 0.02, 0.5].into_iter().enumerate() {
            for s in &bars.sigma[q] {
                assert!((s / sd - 1.0).abs() < tol, "q {q}: {s} against {sd}");
            }
            for m in &bars.model[q] {
                assert!((m - 1.0).abs() < 1e-12, "q {q}: model {m}");
            }
        }
        // A jump of two independent errors is √2 times as uncertain.
        for (i, s) in bars.omega2_jump_sigma_rad_s.iter().enumerate() {
            if i == 0 {
                assert!(s.is_nan());
            } else {
                assert!((s / (0.02 * 2f64.sqrt()) - 1.0).abs() < tol, "{s}");
            }
        }
        assert!(bars.seeds.iter().all(|&n| n == 400));
    }

    #[test]
    fn a_bias_shared_by_every_seed_enters_the_error_bar() {
        // The estimator's own error at a frame (smoothing across an impact) is the same on every
        // seed: it is an error against the truth, so the bar holds it.
        let seeds: Vec<SeedSeries> = (0..10)
            .map(|k| {
                let e = if k % 2 == 0 { 0.1 } else { -0.1 };
                SeedSeries {
                    measured: [vec![0.0], vec![0.0], vec![0.0]],
                    error: [vec![0.3 + e], vec![0.0], vec![0.4]],
                }
            })
            .collect();
        let bars = signal_bars("fused", &seeds);
        let want = ((0.4f64.powi(2) + 0.2f64.powi(2)) / 2.0).sqrt();
        assert!((bars.sigma[0][0] - want).abs() < 1e-12);
        assert!((bars.sigma[2][0] - 0.4).abs() < 1e-12);
    }

    #[test]
    fn missing_values_are_left_out_and_too_few_give_no_bar() {
        let mut a = SeedSeries {
            measured: [vec![1.0, 1.0], vec![0.0, 0.0], vec![0.0, 0.0]],
            error: [vec![0.1, f64::NAN], vec![0.0, 0.0], vec![0.0, 0.0]],
        };
        let b = a.clone();
        a.error[0][0] = 0.3;
        let bars = signal_bars("centre", &[a, b]);
        assert!((bars.sigma[0][0] - (0.05f64).sqrt()).abs() < 1e-12);
        assert!(bars.sigma[0][1].is_nan());
        assert_eq!(bars.seeds, vec![2, 0]);
    }

    #[test]
    fn a_feature_beyond_k_sigma_is_flagged_and_noise_is_not() {
        let flags = beyond_noise(
            &[0.0, 3.5, -2.9, f64::NAN, 1.0],
            &[0.0, 0.0, 0.0, 0.0, 0.0],
            &[1.0, 1.0, 1.0, 1.0, f64::NAN],
            3.0,
        );
        assert_eq!(
            flags,
            vec![Some(false), Some(true), Some(false), None, None]
        );
    }

    #[test]
    fn z_scores_of_errors_drawn_at_their_sigma_spread_by_one() {
        let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(9);
        let sigma: Vec<f64> = (0..2000).map(|i| 0.1 + (i % 7) as f64).collect();
        let error: Vec<f64> = sigma
            .iter()
            .map(|s| Normal::new(0.0, *s).unwrap().sample(&mut rng))
            .collect();
        let (z, n) = z_rms(&error, &sigma);
        assert_eq!(n, 2000);
        assert!((z - 1.0).abs() < 4.0 * sigma_relative_se(2000), "{z}");
        assert_eq!(jumps(&[1.0, 3.0, 2.0])[1..], [2.0, -1.0]);
    }
}
