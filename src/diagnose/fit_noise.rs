//! The fit's own noise (pure): what a second fit of the same candidate on fresh simulation seeds
//! says about the uncertainty of the first.
//!
//! A candidate's parameters are fitted on a few simulation seeds (the fit seeds), and the
//! uncertainty the fit states is the curvature of its χ², whose z-scores divide by the spread of
//! those few seeds. With 2 or 3 seeds that spread is itself a rough draw, and the minimum moves
//! with the seeds' realisation: on one footage of a 0.5 mm clearance, fits on five sets of 3
//! fit seeds gave 0.465–0.529 mm (spread 0.024) while each stated ± 0.009–0.043, and the
//! self-check's fixed pair of fit seeds gave 0.434 ± 0.010 on three data seeds alike
//! (`reports/diagnosis-stop38/`). The noise a seed set adds is measured directly: the same
//! candidate refitted on a disjoint set differs from the first fit by the difference of two
//! independent draws of it, so |v₁ − v₂|/√2 estimates one fit's seed noise (one degree of
//! freedom: a rough but unbiased variance), added in quadrature to the stated ±. The fitted
//! value stays the first fit's: it is the one the candidate was judged with.

/// The first fit's standard uncertainties widened by the seed noise a second fit on disjoint
/// seeds shows: √(σᵢ² + (v₁ᵢ − v₂ᵢ)²/2). A parameter the data do not determine (σ infinite or
/// not a number) keeps its σ; a pair of values that is not finite leaves σ as it was.
pub fn widened_stds(stds: &[f64], first: &[f64], second: &[f64]) -> Vec<f64> {
    stds.iter()
        .enumerate()
        .map(|(i, &s)| {
            let (Some(&a), Some(&b)) = (first.get(i), second.get(i)) else {
                return s;
            };
            if !s.is_finite() || !(a - b).is_finite() {
                return s;
            }
            s.hypot((a - b) / std::f64::consts::SQRT_2)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_difference_of_two_fits_widens_the_stated_uncertainty() {
        // 0.01 stated, fits 0.43 and 0.50: seed noise 0.07/√2 ≈ 0.0495.
        let w = widened_stds(&[0.01], &[0.43], &[0.50]);
        assert!((w[0] - 0.01f64.hypot(0.07 / 2f64.sqrt())).abs() < 1e-15);
        assert!(w[0] > 0.049 && w[0] < 0.051, "{w:?}");
    }

    #[test]
    fn agreement_undetermined_parameters_and_missing_values_change_nothing() {
        assert_eq!(widened_stds(&[0.02], &[1.5], &[1.5]), vec![0.02]);
        let w = widened_stds(&[f64::INFINITY, 0.1], &[1.0, 2.0], &[3.0, 2.0]);
        assert!(w[0].is_infinite());
        assert_eq!(w[1], 0.1);
        assert_eq!(widened_stds(&[0.1, 0.2], &[1.0], &[]), vec![0.1, 0.2]);
        assert_eq!(widened_stds(&[0.1], &[1.0], &[f64::NAN]), vec![0.1]);
        // A zero stated uncertainty (a claimed exact value) gets the seed noise alone.
        let w = widened_stds(&[0.0], &[1.0], &[1.0 + 2f64.sqrt()]);
        assert!((w[0] - 1.0).abs() < 1e-12, "{w:?}");
    }
}
