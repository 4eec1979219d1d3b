//! Ranking of the fitted candidates and the verdict (pure: numbers in, decision out).
//!
//! - `no_gap`: no cell of the nominal comparison is significant (Benjamini–Hochberg at the gap
//!   map's false-discovery rate).
//! - `explained`: the best candidate (or greedy pair) closes at least [`EXPLAINED_SHRINK`] of the
//!   total gap, after a penalty of [`PENALTY_PER_PARAM`] per fitted parameter, and its own
//!   comparison with the real data has no significant cell left.
//! - `unexplained`: anything else; the remaining significant cells are named.
//!
//! Candidates whose penalised shrink is within [`GROUP_MARGIN`] of the best and that also leave
//! no significant cell are reported as a group: the data cannot tell them apart.

use serde::Serialize;

/// Penalised shrink the best candidate must reach for `explained`.
pub const EXPLAINED_SHRINK: f64 = 0.7;
/// Penalty added to a candidate's remaining gap per fitted parameter (units of D).
pub const PENALTY_PER_PARAM: f64 = 2.0;
/// Candidates this close to the best (in penalised shrink) form a group with it.
pub const GROUP_MARGIN: f64 = 0.1;

#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Verdict {
    NoGap,
    Explained,
    Unexplained,
}

impl Verdict {
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::NoGap => "no_gap",
            Verdict::Explained => "explained",
            Verdict::Unexplained => "unexplained",
        }
    }
}

/// What a fitted candidate achieved against the real data.
#[derive(Debug, Clone, PartialEq)]
pub struct Outcome {
    /// Remaining total gap D_k with the candidate fitted.
    pub remaining: f64,
    /// Number of fitted parameters.
    pub params: usize,
    /// Significant cells left with the candidate fitted.
    pub significant_left: usize,
}

/// Penalised shrink 1 − (D_k + penalty·p) / D₀ (0 when there is no gap).
pub fn shrink(d0: f64, o: &Outcome) -> f64 {
    if d0 <= 0.0 {
        return 0.0;
    }
    1.0 - (o.remaining + PENALTY_PER_PARAM * o.params as f64) / d0
}

/// Whether an outcome explains the gap.
pub fn explains(d0: f64, o: &Outcome) -> bool {
    shrink(d0, o) >= EXPLAINED_SHRINK && o.significant_left == 0
}

/// Indices of `outcomes` from best to worst (penalised shrink, then fewer parameters, then
/// input order).
pub fn rank(d0: f64, outcomes: &[Outcome]) -> Vec<usize> {
    let mut order: Vec<usize> = (0..outcomes.len()).collect();
    order.sort_by(|&a, &b| {
        shrink(d0, &outcomes[b])
            .total_cmp(&shrink(d0, &outcomes[a]))
            .then(outcomes[a].params.cmp(&outcomes[b].params))
            .then(a.cmp(&b))
    });
    order
}

/// The candidates grouped with the best one (`ranked[0]`): within [`GROUP_MARGIN`] and also
/// explaining when the best explains (any within the margin otherwise).
pub fn group_of_best(d0: f64, outcomes: &[Outcome], ranked: &[usize]) -> Vec<usize> {
    let Some(&best) = ranked.first() else {
        return Vec::new();
    };
    let s0 = shrink(d0, &outcomes[best]);
    let best_explains = explains(d0, &outcomes[best]);
    ranked
        .iter()
        .copied()
        .filter(|&i| {
            shrink(d0, &outcomes[i]) >= s0 - GROUP_MARGIN
                && (!best_explains || explains(d0, &outcomes[i]))
        })
        .collect()
}

/// The verdict from the nominal comparison's significant cells and the best outcome (single or
/// pair).
pub fn verdict(significant_nominal: usize, d0: f64, best: Option<&Outcome>) -> Verdict {
    if significant_nominal == 0 {
        return Verdict::NoGap;
    }
    match best {
        Some(o) if explains(d0, o) => Verdict::Explained,
        _ => Verdict::Unexplained,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn o(remaining: f64, params: usize, left: usize) -> Outcome {
        Outcome {
            remaining,
            params,
            significant_left: left,
        }
    }

    #[test]
    fn verdicts() {
        assert_eq!(verdict(0, 0.0, None), Verdict::NoGap);
        assert_eq!(verdict(3, 100.0, Some(&o(5.0, 1, 0))), Verdict::Explained);
        // Closes 95 % but leaves a significant cell.
        assert_eq!(verdict(3, 100.0, Some(&o(5.0, 1, 1))), Verdict::Unexplained);
        // No cell left but closes only half.
        assert_eq!(
            verdict(3, 100.0, Some(&o(50.0, 1, 0))),
            Verdict::Unexplained
        );
        assert_eq!(verdict(3, 100.0, None), Verdict::Unexplained);
    }

    #[test]
    fn parameters_are_penalised_and_ties_grouped() {
        let d0 = 100.0;
        let outs = vec![o(10.0, 5, 0), o(12.0, 1, 0), o(60.0, 1, 2), o(14.0, 2, 0)];
        // Penalised: 1 − 20/100 = 0.80, 1 − 14/100 = 0.86, 0.38, 1 − 18/100 = 0.82.
        let r = rank(d0, &outs);
        assert_eq!(r, vec![1, 3, 0, 2]);
        assert_eq!(group_of_best(d0, &outs, &r), vec![1, 3, 0]);
        assert!((shrink(d0, &outs[0]) - 0.8).abs() < 1e-12);
    }
}
