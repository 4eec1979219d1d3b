//! Angles: wrapping into a principal interval (radians and degrees) and unwrapping a series of
//! wrapped angles into a continuous one.
//!
//! The intervals differ only at their end points: [`wrap_pi`] returns −π for an odd multiple of
//! π and [`wrap_pi_upper`] returns +π (the interval `atan2` returns).

use std::f64::consts::{PI, TAU};

/// `a` wrapped into [−π, π).
pub fn wrap_pi(a: f64) -> f64 {
    (a + PI).rem_euclid(TAU) - PI
}

/// `a` wrapped into (−π, π], the interval of `atan2`.
pub fn wrap_pi_upper(a: f64) -> f64 {
    let w = wrap_pi(a);
    if w <= -PI {
        w + TAU
    } else {
        w
    }
}

/// `a` wrapped into [0, 2π).
pub fn wrap_tau(a: f64) -> f64 {
    a.rem_euclid(TAU)
}

/// `a_deg` wrapped into [−180°, 180°).
pub fn wrap_180_deg(a_deg: f64) -> f64 {
    (a_deg + 180.0).rem_euclid(360.0) - 180.0
}

/// Unwraps a series of wrapped angles in place: each step between consecutive values is taken
/// as its representative in [−π, π), so any number of turns is followed as long as the true
/// change between neighbours is below π.
pub fn unwrap_in_place(a: &mut [f64]) {
    for k in 1..a.len() {
        a[k] = a[k - 1] + wrap_pi(a[k] - a[k - 1]);
    }
}

/// [`unwrap_in_place`] over a series with missing samples (`None`, skipped and kept `None`):
/// each step is taken between consecutive *present* samples.
pub fn unwrap(wrapped: &[Option<f64>]) -> Vec<Option<f64>> {
    let mut prev: Option<(f64, f64)> = None; // (wrapped, unwrapped)
    wrapped
        .iter()
        .map(|w| {
            let w = (*w)?;
            let u = match prev {
                None => w,
                Some((pw, pu)) => pu + wrap_pi(w - pw),
            };
            prev = Some((w, u));
            Some(u)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    #[test]
    fn the_end_points_of_each_interval() {
        assert_eq!(wrap_pi(PI), -PI);
        assert_eq!(wrap_pi(-PI), -PI);
        assert_eq!(wrap_pi_upper(-PI), PI);
        assert_eq!(wrap_pi_upper(PI), PI);
        assert_eq!(wrap_tau(-0.5 * PI), 1.5 * PI);
        assert_eq!(wrap_180_deg(180.0), -180.0);
        assert_eq!(wrap_180_deg(-190.0), 170.0);
    }

    proptest! {
        #[test]
        fn a_wrapped_angle_is_in_its_interval_and_a_whole_number_of_turns_away(
            a in -1e3f64..1e3,
        ) {
            for (w, lo, hi) in [
                (wrap_pi(a), -PI, PI - 1e-12),
                (wrap_pi_upper(a), -PI + 1e-12, PI),
                (wrap_tau(a), 0.0, TAU),
            ] {
                prop_assert!(w >= lo - 1e-12 && w <= hi + 1e-12, "{a} → {w}");
                let turns = (a - w) / TAU;
                prop_assert!((turns - turns.round()).abs() < 1e-9, "{a} → {w}");
            }
            let d = wrap_180_deg(a);
            prop_assert!((-180.0..180.0).contains(&d));
            prop_assert!((((a - d) / 360.0) - ((a - d) / 360.0).round()).abs() < 1e-9);
        }

        #[test]
        fn unwrapping_recovers_a_slow_series_over_many_turns(
            start in -10.0f64..10.0,
            step in -3.0f64..3.0,
            gaps in proptest::collection::vec(any::<bool>(), 50),
        ) {
            let truth: Vec<f64> = (0..50).map(|k| start + step * k as f64).collect();
            let mut a: Vec<f64> = truth.iter().map(|&t| wrap_pi(t)).collect();
            unwrap_in_place(&mut a);
            let offset = truth[0] - a[0];
            for (u, t) in a.iter().zip(&truth) {
                prop_assert!((u + offset - t).abs() < 1e-9);
            }
            // With isolated gaps every present step is still below π when |step| < π/2.
            if step.abs() < 0.5 * PI {
                let wrapped: Vec<Option<f64>> = truth
                    .iter()
                    .zip(&gaps)
                    .enumerate()
                    .map(|(k, (&t, &gap))| (k % 2 == 0 || !gap).then_some(wrap_pi(t)))
                    .collect();
                let u = unwrap(&wrapped);
                for ((u, t), w) in u.iter().zip(&truth).zip(&wrapped) {
                    prop_assert_eq!(u.is_some(), w.is_some());
                    if let Some(u) = u {
                        prop_assert!((u + offset - t).abs() < 1e-9);
                    }
                }
            }
        }
    }
}
