//! Golden-section minimisation of a one-dimensional function on a bracket.

/// The minimiser of `f` on [`lo`, `hi`] by `iterations` golden-section steps (f unimodal there),
/// the middle of the final bracket.
pub fn golden_section_min(f: impl Fn(f64) -> f64, lo: f64, hi: f64, iterations: usize) -> f64 {
    const R: f64 = 0.618_033_988_749_894_8;
    let (mut a, mut b) = (lo, hi);
    let (mut c, mut d) = (b - R * (b - a), a + R * (b - a));
    let (mut fc, mut fd) = (f(c), f(d));
    for _ in 0..iterations {
        if fc < fd {
            b = d;
            d = c;
            fd = fc;
            c = b - R * (b - a);
            fc = f(c);
        } else {
            a = c;
            c = d;
            fc = fd;
            d = a + R * (b - a);
            fd = f(d);
        }
    }
    0.5 * (a + b)
}

#[cfg(test)]
mod tests {
    #[test]
    fn finds_the_minimum_of_a_parabola() {
        let x = super::golden_section_min(|x| (x - 0.37).powi(2), 0.0, 2.0, 60);
        assert!((x - 0.37).abs() < 1e-9, "{x}");
    }
}
