//! One-dimensional minimisation on a bracket: golden-section search, for cheap unimodal
//! objectives that are evaluated a fixed number of times (the diagnosis's expensive,
//! evaluation-counted search is `diagnose::search`, a Brent-style method on top of it).

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

/// The maximiser of `f` on [`lo`, `hi`]: [`golden_section_min`] of −`f`.
pub fn golden_section_max(f: impl Fn(f64) -> f64, lo: f64, hi: f64, iterations: usize) -> f64 {
    golden_section_min(|x| -f(x), lo, hi, iterations)
}

#[cfg(test)]
mod tests {
    use super::*;

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
