//! A small Levenberg–Marquardt least-squares minimiser with a forward-difference Jacobian, for
//! fits of a handful of parameters (edge profiles, motion models). Also returns the Jacobian's
//! normal matrix at the solution, so callers get the usual covariance s²·(JᵀJ)⁻¹.

use super::linalg;

/// The minimum found and what is needed for its uncertainty.
#[derive(Debug, Clone, PartialEq)]
pub struct LmFit {
    pub params: Vec<f64>,
    /// Residuals at `params`.
    pub residuals: Vec<f64>,
    /// Σ residual².
    pub cost: f64,
    /// JᵀJ at `params`.
    pub jtj: Vec<Vec<f64>>,
    pub iterations: usize,
}

impl LmFit {
    /// Covariance s²·(JᵀJ)⁻¹ with s² = cost / (n − p); `None` when JᵀJ is singular or there are
    /// no degrees of freedom.
    pub fn covariance(&self) -> Option<Vec<Vec<f64>>> {
        let (n, p) = (self.residuals.len(), self.params.len());
        if n <= p {
            return None;
        }
        let s2 = self.cost / (n - p) as f64;
        let inv = linalg::invert(&self.jtj)?;
        Some(
            inv.into_iter()
                .map(|r| r.into_iter().map(|v| v * s2).collect())
                .collect(),
        )
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
            Some(inv) => (0..p).map(|i| (s2 * inv[i][i]).max(0.0).sqrt()).collect(),
            None => vec![f64::INFINITY; p],
        }
    }

    /// 1-σ standard errors (infinite where the covariance is unavailable).
    pub fn std_errors(&self) -> Vec<f64> {
        match self.covariance() {
            Some(c) => (0..self.params.len())
                .map(|i| c[i][i].max(0.0).sqrt())
                .collect(),
            None => vec![f64::INFINITY; self.params.len()],
        }
    }
}

/// Minimises Σ r(p)² from `start`. `residuals(p, out)` fills `out` (always the same length) and
/// returns false where `p` is not admissible. `steps[i]` is the forward-difference step of
/// parameter i. `None` when the start is not admissible or no finite cost is found.
pub fn minimise(
    residuals: &dyn Fn(&[f64], &mut Vec<f64>) -> bool,
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
    let mut jac = jacobian(residuals, &x, &r, steps)?;
    // Whether `jac` was computed at the current `x` (then the final one is the same, bit for
    // bit: the Jacobian is a pure function of `x` and its residuals).
    let mut jac_at_x = true;
    let mut trial = Vec::with_capacity(r.len());
    while iterations < max_iterations {
        iterations += 1;
        let (jtj, jtr) = normal(&jac, &r);
        let mut improved = false;
        while lambda < 1e12 {
            let mut damped = jtj.clone();
            for (i, row) in damped.iter_mut().enumerate() {
                row[i] += lambda * jtj[i][i].max(1e-12);
            }
            let neg: Vec<f64> = jtr.iter().map(|v| -v).collect();
            let Some(step) = linalg::solve(&damped, &neg) else {
                lambda *= 10.0;
                continue;
            };
            let x_new: Vec<f64> = x.iter().zip(&step).map(|(a, b)| a + b).collect();
            if residuals(&x_new, &mut trial) {
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
        jac = jacobian(residuals, &x, &r, steps)?;
        jac_at_x = true;
    }
    if !jac_at_x {
        jac = jacobian(residuals, &x, &r, steps)?;
    }
    let (jtj, _) = normal(&jac, &r);
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

/// Column-major forward-difference Jacobian (`jac[i]` = ∂r/∂p_i).
fn jacobian(
    residuals: &dyn Fn(&[f64], &mut Vec<f64>) -> bool,
    x: &[f64],
    r: &[f64],
    steps: &[f64],
) -> Option<Vec<Vec<f64>>> {
    let mut out = Vec::with_capacity(x.len());
    let mut buf = Vec::with_capacity(r.len());
    for i in 0..x.len() {
        let mut xp = x.to_vec();
        let mut h = steps[i];
        xp[i] += h;
        if !residuals(&xp, &mut buf) {
            // At a bound: difference backwards.
            h = -h;
            xp[i] = x[i] + h;
            if !residuals(&xp, &mut buf) {
                return None;
            }
        }
        out.push(buf.iter().zip(r).map(|(a, b)| (a - b) / h).collect());
    }
    Some(out)
}

/// JᵀJ and Jᵀr. Every entry is the sum of its products in residual order from −0.0, which is
/// what `Iterator::sum` computes ([`normal_by_entry`]), so the result is the same bits. But the
/// entries of a row of JᵀJ are accumulated side by side, one residual at a time, from the
/// Jacobian laid out residual-major: their additions are independent (each entry's sum no
/// longer waits on its own previous addition, and the compiler can vectorise across entries),
/// and a block of rows shares every load. A pose fit has ~160 parameters (one angle per pose)
/// and ~1200 corner residuals: 12 000 entries of 1200 products each, at every iteration.
fn normal(jac: &[Vec<f64>], r: &[f64]) -> (Vec<Vec<f64>>, Vec<f64>) {
    const BLOCK: usize = 4;
    let p = jac.len();
    let n = r.len();
    if jac.iter().any(|row| row.len() != n) {
        return normal_by_entry(jac, r);
    }
    // by_residual[k * p + j] = ∂r_k/∂p_j.
    let mut by_residual = vec![0.0f64; n * p];
    for (j, row) in jac.iter().enumerate() {
        for (k, &v) in row.iter().enumerate() {
            by_residual[k * p + j] = v;
        }
    }
    let mut jtr = vec![-0.0f64; p];
    for (k, &rk) in r.iter().enumerate() {
        for (s, &a) in jtr.iter_mut().zip(&by_residual[k * p..(k + 1) * p]) {
            *s += a * rk;
        }
    }
    let mut jtj = vec![vec![0.0; p]; p];
    let mut acc = vec![-0.0f64; BLOCK * p];
    for i0 in (0..p).step_by(BLOCK) {
        let rows = BLOCK.min(p - i0);
        acc.fill(-0.0);
        for k in 0..n {
            let grad = &by_residual[k * p..(k + 1) * p];
            for b in 0..rows {
                let i = i0 + b;
                let a = grad[i];
                // Entries j ≥ i of row i; row b of the block keeps them at b·p + j.
                for (s, &g) in acc[b * p + i..(b + 1) * p].iter_mut().zip(&grad[i..]) {
                    *s += a * g;
                }
            }
        }
        for b in 0..rows {
            let i = i0 + b;
            for j in i..p {
                let v = acc[b * p + j];
                jtj[i][j] = v;
                jtj[j][i] = v;
            }
        }
    }
    (jtj, jtr)
}

/// [`normal`] one entry at a time: its reference, and what it does with rows of other lengths
/// (each sum then runs over the shorter of its two rows).
fn normal_by_entry(jac: &[Vec<f64>], r: &[f64]) -> (Vec<Vec<f64>>, Vec<f64>) {
    let p = jac.len();
    let mut jtj = vec![vec![0.0; p]; p];
    let mut jtr = vec![0.0; p];
    for i in 0..p {
        jtr[i] = jac[i].iter().zip(r).map(|(a, b)| a * b).sum();
        for j in i..p {
            let v: f64 = jac[i].iter().zip(&jac[j]).map(|(a, b)| a * b).sum();
            jtj[i][j] = v;
            jtj[j][i] = v;
        }
    }
    (jtj, jtr)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn the_one_pass_normal_equations_are_the_per_entry_sums_bit_for_bit(
            p in 1usize..23,
            n in 0usize..60,
            seed in any::<u64>(),
        ) {
            use rand::Rng;
            let mut rng = crate::rng::stream(seed, crate::rng::Stream::MonteCarlo, 0);
            // Magnitudes over many decades, exact zeros of both signs and a rare infinity,
            // where rounding, the sign of zero and NaN would show any change in the order of
            // the additions.
            let mut value = || match rng.gen_range(0..40) {
                0..=3 => 0.0,
                4..=7 => -0.0,
                8 => f64::INFINITY,
                _ => rng.gen_range(-1.0..1.0) * 10f64.powi(rng.gen_range(-8..9)),
            };
            let jac: Vec<Vec<f64>> = (0..p).map(|_| (0..n).map(|_| value()).collect()).collect();
            let r: Vec<f64> = (0..n).map(|_| value()).collect();
            let bits = |(jtj, jtr): (Vec<Vec<f64>>, Vec<f64>)| -> Vec<u64> {
                jtj.into_iter().flatten().chain(jtr).map(f64::to_bits).collect()
            };
            prop_assert_eq!(bits(normal(&jac, &r)), bits(normal_by_entry(&jac, &r)));
        }
    }

    #[test]
    fn rows_of_other_lengths_are_summed_as_before() {
        let jac = vec![vec![1.0, 2.0, 3.0], vec![4.0, 5.0]];
        let r = [1.0, 1.0, 1.0];
        let (jtj, jtr) = normal(&jac, &r);
        assert_eq!(jtr, vec![6.0, 9.0]);
        assert_eq!(jtj, vec![vec![14.0, 14.0], vec![14.0, 41.0]]);
    }

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
            let (jtj, _) = normal(&jac, &fit.residuals);
            for (got, want) in fit.jtj.iter().flatten().zip(jtj.iter().flatten()) {
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
