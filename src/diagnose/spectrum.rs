//! The largest spectral peak of a residual series sampled at (possibly uneven) frame times:
//! the Lomb–Scargle periodogram (Lomb 1976, Scargle 1982) over a frequency band, and the ratio
//! of its highest value to its mean.
//!
//! A vibration at one frequency (a disc resonance, a shaking camera mount, a periodic impact)
//! puts its power into one peak, while the detector's own error spreads over every frequency.
//! The ratio is scale-free, so two renderers whose detection error differs in size (another
//! anti-aliasing, another edge profile) give the same ratio when no vibration is at work: under
//! white noise it is the largest of about as many exponential draws as the band holds
//! independent frequencies (≈ ln m + 0.58 for m of them), and a sinusoid of amplitude A over
//! N samples of noise σ raises the peak to about N·A²/(4σ²) times the mean.
//!
//! Also the least-squares amplitude of one sinusoid at a known frequency ([`sinusoid_fit`]): a
//! vibration's amplitude read directly, where a band's power would also hold the detector's
//! error, whose size differs between renderers and rigs; and that amplitude inverted through a
//! pipeline's gain simulated on several placements ([`invert_through_gain`]), whose spread the
//! amplitude's ± holds.

/// The highest peak of a periodogram.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SpectralPeak {
    /// Frequency of the highest periodogram value, Hz.
    pub frequency_hz: f64,
    /// Highest periodogram value over its mean across the band, dimensionless.
    pub ratio: f64,
}

/// Frequencies per 1/T of the record (oversampling of the periodogram grid).
const OVERSAMPLE: f64 = 4.0;
/// Most frequencies evaluated (bounds the cost on long records).
const MAX_FREQUENCIES: usize = 4000;
/// Fewest finite samples a periodogram is computed on.
const MIN_SAMPLES: usize = 16;

/// Lomb–Scargle power of `x` (mean removed; NaN samples skipped) at `frequency_hz`.
fn lomb_scargle(t_s: &[f64], x: &[f64], frequency_hz: f64) -> f64 {
    let w = std::f64::consts::TAU * frequency_hz;
    let (mut s2, mut c2) = (0.0, 0.0);
    for &t in t_s {
        let (s, c) = (2.0 * w * t).sin_cos();
        s2 += s;
        c2 += c;
    }
    let tau = s2.atan2(c2) / (2.0 * w);
    let (mut xc, mut xs, mut cc, mut ss) = (0.0, 0.0, 0.0, 0.0);
    for (&t, &v) in t_s.iter().zip(x) {
        let (s, c) = (w * (t - tau)).sin_cos();
        xc += v * c;
        xs += v * s;
        cc += c * c;
        ss += s * s;
    }
    let part = |num: f64, den: f64| if den > 1e-12 { num * num / den } else { 0.0 };
    0.5 * (part(xc, cc) + part(xs, ss))
}

/// The samples of `x` at `t_s` where both are finite.
fn finite_samples(t_s: &[f64], x: &[f64]) -> (Vec<f64>, Vec<f64>) {
    t_s.iter()
        .zip(x)
        .filter(|(t, v)| t.is_finite() && v.is_finite())
        .map(|(t, v)| (*t, *v))
        .unzip()
}

/// The highest Lomb–Scargle peak of `x` at times `t_s` between `f_lo_hz` and `f_hi_hz`.
/// `None` with fewer than [`MIN_SAMPLES`] finite samples, an empty band or a series without
/// power (all samples equal).
pub fn highest_peak(t_s: &[f64], x: &[f64], f_lo_hz: f64, f_hi_hz: f64) -> Option<SpectralPeak> {
    let (t, v) = finite_samples(t_s, x);
    if t.len() < MIN_SAMPLES || !(f_hi_hz > f_lo_hz && f_lo_hz > 0.0) {
        return None;
    }
    let span_s = t[t.len() - 1] - t[0];
    if span_s <= 0.0 {
        return None;
    }
    let mean = v.iter().sum::<f64>() / v.len() as f64;
    let v: Vec<f64> = v.iter().map(|x| x - mean).collect();
    let step_hz = (1.0 / (OVERSAMPLE * span_s)).max((f_hi_hz - f_lo_hz) / MAX_FREQUENCIES as f64);
    let count = ((f_hi_hz - f_lo_hz) / step_hz).floor() as usize + 1;
    let (mut best, mut best_f, mut sum) = (f64::NEG_INFINITY, f_lo_hz, 0.0);
    for k in 0..count {
        let f = f_lo_hz + k as f64 * step_hz;
        let p = lomb_scargle(&t, &v, f);
        sum += p;
        if p > best {
            (best, best_f) = (p, f);
        }
    }
    let mean_power = sum / count as f64;
    (mean_power > 0.0 && best.is_finite()).then_some(SpectralPeak {
        frequency_hz: best_f,
        ratio: best / mean_power,
    })
}

/// One sinusoid fitted by least squares to a series (with a constant, a slope and a curvature
/// beside it, so that a slow drift of the residual is not taken for it).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SinusoidFit {
    pub frequency_hz: f64,
    /// Amplitude, in the series' unit.
    pub amplitude: f64,
    /// Standard uncertainty of the amplitude from the fit's residual scatter.
    pub amplitude_std: f64,
    /// Phase of `amplitude · sin(2π f t + phase)`, rad.
    pub phase_rad: f64,
}

/// Fewest finite samples a sinusoid is fitted on.
const MIN_FIT_SAMPLES: usize = 12;

/// The sinusoid at `frequency_hz` in `x` at times `t_s` (non-finite samples skipped), with a
/// quadratic drift as nuisance. `None` with fewer than 12 finite samples, a frequency that is not
/// positive and finite, or a degenerate design (a frequency the samples cannot resolve).
pub fn sinusoid_fit(t_s: &[f64], x: &[f64], frequency_hz: f64) -> Option<SinusoidFit> {
    let (t, v) = finite_samples(t_s, x);
    if t.len() < MIN_FIT_SAMPLES || !(frequency_hz.is_finite() && frequency_hz > 0.0) {
        return None;
    }
    let n = t.len() as f64;
    let mean_t = t.iter().sum::<f64>() / n;
    let half_span = t.iter().map(|t| (t - mean_t).abs()).fold(0.0, f64::max);
    if half_span <= 0.0 {
        return None;
    }
    let w = std::f64::consts::TAU * frequency_hz;
    let row = |t: f64| {
        let u = (t - mean_t) / half_span;
        let (s, c) = (w * t).sin_cos();
        [s, c, 1.0, u, u * u]
    };
    const P: usize = 5;
    let mut ata = vec![vec![0.0; P]; P];
    let mut atb = [0.0; P];
    for (&t, &y) in t.iter().zip(&v) {
        let r = row(t);
        for i in 0..P {
            atb[i] += r[i] * y;
            for j in 0..P {
                ata[i][j] += r[i] * r[j];
            }
        }
    }
    let inv = crate::numeric::linalg::invert_rows(&ata)?;
    let beta: Vec<f64> = (0..P)
        .map(|i| (0..P).map(|j| inv[i][j] * atb[j]).sum())
        .collect();
    let rss: f64 = t
        .iter()
        .zip(&v)
        .map(|(&t, &y)| {
            let r = row(t);
            let fit: f64 = r.iter().zip(&beta).map(|(a, b)| a * b).sum();
            (y - fit).powi(2)
        })
        .sum();
    let sigma2 = rss / (n - P as f64).max(1.0);
    let (a, b) = (beta[0], beta[1]);
    let amplitude = a.hypot(b);
    // The amplitude's variance through its gradient (a, b)/A; at A = 0 the mean of the two.
    let var = if amplitude > 0.0 {
        sigma2 * (a * a * inv[0][0] + b * b * inv[1][1] + 2.0 * a * b * inv[0][1])
            / (amplitude * amplitude)
    } else {
        0.5 * sigma2 * (inv[0][0] + inv[1][1])
    };
    (amplitude.is_finite() && var.is_finite()).then_some(SinusoidFit {
        frequency_hz,
        amplitude,
        amplitude_std: var.max(0.0).sqrt(),
        phase_rad: b.atan2(a),
    })
}

/// [`sinusoid_fit`] at the frequency within `frequency_hz` ± `half_width_hz` where the
/// amplitude is largest (golden section): a periodogram's grid places a peak only to within
/// its step, and over a record of T seconds a frequency off by δf loses a fraction
/// 1 − sinc(δf·T) of the amplitude.
pub fn sinusoid_fit_refined(
    t_s: &[f64],
    x: &[f64],
    frequency_hz: f64,
    half_width_hz: f64,
) -> Option<SinusoidFit> {
    let at = sinusoid_fit(t_s, x, frequency_hz)?;
    let lo = (frequency_hz - half_width_hz.abs()).max(0.5 * frequency_hz);
    let hi = frequency_hz + half_width_hz.abs();
    let amplitude = |f: f64| sinusoid_fit(t_s, x, f).map_or(f64::INFINITY, |s| -s.amplitude);
    let f = crate::numeric::minimize::golden_section_min(amplitude, lo, hi, 30);
    match sinusoid_fit(t_s, x, f) {
        Some(refined) if refined.amplitude > at.amplitude => Some(refined),
        _ => Some(at),
    }
}

/// A sinusoid's amplitude read through a measurement pipeline ([`invert_through_gain`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct GainInversion {
    /// The input amplitude that explains the measured sinusoid, |c − c̄₀| / |h̄|.
    pub amplitude: f64,
    /// Its standard uncertainty: the measured sinusoid's own (through the mean gain) and the
    /// gain's spread from one simulated placement to the next, in quadrature.
    pub amplitude_std: f64,
    /// |h̄|: the mean complex gain's modulus.
    pub gain: f64,
    /// Sample standard deviation of the per-placement gains |h_k| (n − 1 degrees of freedom).
    pub gain_spread: f64,
    /// |c̄₀|: the mean content at that frequency with no input.
    pub content_without: f64,
}

/// Inverts a measured sinusoid `measured` (complex amplitude: sin and cos coefficients, with
/// standard uncertainty `measured_std` of its amplitude) through a pipeline simulated on n ≥ 2
/// placements: `without[k]` and `with[k]` are the complex amplitudes the k-th simulation
/// measured at input amplitude 0 and `probe`, on common random numbers. Each gives a complex
/// gain h_k = (with_k − without_k) / probe; the amplitude is |c − c̄₀| / |h̄|.
///
/// Why the gain's spread enters the ±: the corners of an unrefined detector are whole pixels,
/// so a motion of a fraction of a pixel (a 2 mrad vibration moves a marker 200 px from the
/// axis by 0.4 px) passes through a quantiser whose gain depends on where the edges sit on the
/// pixel grid. The same scenario with its rotation centre moved by 0.2–0.8 px read one
/// vibration with gains 0.97–1.14, and three fits on 2 placements each agreed on a gain of about
/// 0.9 while the footage's own placement had about 1.09: an amplitude 20 % high, 3.9 of its ±
/// from the truth, when the ± held the footage's noise only (`reports/diagnosis-seed-1/`). The
/// footage's placement is one draw of what the simulations' placements sample, known only to a
/// fraction of a pixel, so its gain is uncertain by their spread s_g, not by s_g/√n:
/// σ_A² = (σ_c / |h̄|)² + (A · s_g / |h̄|)². The spread also holds the simulations' detection
/// noise at that frequency (common random numbers do not cancel it where the marker sits on
/// other pixels), which the measured sinusoid's own σ_c counts again: the ± errs wide, not
/// narrow. The 95 % interval (`fit_noise::interval95`) counts s_g as known, though it rests on
/// n − 1 degrees of freedom (7 at 8 placements per fit, about 21 pooled over three fits:
/// Student's k 2.08 where 1.96 is taken, an interval about 6 % too short on that part). `None` when fewer than two placements, the lists differ in length, any value is
/// not finite, or the probe or the gain is not positive.
pub fn invert_through_gain(
    measured: [f64; 2],
    measured_std: f64,
    without: &[[f64; 2]],
    with: &[[f64; 2]],
    probe: f64,
) -> Option<GainInversion> {
    let n = without.len();
    let finite = |c: &[f64; 2]| c[0].is_finite() && c[1].is_finite();
    let usable = n >= 2
        && with.len() == n
        && probe.is_finite()
        && probe > 0.0
        && measured_std.is_finite()
        && finite(&measured)
        && without.iter().chain(with).all(finite);
    if !usable {
        return None;
    }
    let nf = n as f64;
    let gains: Vec<[f64; 2]> = with
        .iter()
        .zip(without)
        .map(|(c1, c0)| [(c1[0] - c0[0]) / probe, (c1[1] - c0[1]) / probe])
        .collect();
    let mean = |v: &[[f64; 2]]| {
        [
            v.iter().map(|c| c[0]).sum::<f64>() / nf,
            v.iter().map(|c| c[1]).sum::<f64>() / nf,
        ]
    };
    let h = mean(&gains);
    let c0 = mean(without);
    let gain = h[0].hypot(h[1]);
    if gain.is_nan() || gain <= 0.0 {
        return None;
    }
    let moduli: Vec<f64> = gains.iter().map(|g| g[0].hypot(g[1])).collect();
    let mean_modulus = moduli.iter().sum::<f64>() / nf;
    let gain_spread = (moduli
        .iter()
        .map(|g| (g - mean_modulus).powi(2))
        .sum::<f64>()
        / (nf - 1.0))
        .sqrt();
    let amplitude = (measured[0] - c0[0]).hypot(measured[1] - c0[1]) / gain;
    let amplitude_std = (measured_std / gain).hypot(amplitude * gain_spread / gain);
    Some(GainInversion {
        amplitude,
        amplitude_std,
        gain,
        gain_spread,
        content_without: c0[0].hypot(c0[1]),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::Rng;

    fn times(n: usize, fps: f64, jitter_s: f64, seed: u64) -> Vec<f64> {
        let mut r = crate::rng::stream(seed, crate::rng::Stream::DiagnoseNuisance, 99);
        (0..n)
            .map(|k| k as f64 / fps + jitter_s * (r.gen::<f64>() - 0.5))
            .collect()
    }

    fn noise(n: usize, sigma: f64, seed: u64) -> Vec<f64> {
        let mut r = crate::rng::stream(seed, crate::rng::Stream::DiagnoseNuisance, 98);
        (0..n)
            .map(|_| {
                // Sum of 12 uniforms − 6: unit variance, near-Gaussian.
                sigma * ((0..12).map(|_| r.gen::<f64>()).sum::<f64>() - 6.0)
            })
            .collect()
    }

    fn sinusoid(t: &[f64], n: &[f64], amplitude: f64, f_hz: f64, phase: f64) -> Vec<f64> {
        t.iter()
            .zip(n)
            .map(|(t, e)| {
                amplitude * (std::f64::consts::TAU * f_hz * t + phase).sin()
                    + 1e-3 * (t - 3.0).powi(2)
                    + e
            })
            .collect()
    }

    proptest::proptest! {
        #[test]
        fn a_sinusoids_amplitude_is_read_within_its_uncertainty_whatever_the_noise(
            amplitude in 2e-4f64..5e-3,
            f_hz in 2.0f64..14.0,
            phase in -3.1f64..3.1,
            sigma in 1e-5f64..1e-3,
            seed in 0u64..1000,
        ) {
            let t = times(180, 30.0, 0.004, seed);
            let x = sinusoid(&t, &noise(180, sigma, seed + 1), amplitude, f_hz, phase);
            let s = sinusoid_fit(&t, &x, f_hz).unwrap();
            // 4.5 standard uncertainties, and the uncertainty itself as the noise says.
            proptest::prop_assert!(
                (s.amplitude - amplitude).abs() < 4.5 * s.amplitude_std + 1e-9,
                "{s:?} for {amplitude}"
            );
            let expected_std = sigma * (2.0 / 180.0f64).sqrt();
            proptest::prop_assert!(
                s.amplitude_std > 0.6 * expected_std && s.amplitude_std < 1.6 * expected_std,
                "{} against {expected_std}", s.amplitude_std
            );
        }
    }

    #[test]
    fn the_noise_floor_does_not_enter_a_sinusoids_amplitude() {
        // The same 2 mrad vibration under noise 10× apart: a band's power would differ by the
        // noise; the fitted amplitude must not.
        let t = times(180, 30.0, 0.0, 3);
        let quiet = sinusoid(&t, &noise(180, 5e-5, 4), 2e-3, 7.0, 0.4);
        let noisy = sinusoid(&t, &noise(180, 5e-4, 4), 2e-3, 7.0, 0.4);
        let a = sinusoid_fit(&t, &quiet, 7.0).unwrap().amplitude;
        let b = sinusoid_fit(&t, &noisy, 7.0).unwrap().amplitude;
        assert!((a / 2e-3 - 1.0).abs() < 0.01, "{a}");
        assert!((b / 2e-3 - 1.0).abs() < 0.06, "{b}");
    }

    #[test]
    fn an_off_grid_frequency_is_refined_and_other_modes_stay_out() {
        let t = times(180, 30.0, 0.0, 5);
        let n = noise(180, 1e-4, 6);
        let two: Vec<f64> = sinusoid(&t, &n, 2e-3, 7.03, 0.0)
            .iter()
            .zip(&t)
            .map(|(x, t)| x + 1.5e-3 * (std::f64::consts::TAU * 11.0 * t).sin())
            .collect();
        // 0.1 Hz off over 6 s loses about 10 % of the amplitude; the refinement recovers it.
        let coarse = sinusoid_fit(&t, &two, 6.93).unwrap();
        let fine = sinusoid_fit_refined(&t, &two, 6.93, 0.15).unwrap();
        assert!(coarse.amplitude < 0.95 * 2e-3, "{coarse:?}");
        assert!((fine.frequency_hz - 7.03).abs() < 0.01, "{fine:?}");
        assert!((fine.amplitude / 2e-3 - 1.0).abs() < 0.03, "{fine:?}");
    }

    #[test]
    fn a_sinusoid_cannot_be_fitted_on_too_few_samples_or_at_no_frequency() {
        let t = times(11, 30.0, 0.0, 7);
        let x = vec![0.0; 11];
        assert!(sinusoid_fit(&t, &x, 5.0).is_none());
        let t = times(60, 30.0, 0.0, 7);
        let x = vec![1.0; 60];
        assert!(sinusoid_fit(&t, &x, 0.0).is_none());
        assert!(sinusoid_fit(&t, &x, f64::NAN).is_none());
        // At the sampling rate the sine column vanishes: no fit rather than a made-up amplitude.
        assert!(sinusoid_fit(&t, &x, 30.0).is_none());
    }

    #[test]
    fn a_sinusoid_in_noise_is_found_at_its_frequency_on_uneven_times() {
        let t = times(180, 30.0, 0.004, 1);
        let n = noise(180, 3e-4, 2);
        let x: Vec<f64> = t
            .iter()
            .zip(&n)
            .map(|(t, e)| 2e-3 * (std::f64::consts::TAU * 7.0 * t).sin() + e)
            .collect();
        let p = highest_peak(&t, &x, 1.5, 15.0).unwrap();
        assert!((p.frequency_hz - 7.0).abs() < 0.1, "{p:?}");
        // N·A²/(4σ²) = 180 · 4e-6 / (4 · 9e-8) = 2000 times the noise power; the ratio is
        // against the band's mean, which the peak itself raises: far above white noise's ≈ 6.
        assert!(p.ratio > 50.0, "{p:?}");
    }

    #[test]
    fn white_noise_peaks_at_the_extreme_value_of_its_independent_frequencies() {
        // 6 s in 1.5–15 Hz holds 13.5 · 6 ≈ 81 independent frequencies: the largest of 81
        // unit exponentials is ln 81 + 0.58 ≈ 5 on average, rarely above 10.
        let t = times(180, 30.0, 0.0, 3);
        let mut ratios = Vec::new();
        for seed in 0..20 {
            let x = noise(180, 1.0, 10 + seed);
            ratios.push(highest_peak(&t, &x, 1.5, 15.0).unwrap().ratio);
        }
        let mean = ratios.iter().sum::<f64>() / ratios.len() as f64;
        assert!((3.5..7.5).contains(&mean), "{ratios:?}");
        assert!(ratios.iter().all(|r| *r < 12.0), "{ratios:?}");
        // Scale-free: the same noise 100× larger gives the same ratio.
        let x = noise(180, 1.0, 10);
        let big: Vec<f64> = x.iter().map(|v| 100.0 * v).collect();
        let (a, b) = (
            highest_peak(&t, &x, 1.5, 15.0).unwrap().ratio,
            highest_peak(&t, &big, 1.5, 15.0).unwrap().ratio,
        );
        assert!((a - b).abs() < 1e-9 * a, "{a} {b}");
    }

    #[test]
    fn too_few_samples_or_no_power_give_none() {
        let t = times(10, 30.0, 0.0, 4);
        assert!(highest_peak(&t, &[1.0; 10], 1.5, 15.0).is_none());
        let t = times(60, 30.0, 0.0, 4);
        assert!(highest_peak(&t, &[2.0; 60], 1.5, 15.0).is_none());
        let mut x = noise(60, 1.0, 5);
        x[3] = f64::NAN;
        assert!(highest_peak(&t, &x, 1.5, 15.0).is_some());
        assert!(highest_peak(&t, &x, 15.0, 1.5).is_none());
    }
    #[test]
    fn a_sinusoid_is_inverted_through_the_mean_gain_and_its_spread_widens_the_plus_minus(
    ) -> Result<(), String> {
        // Four placements with gains 0.9, 1.1, 1.0, 1.0 (all at phase π/2: cos coefficient),
        // each with its own content 0.1 at phase 0 without input.
        let probe = 2e-3;
        let without = [[1e-4, 0.0]; 4];
        let with: Vec<[f64; 2]> = [0.9, 1.1, 1.0, 1.0]
            .iter()
            .map(|g| [1e-4, g * probe])
            .collect();
        // A footage of amplitude 1.5e-3 through a gain of 1.0, plus the same content.
        let inv = invert_through_gain([1e-4, 1.5e-3], 5e-5, &without, &with, probe)
            .ok_or("no inversion")?;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1e-12);
        assert!(close(inv.gain, 1.0), "{inv:?}");
        assert!(close(inv.amplitude, 1.5e-3), "{inv:?}");
        assert!(close(inv.content_without, 1e-4), "{inv:?}");
        // Gains 0.9, 1.1, 1.0, 1.0: sample sd √(0.02/3).
        let s_g = (0.02f64 / 3.0).sqrt();
        assert!(close(inv.gain_spread, s_g), "{inv:?}");
        assert!(
            close(inv.amplitude_std, (5e-5f64).hypot(1.5e-3 * s_g)),
            "{inv:?}"
        );
        // The same placements all at one gain: the ± is the footage's own, through the gain.
        let same: Vec<[f64; 2]> = (0..4).map(|_| [1e-4, 0.8 * probe]).collect();
        let inv = invert_through_gain([1e-4, 1.2e-3], 5e-5, &without, &same, probe)
            .ok_or("no inversion")?;
        assert!(
            close(inv.amplitude, 1.5e-3) && close(inv.amplitude_std, 5e-5 / 0.8),
            "{inv:?}"
        );
        Ok(())
    }

    #[test]
    fn a_gain_inversion_refuses_what_it_cannot_invert() {
        let one = [[0.0, 1e-3]];
        let two = [[0.0, 0.0]; 2];
        let with = [[0.0, 2e-3]; 2];
        // One placement has no spread; lists of unequal length; no gain; a bad probe; NaN.
        assert!(invert_through_gain([0.0, 1e-3], 1e-5, &one, &one, 2e-3).is_none());
        assert!(invert_through_gain([0.0, 1e-3], 1e-5, &two, &with[..1], 2e-3).is_none());
        assert!(invert_through_gain([0.0, 1e-3], 1e-5, &two, &two, 2e-3).is_none());
        assert!(invert_through_gain([0.0, 1e-3], 1e-5, &two, &with, 0.0).is_none());
        assert!(invert_through_gain([0.0, f64::NAN], 1e-5, &two, &with, 2e-3).is_none());
        assert!(invert_through_gain([0.0, 1e-3], f64::NAN, &two, &with, 2e-3).is_none());
        assert!(invert_through_gain([0.0, 1e-3], 1e-5, &two, &with, 2e-3).is_some());
    }
}
