//! The fit's own noise (pure): what fits of the same candidate on fresh simulation seeds say
//! about the first fit, and the value and uncertainty they give together.
//!
//! A candidate's parameters are fitted on a few simulation seeds (the fit seeds), and the
//! uncertainty the fit states is the curvature of its χ², whose z-scores divide by the spread of
//! those few seeds. With 2 or 3 seeds that spread is itself a rough draw, and the minimum moves
//! with the seeds' realisation: on one footage of a 0.5 mm clearance, fits on five sets of 3
//! fit seeds gave 0.465–0.529 mm (spread 0.024) while each stated ± 0.009–0.043, and the
//! self-check's fixed pair of fit seeds gave 0.434 ± 0.010 on three data seeds alike
//! (commit `8b8b8cf`); a drive speed of −0.150 fitted at −0.137, −0.141, −0.153, −0.140 and
//! −0.156 on five sets (commit `e8f8692`).
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
//!
//! That curvature undercounts the footage's noise when the signature's cells move together (a
//! camera shake's per-band powers in the centre track, the angle and the corners are one draw of
//! the shake, yet χ² counts each cell as its own): on four footages of a 1 px shake the stated
//! value spread 2.3× the stated ± (commit `bcab0e1`). The footage's noise is then
//! measured as it is meant: B footages simulated at the stated values on fresh data seeds, each
//! fitted as the real one was, on the same fit seeds ([`from_footage_fits`]); their mean also
//! shows the fit's bias at the stated value, which is taken off when it is significant.

use crate::numeric::robust;

/// One effect's parameters fitted on disjoint seed sets, pooled. `first` is the first fit's
/// (values, σ) and `refits` each refit's, all in the effect's parameter order. Per parameter:
/// the mean of the fits' values, with σ = √(mean σᵢ² + s²/n) (module docs). A parameter the
/// first fit does not determine (σ infinite or not a number) keeps the first fit's value and
/// σ; a refit whose value or σ for it is not finite is left out of that parameter's pool (a
/// fit that could not determine it says nothing of the seed noise); with no refit left, the
/// first fit's value and σ stand.
pub fn pooled(first: (&[f64], &[f64]), refits: &[(&[f64], &[f64])]) -> (Vec<f64>, Vec<f64>) {
    pools(first, refits)
        .into_iter()
        .map(|p| (p.value, p.std))
        .unzip()
}

/// One parameter's pool ([`pooled`]): the value and σ stated, and the part of σ² the spread
/// of the fits gives (s²/n) with its degrees of freedom (n − 1), what a coverage factor needs
/// ([`interval95`]); 0 and no degrees of freedom when nothing was pooled.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pool {
    pub value: f64,
    pub std: f64,
    /// s²/n of the n fits pooled (0 when fewer than two).
    pub seed_var: f64,
    /// n − 1 (0 when fewer than two fits were pooled).
    pub seed_dof: usize,
}

/// [`pooled`], per parameter, with what each pool's σ² owes to the fits' spread.
pub fn pools(first: (&[f64], &[f64]), refits: &[(&[f64], &[f64])]) -> Vec<Pool> {
    let (values, stds) = first;
    values
        .iter()
        .zip(stds)
        .enumerate()
        .map(|(i, (&v1, &s1))| {
            let alone = Pool {
                value: v1,
                std: s1,
                seed_var: 0.0,
                seed_dof: 0,
            };
            if !(s1.is_finite() && v1.is_finite()) {
                return alone;
            }
            let fits: Vec<(f64, f64)> = std::iter::once((v1, s1))
                .chain(refits.iter().filter_map(|(v, s)| {
                    let (v, s) = (*v.get(i)?, *s.get(i)?);
                    (v.is_finite() && s.is_finite()).then_some((v, s))
                }))
                .collect();
            if fits.len() < 2 {
                return alone;
            }
            let n = fits.len() as f64;
            let values: Vec<f64> = fits.iter().map(|f| f.0).collect();
            let mean = robust::mean(&values);
            let seed_var = robust::sample_variance(&values);
            let curvature_var = fits.iter().map(|f| f.1 * f.1).sum::<f64>() / n;
            Pool {
                value: mean,
                std: (curvature_var + seed_var / n).sqrt(),
                seed_var: seed_var / n,
                seed_dof: fits.len() - 1,
            }
        })
        .collect()
}

/// What fits on footages simulated at a stated value say about it ([`from_footage_fits`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FootageFits {
    /// Sample sd of the footage fits: the footage's noise of one fit.
    pub spread: f64,
    /// Their mean minus the value they were simulated at: the fit's bias there.
    pub bias: f64,
    /// The bias's standard error, spread / √B.
    pub bias_std: f64,
    /// Two-sided Student-t p-value of the bias (B − 1 degrees of freedom).
    pub bias_p: f64,
    /// The value to state: the stated one, less the bias when it is significant.
    pub value: f64,
    /// Its σ: the stated σ widened by the spread beyond the curvature's, and by the bias's
    /// standard error when the bias was taken off.
    pub std: f64,
    /// The part of `std`² the footages estimate, on `footages − 1` degrees of freedom
    /// ([`interval95`]): s_b² where they widened the σ (σ'² = σ² − c² + s_b², so the
    /// curvature's c² is replaced by their spread, not added to), plus the bias's s_b²/B when
    /// it was taken off; 0 when neither.
    pub estimated_var: f64,
    /// The finite footage fits it stands on, B.
    pub footages: usize,
    /// How many of them stopped at an end of the parameter's search: a fit clamped there says
    /// only that the footage asked for at least (or at most) that much, so their spread and
    /// mean bound the footage's noise and the fit's bias instead of measuring them, and no
    /// bias is taken off.
    pub at_search_end: usize,
}

/// Significance level at which a bias the footage fits show is taken off the stated value:
/// with B − 1 degrees of freedom the t test asks much of a few footages (12.7 standard errors
/// at B = 2, 3.2 at B = 4), so only a bias well beyond their spread moves a value.
pub const BIAS_P: f64 = 0.05;

/// Footage fits within this fraction of |value| + σ of each other and of the value reproduced
/// it: they differ by the floating-point rounding of the fit, not by any noise of the footage.
/// A parameter fitted from data every simulated footage shares with the real one (the frame
/// timing, from the timestamps at which every footage is simulated) comes back so, and a t
/// test on rounding calls it biased (7e-18 over a spread of 4e-18: p 0.001).
pub const REPRODUCED_REL: f64 = 1e-9;

/// A stated value and σ once B fits of footages simulated at that value (`footage_values`, on
/// fresh data seeds, the same fit seeds) are known. Their sample variance s_b² (B − 1 degrees
/// of freedom) is the footage's noise of one fit, which the stated σ held as the fits' mean
/// curvature variance c² (`curvature_stds`, the σ of the fits pooled into it): where s_b²
/// exceeds c² the difference is added, σ' = √(σ² + s_b² − c²), never narrowed (with B this
/// small, a spread below the curvature's is as likely the draw's luck). Their mean minus the
/// value is the fit's bias there (the bootstrap's bias estimate); when a t test finds it at
/// p < [`BIAS_P`], the value stated is the bias-corrected one, value − bias, with the bias's
/// standard error s_b/√B added to σ' in quadrature, unless the corrected value leaves `valid`
/// (the values the parameter can take), or a footage fit stopped at an end of `search` (the
/// range the fit searched): three fits of a 15.9 ms exposure all clamped at a 60 fps rig's
/// 16.7 ms frame interval gave a spread of 0 and a "bias" of 0.76 ms at p = 0, which a t test
/// on a spread it cannot see would take off. Footages that reproduce the value to rounding
/// ([`REPRODUCED_REL`]) state a spread and a bias of exactly 0: nothing to widen, no bias to
/// test. `None` when fewer than two footage values are finite or the value or σ is not (a
/// parameter the fit did not determine).
pub fn from_footage_fits(
    value: f64,
    stated_std: f64,
    curvature_stds: &[f64],
    footage_values: &[f64],
    valid: (f64, f64),
    search: (f64, f64),
) -> Option<FootageFits> {
    if !(stated_std.is_finite() && value.is_finite()) {
        return None;
    }
    let values: Vec<f64> = footage_values
        .iter()
        .copied()
        .filter(|v| v.is_finite())
        .collect();
    if values.len() < 2 {
        return None;
    }
    let n = values.len() as f64;
    let mean = robust::mean(&values);
    let rounding = REPRODUCED_REL * (value.abs() + stated_std);
    let footage_var = robust::sample_variance(&values);
    let footage_var = if footage_var.sqrt() <= rounding {
        0.0
    } else {
        footage_var
    };
    let curv: Vec<f64> = curvature_stds
        .iter()
        .copied()
        .filter(|s| s.is_finite())
        .collect();
    let curvature_var = if curv.is_empty() {
        0.0
    } else {
        curv.iter().map(|s| s * s).sum::<f64>() / curv.len() as f64
    };
    let widened_var = stated_std * stated_std + (footage_var - curvature_var).max(0.0);
    let bias = if (mean - value).abs() <= rounding {
        0.0
    } else {
        mean - value
    };
    let bias_std = (footage_var / n).sqrt();
    let bias_p = if bias_std > 0.0 {
        crate::numeric::dist::two_sided_p_student(bias / bias_std, n - 1.0)
    } else if bias == 0.0 {
        1.0
    } else {
        0.0
    };
    let at_search_end = values
        .iter()
        .filter(|&&v| {
            let tol = REPRODUCED_REL * (v.abs() + stated_std);
            (v - search.0).abs() <= tol || (v - search.1).abs() <= tol
        })
        .count();
    let corrected =
        at_search_end == 0 && bias_p < BIAS_P && (valid.0..=valid.1).contains(&(value - bias));
    let estimated_var = if footage_var > curvature_var {
        footage_var
    } else {
        0.0
    } + if corrected { bias_std * bias_std } else { 0.0 };
    Some(FootageFits {
        spread: footage_var.sqrt(),
        bias,
        bias_std,
        bias_p,
        value: if corrected { value - bias } else { value },
        std: if corrected {
            (widened_var + bias_std * bias_std).sqrt()
        } else {
            widened_var.sqrt()
        },
        estimated_var,
        footages: values.len(),
        at_search_end,
    })
}

/// ν truncated to the integer below (GUM G.4.1), at least 1. A σ² that is all one part on ν
/// degrees of freedom gives ν back only to rounding (6.999…), which must not lose a degree.
pub fn truncated_dof(dof: f64) -> usize {
    ((dof * (1.0 + 1e-9)).floor() as usize).max(1)
}

/// A stated value's two-sided 95 % interval ([`interval95`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Interval95 {
    pub low: f64,
    pub high: f64,
    /// Effective degrees of freedom of the σ (Welch–Satterthwaite); infinite when no part of
    /// it was estimated from a few draws.
    pub dof: f64,
    /// The coverage factor k: Student's t₀.₉₇₅ on `dof` truncated to an integer (1.96 when
    /// infinite), so the interval is value ± k·σ before clipping.
    pub k: f64,
    /// The interval was cut at an end of the values the parameter can take.
    pub clipped: bool,
}

/// The 95 % interval of a stated value and σ whose σ² holds parts estimated from a few draws
/// (`estimated`: each part's variance and degrees of freedom: the refits' spread s²/n on n − 1,
/// the footages' spread on B − 1; the rest of σ², the fits' curvature, counts as known).
///
/// A σ estimated on ν degrees of freedom makes (value − truth)/σ a Student t on ν, not a
/// normal: at B = 8 footages the camera shakes' RMS error/± was 1.17, what t₇ gives
/// (√(7/5) = 1.18; commit `590513e`), so a ±1.96σ interval covers less than
/// 95 %. The degrees of freedom of a σ² that sums such parts are Welch–Satterthwaite's,
/// ν = σ⁴ / Σ(uᵢ⁴/νᵢ), truncated to the integer below as the GUM (G.4.1) asks, and k is
/// Student's t₀.₉₇₅ on it. The interval is clipped to `valid`. `None` when the value or σ is not
/// finite (a parameter the fit did not determine).
pub fn interval95(
    value: f64,
    std: f64,
    estimated: &[(f64, usize)],
    valid: (f64, f64),
) -> Option<Interval95> {
    if !(value.is_finite() && std.is_finite()) {
        return None;
    }
    let var = std * std;
    let denominator: f64 = estimated
        .iter()
        .filter(|(u2, _)| *u2 > 0.0)
        .map(|&(u2, dof)| {
            if dof == 0 {
                f64::INFINITY
            } else {
                u2 * u2 / dof as f64
            }
        })
        .sum();
    let dof = if denominator > 0.0 {
        var * var / denominator
    } else {
        f64::INFINITY
    };
    let k = if dof.is_finite() {
        crate::numeric::dist::t975(truncated_dof(dof))
    } else {
        1.959964
    };
    let (low, high) = (value - k * std, value + k * std);
    let (low_c, high_c) = (low.max(valid.0), high.min(valid.1));
    Some(Interval95 {
        low: low_c,
        high: high_c,
        dof,
        k,
        clipped: low_c != low || high_c != high,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    const ANY: (f64, f64) = (f64::NEG_INFINITY, f64::INFINITY);

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
        // The spread's part of σ², with its degrees of freedom, for the interval.
        let p = pools(
            (&[0.43, 1.0], &[0.01, f64::NAN]),
            &[(&[0.50, 1.0], &[0.02, 0.1]), (&[0.48, 1.0], &[0.02, 0.1])],
        );
        assert!(
            close(p[0].seed_var, 0.0013 / 3.0) && p[0].seed_dof == 2,
            "{p:?}"
        );
        assert!(close(p[0].std, s[0]) && close(p[0].value, 0.47), "{p:?}");
        // Undetermined by the first fit: nothing pooled, nothing estimated.
        assert_eq!((p[1].seed_var, p[1].seed_dof), (0.0, 0), "{p:?}");
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

    #[test]
    fn a_footage_spread_beyond_the_curvature_widens_the_stated_sigma_by_the_difference() {
        // Footage fits 0.83, 1.03, 1.23 of a value 1.03: s_b² = (0.2² + 0 + 0.2²)/2 = 0.04, no
        // bias; curvature σ 0.05 and 0.05 (c² = 0.0025); stated 0.06.
        let f =
            from_footage_fits(1.03, 0.06, &[0.05, 0.05], &[0.83, 1.03, 1.23], ANY, ANY).unwrap();
        assert!(close(f.spread, 0.2), "{f:?}");
        assert!(f.bias.abs() < 1e-12 && f.bias_p > 0.99, "{f:?}");
        assert_eq!(f.value, 1.03);
        assert!(close(f.std, (0.0036f64 + 0.04 - 0.0025).sqrt()), "{f:?}");
        // σ'² = 0.0036 − 0.0025 + 0.04: the footages' spread replaced the curvature's, and all
        // of it is their estimate.
        assert!(close(f.estimated_var, 0.04) && f.footages == 3, "{f:?}");
        // A spread below the curvature's never narrows the stated σ.
        let f = from_footage_fits(1.005, 0.06, &[0.05], &[1.0, 1.01], ANY, ANY).unwrap();
        assert!(f.spread < 0.05);
        assert_eq!((f.value, f.std, f.estimated_var), (1.005, 0.06, 0.0));
        // Non-finite footage fits and curvature σ are left out.
        let f =
            from_footage_fits(1.1, 0.1, &[f64::INFINITY], &[1.0, f64::NAN, 1.2], ANY, ANY).unwrap();
        assert!(close(f.spread, 0.02f64.sqrt()), "{f:?}");
    }

    #[test]
    fn footages_that_give_the_value_back_to_rounding_have_no_spread_and_no_bias() {
        // The frame timing's fits on footages simulated at this footage's timestamps: the
        // same value but for the last bit of some. Before, a 4e-17 bias over a 3e-17 spread
        // was "significant" and taken off.
        let value = 0.3f64;
        let next = f64::from_bits(value.to_bits() + 1);
        let f = from_footage_fits(value, 0.011, &[0.011], &[next, next, value, next], ANY, ANY)
            .unwrap();
        assert_eq!(
            (f.spread, f.bias, f.bias_std, f.bias_p),
            (0.0, 0.0, 0.0, 1.0),
            "{f:?}"
        );
        assert_eq!((f.value, f.std), (value, 0.011), "{f:?}");
        // A bias every footage shows alike is no rounding: taken off, exactly known.
        let f = from_footage_fits(value, 0.011, &[0.011], &[0.35, 0.35, 0.35], ANY, ANY).unwrap();
        assert_eq!(
            (f.spread, f.bias_p, f.at_search_end),
            (0.0, 0.0, 0),
            "{f:?}"
        );
        assert!(close(f.value, 0.25) && close(f.std, 0.011), "{f:?}");
        // The same fits stopped at the search's end bound the bias, not measure it: the value
        // stands (a 15.9 ms exposure's three footage fits all stopped at a 60 fps rig's 16.7 ms
        // frame interval).
        let f = from_footage_fits(
            value,
            0.011,
            &[0.011],
            &[0.35, 0.35, 0.35],
            ANY,
            (0.01, 0.35),
        )
        .unwrap();
        assert_eq!(
            (f.at_search_end, f.value, f.std),
            (3, value, 0.011),
            "{f:?}"
        );
        let exposure = from_footage_fits(
            0.0159,
            0.00126,
            &[0.00126],
            &[1.0 / 60.0; 3],
            (0.0, 1.0),
            (1e-4, 1.0 / 60.0),
        )
        .unwrap();
        assert_eq!((exposure.at_search_end, exposure.value), (3, 0.0159));
        // One fit at the lower end is enough to withhold the correction.
        let f =
            from_footage_fits(0.3, 0.011, &[0.011], &[0.35, 0.35, 0.01], ANY, (0.01, 1.0)).unwrap();
        assert_eq!((f.at_search_end, f.value), (1, 0.3));
        // A real spread, however small against the value, is kept.
        let f = from_footage_fits(1.0, 1e-6, &[1e-6], &[1.0 - 1e-6, 1.0 + 1e-6], ANY, ANY).unwrap();
        assert!(
            (f.spread / (2f64.sqrt() * 1e-6) - 1.0).abs() < 1e-6,
            "{f:?}"
        );
    }

    #[test]
    fn a_bias_well_beyond_the_footage_spread_is_taken_off_with_its_standard_error() {
        // Four footages simulated at 1.74 fit 1.45 ± 0.03: a bias of −0.29, t ≈ −22 on 3
        // degrees of freedom. The value stated is 1.74 + 0.29 = 2.03.
        let fits = [1.42, 1.48, 1.44, 1.46];
        let f = from_footage_fits(1.74, 0.05, &[0.05], &fits, ANY, ANY).unwrap();
        let sd = ((0.03f64.powi(2) + 0.03f64.powi(2) + 0.01f64.powi(2) * 2.0) / 3.0).sqrt();
        assert!(close(f.bias, -0.29), "{f:?}");
        assert!(close(f.bias_std, sd / 2.0), "{f:?}");
        assert!(f.bias_p < BIAS_P, "{f:?}");
        assert!(close(f.value, 2.03), "{f:?}");
        assert!(close(f.std, (0.0025f64 + sd * sd / 4.0).sqrt()), "{f:?}");
        // The spread is below the curvature's: only the bias's standard error was added.
        assert!(
            close(f.estimated_var, sd * sd / 4.0) && f.footages == 4,
            "{f:?}"
        );
        // The same bias from two footages that disagree is not significant: nothing moves.
        let f = from_footage_fits(1.74, 0.05, &[0.05], &[1.30, 1.60], ANY, ANY).unwrap();
        assert!(f.bias_p > BIAS_P, "{f:?}");
        assert_eq!(f.value, 1.74);
        // A correction that would leave the parameter's valid values is not taken.
        let f = from_footage_fits(1.74, 0.05, &[0.05], &fits, (0.0, 2.0), ANY).unwrap();
        assert!(f.bias_p < BIAS_P, "{f:?}");
        assert_eq!(f.value, 1.74);
    }

    #[test]
    fn without_two_footage_fits_or_a_determined_value_nothing_is_stated() {
        assert_eq!(from_footage_fits(1.0, 0.1, &[0.1], &[1.0], ANY, ANY), None);
        assert_eq!(
            from_footage_fits(1.0, 0.1, &[0.1], &[1.0, f64::NAN], ANY, ANY),
            None
        );
        assert_eq!(
            from_footage_fits(1.0, f64::INFINITY, &[0.1], &[1.0, 2.0], ANY, ANY),
            None
        );
        assert_eq!(
            from_footage_fits(f64::NAN, 0.1, &[0.1], &[1.0, 2.0], ANY, ANY),
            None
        );
    }

    #[test]
    fn an_interval_on_a_sigma_of_few_draws_uses_students_t_on_its_welch_satterthwaite_dof() {
        // Nothing estimated from a few draws: the normal's 1.96.
        let i = interval95(1.0, 0.1, &[], ANY).unwrap();
        assert!(
            i.dof.is_infinite() && i.k == 1.959964 && !i.clipped,
            "{i:?}"
        );
        assert!(
            close(i.low, 1.0 - 0.1959964) && close(i.high, 1.0 + 0.1959964),
            "{i:?}"
        );
        // A σ² that is one part on 7 but for rounding keeps its 7 degrees of freedom.
        let sd = 0.1f64;
        let i = interval95(1.0, sd, &[(sd * sd * (1.0 + 3e-16), 7)], ANY).unwrap();
        let t = crate::numeric::dist::t975;
        assert!(i.dof < 7.0 && i.k == t(7), "{i:?}");
        // All of σ² from 8 footages: t on 7, 2.365.
        let i = interval95(1.0, 0.1, &[(0.01, 7)], ANY).unwrap();
        assert!(close(i.dof, 7.0) && i.k == t(7), "{i:?}");
        // Two parts of 1 on 2 and 7: ν = 2² / (1/2 + 1/7) = 6.22, truncated to 6: 2.447.
        let i = interval95(0.0, 2f64.sqrt(), &[(1.0, 2), (1.0, 7)], ANY).unwrap();
        assert!(
            close(i.dof, 4.0 / (0.5 + 1.0 / 7.0)) && i.k == t(6),
            "{i:?}"
        );
        // A part of σ² that is small leaves it near the normal: ν = 1/(0.01²/2) = 20000.
        let i = interval95(0.0, 1.0, &[(0.01, 2)], ANY).unwrap();
        assert!(i.dof > 1e4 && (i.k - 1.96).abs() < 1e-3, "{i:?}");
        // Cut at the values the parameter can take, and said so.
        let i = interval95(0.0227, 0.015, &[], (0.0, 1.0)).unwrap();
        assert!(i.low == 0.0 && i.clipped && close(i.high, 0.0227 + 1.959964 * 0.015));
        assert_eq!(interval95(f64::NAN, 0.1, &[], ANY), None);
        assert_eq!(interval95(1.0, f64::INFINITY, &[], ANY), None);
    }

    /// Coverage: a value drawn about the truth, its σ estimated from 8 other draws (7 degrees of
    /// freedom), as the bootstrap estimates it. The t interval covers the truth 95 % of the time
    /// (±1 % is over 3 binomial standard errors at 4000 repetitions); ±1.96σ would cover 91 %.
    #[test]
    fn the_interval_covers_the_truth_95_percent_of_the_time_when_its_sigma_is_a_sample_sd() {
        use rand::SeedableRng;
        use rand_distr::{Distribution, Normal};
        let normal = Normal::new(3.0, 2.0).unwrap();
        let reps = 4000;
        let (mut covered, mut covered_normal) = (0, 0);
        for r in 0..reps {
            let mut rng = rand_pcg::Pcg64Mcg::seed_from_u64(r);
            let value = normal.sample(&mut rng);
            let draws: Vec<f64> = (0..8).map(|_| normal.sample(&mut rng)).collect();
            let mean = draws.iter().sum::<f64>() / 8.0;
            let var = draws.iter().map(|d| (d - mean).powi(2)).sum::<f64>() / 7.0;
            let i = interval95(value, var.sqrt(), &[(var, 7)], ANY).unwrap();
            covered += usize::from(i.low <= 3.0 && 3.0 <= i.high);
            covered_normal += usize::from((value - 3.0).abs() <= 1.959964 * var.sqrt());
        }
        let rate = covered as f64 / reps as f64;
        let rate_normal = covered_normal as f64 / reps as f64;
        assert!((rate - 0.95).abs() < 0.01, "{rate}");
        assert!(rate_normal < 0.93, "{rate_normal}");
    }
}
