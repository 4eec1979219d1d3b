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

/// The highest Lomb–Scargle peak of `x` at times `t_s` between `f_lo_hz` and `f_hi_hz`.
/// `None` with fewer than [`MIN_SAMPLES`] finite samples, an empty band or a series without
/// power (all samples equal).
pub fn highest_peak(t_s: &[f64], x: &[f64], f_lo_hz: f64, f_hi_hz: f64) -> Option<SpectralPeak> {
    let (t, v): (Vec<f64>, Vec<f64>) = t_s
        .iter()
        .zip(x)
        .filter(|(t, v)| t.is_finite() && v.is_finite())
        .map(|(t, v)| (*t, *v))
        .unzip();
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
}
