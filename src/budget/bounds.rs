//! Analytic error bounds beside the measured numbers.
//!
//! **Worst case (the seed's argument, generalised).** The seed study (section 5.3) observed that a
//! detected point moves at most half a pixel in x and in y per step, i.e. up to
//! δs = √2 · 0.5 px perpendicular to the radius; at a radius r_px that is an angle error
//! δθ = δs / r_px (0.707 / 744 = 0.00095 rad). Divided by the shortest frame interval h it gives
//! ω error δθ/h (0.0285 rad/s) and α error δθ/h² (0.856 rad/s²), doubled for a swing from −δ to
//! +δ (0.057 rad/s, 1.71 rad/s² — the report prints 1.73). For any *linear* differentiator
//! with centre weights w (ω̂_i = Σ w_j θ_{i+j}), the worst case over independent per-frame angle
//! errors |e_j| ≤ δθ is δθ · Σ|w_j| — for numpy.gradient this is exactly the seed's δθ/h and δθ/h².
//!
//! **Statistical prediction.** Independent angle noise σ_θ = σ_⊥/r_px gives σ_ω = σ_θ·‖w_ω‖₂ and
//! σ_α = σ_θ·‖w_α‖₂. A timestamp error δt shifts the sampled angle by ω2·δt, so timestamp jitter
//! σ_t adds (ω2_rms·σ_t)² to σ_θ² (it matters in the drive phase, not in dwell).

use serde::{Deserialize, Serialize};

/// The seed's per-axis position error of a detected point, px: "the center point moves no more
/// than half a pixel in x- or y-direction for a given time step" (seed §5.3, from its stationary
/// sequence, Fig. 4.5). It is the seed's observed bound, not derived here; the bounds below
/// generalise the seed's argument from it.
pub const SEED_POSITION_ERROR_PX: f64 = 0.5;

/// Centre weights of a linear differentiator on a uniform grid of step `h_s`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct LinearWeights {
    pub h_s: f64,
    pub omega: Vec<f64>,
    pub alpha: Vec<f64>,
}

impl LinearWeights {
    /// Recovers the weights of any linear differentiator by feeding it unit impulses: the
    /// response at the centre frame to an impulse at frame j is w_j.
    /// `differentiate(t_s, theta) -> (omega, alpha)`; `half_width` frames either side.
    pub fn probe<F>(differentiate: F, h_s: f64, half_width: usize) -> Self
    where
        F: Fn(&[f64], &[f64]) -> (Vec<f64>, Vec<f64>),
    {
        let n = 2 * half_width + 1 + 2 * half_width; // room so the centre sees no edge effects
        let centre = n / 2;
        let t: Vec<f64> = (0..n).map(|i| i as f64 * h_s).collect();
        let mut omega = Vec::with_capacity(n);
        let mut alpha = Vec::with_capacity(n);
        for j in 0..n {
            let mut impulse = vec![0.0; n];
            impulse[j] = 1.0;
            let (w, a) = differentiate(&t, &impulse);
            omega.push(w[centre]);
            alpha.push(a[centre]);
        }
        Self { h_s, omega, alpha }
    }

    pub fn omega_l1(&self) -> f64 {
        self.omega.iter().map(|w| w.abs()).sum()
    }
    pub fn alpha_l1(&self) -> f64 {
        self.alpha.iter().map(|w| w.abs()).sum()
    }
    pub fn omega_l2(&self) -> f64 {
        self.omega.iter().map(|w| w * w).sum::<f64>().sqrt()
    }
    pub fn alpha_l2(&self) -> f64 {
        self.alpha.iter().map(|w| w * w).sum::<f64>().sqrt()
    }
}

/// The seed's half-pixel worst-case bound and its generalisation to the chosen differentiator.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HalfPixelBound {
    /// Per-axis position error assumed (the seed: 0.5 px).
    pub position_error_px: f64,
    /// Distance of the tracked point from the rotation centre.
    pub radius_px: f64,
    /// Shortest frame interval used (the seed: 0.0333 s).
    pub h_min_s: f64,
    /// δθ = √2·position_error_px / radius_px.
    pub theta_rad: f64,
    /// The seed's form: δθ / h and δθ / h².
    pub seed_omega_rad_s: f64,
    pub seed_alpha_rad_s2: f64,
    /// The seed's doubled values (a swing from −δθ to +δθ).
    pub seed_omega_doubled_rad_s: f64,
    pub seed_alpha_doubled_rad_s2: f64,
    /// Generalised worst case for the differentiator in use: δθ·Σ|w|.
    pub omega_rad_s: f64,
    pub alpha_rad_s2: f64,
}

pub fn half_pixel_bound(
    position_error_px: f64,
    radius_px: f64,
    h_min_s: f64,
    weights: &LinearWeights,
) -> HalfPixelBound {
    let theta = std::f64::consts::SQRT_2 * position_error_px / radius_px;
    // Weights were probed at weights.h_s; a linear differentiator's k-th derivative weights scale
    // as h^-k, so rescale them to h_min.
    let s1 = weights.h_s / h_min_s;
    let s2 = s1 * s1;
    HalfPixelBound {
        position_error_px,
        radius_px,
        h_min_s,
        theta_rad: theta,
        seed_omega_rad_s: theta / h_min_s,
        seed_alpha_rad_s2: theta / (h_min_s * h_min_s),
        seed_omega_doubled_rad_s: 2.0 * theta / h_min_s,
        seed_alpha_doubled_rad_s2: 2.0 * theta / (h_min_s * h_min_s),
        omega_rad_s: theta * weights.omega_l1() * s1,
        alpha_rad_s2: theta * weights.alpha_l1() * s2,
    }
}

/// Predicted error standard deviations from position noise and timestamp jitter.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoisePrediction {
    pub sigma_theta_rad: f64,
    pub sigma_omega_rad_s: f64,
    pub sigma_alpha_rad_s2: f64,
}

/// `sigma_perp_px`: σ of the tracked point's position perpendicular to the radius;
/// `omega_rms_rad_s`: RMS true ω2 over the frames considered; `sigma_t_s`: timestamp jitter σ.
pub fn predict_noise(
    sigma_perp_px: f64,
    radius_px: f64,
    weights: &LinearWeights,
    omega_rms_rad_s: f64,
    sigma_t_s: f64,
) -> NoisePrediction {
    let from_position = sigma_perp_px / radius_px;
    let from_timing = omega_rms_rad_s * sigma_t_s;
    let sigma_theta = (from_position.powi(2) + from_timing.powi(2)).sqrt();
    NoisePrediction {
        sigma_theta_rad: sigma_theta,
        sigma_omega_rad_s: sigma_theta * weights.omega_l2(),
        sigma_alpha_rad_s2: sigma_theta * weights.alpha_l2(),
    }
}

/// How often a bound is exceeded.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Exceedance {
    pub bound: f64,
    pub frames: usize,
    pub exceeded: usize,
    pub fraction: f64,
    pub respected: bool,
}

pub fn exceedance(errors: &[f64], bound: f64) -> Exceedance {
    let finite: Vec<f64> = errors.iter().copied().filter(|e| e.is_finite()).collect();
    let exceeded = finite.iter().filter(|e| e.abs() > bound).count();
    let frames = finite.len();
    Exceedance {
        bound,
        frames,
        exceeded,
        fraction: if frames > 0 {
            exceeded as f64 / frames as f64
        } else {
            f64::NAN
        },
        respected: exceeded == 0,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// numpy.gradient on a uniform grid (interior central, one-sided edges), written out here
    /// independently of the estimator so the bound test stands on its own.
    fn gradient(t: &[f64], y: &[f64]) -> Vec<f64> {
        let n = y.len();
        (0..n)
            .map(|i| match i {
                0 => (y[1] - y[0]) / (t[1] - t[0]),
                i if i == n - 1 => (y[n - 1] - y[n - 2]) / (t[n - 1] - t[n - 2]),
                i => (y[i + 1] - y[i - 1]) / (t[i + 1] - t[i - 1]),
            })
            .collect()
    }

    fn seed_differentiator(t: &[f64], theta: &[f64]) -> (Vec<f64>, Vec<f64>) {
        let w = gradient(t, theta);
        let a = gradient(t, &w);
        (w, a)
    }

    #[test]
    fn reproduces_the_seed_numbers() {
        let h = 1.0 / 30.0;
        let weights = LinearWeights::probe(seed_differentiator, h, 3);
        let b = half_pixel_bound(0.5, 744.0, 0.0333, &weights);
        assert!((b.theta_rad - 0.00095).abs() < 0.000005, "{}", b.theta_rad);
        assert!(
            (b.seed_omega_rad_s - 0.0285).abs() < 0.0005,
            "{}",
            b.seed_omega_rad_s
        );
        assert!(
            (b.seed_alpha_rad_s2 - 0.856).abs() < 0.005,
            "{}",
            b.seed_alpha_rad_s2
        );
        assert!((b.seed_omega_doubled_rad_s - 0.057).abs() < 0.001);
        assert!((b.seed_alpha_doubled_rad_s2 - 1.71).abs() < 0.01);
        // For numpy.gradient the generalised worst case equals the seed's form exactly.
        assert!((b.omega_rad_s - b.seed_omega_rad_s).abs() < 1e-12);
        assert!((b.alpha_rad_s2 - b.seed_alpha_rad_s2).abs() < 1e-9);
    }

    #[test]
    fn gradient_twice_weights_are_the_five_point_stencil() {
        let h = 0.05;
        let w = LinearWeights::probe(seed_differentiator, h, 3);
        let c = w.omega.len() / 2;
        assert!((w.omega[c + 1] - 1.0 / (2.0 * h)).abs() < 1e-9);
        assert!((w.alpha[c + 2] - 1.0 / (4.0 * h * h)).abs() < 1e-9);
        assert!((w.alpha[c] + 2.0 / (4.0 * h * h)).abs() < 1e-9);
        // Noise gains: σ_ω/σ_θ = 1/(√2 h), σ_α/σ_θ = √6/(4h²).
        assert!((w.omega_l2() - 1.0 / (2f64.sqrt() * h)).abs() < 1e-9);
        assert!((w.alpha_l2() - 6f64.sqrt() / (4.0 * h * h)).abs() < 1e-6);
    }

    #[test]
    fn timing_jitter_adds_in_quadrature() {
        let w = LinearWeights::probe(seed_differentiator, 0.033, 2);
        let p0 = predict_noise(0.1, 700.0, &w, 0.0, 0.0);
        let p1 = predict_noise(0.1, 700.0, &w, 0.5, 1e-4);
        let expected = ((0.1f64 / 700.0).powi(2) + (0.5f64 * 1e-4).powi(2)).sqrt();
        assert!((p1.sigma_theta_rad - expected).abs() < 1e-15);
        assert!(p1.sigma_omega_rad_s > p0.sigma_omega_rad_s);
    }

    #[test]
    fn exceedance_counts() {
        let e = exceedance(&[0.1, -0.3, 0.2, f64::NAN, 0.5], 0.25);
        assert_eq!((e.frames, e.exceeded), (4, 2));
        assert_eq!(e.fraction, 0.5);
        assert!(!e.respected);
    }
}
