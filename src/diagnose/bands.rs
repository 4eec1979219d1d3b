//! Frequency bands of a residual series sampled at (possibly uneven) frame times: the series is
//! split into complementary components by Gaussian smoothing in time, so the components add up
//! to the series exactly and each holds the power of one band.
//!
//! A Gaussian kernel of standard deviation σ_t has its −3 dB point at f_c ≈ 0.1325 / σ_t, so a
//! band edge f_c uses σ_t = 0.1325 / f_c. The bands are soft (Gaussian transitions, no ringing):
//! a sinusoid in the middle of a band keeps ≥ 55 % of its amplitude there, less in each neighbour. Missing samples (NaN) are skipped by the smoother and
//! stay NaN in every component; the smoother normalises its weights, so it handles gaps and
//! uneven spacing.

/// σ_t (s) of the Gaussian whose −3 dB frequency is `f_c_hz`.
pub fn gaussian_sigma_for_cutoff_s(f_c_hz: f64) -> f64 {
    0.1325 / f_c_hz
}

/// Gaussian-weighted moving average of `x` at times `t_s` (NaN samples ignored; NaN where
/// `x` is NaN). Weights beyond 4σ are dropped.
pub fn smooth(t_s: &[f64], x: &[f64], sigma_s: f64) -> Vec<f64> {
    let n = t_s.len().min(x.len());
    let reach = 4.0 * sigma_s;
    let mut out = vec![f64::NAN; n];
    let mut lo = 0;
    for i in 0..n {
        if !x[i].is_finite() {
            continue;
        }
        while lo < n && t_s[lo] < t_s[i] - reach {
            lo += 1;
        }
        let (mut sw, mut swx) = (0.0, 0.0);
        for j in lo..n {
            if t_s[j] > t_s[i] + reach {
                break;
            }
            if !x[j].is_finite() {
                continue;
            }
            let u = (t_s[j] - t_s[i]) / sigma_s;
            let w = (-0.5 * u * u).exp();
            sw += w;
            swx += w * x[j];
        }
        out[i] = swx / sw;
    }
    out
}

/// Band edges (Hz) for footage with Nyquist rate `nyquist_hz`: [0, fN/10], [fN/10, fN/3],
/// [fN/3, fN]. At 30 fps: 0–1.5 Hz (the motion's own time scale: drive speed, runout,
/// over-rotation), 1.5–5 Hz, 5–15 Hz (frame-to-frame jitter, impacts).
pub fn band_edges_hz(nyquist_hz: f64) -> [[f64; 2]; 3] {
    let (a, b) = (nyquist_hz / 10.0, nyquist_hz / 3.0);
    [[0.0, a], [a, b], [b, nyquist_hz]]
}

/// Splits `x` into the three bands of [`band_edges_hz`]; the components sum to `x` where `x`
/// is finite.
pub fn split(t_s: &[f64], x: &[f64], nyquist_hz: f64) -> [Vec<f64>; 3] {
    let edges = band_edges_hz(nyquist_hz);
    let low = smooth(t_s, x, gaussian_sigma_for_cutoff_s(edges[0][1]));
    let low_mid = smooth(t_s, x, gaussian_sigma_for_cutoff_s(edges[1][1]));
    let mid: Vec<f64> = low_mid.iter().zip(&low).map(|(a, b)| a - b).collect();
    let high: Vec<f64> = x.iter().zip(&low_mid).map(|(a, b)| a - b).collect();
    [low, mid, high]
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::f64::consts::TAU;

    fn rms(v: &[f64]) -> f64 {
        crate::numeric::robust::rms_finite(v.iter().copied()).0
    }

    #[test]
    fn components_sum_to_the_series_and_skip_gaps() {
        let t: Vec<f64> = (0..300)
            .map(|k| k as f64 / 29.87 + 1e-4 * ((k * 7) % 3) as f64)
            .collect();
        let mut x: Vec<f64> = t
            .iter()
            .map(|&s| (TAU * 0.4 * s).sin() + 0.3 * (TAU * 9.0 * s).cos())
            .collect();
        x[50] = f64::NAN;
        let [a, b, c] = split(&t, &x, 15.0);
        for k in 0..t.len() {
            if k == 50 {
                assert!(a[k].is_nan() && b[k].is_nan() && c[k].is_nan());
            } else {
                assert!((a[k] + b[k] + c[k] - x[k]).abs() < 1e-12);
            }
        }
    }

    #[test]
    fn a_sinusoid_lands_in_its_band() {
        let t: Vec<f64> = (0..600).map(|k| k as f64 / 30.0).collect();
        // Gaussian bands are soft (edges are −3 dB points): a sinusoid in the middle of a band
        // has most of its amplitude there and less in each neighbour.
        for (f, band) in [(0.3, 0), (2.7, 1), (10.0, 2)] {
            let x: Vec<f64> = t.iter().map(|&s| (TAU * f * s).sin()).collect();
            let parts = split(&t, &x, 15.0);
            // Away from the ends, where the smoother has both sides.
            let inner = |v: &[f64]| rms(&v[60..540]);
            let total = inner(&x);
            let shares: Vec<f64> = parts.iter().map(|p| inner(p) / total).collect();
            assert!(shares[band] > 0.55, "f = {f} Hz: shares {shares:?}");
            for (b, s) in shares.iter().enumerate() {
                assert!(
                    b == band || *s < shares[band],
                    "f = {f} Hz: shares {shares:?}"
                );
            }
        }
    }
}
