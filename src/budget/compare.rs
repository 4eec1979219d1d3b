//! Where truth meets measurement: turns estimated screen angles into the wheel's convention and
//! subtracts the truth, frame by frame.
//!
//! The estimator measures angles counter-clockwise on screen about its fitted centre; the
//! mechanism's θ2 has its own sense. `sign` (±1) maps one onto the other (computed by the
//! pipeline from the camera geometry), and each signal's constant angular position on the disc
//! is taken from the *true* geometry at the first frame (`screen_offset_rad`), never fitted to
//! the measurement — so a constant bias in the measurement stays visible as bias. Errors are
//! taken against the resolvable truth (what the frames can follow, `budget::resolvable`) and
//! against the raw truth (the actual motion at the timestamps).

/// Per-frame truth, SI units, wheel convention.
#[derive(Debug, Clone, PartialEq)]
pub struct TruthSeries {
    pub t_s: Vec<f64>,
    pub theta2_rad: Vec<f64>,
    pub omega2_rad_s: Vec<f64>,
    pub alpha2_rad_s2: Vec<f64>,
    pub phase: Vec<&'static str>,
}

/// One signal's measurement in the wheel convention and its errors against the resolvable
/// truth (the headline: `*_err_*`) and against the raw truth (`*_raw_err_*`).
#[derive(Debug, Clone, PartialEq)]
pub struct SignalErrors {
    pub signal: String,
    pub theta2_rad: Vec<f64>,
    pub omega2_rad_s: Vec<f64>,
    pub alpha2_rad_s2: Vec<f64>,
    pub theta_err_rad: Vec<f64>,
    pub omega_err_rad_s: Vec<f64>,
    pub alpha_err_rad_s2: Vec<f64>,
    pub theta_raw_err_rad: Vec<f64>,
    pub omega_raw_err_rad_s: Vec<f64>,
    pub alpha_raw_err_rad_s2: Vec<f64>,
}

/// Maps measured screen angles `[θ, ω, α]` (CCW positive, NaN where missing) into the wheel
/// convention: θ2_meas = sign·(θ_screen − screen_offset) + θ2_raw(first frame); ω, α = sign·(…),
/// and subtracts the resolvable and the raw truth.
pub fn to_wheel_convention(
    signal: &str,
    screen: [&[f64]; 3],
    sign: f64,
    screen_offset_rad: f64,
    raw: &TruthSeries,
    resolvable: &TruthSeries,
) -> SignalErrors {
    let n = raw.t_s.len();
    let theta2_first = raw.theta2_rad.first().copied().unwrap_or(0.0);
    let mut theta: Vec<f64> = screen[0]
        .iter()
        .map(|th| sign * (th - screen_offset_rad) + theta2_first)
        .collect();
    // Unwrapping may start on another branch than the truth: shift by whole turns so the first
    // measured frame lies within ±π of the truth.
    if let Some(k) = theta.iter().position(|v| v.is_finite()) {
        let turns = ((theta[k] - raw.theta2_rad[k]) / std::f64::consts::TAU).round();
        if turns != 0.0 {
            theta
                .iter_mut()
                .for_each(|v| *v -= turns * std::f64::consts::TAU);
        }
    }
    let omega: Vec<f64> = screen[1].iter().map(|w| sign * w).collect();
    let alpha: Vec<f64> = screen[2].iter().map(|a| sign * a).collect();
    let diff = |m: &[f64], t: &[f64]| (0..n).map(|i| m[i] - t[i]).collect::<Vec<f64>>();
    SignalErrors {
        signal: signal.to_string(),
        theta_err_rad: diff(&theta, &resolvable.theta2_rad),
        omega_err_rad_s: diff(&omega, &resolvable.omega2_rad_s),
        alpha_err_rad_s2: diff(&alpha, &resolvable.alpha2_rad_s2),
        theta_raw_err_rad: diff(&theta, &raw.theta2_rad),
        omega_raw_err_rad_s: diff(&omega, &raw.omega2_rad_s),
        alpha_raw_err_rad_s2: diff(&alpha, &raw.alpha2_rad_s2),
        theta2_rad: theta,
        omega2_rad_s: omega,
        alpha2_rad_s2: alpha,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sign_offset_and_turns_are_applied() {
        let truth = TruthSeries {
            t_s: vec![0.0, 1.0],
            theta2_rad: vec![1.0, 1.5],
            omega2_rad_s: vec![0.5, 0.5],
            alpha2_rad_s2: vec![0.0, 0.0],
            phase: vec!["drive", "drive"],
        };
        // Screen angle runs the other way, starts at 0.3 on screen, and sits one turn up.
        let tau = std::f64::consts::TAU;
        // The resolvable truth differs from the raw one by a known amount.
        let mut resolvable = truth.clone();
        resolvable.omega2_rad_s[1] = 0.45;
        let e = to_wheel_convention(
            "centre",
            [
                &[0.3 + tau, 0.3 - 0.5 + tau],
                &[-0.5, -0.4],
                &[0.0, f64::NAN],
            ],
            -1.0,
            0.3,
            &truth,
            &resolvable,
        );
        assert!((e.omega_raw_err_rad_s[1] + 0.1).abs() < 1e-12);
        assert!((e.omega_err_rad_s[1] + 0.05).abs() < 1e-12);
        assert!(
            e.theta_err_rad.iter().all(|v| v.abs() < 1e-12),
            "{:?}",
            e.theta_err_rad
        );
        assert!(e.alpha_err_rad_s2[1].is_nan());
    }
}
