//! Bounded one-dimensional minimisation for parameter fits whose objective is expensive (each
//! evaluation runs simulations): bracket from a start value, then Brent-style steps (parabolic
//! interpolation, golden section when a parabola is not trusted), then a parabola through the
//! best three points for the minimum's curvature (the uncertainty).
//!
//! The search runs on a coordinate u: log10 of the parameter for scale-like parameters, the
//! parameter itself otherwise, always inside [lo, hi]. Deterministic: the same objective values
//! give the same sequence of evaluations.

/// Result of a search.
#[derive(Debug, Clone, PartialEq)]
pub struct SearchResult {
    /// Best parameter value found.
    pub value: f64,
    /// Objective there.
    pub objective: f64,
    /// 1-σ uncertainty of the value from the curvature of the objective (treated as χ²:
    /// Δ = 1 at one σ); infinite when the objective is flat or the minimum sits on a bound.
    pub std: f64,
    /// Every (value, objective) evaluated, in order.
    pub evaluations: Vec<(f64, f64)>,
    /// The bracket the search ended with (low, high value): the minimum lies in it. Narrower
    /// than the tolerance when the search converged; wider when the evaluations ran out first.
    pub bracket: (f64, f64),
}

impl SearchResult {
    /// The standard deviation of a minimum known only to lie somewhere in [`Self::bracket`]
    /// (uniform): what a search that ran out of evaluations adds to the curvature's
    /// uncertainty, which is taken at the best point found and not at the minimum.
    pub fn bracket_std(&self) -> f64 {
        (self.bracket.1 - self.bracket.0).abs() / 12f64.sqrt()
    }
}

/// Search settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SearchOptions {
    pub lo: f64,
    pub hi: f64,
    pub log_scale: bool,
    /// First step in u (decades for log scale).
    pub step_u: f64,
    /// Largest number of objective evaluations.
    pub max_evaluations: usize,
    /// Stop when the bracket is narrower than this in u.
    pub tol_u: f64,
}

impl SearchOptions {
    pub fn new(lo: f64, hi: f64, log_scale: bool) -> Self {
        let (step_u, tol_u) = if log_scale {
            (0.3, 0.02)
        } else {
            (0.15 * (hi - lo), 0.01 * (hi - lo))
        };
        Self {
            lo,
            hi,
            log_scale,
            step_u,
            max_evaluations: 9,
            tol_u,
        }
    }

    fn search_u_of(&self, v: f64) -> f64 {
        if self.log_scale {
            v.max(self.lo).log10()
        } else {
            v
        }
    }

    fn value_of_u(&self, u: f64) -> f64 {
        if self.log_scale {
            10f64.powf(u)
        } else {
            u
        }
    }

    fn bounds_u(&self) -> (f64, f64) {
        (self.search_u_of(self.lo), self.search_u_of(self.hi))
    }
}

/// Minimises `f` over [lo, hi] starting from `start`.
pub fn minimise(mut f: impl FnMut(f64) -> f64, start: f64, o: &SearchOptions) -> SearchResult {
    let (ulo, uhi) = o.bounds_u();
    let clamp = |u: f64| u.clamp(ulo, uhi);
    let mut evals: Vec<(f64, f64)> = Vec::new(); // (u, f)
    let mut eval = |u: f64, evals: &mut Vec<(f64, f64)>| -> f64 {
        let u = clamp(u);
        if let Some(&(_, v)) = evals.iter().find(|(x, _)| (x - u).abs() < 1e-12) {
            return v;
        }
        let v = f(o.value_of_u(u));
        let v = if v.is_finite() { v } else { f64::INFINITY };
        evals.push((u, v));
        v
    };
    let budget = o.max_evaluations.max(3);
    let u0 = clamp(o.search_u_of(if start.is_finite() {
        start
    } else {
        0.5 * (o.lo + o.hi)
    }));
    let f0 = eval(u0, &mut evals);
    let (mut a, mut b, mut c) = (u0 - o.step_u, u0, u0 + o.step_u);
    let mut fa = eval(a, &mut evals);
    let mut fb = f0;
    let mut fc = eval(c, &mut evals);
    // Expand towards the lower side until the middle point is the lowest (or a bound is hit).
    while (fa < fb || fc < fb) && evals.len() < budget {
        if fa < fc {
            if clamp(a) <= ulo {
                break;
            }
            (c, fc) = (b, fb);
            (b, fb) = (a, fa);
            a = b - 2.0 * (c - b);
            fa = eval(a, &mut evals);
        } else {
            if clamp(c) >= uhi {
                break;
            }
            (a, fa) = (b, fb);
            (b, fb) = (c, fc);
            c = b + 2.0 * (b - a);
            fc = eval(c, &mut evals);
        }
    }
    let (mut a, mut c) = (clamp(a), clamp(c));
    let (mut fa, mut fc) = (eval(a, &mut evals), eval(c, &mut evals));
    // Brent-style: a parabolic step through (a, b, c) when it lands well inside the bracket,
    // a golden-section step otherwise. The objective is a sum of squared z-scores, close to a
    // parabola near its minimum, so parabolic steps reach the minimum in a few evaluations where
    // golden section alone shrinks the bracket by only 0.618 each.
    const R: f64 = 0.381_966_011_250_105_1;
    let mut last_was_parabolic = false;
    while evals.len() < budget && (c - a) > o.tol_u {
        let parabolic = if last_was_parabolic {
            None
        } else {
            parabola_vertex((a, fa), (b, fb), (c, fc))
                .filter(|&x| x > a + 0.5 * o.tol_u && x < c - 0.5 * o.tol_u)
                .map(|x| {
                    // Never evaluate (almost) at b again: step at least half the tolerance away.
                    if (x - b).abs() < 0.5 * o.tol_u {
                        if c - b > b - a {
                            b + 0.5 * o.tol_u
                        } else {
                            b - 0.5 * o.tol_u
                        }
                    } else {
                        x
                    }
                })
        };
        last_was_parabolic = parabolic.is_some();
        let x = parabolic.unwrap_or(if (c - b) > (b - a) {
            b + R * (c - b)
        } else {
            b - R * (b - a)
        });
        let fx = eval(x, &mut evals);
        if fx < fb {
            if x > b {
                (a, fa) = (b, fb);
            } else {
                (c, fc) = (b, fb);
            }
            (b, fb) = (x, fx);
        } else if x > b {
            (c, fc) = (x, fx);
        } else {
            (a, fa) = (x, fx);
        }
    }
    // The best point in order of u (the first of equal objectives), as its curvature is taken.
    let mut sorted = evals.clone();
    sorted.sort_by(|p, q| p.0.total_cmp(&q.0));
    let (best, fbest) = sorted
        .iter()
        .copied()
        .min_by(|p, q| p.1.total_cmp(&q.1))
        .unwrap_or((u0, f0));
    let value = o.value_of_u(best);
    let std = std_from_curvature(&evals, best, o);
    let (lo, hi) = (o.value_of_u(a.min(c)), o.value_of_u(a.max(c)));
    SearchResult {
        value,
        objective: fbest,
        std,
        bracket: (lo, hi),
        evaluations: evals.iter().map(|&(u, v)| (o.value_of_u(u), v)).collect(),
    }
}

/// Half the spread of the values whose objective lies within `delta` of the lowest
/// (`points`: (value, objective) pairs; non-finite objectives ignored): the profile interval
/// the evaluations themselves show, Δ = `delta`. For a parabola sampled densely it is the σ of
/// its curvature at Δ = 1, and sparse samples only narrow it, so it is a floor for that σ. It
/// matters where the objective is simulated on a few seeds and flat: neighbouring evaluations
/// then scatter by more than the curvature between them, and their parabola can be far narrower
/// than the region the objective does not tell apart. Zero when one point alone lies within.
pub fn profile_half_width(points: &[(f64, f64)], delta: f64) -> f64 {
    let lowest = points
        .iter()
        .map(|p| p.1)
        .filter(|f| f.is_finite())
        .fold(f64::INFINITY, f64::min);
    let (lo, hi) = points
        .iter()
        .filter(|p| p.1.is_finite() && p.1 <= lowest + delta)
        .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), p| {
            (lo.min(p.0), hi.max(p.0))
        });
    if hi > lo {
        0.5 * (hi - lo)
    } else {
        0.0
    }
}

/// The 1-σ uncertainty of the parameter at `at_value` from the curvature of another objective
/// evaluated at the same points (`points`: (value, objective) pairs, e.g. a correlated χ² beside
/// the Σ z² that [`minimise`] searched): the parabola through `at_value` and its nearest
/// evaluated neighbours, Δ = 1 at σ. Infinite when `at_value` has no neighbour on either side
/// or the parabola does not open upwards.
pub fn curvature_std_about(points: &[(f64, f64)], at_value: f64, o: &SearchOptions) -> f64 {
    let evals: Vec<(f64, f64)> = points
        .iter()
        .map(|&(v, f)| {
            (
                o.search_u_of(v),
                if f.is_finite() { f } else { f64::INFINITY },
            )
        })
        .collect();
    std_from_curvature(&evals, o.search_u_of(at_value), o)
}

/// σ in parameter units from the parabola through (u_at, f there) and the nearest evaluated
/// neighbours of u_at in `evals` ((u, f) pairs).
fn std_from_curvature(evals: &[(f64, f64)], u_at: f64, o: &SearchOptions) -> f64 {
    let mut sorted = evals.to_vec();
    sorted.sort_by(|p, q| p.0.total_cmp(&q.0));
    let Some(i) = sorted.iter().position(|&(u, _)| (u - u_at).abs() < 1e-12) else {
        return f64::INFINITY;
    };
    let (ub, fb) = sorted[i];
    let mut std_u = f64::INFINITY;
    if i > 0 && i + 1 < sorted.len() {
        let (x0, y0) = sorted[i - 1];
        let (x2, y2) = sorted[i + 1];
        // Second derivative of the parabola through three points.
        let d = 2.0 * ((y2 - fb) / (x2 - ub) - (fb - y0) / (ub - x0)) / (x2 - x0);
        if d > 0.0 {
            // f ≈ f_min + (d/2)(u − u*)²; Δf = 1 at σ.
            std_u = (2.0 / d).sqrt();
        }
    }
    if !std_u.is_finite() {
        f64::INFINITY
    } else if o.log_scale {
        o.value_of_u(ub) * std::f64::consts::LN_10 * std_u
    } else {
        std_u
    }
}

/// The most of a parameter's uncertainty [`std_with_other_free`] lets the other parameter's
/// freedom explain: ρ² is capped here (σ grows at most tenfold). A cross-curvature at or past
/// ±1 from one noisy evaluation says the two are not told apart along some line, not by how
/// much; the caller says the ± is a lower bound then.
pub const COUPLING_SQ_MAX: f64 = 0.99;

/// The normalised cross-curvature ρ of a χ² (Δ = 1 at σ) in two parameters a and b, each
/// searched with the other held, from one evaluation off both search lines.
///
/// b was searched first, at a = a₀: its minimum b\*, curvature σ_b. Then a was searched at
/// b = b\*: its minimum a\*, curvature σ_a, χ² there `at_minimum`. At (a\* + s·σ_a, b\* + t·σ_b)
/// the χ² is `off`. With `o` = (a\* − a₀)/σ_a the quadratic model (each line's minimum where
/// its search found it) gives
///
///   off − at_minimum = s² + t² + 2ρ(o + s)t,
///
/// and the two estimates' correlation is |ρ| (ρ is the Hessian's, of the opposite sign). `None`
/// when the evaluation says nothing about ρ (the point on the b line, (o + s)·t = 0) or a value
/// is not finite.
pub fn coupling_from_off_point(at_minimum: f64, off: f64, s: f64, t: f64, o: f64) -> Option<f64> {
    let lever = 2.0 * (o + s) * t;
    let rho = (off - at_minimum - s * s - t * t) / lever;
    (lever.abs() >= 1e-9 && rho.is_finite()).then_some(rho)
}

/// A parameter's σ with another parameter free, from its σ with that one held and their
/// coupling ρ ([`coupling_from_off_point`]): σ / √(1 − ρ²), ρ² capped at [`COUPLING_SQ_MAX`];
/// the flag says the cap bit.
pub fn std_with_other_free(std_held: f64, rho: f64) -> (f64, bool) {
    let rho_sq = rho * rho;
    let capped = rho_sq > COUPLING_SQ_MAX;
    (
        std_held / (1.0 - rho_sq.min(COUPLING_SQ_MAX)).sqrt(),
        capped,
    )
}

/// The vertex of the parabola through three points of distinct abscissae, when it opens
/// upwards.
fn parabola_vertex(p0: (f64, f64), p1: (f64, f64), p2: (f64, f64)) -> Option<f64> {
    let ((x0, y0), (x1, y1), (x2, y2)) = (p0, p1, p2);
    if !(y0.is_finite() && y1.is_finite() && y2.is_finite()) {
        return None;
    }
    let num = (x1 - x0).powi(2) * (y1 - y2) - (x1 - x2).powi(2) * (y1 - y0);
    let den = (x1 - x0) * (y1 - y2) - (x1 - x2) * (y1 - y0);
    // Upward opening: the second divided difference is positive.
    let curvature = ((y2 - y1) / (x2 - x1) - (y1 - y0) / (x1 - x0)) / (x2 - x0);
    if den == 0.0 || curvature.is_nan() || curvature <= 0.0 {
        return None;
    }
    let x = x1 - 0.5 * num / den;
    x.is_finite().then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn finds_the_minimum_of_a_log_parabola_from_far_away() {
        // χ²-like objective: ((log10 v − log10 0.8) / 0.05)² + 3 → σ_u = 0.05 decades.
        let f = |v: f64| ((v.log10() - 0.8f64.log10()) / 0.05).powi(2) + 3.0;
        let mut o = SearchOptions::new(0.01, 10.0, true);
        o.max_evaluations = 14;
        let r = minimise(f, 0.05, &o);
        assert!((r.value / 0.8 - 1.0).abs() < 0.06, "{r:?}");
        assert!(r.evaluations.len() <= 14);
        let expected_std = 0.8 * std::f64::consts::LN_10 * 0.05;
        assert!(
            (r.std / expected_std - 1.0).abs() < 0.35,
            "{} vs {expected_std}",
            r.std
        );
    }

    #[test]
    fn nine_evaluations_locate_a_smooth_minimum_to_a_few_percent() {
        // The fits' budget: a χ²-like objective that is not an exact parabola in log10(v)
        // (quartic term), minimum up to 0.6 decades from the start.
        for (truth, start) in [(0.8f64, 0.2f64), (0.03, 0.12), (2.5, 1.0)] {
            let f = |v: f64| {
                let d = (v.log10() - truth.log10()) / 0.05;
                d * d + 0.02 * d.powi(4) + 3.0
            };
            let mut o = SearchOptions::new(0.01, 10.0, true);
            o.max_evaluations = 9;
            let r = minimise(f, start, &o);
            assert!(
                (r.value / truth - 1.0).abs() < 0.03,
                "truth {truth} from {start}: {r:?}"
            );
            assert!(r.evaluations.len() <= 9);
        }
    }

    #[test]
    fn linear_search_stops_at_a_bound() {
        let f = |v: f64| (v - 5.0).powi(2);
        let r = minimise(f, 0.0, &SearchOptions::new(-0.3, 0.3, false));
        assert!((r.value - 0.3).abs() < 1e-12, "{r:?}");
        assert!(r.std.is_infinite());
    }

    #[test]
    fn non_finite_objective_values_are_avoided() {
        let f = |v: f64| if v > 2.0 { f64::NAN } else { (v - 1.5).powi(2) };
        let mut o = SearchOptions::new(0.1, 10.0, true);
        o.max_evaluations = 12;
        let r = minimise(f, 1.0, &o);
        assert!((r.value - 1.5).abs() < 0.15, "{r:?}");
    }

    #[test]
    fn another_objective_at_the_same_points_gives_its_own_curvature() {
        // A χ² and the same χ² at a quarter of its weight: twice the uncertainty, about the
        // minimum the first search found.
        let f = |v: f64| ((v.log10() - 0.8f64.log10()) / 0.05).powi(2) + 3.0;
        let mut o = SearchOptions::new(0.01, 10.0, true);
        o.max_evaluations = 14;
        let r = minimise(f, 0.3, &o);
        let same: Vec<(f64, f64)> = r.evaluations.iter().map(|&(v, _)| (v, f(v))).collect();
        let s = curvature_std_about(&same, r.value, &o);
        assert!((s / r.std - 1.0).abs() < 1e-9, "{s} vs {}", r.std);
        let quarter: Vec<(f64, f64)> = r
            .evaluations
            .iter()
            .map(|&(v, _)| (v, f(v) / 4.0))
            .collect();
        let s = curvature_std_about(&quarter, r.value, &o);
        assert!((s / (2.0 * r.std) - 1.0).abs() < 1e-9, "{s} vs {}", r.std);
        // No neighbour on one side, or a flat objective: no curvature.
        let flat: Vec<(f64, f64)> = r.evaluations.iter().map(|&(v, _)| (v, 1.0)).collect();
        assert_eq!(curvature_std_about(&flat, r.value, &o), f64::INFINITY);
        assert_eq!(
            curvature_std_about(&same[..1], same[0].0, &o),
            f64::INFINITY
        );
        assert_eq!(curvature_std_about(&same, 123.0, &o), f64::INFINITY);
    }

    #[test]
    fn the_profile_interval_spans_the_points_within_delta_of_the_lowest() {
        // A parabola of σ = 2 about 5, sampled on a fine grid: the half-width is σ.
        let dense: Vec<(f64, f64)> = (0..=4000)
            .map(|k| {
                let x = k as f64 * 0.0025;
                (x, 3.0 + ((x - 5.0) / 2.0).powi(2))
            })
            .collect();
        assert!((profile_half_width(&dense, 1.0) - 2.0).abs() < 0.01);
        // A flat objective with noise: every point within 1 of the lowest counts, wherever the
        // lowest lies (240 to 1600); 100, 1.1 above the lowest, and 50, far above, do not; NaN
        // is ignored.
        let flat = [
            (100.0, 15.4),
            (240.0, 14.9),
            (400.0, 14.3),
            (460.0, 15.0),
            (800.0, 14.5),
            (1600.0, 15.2),
            (50.0, 35.0),
            (70.0, f64::NAN),
        ];
        assert_eq!(profile_half_width(&flat, 1.0), 680.0);
        assert_eq!(profile_half_width(&[(1.0, 2.0)], 1.0), 0.0);
        assert_eq!(profile_half_width(&[], 1.0), 0.0);
    }

    #[test]
    fn a_search_out_of_evaluations_says_so_in_its_bracket() {
        // A minimum at 2.0 in [0, 5], a narrow χ² (σ = 0.01): three evaluations cannot close the
        // bracket; fifteen can.
        let f = |x: f64| ((x - 2.0) / 0.01).powi(2);
        let mut o = SearchOptions::new(0.0, 5.0, false);
        o.max_evaluations = 15;
        let r = minimise(f, 1.0, &o);
        assert!(r.bracket.0 <= 2.0 && 2.0 <= r.bracket.1, "{r:?}");
        assert!(r.bracket.1 - r.bracket.0 <= o.tol_u + 1e-12, "{r:?}");
        o.max_evaluations = 5;
        let r = minimise(f, 1.0, &o);
        assert!(r.bracket.0 <= 2.0 && 2.0 <= r.bracket.1, "{r:?}");
        assert!(r.bracket_std() > (r.value - 2.0).abs() / 4.0, "{r:?}");
        assert!(r.bracket.1 - r.bracket.0 > o.tol_u, "{r:?}");
    }

    /// A quadratic χ² in two parameters, Δ = 1 at σ along each with the other held: the
    /// coupling one evaluation off the two search lines recovers is the χ²'s own, and the
    /// σ with the other free is the inverse Hessian's.
    fn two_parameter_chi2(
        rho: f64,
        (sa, sb): (f64, f64),
        (a0, b0): (f64, f64),
    ) -> impl Fn(f64, f64) -> f64 {
        move |a: f64, b: f64| {
            let (x, y) = ((a - a0) / sa, (b - b0) / sb);
            3.0 + x * x + y * y + 2.0 * rho * x * y
        }
    }

    proptest::proptest! {
        #[test]
        fn the_coupling_off_both_search_lines_is_the_chi2s_own(
            rho in -0.97f64..0.97,
            sa in 0.01f64..10.0,
            sb in 0.01f64..10.0,
            a_start in -5.0f64..5.0,
            s in proptest::prop_oneof![-3.0f64..-0.5, 0.5f64..3.0],
            t in proptest::prop_oneof![-3.0f64..-0.5, 0.5f64..3.0],
        ) {
            let (a0, b0) = (1.0, -2.0);
            let f = two_parameter_chi2(rho, (sa, sb), (a0, b0));
            // b searched at a = a_start·σ_a: its minimum; then a searched there.
            let a_held = a0 + a_start * sa;
            let b_star = b0 - rho * (a_held - a0) / sa * sb;
            let a_star = a0 - rho * (b_star - b0) / sb * sa;
            let o = (a_star - a_held) / sa;
            proptest::prop_assume!(((o + s) * t).abs() > 0.1);
            let off = f(a_star + s * sa, b_star + t * sb);
            let got = coupling_from_off_point(f(a_star, b_star), off, s, t, o).unwrap();
            proptest::prop_assert!((got - rho).abs() < 1e-9 * (1.0 + o.abs()), "{got} vs {rho}");
            // σ_a with b free: Δχ² = 1 along the valley's floor.
            let (free, capped) = std_with_other_free(1.0, got);
            proptest::prop_assert!(!capped || rho * rho > COUPLING_SQ_MAX - 1e-6);
            let a_free = a0 + free * sa;
            let b_floor = b0 - rho * (a_free - a0) / sa * sb;
            proptest::prop_assert!((f(a_free, b_floor) - 4.0).abs() < 1e-6);
        }
    }

    #[test]
    fn a_point_on_the_held_line_says_nothing_and_a_coupling_past_one_is_capped() {
        assert_eq!(coupling_from_off_point(1.0, 5.0, -2.0, 2.0, 2.0), None);
        assert_eq!(coupling_from_off_point(1.0, 5.0, 2.0, 0.0, 0.0), None);
        assert_eq!(coupling_from_off_point(1.0, f64::NAN, 2.0, 2.0, 0.0), None);
        assert_eq!(std_with_other_free(2.0, 0.0), (2.0, false));
        let (s, capped) = std_with_other_free(1.0, -1.3);
        assert!(capped);
        assert!((s - 10.0).abs() < 1e-9, "{s}");
    }
}
