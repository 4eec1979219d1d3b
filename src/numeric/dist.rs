//! Distributions and special functions, through `statrs`: the normal distribution (density,
//! CDF, quantile, two-sided p-value), the complementary error function, Student's t (quantiles
//! and two-sided p-values) and the Wilson score interval of a binomial rate.
//!
//! Quantiles are evaluated, not read from tables, so every caller gets the same value for the
//! same degrees of freedom.

use statrs::distribution::{Continuous, ContinuousCDF, Normal, StudentsT};

fn standard_normal() -> Normal {
    Normal::standard()
}

/// The complementary error function erfc(x) = 1 − erf(x), to a relative 1e-10 also in the far
/// tail (where the p-values of large z live).
pub fn erfc(x: f64) -> f64 {
    statrs::function::erf::erfc(x)
}

/// The error function erf(x).
pub fn erf(x: f64) -> f64 {
    statrs::function::erf::erf(x)
}

/// Standard normal CDF Φ(z).
pub fn normal_cdf(z: f64) -> f64 {
    0.5 * erfc(-z * std::f64::consts::FRAC_1_SQRT_2)
}

/// Standard normal density φ(z).
#[inline]
pub fn normal_pdf(z: f64) -> f64 {
    (-0.5 * z * z).exp() * 0.398_942_280_401_432_7
}

/// The standard deviation of a standard normal censored `d` standard deviations from its mean on
/// one side (max(X, −d), as a tone curve clips noise at its black level): 1 far from the end,
/// 0.98 at d = 2, 0.87 at d = 1.
pub fn censored_normal_sd_ratio(d: f64) -> f64 {
    let tail = normal_cdf(-d);
    let mean = normal_pdf(d) - d * tail;
    let second = d * d * tail + 1.0 - tail - d * normal_pdf(d);
    (second - mean * mean).max(0.0).sqrt()
}

/// Standard normal quantile Φ⁻¹(p), p in [0, 1] (±∞ at the ends, NaN outside).
pub fn normal_quantile(p: f64) -> f64 {
    if !(0.0..=1.0).contains(&p) {
        return f64::NAN;
    }
    standard_normal().inverse_cdf(p)
}

/// Two-sided standard-normal p-value of `z`: P(|Z| ≥ |z|).
pub fn two_sided_p_normal(z: f64) -> f64 {
    erfc(z.abs() / std::f64::consts::SQRT_2).min(1.0)
}

/// Two-sided p-value of `t` under Student's t with `dof` degrees of freedom, P(|T| ≥ |t|) =
/// I_{ν/(ν+t²)}(ν/2, ½); the normal's for `dof` = ∞ or above 10⁶, and `dof` below 1 taken as 1.
/// NaN for a NaN `t`.
pub fn two_sided_p_student(t: f64, dof: f64) -> f64 {
    if !dof.is_finite() || dof > 1e6 {
        return two_sided_p_normal(t);
    }
    let dof = dof.max(1.0);
    statrs::function::beta::checked_beta_reg(0.5 * dof, 0.5, dof / (dof + t * t))
        .map_or(f64::NAN, |p| p.clamp(0.0, 1.0))
}

/// The quantile of Student's t with `dof` degrees of freedom at probability `p` in (0, 1):
/// infinite for no degree of freedom, the normal's for `dof` = ∞; NaN for `p` outside (0, 1).
///
/// `statrs`' own Student-t quantile (AS 109 on the incomplete beta) never returns for
/// ν ≥ 10⁸ and is wrong in the second digit at 10⁷, so the quantile is solved here: the
/// Cornish–Fisher expansion from 10⁵ degrees of freedom on (its error is O(ν⁻⁴), below 10⁻¹⁵
/// even 7 σ out), otherwise a bracketed Newton iteration on the exact tail P(T > u) = ½ I_{ν/(ν+u²)}(ν/2, ½),
/// which keeps relative accuracy in the far tail and always terminates.
pub fn student_t_quantile(p: f64, dof: f64) -> f64 {
    if !(p > 0.0 && p < 1.0) || dof.is_nan() {
        return f64::NAN;
    }
    if dof <= 0.0 {
        return if p >= 0.5 {
            f64::INFINITY
        } else {
            f64::NEG_INFINITY
        };
    }
    let tail = p.min(1.0 - p);
    let u = if dof.is_infinite() {
        -normal_quantile(tail)
    } else if dof >= STUDENT_T_SERIES_DOF_MIN {
        cornish_fisher_t(-normal_quantile(tail), dof)
    } else {
        upper_t_quantile(tail, dof)
    };
    if p >= 0.5 {
        u
    } else {
        -u
    }
}

/// From this many degrees of freedom on the quantile is the Cornish–Fisher series (below it the
/// incomplete beta's own accuracy, ~3e-11 relative at 10⁵, bounds the solved quantile's).
const STUDENT_T_SERIES_DOF_MIN: f64 = 1e5;

/// Student's t quantile from the normal's `z` by the Cornish–Fisher expansion in 1/ν (Abramowitz
/// & Stegun 26.7.5), to the ν⁻³ term.
fn cornish_fisher_t(z: f64, dof: f64) -> f64 {
    let z2 = z * z;
    let g1 = (z2 + 1.0) * z / 4.0;
    let g2 = ((5.0 * z2 + 16.0) * z2 + 3.0) * z / 96.0;
    let g3 = (((3.0 * z2 + 19.0) * z2 + 17.0) * z2 - 15.0) * z / 384.0;
    z + (g1 + (g2 + g3 / dof) / dof) / dof
}

/// The u ≥ 0 with P(T > u) = `tail` (0 < tail ≤ ½) for finite `dof` > 0: Newton steps kept
/// inside a bracket that halves whenever a step would leave it.
fn upper_t_quantile(tail: f64, dof: f64) -> f64 {
    if tail >= 0.5 {
        return 0.0;
    }
    let Ok(t) = StudentsT::new(0.0, 1.0, dof) else {
        return f64::NAN;
    };
    let excess = |u: f64| 0.5 * two_sided_p_student(u, dof) - tail;
    let (mut low, mut high) = (0.0_f64, 1.0_f64);
    while excess(high) > 0.0 {
        low = high;
        high *= 2.0;
        if !high.is_finite() {
            return f64::INFINITY;
        }
    }
    let mut u = cornish_fisher_t(-normal_quantile(tail), dof);
    if !(u > low && u < high) {
        u = 0.5 * (low + high);
    }
    for _ in 0..200 {
        let f = excess(u);
        if f == 0.0 {
            return u;
        }
        if f > 0.0 {
            low = u;
        } else {
            high = u;
        }
        // d/du P(T > u) = −pdf(u): the Newton step is +f/pdf.
        let mut next = u + f / t.pdf(u);
        if !(next > low && next < high) {
            next = 0.5 * (low + high);
        }
        if (next - u).abs() <= 4.0 * f64::EPSILON * next.abs() || high - low <= f64::EPSILON * high
        {
            return next;
        }
        u = next;
    }
    u
}

/// The 97.5 % quantile of Student's t with `dof` degrees of freedom: the half-width, in
/// standard errors, of a two-sided 95 % interval (infinite for 0 degrees of freedom).
pub fn t975(dof: usize) -> f64 {
    student_t_quantile(0.975, dof as f64)
}

/// The Wilson score interval of `k` successes in `n` trials at `z` standard errors (1.96 for
/// 95 %), clipped to [0, 1]; `None` for no trial.
pub fn wilson_interval(k: usize, n: usize, z: f64) -> Option<(f64, f64)> {
    if n == 0 {
        return None;
    }
    let (n, p) = (n as f64, k as f64 / n as f64);
    let d = 1.0 + z * z / n;
    let c = (p + z * z / (2.0 * n)) / d;
    let h = z * (p * (1.0 - p) / n + z * z / (4.0 * n * n)).sqrt() / d;
    Some(((c - h).max(0.0), (c + h).min(1.0)))
}

#[cfg(test)]
mod tests {

    /// Against a direct sum over a fine grid of the censored variable's density.
    #[test]
    fn censored_sd_matches_a_numeric_integral() {
        for d in [0.5, 1.0, 2.0, 3.0] {
            let (step, mut m0, mut m1, mut m2) = (1e-4, normal_cdf(-d), 0.0, 0.0);
            m1 += -d * m0;
            m2 += d * d * m0;
            let mut x = -d + step / 2.0;
            while x < 10.0 {
                let p = normal_pdf(x) * step;
                m0 += p;
                m1 += x * p;
                m2 += x * x * p;
                x += step;
            }
            let direct = (m2 / m0 - (m1 / m0).powi(2)).sqrt();
            assert!(
                (censored_normal_sd_ratio(d) - direct).abs() < 1e-6,
                "d = {d}"
            );
        }
        assert!((censored_normal_sd_ratio(40.0) - 1.0).abs() < 1e-12);
    }
    use super::*;

    fn close(got: f64, want: f64, tol: f64) {
        assert!((got - want).abs() <= tol, "{got} against {want}");
    }

    #[test]
    fn student_t_quantiles_match_tables() {
        // Two-sided 95 % (p = 0.975), to the tables' 3 decimals and beyond.
        for (dof, want) in [
            (1, 12.706_204_736),
            (2, 4.302_652_730),
            (5, 2.570_581_836),
            (10, 2.228_138_852),
            (15, 2.131_449_546),
            (30, 2.042_272_456),
            (120, 1.979_930_405),
        ] {
            close(t975(dof), want, 1e-8);
        }
        assert_eq!(t975(0), f64::INFINITY);
        // Large ν, where statrs' own quantile loses digits (reference values: the Cornish–Fisher
        // series to ν⁻⁴ in 40-digit decimal arithmetic).
        for (dof, want) in [
            (20_000, 1.960_082_605_158_135),
            (100_000, 1.959_987_707_534_61),
            (1_000_000, 1.959_966_356_814_107),
        ] {
            close(t975(dof), want, 1e-12);
        }
        close(student_t_quantile(0.025, 1e5), -1.959_987_707_534_61, 1e-12);
        close(student_t_quantile(0.025, 15.0), -2.131_449_546, 1e-8);
        close(
            student_t_quantile(0.975, f64::INFINITY),
            1.959_963_985,
            1e-8,
        );
        assert!(student_t_quantile(1.0, 3.0).is_nan());
    }

    #[test]
    fn student_t_quantiles_invert_the_tail_everywhere_and_always_return() {
        // Fractional and huge degrees of freedom, far tails on both sides: the tail at the
        // quantile gives back the probability to 5e-10 relative (the incomplete beta's own
        // accuracy in the far tail).
        for dof in [1.0, 1.5, 2.7, 8.2, 30.0, 1e3, 5e4, 1e5, 1e6] {
            for tail in [0.4, 0.025, 1e-6, 1e-12] {
                let u = student_t_quantile(1.0 - tail, dof);
                let back = 0.5 * two_sided_p_student(u, dof);
                // The tail asked for is 1 − (1 − tail), which rounds at 1e-12.
                close(back / (1.0 - (1.0 - tail)), 1.0, 5e-10);
                // Symmetric, up to 1 − tail's rounding (1e-16 / tail relative).
                let rounding = (1.0 - (1.0 - tail) - tail).abs() / tail;
                close(
                    student_t_quantile(tail, dof),
                    -u,
                    (1e-12 + 2.0 * rounding) * u,
                );
            }
        }
        // Where the series takes over it agrees with the solved tail.
        close(
            cornish_fisher_t(-normal_quantile(0.025), 1e5),
            upper_t_quantile(0.025, 1e5),
            1e-10,
        );
        // statrs' quantile returns 1.8266 at 10⁷ and never returns from 10⁸ on.
        let z = normal_quantile(0.975);
        close(
            student_t_quantile(0.975, 1e7),
            z + (z * z * z + z) / 4e7,
            1e-13,
        );
        for dof in [1e8, 1e12, usize::MAX as f64] {
            close(student_t_quantile(0.975, dof), z, 1e-7);
        }
        close(t975(usize::MAX), z, 1e-15);
    }

    #[test]
    fn normal_functions_match_known_values() {
        close(normal_cdf(1.959_963_984_540_054), 0.975, 1e-11);
        // statrs' erfc: relative error below 1e-10 (the hand-written one's was 1.2e-7).
        close(normal_cdf(-3.0) / 0.001_349_898_031_630_094_5, 1.0, 1e-10);
        close(normal_quantile(0.975), 1.959_963_984_540_054, 1e-14);
        close(normal_quantile(0.001), -3.090_232_306_167_813, 1e-13);
        assert!(normal_quantile(0.5).abs() < 1e-15);
        assert!(normal_quantile(1.5).is_nan());
        close(normal_pdf(0.0), 0.398_942_280_401_432_7, 0.0);
        close(two_sided_p_normal(1.959_963_984_540_054), 0.05, 1e-10);
        // Far tail: relative accuracy (6 σ and 20 σ).
        close(
            two_sided_p_normal(6.0) / 1.973_175_290_075_19e-9,
            1.0,
            1e-10,
        );
        close(
            erfc(20.0 / std::f64::consts::SQRT_2) / 5.507_248_237_212_467e-89,
            1.0,
            1e-9,
        );
    }

    #[test]
    fn student_p_values_match_tables() {
        for (t, dof, p) in [
            (2.228_138_852, 10.0, 0.05),
            (12.706_204_736, 1.0, 0.05),
            (2.131_449_546, 15.0, 0.05),
            (3.182_446_305, 3.0, 0.05),
        ] {
            close(two_sided_p_student(t, dof), p, 1e-9);
        }
        close(
            two_sided_p_student(2.0, 1e7),
            two_sided_p_normal(2.0),
            1e-12,
        );
        assert_eq!(two_sided_p_student(0.0, 4.0), 1.0);
        assert!(two_sided_p_student(f64::NAN, 4.0).is_nan());
    }

    #[test]
    fn wilson_interval_contains_the_rate_and_shrinks_with_n() {
        assert_eq!(wilson_interval(0, 0, 1.96), None);
        let (lo, hi) = wilson_interval(1, 96, 1.96).unwrap();
        close(lo, 0.001_841_2, 1e-6);
        close(hi, 0.056_667_6, 1e-6);
        let (lo2, hi2) = wilson_interval(10, 960, 1.96).unwrap();
        assert!(lo2 > lo && hi2 < hi);
        assert_eq!(wilson_interval(5, 5, 1.96).unwrap().1, 1.0);
    }
}
