//! Measured series without any truth: an [`Estimate`]'s per-signal screen angles mapped into a
//! wheel convention (sign and a constant offset per signal), as real footage yields them.
//!
//! Synthetic runs compare these with the truth in `budget::compare`; real footage stops here.
//! The phases of real data are not part of a measurement: they come from an aligned nominal
//! motion (`diagnose`).

use super::Estimate;

/// One signal's measured θ2, ω2, α2 in a wheel convention (NaN where the frame is missing).
#[derive(Debug, Clone, PartialEq)]
pub struct MeasuredSignal {
    /// Signal name (`corner0` … `corner3`, `centre`, `fused`).
    pub signal: String,
    pub theta2_rad: Vec<f64>,
    pub omega2_rad_s: Vec<f64>,
    pub alpha2_rad_s2: Vec<f64>,
}

/// Maps each signal of `est` into a wheel convention: θ2 = sign·(θ_screen − first detected
/// θ_screen of that signal), ω2 = sign·ω_screen, α2 = sign·α_screen. `sign` = +1 keeps screen
/// counter-clockwise positive; −1 makes clockwise on screen positive.
pub fn relative_to_first_frame(est: &Estimate, sign: f64) -> Vec<MeasuredSignal> {
    est.signals
        .iter()
        .map(|s| {
            let first = s
                .theta_rad
                .iter()
                .copied()
                .find(|v| v.is_finite())
                .unwrap_or(0.0);
            MeasuredSignal {
                signal: s.signal.name().to_string(),
                theta2_rad: s.theta_rad.iter().map(|th| sign * (th - first)).collect(),
                omega2_rad_s: s.omega_rad_s.iter().map(|w| sign * w).collect(),
                alpha2_rad_s2: s.alpha_rad_s2.iter().map(|a| sign * a).collect(),
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimate::{estimate, EstimatorConfig};

    #[test]
    fn relative_series_start_at_zero_and_carry_the_sign() {
        // A marker turning counter-clockwise on screen at 0.5 rad/s about (100, 100).
        let t: Vec<f64> = (0..40).map(|k| k as f64 / 30.0).collect();
        let corners: Vec<Option<[[f64; 2]; 4]>> = t
            .iter()
            .map(|&ti| {
                let a = 0.5 * ti;
                let p = |da: f64, r: f64| {
                    // Screen y points down: counter-clockwise on screen is a decreasing angle
                    // in the (x, y-down) frame's atan2 sense, handled by the estimator.
                    [100.0 + r * (a + da).cos(), 100.0 - r * (a + da).sin()]
                };
                Some([p(-0.1, 80.0), p(0.1, 80.0), p(0.1, 60.0), p(-0.1, 60.0)])
            })
            .collect();
        let est = estimate(&EstimatorConfig::default(), &t, &corners, None).unwrap();
        for sign in [1.0, -1.0] {
            let m = relative_to_first_frame(&est, sign);
            assert_eq!(m.len(), est.signals.len());
            for s in &m {
                assert_eq!(s.theta2_rad[0], 0.0);
                let last = s.theta2_rad[39];
                let expected = sign * 0.5 * t[39];
                assert!(
                    (last.abs() - expected.abs()).abs() < 1e-6,
                    "{} {last}",
                    s.signal
                );
                // ω has the sign of the angle's growth.
                assert!(s.omega2_rad_s[20] * last > 0.0);
            }
        }
    }
}
