//! Monte Carlo aggregation: a metric measured once per seed, summarised with a 95 % confidence
//! interval for its mean (Student's t for small N).

use crate::numeric::robust;
use serde::{Deserialize, Serialize};

/// Mean of a per-seed metric with its 95 % confidence interval.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct MeanCi {
    pub mean: f64,
    pub ci95_low: f64,
    pub ci95_high: f64,
    pub n: usize,
}

/// Two-sided 97.5 % quantile of Student's t with `dof` degrees of freedom (table + asymptote).
pub fn t975(dof: usize) -> f64 {
    const TABLE: [f64; 30] = [
        12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
        2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
        2.052, 2.048, 2.045, 2.042,
    ];
    match dof {
        0 => f64::INFINITY,
        d if d <= 30 => TABLE[d - 1],
        // Cornish–Fisher style expansion; error < 1e-3 beyond 30 dof.
        d => {
            let z: f64 = 1.959964;
            let d = d as f64;
            z + (z.powi(3) + z) / (4.0 * d)
                + (5.0 * z.powi(5) + 16.0 * z.powi(3) + 3.0 * z) / (96.0 * d * d)
        }
    }
}

impl MeanCi {
    /// Mean and 95 % CI of the finite values (a single value gives an infinite interval).
    pub fn of(values: &[f64]) -> Self {
        let v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
        let n = v.len();
        if n == 0 {
            return Self {
                mean: f64::NAN,
                ci95_low: f64::NAN,
                ci95_high: f64::NAN,
                n,
            };
        }
        let mean = robust::mean(&v);
        if n == 1 {
            return Self {
                mean,
                ci95_low: f64::NEG_INFINITY,
                ci95_high: f64::INFINITY,
                n,
            };
        }
        let var = robust::sample_variance(&v);
        let half = t975(n - 1) * (var / n as f64).sqrt();
        Self {
            mean,
            ci95_low: mean - half,
            ci95_high: mean + half,
            n,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn t_quantiles() {
        assert_eq!(t975(1), 12.706);
        assert!((t975(1000) - 1.962).abs() < 1e-3);
        assert!((t975(31) - 2.040).abs() < 2e-3);
    }

    /// Coverage check: over many repetitions the 95 % interval contains the true mean ~95 % of
    /// the time (binomial tolerance for 2000 repetitions: ±3σ = ±1.5 %).
    #[test]
    fn interval_has_nominal_coverage() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let normal = Normal::new(3.0, 2.0).unwrap();
        let reps = 2000;
        let mut covered = 0;
        for r in 0..reps {
            let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(r);
            let v: Vec<f64> = (0..8).map(|_| normal.sample(&mut rng)).collect();
            let ci = MeanCi::of(&v);
            if ci.ci95_low <= 3.0 && 3.0 <= ci.ci95_high {
                covered += 1;
            }
        }
        let frac = covered as f64 / reps as f64;
        assert!((frac - 0.95).abs() < 0.015, "coverage {frac}");
    }
}
