//! Kalman filter + Rauch–Tung–Striebel smoother for θ with a white-jerk (constant-acceleration)
//! model on non-uniform steps; state (θ, ω, α).
//!
//! Model for a step h: F = [[1, h, h²/2], [0, 1, h], [0, 0, 1]],
//! Q = q·[[h⁵/20, h⁴/8, h³/6], [h⁴/8, h³/3, h²/2], [h³/6, h²/2, h]], measurement θ + v, Var v = r.
//! Only λ = q/r (1/s⁶) matters for the estimate; r is concentrated out of the likelihood
//! (r̂ = mean ν²/S), and λ is chosen automatically by maximising that profile likelihood over a
//! log grid of λ·h̄⁶ in [1e−10, 1e4] followed by golden-section search on log λ.
//! The prior is nearly diffuse (variances 1e8 r, scaled by the mean step), and the first three
//! innovations, which only initialise the state, are left out of the likelihood.
//!
//! Noise gain (uniform h, fixed λ): the interior smoother is time-invariant, so the weights of
//! the inputs on one output are the output response to one impulse; σ_ω/σ_θ = ‖response‖₂.
//! It is computed numerically from the filter (no closed form). The smoother is zero-lag
//! (symmetric weights) away from the ends.

type M3 = [[f64; 3]; 3];
type V3 = [f64; 3];

fn mul(a: &M3, b: &M3) -> M3 {
    let mut c = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    c
}

fn transpose(a: &M3) -> M3 {
    let mut t = [[0.0; 3]; 3];
    for i in 0..3 {
        for j in 0..3 {
            t[i][j] = a[j][i];
        }
    }
    t
}

fn add(a: &M3, b: &M3) -> M3 {
    let mut c = *a;
    for i in 0..3 {
        for j in 0..3 {
            c[i][j] += b[i][j];
        }
    }
    c
}

fn mv(a: &M3, v: &V3) -> V3 {
    [0, 1, 2].map(|i| (0..3).map(|k| a[i][k] * v[k]).sum())
}

fn inv3(a: &M3) -> Option<M3> {
    crate::numeric::linalg::invert3(a)
}

fn transition(h: f64, lambda: f64) -> (M3, M3) {
    let f = [[1.0, h, h * h / 2.0], [0.0, 1.0, h], [0.0, 0.0, 1.0]];
    let (h2, h3, h4, h5) = (h * h, h.powi(3), h.powi(4), h.powi(5));
    let q = [
        [h5 / 20.0, h4 / 8.0, h3 / 6.0],
        [h4 / 8.0, h3 / 3.0, h2 / 2.0],
        [h3 / 6.0, h2 / 2.0, h],
    ]
    .map(|r| r.map(|v| v * lambda));
    (f, q)
}

/// Result of one filter + smoother pass with r = 1.
pub struct Smoothed {
    pub theta: Vec<f64>,
    pub omega: Vec<f64>,
    pub alpha: Vec<f64>,
    /// Profile log-likelihood of λ (r concentrated out).
    pub log_likelihood: f64,
}

/// Filter and smooth `y` at times `t` (strictly increasing, ≥ 4 samples) with ratio `lambda`.
pub fn smooth(t: &[f64], y: &[f64], lambda: f64) -> Smoothed {
    let n = y.len();
    let hbar = (t[n - 1] - t[0]) / (n - 1) as f64;
    let big = 1e8;
    let mut x: V3 = [y[0], 0.0, 0.0];
    let mut p: M3 = [
        [big, 0.0, 0.0],
        [0.0, big / (hbar * hbar), 0.0],
        [0.0, 0.0, big / hbar.powi(4)],
    ];
    let mut xs_pred = Vec::with_capacity(n);
    let mut ps_pred = Vec::with_capacity(n);
    let mut xs = Vec::with_capacity(n);
    let mut ps = Vec::with_capacity(n);
    let mut fs = Vec::with_capacity(n);
    let (mut sum_log_s, mut sum_nu2_s, mut used) = (0.0, 0.0, 0usize);
    for k in 0..n {
        let (f, q) = if k == 0 {
            (
                [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]],
                [[0.0; 3]; 3],
            )
        } else {
            transition(t[k] - t[k - 1], lambda)
        };
        if k > 0 {
            x = mv(&f, &x);
            p = add(&mul(&mul(&f, &p), &transpose(&f)), &q);
        }
        xs_pred.push(x);
        ps_pred.push(p);
        fs.push(f);
        let s = p[0][0] + 1.0;
        let nu = y[k] - x[0];
        if k >= 3 {
            sum_log_s += s.ln();
            sum_nu2_s += nu * nu / s;
            used += 1;
        }
        let gain = [p[0][0] / s, p[1][0] / s, p[2][0] / s];
        x = [
            x[0] + gain[0] * nu,
            x[1] + gain[1] * nu,
            x[2] + gain[2] * nu,
        ];
        // Joseph form keeps P symmetric positive under the nearly diffuse start.
        let mut ikh = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [0.0, 0.0, 1.0]];
        for (i, row) in ikh.iter_mut().enumerate() {
            row[0] -= gain[i];
        }
        let mut kkt = [[0.0; 3]; 3];
        for i in 0..3 {
            for j in 0..3 {
                kkt[i][j] = gain[i] * gain[j];
            }
        }
        p = add(&mul(&mul(&ikh, &p), &transpose(&ikh)), &kkt);
        xs.push(x);
        ps.push(p);
    }
    let r_hat = (sum_nu2_s / used.max(1) as f64).max(1e-300);
    let log_likelihood = -0.5 * (sum_log_s + used as f64 * r_hat.ln());
    // RTS backward pass.
    let mut xsm = xs.clone();
    for k in (0..n - 1).rev() {
        let Some(pinv) = inv3(&ps_pred[k + 1]) else {
            continue;
        };
        let c = mul(&mul(&ps[k], &transpose(&fs[k + 1])), &pinv);
        let d = [0, 1, 2].map(|i| xsm[k + 1][i] - xs_pred[k + 1][i]);
        let corr = mv(&c, &d);
        xsm[k] = [0, 1, 2].map(|i| xs[k][i] + corr[i]);
    }
    Smoothed {
        theta: xsm.iter().map(|v| v[0]).collect(),
        omega: xsm.iter().map(|v| v[1]).collect(),
        alpha: xsm.iter().map(|v| v[2]).collect(),
        log_likelihood,
    }
}

/// λ maximising the profile likelihood (log grid, then golden section on log λ).
pub fn choose_lambda(t: &[f64], y: &[f64]) -> f64 {
    let n = y.len();
    let hbar = (t[n - 1] - t[0]) / (n - 1) as f64;
    let ll = |log_l: f64| smooth(t, y, log_l.exp()).log_likelihood;
    let base = -6.0 * hbar.ln();
    let grid: Vec<f64> = (0..=28)
        .map(|i| base + (-10.0 + 0.5 * i as f64) * std::f64::consts::LN_10)
        .collect();
    let vals: Vec<f64> = grid.iter().map(|&g| ll(g)).collect();
    let best = (0..grid.len())
        .max_by(|&a, &b| vals[a].total_cmp(&vals[b]))
        .unwrap_or(0);
    let lo = grid[best.saturating_sub(1)];
    let hi = grid[(best + 1).min(grid.len() - 1)];
    crate::numeric::minimize::golden_section_max(ll, lo, hi, 30).exp()
}

/// (σ_ω/σ_θ, σ_α/σ_θ) for uniform steps `h` and ratio `lambda`, from the impulse response.
pub fn noise_gain(h: f64, lambda: f64) -> (f64, f64) {
    // Smoother time scale ≈ λ^(−1/6); make the sequence long enough for the response to die out.
    let frames_per_scale = lambda.powf(-1.0 / 6.0) / h;
    let half = (20.0 * frames_per_scale).clamp(50.0, 5000.0) as usize;
    let n = 2 * half + 1;
    let t: Vec<f64> = (0..n).map(|k| k as f64 * h).collect();
    let mut y = vec![0.0; n];
    y[half] = 1.0;
    let s = smooth(&t, &y, lambda);
    let norm = |v: &[f64]| v.iter().map(|x| x * x).sum::<f64>().sqrt();
    (norm(&s.omega), norm(&s.alpha))
}
