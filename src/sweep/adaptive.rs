//! Which sweep points get more seeds: those whose 95 % intervals still straddle a decision
//! boundary (see [`super::summary::Decision`]). Pure: summaries in, seed ranges out.

use super::summary::{Decision, PointSummary};

/// For every undecided point below `cap` seeds: (point, first new seed index, seed count to
/// reach), doubling its seeds (at least one more, at most `cap`).
pub fn more_seeds(summary: &[PointSummary], cap: usize) -> Vec<(usize, usize, usize)> {
    summary
        .iter()
        .filter(|s| s.decision == Decision::Undecided && s.status == "ok")
        .filter_map(|s| {
            let n = s.runs_expected;
            let next = (2 * n).max(n + 1).min(cap);
            (next > n).then_some((s.index, n, next))
        })
        .collect()
}
