//! Derivative-free minimisation for objectives evaluated a fixed number of times: golden-section
//! search on a bracket (one dimension, unimodal), and Nelder–Mead's simplex for a few
//! parameters whose objective is piecewise flat at small scales (a render quantised to 8 bits),
//! where finite-difference gradients fail (the diagnosis's expensive, evaluation-counted search
//! is `diagnose::search`, a Brent-style method on top of the golden section).

/// 1 − 1/φ = (3 − √5)/2: the share of a bracket a golden-section step cuts off.
pub const GOLDEN_CUT: f64 = 0.381_966_011_250_105_1;

/// 1/φ = (√5 − 1)/2, correctly rounded.
const INV_PHI: f64 = 0.618_033_988_749_894_9;

/// The minimiser of `f` on [`lo`, `hi`] by `iterations` golden-section steps (`f` unimodal
/// there): the middle of the final bracket. Evaluates `f` `iterations + 2` times.
pub fn golden_section_min(f: impl Fn(f64) -> f64, lo: f64, hi: f64, iterations: usize) -> f64 {
    let (mut a, mut b) = (lo, hi);
    let (mut c, mut d) = (b - INV_PHI * (b - a), a + INV_PHI * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..iterations {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - INV_PHI * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + INV_PHI * (b - a);
            fd = f(d);
        }
    }
    0.5 * (a + b)
}

/// The minimiser of `f` from `start` by Nelder–Mead (reflection 1, expansion 2, contraction ½,
/// shrink ½; Lagarias et al. 1998, SIAM J. Optim. 9(1)), the first simplex `start` and `start`
/// plus `step[i]` along each axis, until `evaluations` calls of `f` are used (a last shrink may
/// add `start.len()` more). A NaN value
/// counts as +∞ (outside the domain). Returns the best vertex and its value.
pub fn nelder_mead(
    f: impl Fn(&[f64]) -> f64,
    start: &[f64],
    step: &[f64],
    evaluations: usize,
) -> (Vec<f64>, f64) {
    let n = start.len();
    let value = |x: &[f64]| {
        let v = f(x);
        if v.is_nan() {
            f64::INFINITY
        } else {
            v
        }
    };
    let mut simplex: Vec<(Vec<f64>, f64)> = Vec::with_capacity(n + 1);
    simplex.push((start.to_vec(), value(start)));
    for i in 0..n {
        let mut x = start.to_vec();
        x[i] += step[i];
        let v = value(&x);
        simplex.push((x, v));
    }
    let mut used = n + 1;
    let along = |c: &[f64], w: &[f64], t: f64| -> Vec<f64> {
        c.iter().zip(w).map(|(c, w)| c + t * (w - c)).collect()
    };
    while used < evaluations {
        simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
        let worst = simplex[n].clone();
        let centroid: Vec<f64> = (0..n)
            .map(|j| simplex[..n].iter().map(|v| v.0[j]).sum::<f64>() / n as f64)
            .collect();
        let r = along(&centroid, &worst.0, -1.0);
        let fr = value(&r);
        used += 1;
        if fr < simplex[0].1 {
            let e = along(&centroid, &worst.0, -2.0);
            let fe = value(&e);
            used += 1;
            simplex[n] = if fe < fr { (e, fe) } else { (r, fr) };
            continue;
        }
        if fr < simplex[n - 1].1 {
            simplex[n] = (r, fr);
            continue;
        }
        // Contraction: outside when the reflection improved on the worst, inside otherwise.
        let (c, fc) = if fr < worst.1 {
            let c = along(&centroid, &worst.0, -0.5);
            let v = value(&c);
            (c, v)
        } else {
            let c = along(&centroid, &worst.0, 0.5);
            let v = value(&c);
            (c, v)
        };
        used += 1;
        if fc < worst.1.min(fr) {
            simplex[n] = (c, fc);
            continue;
        }
        let best = simplex[0].0.clone();
        for v in simplex.iter_mut().skip(1) {
            v.0 = along(&best, &v.0, 0.5);
            v.1 = value(&v.0);
        }
        used += n;
    }
    simplex.sort_by(|a, b| a.1.total_cmp(&b.1));
    simplex.swap_remove(0)
}

/// The maximiser of `f` on [`lo`, `hi`]: [`golden_section_min`] of −`f`.
pub fn golden_section_max(f: impl Fn(f64) -> f64, lo: f64, hi: f64, iterations: usize) -> f64 {
    golden_section_min(|x| -f(x), lo, hi, iterations)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn nelder_mead_follows_a_curved_valley_and_respects_its_budget() {
        // Rosenbrock's valley, minimum at (1, 1).
        let calls = std::cell::Cell::new(0usize);
        let f = |x: &[f64]| {
            calls.set(calls.get() + 1);
            (1.0 - x[0]).powi(2) + 100.0 * (x[1] - x[0] * x[0]).powi(2)
        };
        let (x, v) = nelder_mead(f, &[-1.2, 1.0], &[0.3, 0.3], 600);
        assert!(
            (x[0] - 1.0).abs() < 1e-3 && (x[1] - 1.0).abs() < 2e-3,
            "{x:?} {v}"
        );
        assert!(calls.get() <= 600 + 2, "{} calls", calls.get());
        // An objective undefined outside x > 0 is kept inside.
        let (x, _) = nelder_mead(
            |x: &[f64]| {
                if x[0] > 0.0 {
                    (x[0] - 0.2).powi(2)
                } else {
                    f64::NAN
                }
            },
            &[1.0],
            &[0.5],
            80,
        );
        assert!((x[0] - 0.2).abs() < 1e-3, "{x:?}");
    }

    #[test]
    fn finds_the_minimum_of_a_parabola() {
        let x = golden_section_min(|x| (x - 0.37).powi(2), 0.0, 2.0, 60);
        assert!((x - 0.37).abs() < 1e-9, "{x}");
        let x = golden_section_max(|x| -(x + 1.2).powi(2), -3.0, 1.0, 60);
        assert!((x + 1.2).abs() < 1e-9, "{x}");
    }

    #[test]
    fn the_constants_are_the_golden_ratios() {
        assert_eq!(INV_PHI, (5f64.sqrt() - 1.0) / 2.0);
        assert!((GOLDEN_CUT - (1.0 - INV_PHI)).abs() < 1e-16);
    }

    #[test]
    fn evaluates_the_objective_iterations_plus_two_times() {
        let calls = std::cell::Cell::new(0);
        golden_section_min(
            |x| {
                calls.set(calls.get() + 1);
                x * x
            },
            -1.0,
            1.0,
            25,
        );
        assert_eq!(calls.get(), 27);
    }
}
