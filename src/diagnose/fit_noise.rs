//! The fit's own noise (pure): what fits of the same candidate on fresh simulation seeds say
//! about the first fit, and the value and uncertainty they give together.
//!
//! A candidate's parameters are fitted on a few simulation seeds (the fit seeds), and the
//! uncertainty the fit states is the curvature of its χ², whose z-scores divide by the spread of
//! those few seeds. With 2 or 3 seeds that spread is itself a rough draw, and the minimum moves
//! with the seeds' realisation: on one footage of a 0.5 mm clearance, fits on five sets of 3
//! fit seeds gave 0.465–0.529 mm (spread 0.024) while each stated ± 0.009–0.043, and the
//! self-check's fixed pair of fit seeds gave 0.434 ± 0.010 on three data seeds alike
//! (`reports/diagnosis-stop38/`); a drive speed of −0.150 fitted at −0.137, −0.141, −0.153,
//! −0.140 and −0.156 on five sets (`reports/diagnosis-stop39/`).
//!
//! The noise a seed set adds is measured directly: the candidate is fitted again on R sets
//! of fresh seeds, disjoint from the first fit's and from each other's, so the n = R + 1 fits
//! are n independent draws of it on the same footage. Their sample variance s² (n − 1 degrees
//! of freedom; a single refit's (v₁ − v₂)²/2 had one, and understated the drive speed's seed
//! noise about twofold) is the seed noise of one fit, and their mean has s²/n of it. The
//! footage's own noise is what each fit's curvature states, and it is the same footage for
//! all, so averaging does not reduce it: its variance is taken as the mean of the fits' σ²
//! (each one a rough draw, their mean less so). The pooled value is the mean, with
//! σ = √(mean σᵢ² + s²/n).

/// One effect's parameters fitted on disjoint seed sets, pooled. `first` is the first fit's
/// (values, σ) and `refits` each refit's, all in the effect's parameter order. Per parameter:
/// the mean of the fits' values, with σ = √(mean σᵢ² + s²/n) (module docs). A parameter the
/// first fit does not determine (σ infinite or not a number) keeps the first fit's value and
/// σ; a refit whose value or σ for it is not finite is left out of that parameter's pool (a
/// fit that could not determine it says nothing of the seed noise); with no refit left, the
/// first fit's value and σ stand.
pub fn pooled(first: (&[f64], &[f64]), refits: &[(&[f64], &[f64])]) -> (Vec<f64>, Vec<f64>) {
    let (values, stds) = first;
    values
        .iter()
        .zip(stds)
        .enumerate()
        .map(|(i, (&v1, &s1))| {
            if !(s1.is_finite() && v1.is_finite()) {
                return (v1, s1);
            }
            let fits: Vec<(f64, f64)> = std::iter::once((v1, s1))
                .chain(refits.iter().filter_map(|(v, s)| {
                    let (v, s) = (*v.get(i)?, *s.get(i)?);
                    (v.is_finite() && s.is_finite()).then_some((v, s))
                }))
                .collect();
            if fits.len() < 2 {
                return (v1, s1);
            }
            let n = fits.len() as f64;
            let mean = fits.iter().map(|f| f.0).sum::<f64>() / n;
            let seed_var = fits.iter().map(|f| (f.0 - mean).powi(2)).sum::<f64>() / (n - 1.0);
            let curvature_var = fits.iter().map(|f| f.1 * f.1).sum::<f64>() / n;
            (mean, (curvature_var + seed_var / n).sqrt())
        })
        .unzip()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn close(a: f64, b: f64) -> bool {
        (a - b).abs() <= 1e-12 * b.abs().max(1e-300)
    }

    #[test]
    fn three_fits_give_their_mean_with_the_footages_and_the_means_seed_noise() {
        // σ 0.01, 0.02, 0.02 (mean σ² 0.0003); values 0.43, 0.50, 0.48: mean 0.47,
        // s² = (0.04² + 0.03² + 0.01²)/2 = 0.0013, of the mean 0.0013/3.
        let (v, s) = pooled(
            (&[0.43], &[0.01]),
            &[(&[0.50], &[0.02]), (&[0.48], &[0.02])],
        );
        assert!(close(v[0], 0.47), "{v:?}");
        assert!(close(s[0], (0.0003f64 + 0.0013 / 3.0).sqrt()), "{s:?}");
        // Two fits: the mean, with half the one-degree-of-freedom variance (v₁ − v₂)²/2.
        let (v, s) = pooled((&[0.43], &[0.01]), &[(&[0.50], &[0.03])]);
        assert!(close(v[0], 0.465), "{v:?}");
        let want = ((0.01f64.powi(2) + 0.03f64.powi(2)) / 2.0 + 0.07f64.powi(2) / 4.0).sqrt();
        assert!(close(s[0], want), "{s:?}");
    }

    #[test]
    fn more_fits_that_agree_state_a_smaller_seed_noise() {
        let one = pooled((&[1.0], &[0.0]), &[(&[1.2], &[0.0])]).1[0];
        let two = pooled((&[1.0], &[0.0]), &[(&[1.2], &[0.0]), (&[1.1], &[0.0])]).1[0];
        assert!(two < one, "{one} {two}");
        // Identical fits add no seed noise: the footage's σ alone.
        let (v, s) = pooled((&[2.0], &[0.1]), &[(&[2.0], &[0.1]), (&[2.0], &[0.1])]);
        assert_eq!(v[0], 2.0);
        assert!(close(s[0], 0.1), "{s:?}");
    }

    #[test]
    fn undetermined_parameters_and_unfit_refits_are_left_as_the_first_fit_stated_them() {
        // The first fit does not determine the parameter: value and σ stay.
        let (v, s) = pooled((&[1.0], &[f64::INFINITY]), &[(&[3.0], &[0.1])]);
        assert_eq!(v[0], 1.0);
        assert!(s[0].is_infinite());
        // A refit that does not determine it (or lost it) is left out of that parameter's pool.
        let (v, s) = pooled(
            (&[1.0, 2.0], &[0.1, 0.2]),
            &[(&[f64::NAN, 4.0], &[0.1, 0.2]), (&[1.0], &[f64::INFINITY])],
        );
        assert_eq!((v[0], s[0]), (1.0, 0.1));
        assert!(close(v[1], 3.0), "{v:?}");
        assert!(close(s[1], (0.04f64 + 2.0 / 2.0).sqrt()), "{s:?}");
        // No refit: the first fit's.
        assert_eq!(pooled((&[0.5], &[0.0]), &[]), (vec![0.5], vec![0.0]));
    }
}
