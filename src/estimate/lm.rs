//! Levenberg–Marquardt least squares with a forward-difference Jacobian (or one the caller
//! computes, [`minimise_with_jacobian`]), on `nalgebra` matrices:
//! fits of a few parameters (edge profiles, motion models) up to the pose fit's ~160 (one angle
//! per pose, ~1200 corner residuals). Also returns the Jacobian's normal matrix at the solution,
//! so callers get the usual covariance s²·(JᵀJ)⁻¹.

use crate::numeric::linalg;
use nalgebra::{DMatrix, DVector};

/// The minimum found and what is needed for its uncertainty.
#[derive(Debug, Clone, PartialEq)]
pub struct LmFit {
    pub params: Vec<f64>,
    /// Residuals at `params`.
    pub residuals: Vec<f64>,
    /// Σ residual².
    pub cost: f64,
    /// JᵀJ at `params`.
    pub jtj: DMatrix<f64>,
    pub iterations: usize,
}

impl LmFit {
    /// Covariance s²·(JᵀJ)⁻¹ with s² = cost / (n − p); `None` when JᵀJ is singular or there are
    /// no degrees of freedom.
    pub fn covariance(&self) -> Option<DMatrix<f64>> {
        let (n, p) = (self.residuals.len(), self.params.len());
        if n <= p {
            return None;
        }
        let s2 = self.cost / (n - p) as f64;
        Some(linalg::invert(&self.jtj)? * s2)
    }

    /// 1-σ standard errors with the residual σ taken as at least `min_sigma` (for data whose
    /// errors have a known floor the residuals may not show).
    pub fn std_errors_with_floor(&self, min_sigma: f64) -> Vec<f64> {
        let (n, p) = (self.residuals.len(), self.params.len());
        let s2 = if n > p {
            (self.cost / (n - p) as f64).max(min_sigma * min_sigma)
        } else {
            f64::INFINITY
        };
        match linalg::invert(&self.jtj) {
            Some(inv) => (0..p).map(|i| (s2 * inv[(i, i)]).max(0.0).sqrt()).collect(),
            None => vec![f64::INFINITY; p],
        }
    }

    /// 1-σ standard errors (infinite where the covariance is unavailable).
    pub fn std_errors(&self) -> Vec<f64> {
        match self.covariance() {
            Some(c) => (0..self.params.len())
                .map(|i| c[(i, i)].max(0.0).sqrt())
                .collect(),
            None => vec![f64::INFINITY; self.params.len()],
        }
    }
}

/// Minimises Σ r(p)² from `start`. `residuals(p, out)` fills `out` (always the same length) and
/// returns false where `p` is not admissible. `steps[i]` is the forward-difference step of
/// parameter i. `None` when the start is not admissible, no finite cost is found or the
/// residuals change length.
pub fn minimise(
    residuals: &dyn Fn(&[f64], &mut Vec<f64>) -> bool,
    start: &[f64],
    steps: &[f64],
    max_iterations: usize,
) -> Option<LmFit> {
    let forward = |x: &[f64], r: &[f64]| jacobian(residuals, x, r, steps);
    minimise_with_jacobian(residuals, &forward, start, steps, max_iterations)
}

/// ∂r/∂p at a point `p` whose residuals are `r` ([`minimise_with_jacobian`]).
pub type JacobianFn<'a> = dyn Fn(&[f64], &[f64]) -> Option<DMatrix<f64>> + 'a;

/// [`minimise`] with the Jacobian given: `jacobian(p, r)` is ∂r/∂p at `p`, whose residuals are
/// `r` (one row per residual, one column per parameter; `None` where it cannot be formed).
/// `steps[i]` is only the scale of parameter i below which a step counts as converged.
pub fn minimise_with_jacobian(
    residuals: &dyn Fn(&[f64], &mut Vec<f64>) -> bool,
    jacobian: &JacobianFn<'_>,
    start: &[f64],
    steps: &[f64],
    max_iterations: usize,
) -> Option<LmFit> {
    let mut x = start.to_vec();
    let mut r = Vec::new();
    if !residuals(&x, &mut r) {
        return None;
    }
    let mut cost = sum_sq(&r);
    if !cost.is_finite() {
        return None;
    }
    let mut lambda = 1e-3;
    let mut iterations = 0;
    let mut jac = jacobian(&x, &r)?;
    // Whether `jac` was computed at the current `x` (then the final one is the same, bit for
    // bit: the Jacobian is a pure function of `x` and its residuals).
    let mut jac_at_x = true;
    let mut trial = Vec::with_capacity(r.len());
    while iterations < max_iterations {
        iterations += 1;
        let (jtj, jtr) = linalg::normal_equations(&jac, &DVector::from_column_slice(&r));
        let neg = -jtr;
        let mut improved = false;
        while lambda < 1e12 {
            let mut damped = jtj.clone();
            for i in 0..damped.nrows() {
                damped[(i, i)] += lambda * jtj[(i, i)].max(1e-12);
            }
            let Some(step) = linalg::solve(&damped, &neg) else {
                lambda *= 10.0;
                continue;
            };
            let x_new: Vec<f64> = x.iter().zip(step.iter()).map(|(a, b)| a + b).collect();
            if residuals(&x_new, &mut trial) && trial.len() == r.len() {
                let c = sum_sq(&trial);
                if c.is_finite() && c <= cost {
                    let small = step
                        .iter()
                        .zip(steps)
                        .all(|(s, h)| s.abs() < 1e-3 * h.abs().max(1e-15));
                    let gain = cost - c;
                    x = x_new;
                    jac_at_x = false;
                    std::mem::swap(&mut r, &mut trial);
                    cost = c;
                    lambda = (lambda / 10.0).max(1e-12);
                    improved = !(small || gain <= 1e-12 * cost.max(1e-300));
                    break;
                }
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
        jac = jacobian(&x, &r)?;
        jac_at_x = true;
    }
    if !jac_at_x {
        jac = jacobian(&x, &r)?;
    }
    let jtj = jac.tr_mul(&jac);
    Some(LmFit {
        params: x,
        residuals: r,
        cost,
        jtj,
        iterations,
    })
}

fn sum_sq(r: &[f64]) -> f64 {
    r.iter().map(|v| v * v).sum()
}

/// Forward-difference Jacobian: one row per residual, one column per parameter; `None` when a
/// parameter can be stepped neither way or the residuals change length.
fn jacobian(
    residuals: &dyn Fn(&[f64], &mut Vec<f64>) -> bool,
    x: &[f64],
    r: &[f64],
    steps: &[f64],
) -> Option<DMatrix<f64>> {
    let mut jac = DMatrix::zeros(r.len(), x.len());
    let mut buf = Vec::with_capacity(r.len());
    let mut xp = x.to_vec();
    for i in 0..x.len() {
        let mut h = steps[i];
        xp[i] = x[i] + h;
        if !residuals(&xp, &mut buf) {
            // At a bound: difference backwards.
            h = -h;
            xp[i] = x[i] + h;
            if !residuals(&xp, &mut buf) {
                return None;
            }
        }
        xp[i] = x[i];
        if buf.len() != r.len() {
            return None;
        }
        for (dst, (a, b)) in jac.column_mut(i).iter_mut().zip(buf.iter().zip(r)) {
            *dst = (a - b) / h;
        }
    }
    Some(jac)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_an_exponential_and_reports_sensible_errors() {
        let ts: Vec<f64> = (0..40).map(|k| k as f64 * 0.1).collect();
        // Deterministic ±0.01 "noise".
        let ys: Vec<f64> = ts
            .iter()
            .enumerate()
            .map(|(k, t)| 2.0 * (-0.7 * t).exp() + if k % 2 == 0 { 0.01 } else { -0.01 })
            .collect();
        let f = |p: &[f64], out: &mut Vec<f64>| {
            out.clear();
            out.extend(
                ts.iter()
                    .zip(&ys)
                    .map(|(t, y)| p[0] * (-p[1] * t).exp() - y),
            );
            true
        };
        let fit = minimise(&f, &[1.0, 0.2], &[1e-6, 1e-6], 100).unwrap();
        assert!((fit.params[0] - 2.0).abs() < 0.01, "{:?}", fit.params);
        assert!((fit.params[1] - 0.7).abs() < 0.01, "{:?}", fit.params);
        let se = fit.std_errors();
        assert!(
            se.iter().all(|s| s.is_finite() && *s > 0.0 && *s < 0.01),
            "{se:?}"
        );
    }

    #[test]
    fn the_curvature_returned_is_the_one_at_the_solution_on_every_way_out() {
        // Out by the iteration cap (the last Jacobian was taken at x), by convergence (a last
        // small step moved x after it), and from a start already at the minimum (no step taken).
        let ts: Vec<f64> = (0..30).map(|k| k as f64 * 0.1).collect();
        let f = |p: &[f64], out: &mut Vec<f64>| {
            out.clear();
            out.extend(
                ts.iter()
                    .map(|t| p[0] * (-p[1] * t).exp() - 2.0 * (-0.7 * t).exp()),
            );
            true
        };
        let steps = [1e-6, 1e-6];
        for (start, cap) in [([1.0, 0.2], 2), ([1.0, 0.2], 100), ([2.0, 0.7], 100)] {
            let fit = minimise(&f, &start, &steps, cap).unwrap();
            let jac = jacobian(&f, &fit.params, &fit.residuals, &steps).unwrap();
            let jtj = jac.tr_mul(&jac);
            for (got, want) in fit.jtj.iter().zip(jtj.iter()) {
                assert_eq!(got.to_bits(), want.to_bits(), "start {start:?}, cap {cap}");
            }
        }
    }

    #[test]
    fn inadmissible_start_is_refused() {
        let f = |_: &[f64], _: &mut Vec<f64>| false;
        assert!(minimise(&f, &[0.0], &[1e-6], 10).is_none());
    }
}
