//! Location and scale of samples: mean, sample variance and standard deviation, the RMS of the
//! finite values, medians (the
//! mean of the two middle values, and the upper one), the median absolute deviation, and
//! numpy-style percentiles.
//!
//! Every function reads its values in order, so the same values give the same bits.

/// Scale of the MAD to the standard deviation of normal data (1 / Φ⁻¹(3/4), rounded as used).
pub const MAD_TO_SD: f64 = 1.4826;

/// Arithmetic mean (NaN for no values).
pub fn mean(xs: &[f64]) -> f64 {
    xs.iter().sum::<f64>() / xs.len() as f64
}

/// Sample variance about the mean, divided by n − 1 (NaN for fewer than two values).
pub fn sample_variance(xs: &[f64]) -> f64 {
    if xs.len() < 2 {
        return f64::NAN;
    }
    let m = mean(xs);
    xs.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (xs.len() - 1) as f64
}

/// Sample standard deviation (n − 1); 0 for fewer than two values.
pub fn sample_sd(xs: &[f64]) -> f64 {
    if xs.len() < 2 {
        return 0.0;
    }
    sample_variance(xs).sqrt()
}

/// Median of `v`, sorting it in place: the middle value, or the mean of the two middle values of
/// an even count; NaN for no values. NaNs sort above every number (`f64::total_cmp`).
/// Root mean square of the finite values and how many there were; NaN (and 0) when none is.
pub fn rms_finite(values: impl IntoIterator<Item = f64>) -> (f64, usize) {
    let (mut n, mut sum_sq) = (0usize, 0.0);
    for x in values.into_iter().filter(|x| x.is_finite()) {
        n += 1;
        sum_sq += x * x;
    }
    if n == 0 {
        (f64::NAN, 0)
    } else {
        ((sum_sq / n as f64).sqrt(), n)
    }
}

pub fn median_in_place(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    match n {
        0 => f64::NAN,
        _ if n % 2 == 1 => v[n / 2],
        _ => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// [`median_in_place`] of a copy of `xs`.
pub fn median(xs: &[f64]) -> f64 {
    median_in_place(&mut xs.to_vec())
}

/// [`median`] of the finite values of `v`; `None` when there are none.
pub fn median_finite(mut v: Vec<f64>) -> Option<f64> {
    v.retain(|x| x.is_finite());
    (!v.is_empty()).then(|| median_in_place(&mut v))
}

/// The upper median of the finite values of `v` (the middle value, or the upper of the two
/// middle values of an even count); `None` when there are none. Always one of the values.
pub fn upper_median_finite(mut v: Vec<f64>) -> Option<f64> {
    v.retain(|x| x.is_finite());
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    Some(v[v.len() / 2])
}

/// The median absolute deviation from the median, `median(|x − median(xs)|)` (NaN for no
/// values); × [`MAD_TO_SD`] it estimates the standard deviation of normal data.
pub fn mad(xs: &[f64]) -> f64 {
    let m = median(xs);
    median_in_place(&mut xs.iter().map(|x| (x - m).abs()).collect::<Vec<f64>>())
}

/// Percentile `q` (0–100) of an ascending slice, numpy's "linear" method (NaN for no values).
pub fn percentile_sorted(sorted: &[f64], q: f64) -> f64 {
    match sorted.len() {
        0 => f64::NAN,
        1 => sorted[0],
        n => {
            let pos = (q / 100.0).clamp(0.0, 1.0) * (n - 1) as f64;
            let lo = pos.floor() as usize;
            let hi = (lo + 1).min(n - 1);
            let frac = pos - lo as f64;
            sorted[lo] + (sorted[hi] - sorted[lo]) * frac
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn rms_skips_non_finite_values_and_counts_the_rest() {
        let (r, n) = rms_finite([3.0, f64::NAN, -4.0, f64::INFINITY]);
        assert_eq!(n, 2);
        assert!((r - (12.5f64).sqrt()).abs() < 1e-15);
        let (r, n) = rms_finite([f64::NAN]);
        assert!(r.is_nan() && n == 0);
    }

    #[test]
    fn known_values() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), 2.0);
        assert_eq!(median(&[4.0, 1.0, 3.0, 2.0]), 2.5);
        assert!(median(&[]).is_nan());
        assert_eq!(median_finite(vec![f64::NAN, 4.0, 1.0, 3.0, 2.0]), Some(2.5));
        assert_eq!(
            upper_median_finite(vec![4.0, 1.0, f64::INFINITY, 3.0, 2.0]),
            Some(3.0)
        );
        assert_eq!(median_finite(vec![f64::NAN]), None);
        assert_eq!(upper_median_finite(vec![]), None);
        assert_eq!(sample_sd(&[1.0]), 0.0);
        assert!((sample_sd(&[1.0, 2.0, 3.0, 4.0]) - (5.0f64 / 3.0).sqrt()).abs() < 1e-15);
        assert!(sample_variance(&[1.0]).is_nan());
        assert_eq!(mad(&[1.0, 2.0, 4.0, 8.0, 100.0]), 3.0);
        assert!(mad(&[]).is_nan());
        // numpy's "linear" method.
        let v = [1.0, 2.0, 3.0, 4.0, 5.0];
        assert_eq!(percentile_sorted(&v, 50.0), 3.0);
        assert!((percentile_sorted(&v, 95.0) - 4.8).abs() < 1e-12);
        assert_eq!(percentile_sorted(&v, 0.0), 1.0);
        assert_eq!(percentile_sorted(&v, 100.0), 5.0);
        assert_eq!(percentile_sorted(&[1.0, 2.0, 3.0, 4.0], 50.0), 2.5);
    }

    proptest! {
        #[test]
        fn the_median_splits_the_values_in_halves(
            v in proptest::collection::vec(-1e6f64..1e6, 1..40),
        ) {
            let m = median(&v);
            let below = v.iter().filter(|&&x| x < m).count();
            let above = v.iter().filter(|&&x| x > m).count();
            prop_assert!(below <= v.len() / 2 && above <= v.len() / 2);
            let u = upper_median_finite(v.clone()).unwrap();
            prop_assert!(u >= m && v.contains(&u));
            let mut sorted = v.clone();
            sorted.sort_by(f64::total_cmp);
            prop_assert!((percentile_sorted(&sorted, 50.0) - m).abs() <= 1e-9 * m.abs().max(1.0));
        }
    }
}
