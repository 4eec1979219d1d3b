//! The maximum-likelihood normal behind a clipped, 8-bit histogram (the Tobit model with
//! interval-censored levels): the noise and mean a tone curve's clip and the quantisation hid.
//!
//! Solved by Newton's method in Olsen's parameters (α, β) = (μ/σ, 1/σ), where the negative
//! log-likelihood is convex: every level's probability is Φ(u) − Φ(l) with u and l affine in
//! (α, β), and log(Φ(u) − Φ(l)) is jointly concave in (l, u) (Pratt 1981, "Concavity of the log
//! likelihood", JASA 76:103–106). So the maximum is unique and a damped Newton iteration reaches
//! it from the moments in a handful of steps; a nested golden-section search (the profile over σ
//! of the best μ, each unimodal for the same reason) remains for the histograms where Newton does
//! not settle inside the search box (a likelihood that rises without bound as σ → 0).

use crate::numeric::dist::{normal_cdf, normal_pdf};
use crate::numeric::minimize::golden_section_min;

/// One occupied level: its count and its ends in DN (±∞ for a censored end level).
#[derive(Debug, Clone, Copy)]
struct Cell {
    count: f64,
    lo_dn: f64,
    hi_dn: f64,
}

/// Maximum-likelihood mean and σ (DN, without quantisation) of a normal seen through 8-bit
/// rounding, with the lowest observed level standing for everything below it when `low` is
/// censored and the highest for everything above when `high` is: the Tobit model on a
/// histogram. A level v holds P(v − ½ < x < v + ½); a censored end level c holds P(x < c + ½)
/// (or P(x > c − ½)). `None` for fewer than two occupied levels. σ lies in [0.02, 3·sd + 2] and
/// μ within 4·sd + 2 of the occupied levels (sd the histogram's own).
pub fn censored_normal_fit(hist: &[usize; 256], low: bool, high: bool) -> Option<(f64, f64)> {
    let problem = Problem::of(hist, low, high)?;
    newton(&problem.cells, problem.mean, problem.sd.max(0.3))
        .filter(|&(mu, sigma)| problem.bounds.holds(mu, sigma))
        .or_else(|| Some(golden_search(&problem.cells, &problem.bounds)))
}

/// A histogram as the likelihood sees it: its occupied levels, moments and search box.
struct Problem {
    cells: Vec<Cell>,
    mean: f64,
    sd: f64,
    bounds: SearchBox,
}

impl Problem {
    /// `None` for fewer than two occupied levels.
    fn of(hist: &[usize; 256], low: bool, high: bool) -> Option<Self> {
        let lo = hist.iter().position(|&c| c > 0)?;
        let hi = hist.iter().rposition(|&c| c > 0)?;
        if hi == lo {
            return None;
        }
        let cells: Vec<Cell> = (lo..=hi)
            .filter(|&v| hist[v] > 0)
            .map(|v| Cell {
                count: hist[v] as f64,
                lo_dn: if low && v == lo {
                    f64::NEG_INFINITY
                } else {
                    v as f64 - 0.5
                },
                hi_dn: if high && v == hi {
                    f64::INFINITY
                } else {
                    v as f64 + 0.5
                },
            })
            .collect();
        let n: f64 = cells.iter().map(|c| c.count).sum();
        let mean = (lo..=hi).map(|v| v as f64 * hist[v] as f64).sum::<f64>() / n;
        let sd = ((lo..=hi)
            .map(|v| (v as f64 - mean).powi(2) * hist[v] as f64)
            .sum::<f64>()
            / n)
            .sqrt();
        let reach = 4.0 * sd + 2.0;
        let bounds = SearchBox {
            mu: (lo as f64 - reach, hi as f64 + reach),
            sigma: (0.02, 3.0 * sd + 2.0),
        };
        Some(Self {
            cells,
            mean,
            sd,
            bounds,
        })
    }
}

/// Where μ and σ are searched.
struct SearchBox {
    mu: (f64, f64),
    sigma: (f64, f64),
}

impl SearchBox {
    fn holds(&self, mu: f64, sigma: f64) -> bool {
        (self.mu.0..=self.mu.1).contains(&mu) && (self.sigma.0..=self.sigma.1).contains(&sigma)
    }
}

/// log P(l < Z < u) for the standard normal, the upper tail from the mirrored CDF (both ends
/// near 1 would cancel).
fn log_p(l: f64, u: f64) -> f64 {
    let p = if l > 0.0 {
        normal_cdf(-l) - normal_cdf(-u)
    } else {
        normal_cdf(u) - normal_cdf(l)
    };
    p.max(1e-300).ln()
}

/// The negative log-likelihood at (μ, σ).
fn nll(cells: &[Cell], mu: f64, sigma: f64) -> f64 {
    cells
        .iter()
        .map(|c| -c.count * log_p((c.lo_dn - mu) / sigma, (c.hi_dn - mu) / sigma))
        .sum()
}

/// One end of a level in (α, β): x = β·d − α and φ(x) times 1, d, x, d·x and d²·x.
#[derive(Debug, Clone, Copy, Default)]
struct End {
    x: f64,
    f: f64,
    df: f64,
    xf: f64,
    dxf: f64,
    ddxf: f64,
}

/// The negative log-likelihood in (α, β) = (μ/σ, 1/σ) with its gradient and Hessian.
fn nll_newton_terms(cells: &[Cell], alpha: f64, beta: f64) -> (f64, [f64; 2], [f64; 3]) {
    // One end of a level: its DN coordinate d, standardised x = β·d − α, and φ(x) with the
    // products the derivatives need (all zero at an infinite end, where φ vanishes faster).
    let end = |d: f64| -> End {
        if d.is_finite() {
            let x = beta * d - alpha;
            let f = normal_pdf(x);
            let xf = x * f;
            End {
                x,
                f,
                df: d * f,
                xf,
                dxf: d * xf,
                ddxf: d * d * xf,
            }
        } else {
            End {
                x: d,
                ..End::default()
            }
        }
    };
    let (mut value, mut g, mut h) = (0.0, [0.0; 2], [0.0; 3]);
    for c in cells {
        let (l, u) = (end(c.lo_dn), end(c.hi_dn));
        let lp = log_p(l.x, u.x);
        let p = lp.exp();
        // ∂P/∂α and ∂P/∂β.
        let (pa, pb) = (l.f - u.f, u.df - l.df);
        // ∂²P/∂α², ∂²P/∂α∂β, ∂²P/∂β² (φ′(x) = −x·φ(x)).
        let (paa, pab, pbb) = (l.xf - u.xf, u.dxf - l.dxf, l.ddxf - u.ddxf);
        let (ga, gb) = (pa / p, pb / p);
        value -= c.count * lp;
        g[0] -= c.count * ga;
        g[1] -= c.count * gb;
        h[0] -= c.count * (paa / p - ga * ga);
        h[1] -= c.count * (pab / p - ga * gb);
        h[2] -= c.count * (pbb / p - gb * gb);
    }
    (value, g, h)
}

/// The maximum by damped Newton steps from (μ₀, σ₀); `None` when it does not settle (a
/// singular Hessian, a step that no backtracking makes descend before convergence, or 100
/// steps). The terms at the point a line search accepts are the next step's.
fn newton(cells: &[Cell], mu0: f64, sigma0: f64) -> Option<(f64, f64)> {
    let (mut alpha, mut beta) = (mu0 / sigma0, 1.0 / sigma0);
    let (mut f, mut g, mut h) = nll_newton_terms(cells, alpha, beta);
    for _ in 0..100 {
        let det = h[0] * h[2] - h[1] * h[1];
        if !(f.is_finite() && det.is_finite() && det > 0.0 && h[0] > 0.0) {
            return None;
        }
        let da = -(h[2] * g[0] - h[1] * g[1]) / det;
        let db = -(h[0] * g[1] - h[1] * g[0]) / det;
        if !(da.is_finite() && db.is_finite()) {
            return None;
        }
        // The Newton decrement: about twice how far the value is above the minimum.
        let decrement = -(g[0] * da + g[1] * db);
        if decrement < 1e-20 * (1.0 + f.abs()) {
            return Some((alpha / beta, 1.0 / beta));
        }
        let mut t = 1.0;
        while beta + t * db <= 0.0 {
            t *= 0.5;
        }
        loop {
            let trial = nll_newton_terms(cells, alpha + t * da, beta + t * db);
            // (A value that is not a number is taken: the next step then ends the fit.)
            if trial.0.is_nan() || trial.0 <= f - 1e-4 * t * decrement {
                (f, g, h) = trial;
                break;
            }
            t *= 0.5;
            if t < 1e-12 {
                // No descent left at double precision: settled if the step is already tiny.
                return (decrement < 1e-12 * (1.0 + f.abs())).then(|| (alpha / beta, 1.0 / beta));
            }
        }
        alpha += t * da;
        beta += t * db;
    }
    None
}

/// The nested golden-section search: for each σ the best μ, and σ where that profile is lowest.
fn golden_search(cells: &[Cell], bounds: &SearchBox) -> (f64, f64) {
    let best_mu =
        |sigma: f64| golden_section_min(|mu| nll(cells, mu, sigma), bounds.mu.0, bounds.mu.1, 60);
    let sigma = golden_section_min(
        |s| nll(cells, best_mu(s), s),
        bounds.sigma.0,
        bounds.sigma.1,
        50,
    );
    (best_mu(sigma), sigma)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_distr::{Distribution, Normal};

    /// A histogram of `n` draws of N(μ, σ), rounded and clipped to [black, white].
    fn clipped(mu: f64, sigma: f64, n: usize, black: i64, white: i64, seed: u64) -> [usize; 256] {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(seed);
        let d = Normal::new(mu, sigma).unwrap();
        let mut hist = [0usize; 256];
        for _ in 0..n {
            let v = (d.sample(&mut rng).round() as i64).clamp(black, white);
            hist[v as usize] += 1;
        }
        hist
    }

    /// Newton's answer is the nested search's (a reference that assumes nothing but the
    /// unimodality of each slice) over clipped and unclipped histograms from σ = 0.3 DN (two or
    /// three levels) to 40 DN (most of the range cut), to 1e-4 of the estimate's own sampling
    /// error σ/√n. The search is the less precise of the two: near the minimum the likelihood
    /// is flat, so comparing values of about n rounded to 1e-16 places its argmin only to about
    /// σ·√(1e-15), up to 1e-6 DN here.
    #[test]
    fn newton_agrees_with_the_nested_golden_section_search() {
        let mut rng = rand_pcg::Pcg64::seed_from_u64(11);
        let mut newton_used = 0;
        for case in 0..120 {
            let sigma = 0.3 * (40.0f64 / 0.3).powf(rng.gen::<f64>());
            let mu = rng.gen_range(-30.0..285.0);
            let n = [60, 400, 5000][case % 3];
            let hist = clipped(mu, sigma, n, 0, 255, case as u64);
            let lo = hist.iter().position(|&c| c > 0).unwrap();
            let hi = hist.iter().rposition(|&c| c > 0).unwrap();
            if hi == lo {
                assert_eq!(censored_normal_fit(&hist, lo == 0, hi == 255), None);
                continue;
            }
            let tol = 1e-4 * sigma / (n as f64).sqrt();
            for (low, high) in [(lo == 0, hi == 255), (false, false), (true, false)] {
                let Problem { cells, bounds, .. } = Problem::of(&hist, low, high).unwrap();
                let reference = golden_search(&cells, &bounds);
                let fitted = censored_normal_fit(&hist, low, high).unwrap();
                if let Some(x) = newton(&cells, 128.0, 5.0).filter(|&(m, s)| bounds.holds(m, s)) {
                    newton_used += 1;
                    assert!(
                        (x.0 - reference.0).abs() < tol && (x.1 - reference.1).abs() < tol,
                        "case {case} (μ {mu}, σ {sigma}, {low} {high}): Newton {x:?}, search \
                         {reference:?}"
                    );
                }
                assert!(
                    (fitted.0 - reference.0).abs() < tol && (fitted.1 - reference.1).abs() < tol,
                    "case {case} (μ {mu}, σ {sigma}, {low} {high}): {fitted:?} vs {reference:?}"
                );
            }
        }
        // Newton from a far start settles on nearly every histogram, not only from the moments.
        assert!(newton_used > 250, "{newton_used}");
    }

    /// The truth behind a heavily clipped histogram: 40 % of the draws cut at the black level.
    #[test]
    fn a_clipped_normal_is_recovered_from_its_histogram() {
        let hist = clipped(4.0, 15.0, 200_000, 0, 255, 3);
        let (mu, sigma) = censored_normal_fit(&hist, true, false).unwrap();
        // Sampling error of the MLE on 200k draws is about 0.05 DN for both.
        assert!((mu - 4.0).abs() < 0.2, "{mu}");
        assert!((sigma - 15.0).abs() < 0.2, "{sigma}");
    }

    /// Two levels, both censored, hold any σ equally well: the likelihood has no interior
    /// maximum, Newton does not settle and the search's box decides, as it always did.
    #[test]
    fn a_likelihood_without_a_maximum_falls_back_to_the_search() {
        let mut hist = [0usize; 256];
        hist[0] = 30;
        hist[1] = 50;
        let Problem { cells, bounds, .. } = Problem::of(&hist, true, true).unwrap();
        let fitted = censored_normal_fit(&hist, true, true).unwrap();
        assert_eq!(fitted, golden_search(&cells, &bounds));
    }
}
