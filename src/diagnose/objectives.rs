//! A fit trial's two objectives and the uncertainty a search of them states: the curvature of
//! the shared-tolerance χ² at the points a search evaluated, held no tighter than Σ z²'s own,
//! in quadrature with the spread of the bracket the search ended with. Pure: the trials'
//! simulations are the fitter's (`diagnose::fit`).

use crate::diagnose::search::{curvature_std_about, SearchOptions, SearchResult};

/// One trial's two objectives, from the same simulations. The searches minimise `sum_z2`, Σ z²
/// over the signature cells; the uncertainty they report is the curvature of `shared_chi2`
/// ([`crate::diagnose::gap::shared_tolerance_chi2`]), which counts a channel's tolerance once for all its phases
/// instead of once per phase (Σ z²'s curvature claimed ±37 e⁻ on a full well fitted 47 % low).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Objectives {
    pub sum_z2: f64,
    pub shared_chi2: f64,
}

/// The uncertainty of a search's result `r` over coordinate `i` of `base`: the curvature of the
/// shared-tolerance χ² at the evaluated points (looked up in `evaluated`), never below the
/// search's own (the search's own when the shared χ² has no curvature there), in quadrature
/// with the spread of a minimum anywhere in the bracket the search ended with
/// ([`SearchResult::bracket_std`]): the curvature is taken at the best point found, and a search
/// that ran out of evaluations has not found the minimum (a k1 = −0.3 lens fitted at −0.24 ±
/// 0.0009 on the project's own renderer).
pub fn shared_std(
    evaluated: &[(Vec<f64>, Objectives)],
    base: &[f64],
    i: usize,
    r: &SearchResult,
    o: &SearchOptions,
) -> f64 {
    shared_std_along(
        evaluated,
        |x| {
            let mut v = base.to_vec();
            v[i] = x;
            v
        },
        r,
        o,
    )
}

/// [`shared_std`] for a search along any curve of the parameters: `at` maps the searched value
/// to the parameters evaluated there.
pub fn shared_std_along(
    evaluated: &[(Vec<f64>, Objectives)],
    at: impl Fn(f64) -> Vec<f64>,
    r: &SearchResult,
    o: &SearchOptions,
) -> f64 {
    held_curvature_std(r.std, shared_curvature_std_along(evaluated, at, r, o))
        .hypot(r.bracket_std())
}

/// The curvature part of a searched parameter's ±: the shared-tolerance χ²'s (`shared`), never
/// below Σ z²'s own (`search`, the one the search decides on); Σ z²'s alone where the shared χ²
/// has none (`shared` infinite).
pub fn held_curvature_std(search: f64, shared: f64) -> f64 {
    if shared.is_finite() {
        search.max(shared)
    } else {
        search
    }
}

/// The curvature part of [`shared_std_along`]: the shared-tolerance χ²'s alone, at the
/// search's result (infinite where it has none).
pub fn shared_curvature_std_along(
    evaluated: &[(Vec<f64>, Objectives)],
    at: impl Fn(f64) -> Vec<f64>,
    r: &SearchResult,
    o: &SearchOptions,
) -> f64 {
    let points: Vec<(f64, f64)> = r
        .evaluations
        .iter()
        .filter_map(|&(x, _)| objective_at(evaluated, &at(x)).map(|f| (x, f.shared_chi2)))
        .collect();
    curvature_std_about(&points, r.value, o)
}

/// The objectives already evaluated at exactly `values` (the objective is deterministic: fixed
/// seeds).
pub fn objective_at(evaluated: &[(Vec<f64>, Objectives)], values: &[f64]) -> Option<Objectives> {
    evaluated
        .iter()
        .find(|(w, _)| w.as_slice() == values)
        .map(|&(_, f)| f)
}
