//! The form of an axis runout read off the marker-centre track (pure): the wheel centre moving by
//! A·(cos ψ, sin ψ), ψ = n·θ2 + φ, displaces the marker centre in the image by the camera's
//! Jacobian times that offset, in both directions (radially and tangentially). A linear least
//! squares fit per cycle count n gives (A cos φ, A sin φ) beside the nuisance every alignment
//! leaves free (a constant image shift, a radius change, an angle offset and an angle drift
//! linear in θ2, which the circle fit, the marker's angle and the crank speed absorb, and the
//! angle errors of the nominal's crank phase and speed: ω2 and ω2·t); the n that takes most of
//! the residual wins.
//!
//! Why the crank columns: the nominal's motion was aligned to the real angle, runout included,
//! and on footage that covers less than one cycle of the wobble the alignment takes much of the
//! runout's tangential half for a crank phase and speed. That error is what is left of the
//! runout along the track, not a runout; without columns for it the fitted phase came out
//! 0.9–1.1 rad off on the independent renderer's footage and the candidate, taking that form,
//! fitted a quarter to a half of the amplitude.
//!
//! Why: the candidate's own form (n = 2, φ = 0) is a guess; a runout of another order or phase
//! explained only part of a gap whose shape it could have matched, and the ranking went to
//! effects that bend the angle alone. Angle-only effects (backlash, a drive-speed variation,
//! disc vibration) move the centre tangentially only: a runout form cannot take their
//! residual without the radial half it does not find.

/// One frame of the track, in image px.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunoutSample {
    /// Frame time, s.
    pub t_s: f64,
    /// Wheel angle (the aligned nominal's), rad.
    pub theta2_rad: f64,
    /// Wheel speed (the aligned nominal's), rad/s: where a crank phase or speed error shows.
    pub omega2_rad_s: f64,
    /// Measured marker centre minus the aligned nominal's, px.
    pub residual_px: [f64; 2],
    /// Image motion of the marker centre per metre of wheel-centre offset along the global x
    /// and y axes: `[d/dx, d/dy]`, each an image vector, px/m.
    pub jacobian_px_per_m: [[f64; 2]; 2],
    /// Unit vector from the rotation centre to the marker centre in the image.
    pub radial: [f64; 2],
}

/// A fitted runout form.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RunoutForm {
    pub cycles_per_wheel_rev: f64,
    /// Phase of ψ at θ2 = 0, rad, in (−π, π].
    pub phase_rad: f64,
    pub amplitude_m: f64,
    /// Share of the nuisance-only residual sum of squares the runout terms take, in [0, 1].
    pub rss_reduction_frac: f64,
    /// Number of frames fitted.
    pub frames: usize,
}

/// Cycle counts tried: the lowest orders a camera can see (0 and 1 are the centre's and the
/// marker's own position), either sense.
pub const CYCLES_TRIED: [f64; 7] = [2.0, 3.0, 4.0, 5.0, 6.0, -2.0, -3.0];

/// Nuisance columns: shift x and y, radius, angle offset, drift in θ2, and (when the wheel
/// moves) crank phase and speed.
const NUISANCE: usize = 7;

/// Residual sum of squares and coefficients of the least-squares fit of `samples` on the
/// nuisance columns and, when `cycles` is given, the two runout columns of that order (the last
/// two coefficients).
fn fit(samples: &[RunoutSample], cycles: Option<f64>) -> Option<(f64, Vec<f64>)> {
    let n = samples.len().max(1) as f64;
    let mean_theta = samples.iter().map(|s| s.theta2_rad).sum::<f64>() / n;
    let mean_t = samples.iter().map(|s| s.t_s).sum::<f64>() / n;
    let span_t = samples
        .iter()
        .map(|s| (s.t_s - mean_t).abs())
        .fold(0.0, f64::max);
    let omega_max = samples
        .iter()
        .map(|s| s.omega2_rad_s.abs())
        .fold(0.0, f64::max);
    // A wheel that never moves has no crank error to show (and the columns would be zero).
    let crank = omega_max > 0.0 && span_t > 0.0;
    let nuisance = if crank { NUISANCE } else { NUISANCE - 2 };
    let columns = nuisance + if cycles.is_some() { 2 } else { 0 };
    let mut ata = vec![vec![0.0; columns]; columns];
    let mut atb = vec![0.0; columns];
    let mut rows: Vec<(Vec<f64>, f64)> = Vec::with_capacity(2 * samples.len());
    for s in samples {
        let r = s.radial;
        let t = [-r[1], r[0]];
        let drift = s.theta2_rad - mean_theta;
        let runout = cycles.map(|n| {
            let (sn, cn) = (n * s.theta2_rad).sin_cos();
            let [jx, jy] = s.jacobian_px_per_m;
            // Offset (a cos nθ − b sin nθ, a sin nθ + b cos nθ) through the Jacobian, in mm
            // so that the columns are of the order of the nuisance's.
            let a = [
                1e-3 * (jx[0] * cn + jy[0] * sn),
                1e-3 * (jx[1] * cn + jy[1] * sn),
            ];
            let b = [
                1e-3 * (-jx[0] * sn + jy[0] * cn),
                1e-3 * (-jx[1] * sn + jy[1] * cn),
            ];
            (a, b)
        });
        for axis in 0..2 {
            let mut row = vec![
                if axis == 0 { 1.0 } else { 0.0 },
                if axis == 0 { 0.0 } else { 1.0 },
                r[axis],
                t[axis],
                t[axis] * drift,
            ];
            if crank {
                let w = s.omega2_rad_s / omega_max;
                row.push(t[axis] * w);
                row.push(t[axis] * w * (s.t_s - mean_t) / span_t);
            }
            if let Some((a, b)) = runout {
                row.push(a[axis]);
                row.push(b[axis]);
            }
            rows.push((row, s.residual_px[axis]));
        }
    }
    for (row, y) in &rows {
        for i in 0..columns {
            atb[i] += row[i] * y;
            for j in 0..columns {
                ata[i][j] += row[i] * row[j];
            }
        }
    }
    let x = crate::numeric::linalg::solve_rows(&ata, &atb)?;
    let rss = rows
        .iter()
        .map(|(row, y)| {
            let fit: f64 = row.iter().zip(&x).map(|(a, b)| a * b).sum();
            (y - fit).powi(2)
        })
        .sum();
    Some((rss, x))
}

/// The runout form that takes most of the residual among `cycles`, `None` when the track is too
/// short or degenerate. Non-finite samples are skipped.
pub fn fit_runout_form(samples: &[RunoutSample], cycles: &[f64]) -> Option<RunoutForm> {
    let samples: Vec<RunoutSample> = samples
        .iter()
        .copied()
        .filter(|s| {
            s.theta2_rad.is_finite()
                && s.t_s.is_finite()
                && s.omega2_rad_s.is_finite()
                && s.residual_px.iter().all(|v| v.is_finite())
                && s.jacobian_px_per_m.iter().flatten().all(|v| v.is_finite())
                && s.radial.iter().all(|v| v.is_finite())
        })
        .collect();
    if samples.len() < 2 * (NUISANCE + 2) {
        return None;
    }
    let (rss0, _) = fit(&samples, None)?;
    if rss0.is_nan() || rss0 <= 0.0 {
        return None;
    }
    let mut best: Option<RunoutForm> = None;
    for &n in cycles {
        let Some((rss, x)) = fit(&samples, Some(n)) else {
            continue;
        };
        let (a, b) = (x[x.len() - 2], x[x.len() - 1]);
        let form = RunoutForm {
            cycles_per_wheel_rev: n,
            phase_rad: b.atan2(a),
            amplitude_m: 1e-3 * a.hypot(b),
            rss_reduction_frac: ((rss0 - rss) / rss0).clamp(0.0, 1.0),
            frames: samples.len(),
        };
        if best.is_none_or(|b| form.rss_reduction_frac > b.rss_reduction_frac) {
            best = Some(form);
        }
    }
    best
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// Wheel speed of frame `k` of 180 at 30 fps, over `span_rad` in all: three Geneva-like
    /// steps (a sine-squared bump of speed, then a dwell), as the footage sees them.
    fn omega(k: usize, span_rad: f64) -> f64 {
        let x = (k % 60) as f64 / 30.0;
        if x < 1.0 {
            // Each bump turns span/3 over one second: ∫₀¹ 2 sin²(πx) dx = 1.
            span_rad / 3.0 * 2.0 * (std::f64::consts::PI * x).sin().powi(2)
        } else {
            0.0
        }
    }

    /// A top-down camera at `px_per_m` with the image y axis down; the marker at radius `r_px`
    /// about (640, 360) turning with θ2 over `span_rad` in three steps; `angle_noise` is an angle
    /// error of the frame (k, its wheel speed).
    fn track(
        cycles: f64,
        phase: f64,
        amplitude_m: f64,
        span_rad: f64,
        angle_noise: impl Fn(usize, f64) -> f64,
    ) -> Vec<RunoutSample> {
        let px_per_m = 2000.0;
        let r_px = 200.0;
        let mut th = 0.0;
        (0..180)
            .map(|k| {
                let w = omega(k, span_rad);
                th += w / 30.0;
                let psi = cycles * th + phase;
                let offset = [amplitude_m * psi.cos(), amplitude_m * psi.sin()];
                let j = [[px_per_m, 0.0], [0.0, -px_per_m]];
                let radial = [th.cos(), -th.sin()];
                let tangential = [-radial[1], radial[0]];
                let e = angle_noise(k, w) * r_px;
                RunoutSample {
                    t_s: k as f64 / 30.0,
                    theta2_rad: th,
                    omega2_rad_s: w,
                    residual_px: [
                        j[0][0] * offset[0] + j[1][0] * offset[1] + e * tangential[0] + 0.7,
                        j[0][1] * offset[0] + j[1][1] * offset[1] + e * tangential[1] - 0.4,
                    ],
                    jacobian_px_per_m: j,
                    radial,
                }
            })
            .collect()
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// A runout of any tried order and phase, seen over half a wheel turn, is recovered.
        #[test]
        fn a_runout_form_is_recovered(
            k in 0usize..CYCLES_TRIED.len(),
            phase in -3.0f64..3.0,
            amplitude_mm in 0.3f64..3.0,
        ) {
            let n = CYCLES_TRIED[k];
            let f = fit_runout_form(&track(n, phase, amplitude_mm * 1e-3, 3.2, |_, _| 0.0), &CYCLES_TRIED)
                .unwrap();
            prop_assert_eq!(f.cycles_per_wheel_rev, n);
            prop_assert!((f.amplitude_m / (amplitude_mm * 1e-3) - 1.0).abs() < 0.02, "{:?}", f);
            let dphi = crate::numeric::angle::wrap_pi(f.phase_rad - phase);
            prop_assert!(dphi.abs() < 0.02, "{:?} vs phase {}", f, phase);
            prop_assert!(f.rss_reduction_frac > 0.99);
        }
    }

    /// An angle-only error (a backlash-like step pattern) is no runout: no form takes much of it.
    #[test]
    fn an_angle_only_error_is_not_read_as_a_runout() {
        let steps = |k: usize, _| if (k / 30) % 2 == 0 { 4e-3 } else { -4e-3 };
        let f = fit_runout_form(&track(2.0, 0.0, 0.0, 3.2, steps), &CYCLES_TRIED).unwrap();
        assert!(f.rss_reduction_frac < 0.5, "{f:?}");
        let with = fit_runout_form(&track(3.0, 1.1, 2e-3, 3.2, steps), &CYCLES_TRIED).unwrap();
        assert_eq!(with.cycles_per_wheel_rev, 3.0, "{with:?}");
    }

    /// The nominal's crank phase and speed, aligned to an angle that held the runout, are off:
    /// the track then carries an angle error c₁·ω2 + c₂·ω2·t besides the runout (here about a
    /// third of the runout's tangential half). The form is still read right.
    #[test]
    fn a_crank_error_left_by_the_alignment_is_not_read_as_the_runouts_phase() {
        let crank_error = |k: usize, w: f64| w * (0.004 - 0.003 * k as f64 / 30.0);
        let f = fit_runout_form(&track(2.0, 0.0, 2e-3, 2.4, crank_error), &CYCLES_TRIED).unwrap();
        assert_eq!(f.cycles_per_wheel_rev, 2.0, "{f:?}");
        assert!(f.phase_rad.abs() < 0.02, "{f:?}");
        assert!((f.amplitude_m / 2e-3 - 1.0).abs() < 0.02, "{f:?}");
    }

    #[test]
    fn a_short_track_gives_no_form() {
        let t = track(2.0, 0.0, 1e-3, 3.0, |_, _| 0.0);
        assert!(fit_runout_form(&t[..10], &CYCLES_TRIED).is_none());
    }
}
