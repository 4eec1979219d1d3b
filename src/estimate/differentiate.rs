//! Numerical first and second derivatives of an angle series on non-uniform timestamps, and the
//! noise gain of each method (σ_ω/σ_θ, σ_α/σ_θ for uniform steps h), used by the error budgets.
//!
//! Methods (all zero-lag: symmetric stencils on uniform steps; SG edges use an asymmetric window
//! and are not zero-lag there):
//! - `seed`: `numpy.gradient(θ, t)` applied twice, exactly numpy's uneven-spacing definition
//!   (second-order interior with h_s, h_d; first-order one-sided edges, `edge_order=1`).
//!   Uniform gains: σ_ω = σ_θ/(√2 h) (stencil ±1/(2h)); α = gradient of gradient has stencil
//!   (1, 0, −2, 0, 1)/(4h²), σ_α = √6 σ_θ/(4h²).
//! - `central3`: Lagrange 3-point derivative at the middle point for ω; the 3-point non-uniform
//!   second derivative 2[(θ₊−θ₀)/h_d − (θ₀−θ₋)/h_s]/(h_s+h_d) for α, directly from θ. Edges use
//!   the first/last three points (Lagrange derivative at the end node). Uniform gains:
//!   σ_ω = σ_θ/(√2 h), σ_α = √6 σ_θ/h².
//! - `savitzky_golay`: local least-squares polynomial of `order` in real time over a window of
//!   `window_frames` frames (odd) or of ±`window_s`/2 seconds; ω = p'(t_i), α = p''(t_i). Edges
//!   take the nearest full window. Uniform gains are computed from the filter coefficients
//!   (‖row of the pseudo-inverse‖ · k!/h^k).
//! - `kalman_rts`: white-jerk Kalman filter + RTS smoother with the jerk-to-noise ratio λ chosen
//!   by maximum marginal likelihood (see [`super::kalman`]); gains computed from the smoother's
//!   impulse response for the given λ. With λ unset (automatic) the gain depends on the data:
//!   call [`Differentiator::resolved`] first, which fixes λ from the series.

use serde::{Deserialize, Serialize};

use super::error::EstimateError;
use super::kalman;
use crate::numeric::linalg;
use crate::validation::{join, Problems};

/// Numerical differentiator (`[estimator.differentiator]`, `kind = ...`).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Differentiator {
    /// numpy.gradient twice (the seed study).
    Seed,
    /// Non-uniform 3-point central differences.
    Central3,
    /// Savitzky–Golay on real time.
    SavitzkyGolay {
        /// Window length in frames, odd, ≥ order + 1 (and ≥ 3), ≤ 10001; default 9. Ignored when
        /// `window_s` is set.
        #[serde(default = "default_sg_window")]
        window_frames: usize,
        /// Optional window length in seconds, in [1e-4, 3600] (frames within ±window_s/2 of the
        /// evaluated frame);
        /// default unset (use `window_frames`).
        #[serde(default)]
        window_s: Option<f64>,
        /// Polynomial order, 2..=8; default 2.
        #[serde(default = "default_sg_order")]
        order: usize,
    },
    /// Kalman filter + RTS smoother, white-jerk model (default, with λ automatic: the best of
    /// `reports/defaults/`).
    KalmanRts {
        /// Jerk PSD over measurement variance λ = q/r, 1/s⁶, in [1e-20, 1e30]; default unset =
        /// chosen automatically
        /// by maximum marginal likelihood for each series.
        #[serde(default)]
        lambda_per_s6: Option<f64>,
    },
}

impl Default for Differentiator {
    fn default() -> Self {
        Differentiator::KalmanRts {
            lambda_per_s6: None,
        }
    }
}

fn default_sg_window() -> usize {
    9
}
fn default_sg_order() -> usize {
    2
}

/// Angle-noise-to-derivative-noise gains for uniform steps, per radian of angle noise.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct NoiseGain {
    /// σ_ω / σ_θ, 1/s.
    pub omega_per_rad: f64,
    /// σ_α / σ_θ, 1/s².
    pub alpha_per_rad: f64,
}

/// ω and α for every input sample (same length as the input).
#[derive(Debug, Clone, PartialEq)]
pub struct Derivatives {
    pub omega_rad_s: Vec<f64>,
    pub alpha_rad_s2: Vec<f64>,
}

/// Longest Savitzky–Golay window, frames (five minutes at 30 fps).
const MAX_WINDOW_FRAMES: usize = 10_001;

impl Differentiator {
    /// A short comma-free label with the parameters (`savitzky_golay 9 frames order 2`,
    /// `kalman_rts` with λ automatic, `kalman_rts λ 1e7` when fixed).
    pub fn label(&self) -> String {
        match self {
            Differentiator::Seed => "seed".into(),
            Differentiator::Central3 => "central3".into(),
            Differentiator::SavitzkyGolay {
                window_frames,
                window_s,
                order,
            } => match window_s {
                Some(w) => format!("savitzky_golay {w} s order {order}"),
                None => format!("savitzky_golay {window_frames} frames order {order}"),
            },
            Differentiator::KalmanRts { lambda_per_s6 } => match lambda_per_s6 {
                Some(l) => format!("kalman_rts λ {l:.3e} /s⁶"),
                None => "kalman_rts".into(),
            },
        }
    }

    /// Pushes problems for invalid settings.
    pub fn validate(&self, path: &str, problems: &mut Problems) {
        if let Differentiator::KalmanRts {
            lambda_per_s6: Some(l),
        } = self
        {
            // The automatic choice searches h⁻⁶·10^[−10, 4] for frame intervals h of 0.1 ms to
            // 10 s; this range holds all of it.
            problems.range(join(path, "lambda_per_s6"), *l, 1e-20, 1e30);
        }
        if let Differentiator::SavitzkyGolay {
            window_frames,
            window_s,
            order,
        } = self
        {
            if !(2..=8).contains(order) {
                problems.push(
                    join(path, "order"),
                    format!("must be in [2, 8], got {order}"),
                );
            }
            if let Some(w) = window_s {
                problems.range(join(path, "window_s"), *w, 1e-4, 3600.0);
            }
            // Ignored when `window_s` is set, but never out of all bounds.
            let ignored = window_s.is_some() && *window_frames <= MAX_WINDOW_FRAMES;
            if !ignored
                && (window_frames % 2 == 0
                    || *window_frames < 3
                    || *window_frames < order + 1
                    || *window_frames > MAX_WINDOW_FRAMES)
            {
                problems.push(
                    join(path, "window_frames"),
                    format!(
                        "must be odd and in [max(3, order + 1), {MAX_WINDOW_FRAMES}], got \
                         {window_frames}"
                    ),
                );
            }
        }
    }

    /// The same differentiator with every data-driven parameter fixed from this series (the
    /// Kalman λ); other methods are returned unchanged.
    pub fn resolved(
        &self,
        t_s: &[f64],
        theta_rad: &[f64],
    ) -> Result<Differentiator, EstimateError> {
        match self {
            Differentiator::KalmanRts {
                lambda_per_s6: None,
            } => {
                check_series(t_s, theta_rad, 5)?;
                Ok(Differentiator::KalmanRts {
                    lambda_per_s6: Some(kalman::choose_lambda(t_s, theta_rad)),
                })
            }
            other => Ok(other.clone()),
        }
    }

    /// ω and α of `theta_rad` sampled at strictly increasing `t_s`.
    pub fn differentiate(
        &self,
        t_s: &[f64],
        theta_rad: &[f64],
    ) -> Result<Derivatives, EstimateError> {
        let min_len = if matches!(self, Differentiator::KalmanRts { .. }) {
            5
        } else {
            3
        };
        check_series(t_s, theta_rad, min_len)?;
        match self {
            Differentiator::Seed => {
                let omega = numpy_gradient(t_s, theta_rad);
                let alpha = numpy_gradient(t_s, &omega);
                Ok(Derivatives {
                    omega_rad_s: omega,
                    alpha_rad_s2: alpha,
                })
            }
            Differentiator::Central3 => central3(t_s, theta_rad),
            Differentiator::SavitzkyGolay {
                window_frames,
                window_s,
                order,
            } => savitzky_golay(t_s, theta_rad, *window_frames, *window_s, *order),
            Differentiator::KalmanRts { lambda_per_s6 } => {
                let lambda = lambda_per_s6.unwrap_or_else(|| kalman::choose_lambda(t_s, theta_rad));
                let s = kalman::smooth(t_s, theta_rad, lambda);
                Ok(Derivatives {
                    omega_rad_s: s.omega,
                    alpha_rad_s2: s.alpha,
                })
            }
        }
    }

    /// Noise gain for uniform steps of `h_s` seconds (see the module doc for the formulas).
    pub fn noise_gain(&self, h_s: f64) -> NoiseGain {
        match self {
            Differentiator::Seed => NoiseGain {
                omega_per_rad: 1.0 / (2.0_f64.sqrt() * h_s),
                alpha_per_rad: 6.0_f64.sqrt() / (4.0 * h_s * h_s),
            },
            Differentiator::Central3 => NoiseGain {
                omega_per_rad: 1.0 / (2.0_f64.sqrt() * h_s),
                alpha_per_rad: 6.0_f64.sqrt() / (h_s * h_s),
            },
            Differentiator::SavitzkyGolay {
                window_frames,
                window_s,
                order,
            } => {
                let half = match window_s {
                    // Frames within ±w/2 of the centre, with a small tolerance for rounding.
                    Some(w) => ((w / 2.0) / h_s + 1e-9).floor() as usize,
                    None => window_frames / 2,
                };
                let t: Vec<f64> = (0..=2 * half)
                    .map(|k| (k as f64 - half as f64) * h_s)
                    .collect();
                match sg_weights(&t, 0.0, *order) {
                    Some((w1, w2)) => NoiseGain {
                        omega_per_rad: w1.iter().map(|w| w * w).sum::<f64>().sqrt(),
                        alpha_per_rad: w2.iter().map(|w| w * w).sum::<f64>().sqrt(),
                    },
                    None => NoiseGain {
                        omega_per_rad: f64::NAN,
                        alpha_per_rad: f64::NAN,
                    },
                }
            }
            Differentiator::KalmanRts {
                lambda_per_s6: Some(lambda),
            } => {
                let (w, a) = kalman::noise_gain(h_s, *lambda);
                NoiseGain {
                    omega_per_rad: w,
                    alpha_per_rad: a,
                }
            }
            // Data-dependent: resolve λ first.
            Differentiator::KalmanRts {
                lambda_per_s6: None,
            } => NoiseGain {
                omega_per_rad: f64::NAN,
                alpha_per_rad: f64::NAN,
            },
        }
    }
}

fn check_series(t_s: &[f64], theta_rad: &[f64], min_len: usize) -> Result<(), EstimateError> {
    if t_s.len() != theta_rad.len() {
        return Err(EstimateError::LengthMismatch {
            what: "theta_rad",
            got: theta_rad.len(),
            expected: t_s.len(),
        });
    }
    if t_s.len() < min_len {
        return Err(EstimateError::TooFewFrames {
            what: "derivatives",
            got: t_s.len(),
            need: min_len,
        });
    }
    for (i, (t, th)) in t_s.iter().zip(theta_rad).enumerate() {
        if !t.is_finite() {
            return Err(EstimateError::NonFinite {
                what: "timestamp",
                frame: i,
            });
        }
        if !th.is_finite() {
            return Err(EstimateError::NonFinite {
                what: "angle",
                frame: i,
            });
        }
        if i > 0 && *t <= t_s[i - 1] {
            return Err(EstimateError::NonIncreasingTime { frame: i });
        }
    }
    Ok(())
}

/// `numpy.gradient(f, x)` with `edge_order=1` (numpy ≥ 1.13 uneven-spacing formula).
/// Needs at least two samples; callers check.
pub fn numpy_gradient(x: &[f64], f: &[f64]) -> Vec<f64> {
    let n = f.len();
    let mut g = vec![0.0; n];
    for i in 1..n - 1 {
        let hs = x[i] - x[i - 1];
        let hd = x[i + 1] - x[i];
        g[i] = (hs * hs * f[i + 1] + (hd * hd - hs * hs) * f[i] - hd * hd * f[i - 1])
            / (hs * hd * (hd + hs));
    }
    g[0] = (f[1] - f[0]) / (x[1] - x[0]);
    g[n - 1] = (f[n - 1] - f[n - 2]) / (x[n - 1] - x[n - 2]);
    g
}

/// Derivatives of the Lagrange parabola through (t[j], f[j]) for j in `idx` (3 points), at `te`.
fn lagrange3(t: &[f64], f: &[f64], idx: [usize; 3], te: f64) -> (f64, f64) {
    let [a, b, c] = idx;
    let (x0, x1, x2) = (t[a], t[b], t[c]);
    let d0 = (x0 - x1) * (x0 - x2);
    let d1 = (x1 - x0) * (x1 - x2);
    let d2 = (x2 - x0) * (x2 - x1);
    let first = f[a] * (2.0 * te - x1 - x2) / d0
        + f[b] * (2.0 * te - x0 - x2) / d1
        + f[c] * (2.0 * te - x0 - x1) / d2;
    let second = 2.0 * (f[a] / d0 + f[b] / d1 + f[c] / d2);
    (first, second)
}

fn central3(t: &[f64], f: &[f64]) -> Result<Derivatives, EstimateError> {
    let n = f.len();
    let mut omega = vec![0.0; n];
    let mut alpha = vec![0.0; n];
    for i in 0..n {
        let centre = i.clamp(1, n - 2);
        let (w, a) = lagrange3(t, f, [centre - 1, centre, centre + 1], t[i]);
        omega[i] = w;
        alpha[i] = a;
    }
    Ok(Derivatives {
        omega_rad_s: omega,
        alpha_rad_s2: alpha,
    })
}

/// Weights (w1, w2) such that p'(te) = Σ w1_j f_j and p''(te) = Σ w2_j f_j for the least-squares
/// polynomial of `order` through (t_j, f_j). `None` if the fit is singular.
fn sg_weights(t: &[f64], te: f64, order: usize) -> Option<(Vec<f64>, Vec<f64>)> {
    let m = t.len();
    let p = order + 1;
    if m < p {
        return None;
    }
    // Scale time to O(1) so the normal equations stay well conditioned.
    let scale = t.iter().map(|x| (x - te).abs()).fold(0.0_f64, f64::max);
    if scale.is_nan() || scale <= 0.0 {
        return None;
    }
    let u: Vec<f64> = t.iter().map(|x| (x - te) / scale).collect();
    let vand: Vec<Vec<f64>> = u
        .iter()
        .map(|&x| (0..p).map(|k| x.powi(k as i32)).collect())
        .collect();
    let mut ata = vec![vec![0.0; p]; p];
    for row in &vand {
        for a in 0..p {
            for b in 0..p {
                ata[a][b] += row[a] * row[b];
            }
        }
    }
    let inv = linalg::invert_rows(&ata)?;
    // Coefficient c_k = Σ_j (inv · Vᵀ)[k][j] f_j; p'(te) = c1/scale, p''(te) = 2 c2/scale².
    let coef_row = |k: usize| -> Vec<f64> {
        vand.iter()
            .map(|row| (0..p).map(|b| inv[k][b] * row[b]).sum::<f64>())
            .collect()
    };
    let w1: Vec<f64> = coef_row(1).into_iter().map(|c| c / scale).collect();
    let w2: Vec<f64> = coef_row(2)
        .into_iter()
        .map(|c| 2.0 * c / (scale * scale))
        .collect();
    Some((w1, w2))
}

fn savitzky_golay(
    t: &[f64],
    f: &[f64],
    window_frames: usize,
    window_s: Option<f64>,
    order: usize,
) -> Result<Derivatives, EstimateError> {
    let n = f.len();
    if order < 2 {
        return Err(EstimateError::InvalidDifferentiator(format!(
            "order must be >= 2, got {order}"
        )));
    }
    let mut omega = vec![0.0; n];
    let mut alpha = vec![0.0; n];
    for i in 0..n {
        let (lo, hi) = match window_s {
            Some(w) => {
                let lo = t.partition_point(|x| *x < t[i] - w / 2.0);
                let hi = t.partition_point(|x| *x <= t[i] + w / 2.0);
                (lo, hi)
            }
            None => {
                if window_frames % 2 == 0 || window_frames > n {
                    return Err(EstimateError::InvalidDifferentiator(format!(
                        "window_frames must be odd and <= number of detected frames ({n}), got {window_frames}"
                    )));
                }
                let lo = i.saturating_sub(window_frames / 2).min(n - window_frames);
                (lo, lo + window_frames)
            }
        };
        let (w1, w2) = sg_weights(&t[lo..hi], t[i], order).ok_or_else(|| {
            EstimateError::InvalidDifferentiator(format!(
                "Savitzky-Golay window at frame {i} holds {} samples, need more than order {order}",
                hi - lo
            ))
        })?;
        omega[i] = w1.iter().zip(&f[lo..hi]).map(|(w, y)| w * y).sum();
        alpha[i] = w2.iter().zip(&f[lo..hi]).map(|(w, y)| w * y).sum();
    }
    Ok(Derivatives {
        omega_rad_s: omega,
        alpha_rad_s2: alpha,
    })
}
