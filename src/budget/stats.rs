//! Error statistics of one error series: bias, RMS, 95th percentile and maximum of |error|.
//!
//! Missing values (NaN) are skipped and counted, never imputed.

use crate::numeric::robust::percentile_sorted;
use serde::{Deserialize, Serialize};

/// Statistics of an error series `e = measured − truth` (units of the quantity).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ErrorStats {
    /// Number of finite errors used.
    pub n: usize,
    /// Mean error (signed).
    pub bias: f64,
    /// Root mean square error (includes the bias).
    pub rms: f64,
    /// Standard deviation about the bias (population form, √(rms² − bias²)).
    pub std: f64,
    /// 95th percentile of |error| (linear interpolation between order statistics, numpy's default).
    pub p95: f64,
    /// Largest |error|.
    pub max: f64,
}

impl ErrorStats {
    /// Statistics of the finite entries of `errors`; all NaN when there are none.
    pub fn of(errors: &[f64]) -> Self {
        let finite: Vec<f64> = errors.iter().copied().filter(|e| e.is_finite()).collect();
        let n = finite.len();
        if n == 0 {
            return Self {
                n: 0,
                bias: f64::NAN,
                rms: f64::NAN,
                std: f64::NAN,
                p95: f64::NAN,
                max: f64::NAN,
            };
        }
        let nf = n as f64;
        let bias = finite.iter().sum::<f64>() / nf;
        let rms = (finite.iter().map(|e| e * e).sum::<f64>() / nf).sqrt();
        let std = (finite.iter().map(|e| (e - bias) * (e - bias)).sum::<f64>() / nf).sqrt();
        let mut abs: Vec<f64> = finite.iter().map(|e| e.abs()).collect();
        abs.sort_by(f64::total_cmp);
        Self {
            n,
            bias,
            rms,
            std,
            p95: percentile_sorted(&abs, 95.0),
            max: abs[n - 1],
        }
    }

    /// The same statistics divided by `scale` (e.g. the phase's peak true value); bias keeps its sign.
    pub fn relative_to(&self, scale: f64) -> Self {
        let s = if scale.abs() > 0.0 {
            scale.abs()
        } else {
            f64::NAN
        };
        Self {
            n: self.n,
            bias: self.bias / s,
            rms: self.rms / s,
            std: self.std / s,
            p95: self.p95 / s,
            max: self.max / s,
        }
    }
}

/// Largest |value| over the finite entries (the "peak true value" used for relative errors).
pub fn peak_abs(values: &[f64]) -> f64 {
    values
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .fold(0.0, |m, v| m.max(v.abs()))
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn known_series() {
        let s = ErrorStats::of(&[1.0, -1.0, 3.0, f64::NAN, -3.0]);
        assert_eq!(s.n, 4);
        assert_eq!(s.bias, 0.0);
        assert!((s.rms - 5f64.sqrt()).abs() < 1e-15);
        assert_eq!(s.max, 3.0);
        // |e| sorted = 1,1,3,3; pos = 0.95·3 = 2.85 → 3.
        assert_eq!(s.p95, 3.0);
        assert!(ErrorStats::of(&[f64::NAN]).rms.is_nan());
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(32))]
        /// Gaussian errors with known bias and σ: the estimates fall inside sampling tolerances
        /// derived from n (bias: 5σ/√n; std: 5σ/√(2n); p95 of |N(μ,σ)| for μ = 0 is 1.95996σ).
        #[test]
        fn gaussian_series_recover_known_statistics(seed in 0u64..1000, bias in -2.0f64..2.0, sigma in 0.01f64..3.0) {
            use rand::SeedableRng;
            use rand_distr::{Distribution, Normal};
            let n = 20_000usize;
            let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(seed);
            let normal = Normal::new(bias, sigma).unwrap();
            let e: Vec<f64> = (0..n).map(|_| normal.sample(&mut rng)).collect();
            let s = ErrorStats::of(&e);
            let nf = n as f64;
            prop_assert!((s.bias - bias).abs() < 5.0 * sigma / nf.sqrt());
            prop_assert!((s.std - sigma).abs() < 5.0 * sigma / (2.0 * nf).sqrt());
            prop_assert!((s.rms - (bias * bias + sigma * sigma).sqrt()).abs() < 5.0 * sigma / nf.sqrt() + 5.0 * sigma / (2.0 * nf).sqrt());
            let centred: Vec<f64> = e.iter().map(|x| x - bias).collect();
            let c = ErrorStats::of(&centred);
            prop_assert!((c.p95 / sigma - 1.959964).abs() < 0.06);
            prop_assert!(s.max >= s.p95 && s.p95 >= 0.0);
        }
    }
}
