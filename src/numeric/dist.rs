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
    if dof.is_infinite() {
        return normal_quantile(p);
    }
    let Ok(t) = StudentsT::new(0.0, 1.0, dof) else {
        return f64::NAN;
    };
    let x = t.inverse_cdf(p);
    if dof <= STATRS_T_QUANTILE_DOF_MAX {
        return x;
    }
    // Newton steps on the tail P(T > |x|) = ½ I_{ν/(ν+x²)}(ν/2, ½), which keeps its relative
    // accuracy where the CDF's difference to p cancels.
    let tail = p.min(1.0 - p);
    let mut u = x.abs();
    for _ in 0..6 {
        let step = (0.5 * two_sided_p_student(u, dof) - tail) / t.pdf(u);
        u += step;
        if step.abs() <= 1e-15 * u.abs() {
            break;
        }
    }
    if p >= 0.5 {
        u
    } else {
        -u
    }
}

/// Up to this many degrees of freedom `statrs`' Student-t quantile is accurate to ~1e-13
/// (measured); beyond, it loses digits (7e-6 at 10⁵, 1.2e-4 at 10⁶) and is refined.
const STATRS_T_QUANTILE_DOF_MAX: f64 = 1e4;

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
        // Beyond statrs' accurate range: refined to the tail's accuracy.
        for (dof, want) in [(20_000, 1.960_082_605_159), (100_000, 1.959_987_707_502)] {
            close(t975(dof), want, 1e-11);
        }
        close(t975(1_000_000), 1.959_966_356_98, 1e-10);
        close(student_t_quantile(0.025, 1e5), -1.959_987_707_502, 1e-11);
        close(student_t_quantile(0.025, 15.0), -2.131_449_546, 1e-8);
        close(
            student_t_quantile(0.975, f64::INFINITY),
            1.959_963_985,
            1e-8,
        );
        assert!(student_t_quantile(1.0, 3.0).is_nan());
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
