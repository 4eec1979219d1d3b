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
//!
//! An explanation must also differ from the nominal ([`tells_from_nominal`]): a candidate whose
//! fitted values all lie within [`DISTINCT_Z`] standard uncertainties of the values at which it
//! would leave the nominal as it is closes the gap by the luck of the seeds it was judged on,
//! not by the effect, and the verdict does not rest on it. And it must predict what its fit did
//! not use ([`super::holdout`]): a candidate that matched the cells' magnitudes but not the
//! footage's waveform is a flexible stand-in for something outside the vocabulary.

use crate::scenario::effects::same_search_point;
use serde::Serialize;

/// Penalised shrink the best candidate must reach for `explained`.
pub const EXPLAINED_SHRINK: f64 = 0.7;
/// Penalty added to a candidate's remaining gap per fitted parameter (units of D).
pub const PENALTY_PER_PARAM: f64 = 2.0;
/// Candidates this close to the best (in penalised shrink) form a group with it.
pub const GROUP_MARGIN: f64 = 0.1;
/// Standard uncertainties by which at least one fitted value of an explanation must lie from
/// the value at which its effect would leave the nominal as it is ([`tells_from_nominal`]).
///
/// One, not two: this asks whether the fit found any effect at all, not whether it is
/// significant, and near the detection limit the right effect's fit can be under 2 σ from
/// doing nothing (a weak JPEG compression at 1.9 σ in the self-check,
/// commit `dd41046`). Over the 86 explained cases of the self-check suites run before it, one candidate fell under it: a lens k1 = 0.006 ± 0.010 that "explained" a weak
/// optical blur's footage by closing one side-length cell on fresh seeds, the one wrong
/// attribution among them.
pub const DISTINCT_Z: f64 = 1.0;

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

/// The penalised shrink `o`'s parameters allow at best on a gap of total `d0`: its [`shrink`]
/// had it closed all of the gap.
pub fn best_possible_shrink(d0: f64, o: &Outcome) -> f64 {
    shrink(
        d0,
        &Outcome {
            remaining: 0.0,
            ..o.clone()
        },
    )
}

/// Whether `o` closed at least [`EXPLAINED_SHRINK`] of a gap of total `d0` before its penalty
/// and left no significant cell, yet no fit with its parameters could explain that gap: even
/// closing all of it scores under [`EXPLAINED_SHRINK`] ([`best_possible_shrink`]), that is
/// D₀ < [`PENALTY_PER_PARAM`]·p / (1 − [`EXPLAINED_SHRINK`]). Such a gap is too small to single
/// out an effect; a shrink short of the bar with a penalty that leaves room is not this case.
pub fn too_small_to_attribute(d0: f64, o: &Outcome) -> bool {
    d0 > 0.0
        && o.significant_left == 0
        && 1.0 - o.remaining / d0 >= EXPLAINED_SHRINK
        && best_possible_shrink(d0, o) < EXPLAINED_SHRINK
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

/// One fitted value beside the value at which its effect would leave the nominal as it is.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FromNominal {
    pub value: f64,
    /// One standard uncertainty of `value` (infinite when the data do not determine it).
    pub std: f64,
    pub nominal: f64,
}

impl FromNominal {
    /// |value − nominal| in standard uncertainties (infinite for an exact value off the
    /// nominal's, 0 at it).
    pub fn z(&self) -> f64 {
        let d = (self.value - self.nominal).abs();
        if d == 0.0 {
            0.0
        } else {
            d / self.std
        }
    }
}

/// Whether fitted values tell their candidate from the nominal: `Some(false)` when every one
/// lies within [`DISTINCT_Z`] standard uncertainties of its nominal value, `Some(true)` when
/// one lies farther, `None` when it cannot be said: nothing to compare, or a value the data do
/// not determine (a sensor noise whose full well and read noise trade along a valley: their
/// combination is measured, not each).
pub fn tells_from_nominal(values: &[FromNominal]) -> Option<bool> {
    tells_from_nominal_at(values, DISTINCT_Z)
}

/// [`tells_from_nominal`] with another threshold: `Some(true)` when one value lies at least
/// `z_min` standard uncertainties from its nominal value.
pub fn tells_from_nominal_at(values: &[FromNominal], z_min: f64) -> Option<bool> {
    if values.is_empty()
        || values
            .iter()
            .any(|v| !v.std.is_finite() || !v.value.is_finite())
    {
        return None;
    }
    Some(values.iter().any(|v| v.z() >= z_min))
}

/// Whether a fit left its effect undetermined at the edge of what it searched: every value
/// without a finite uncertainty (the objective has no curvature there) and at an end of its
/// search range `search` (low, high). Such a fit measured no value: what it closed, switching the
/// effect on closed, at whatever value the search stopped. An overrotation, whose switch turns the
/// wheel dynamics on, "explained" a withheld axis runout with its friction at the search's upper
/// end and no ± when the runout was excluded from the candidates (commit `7284926`).
/// A valley's values (a full well and read noise that trade) are not at an end together.
pub fn undetermined_at_search_end(values: &[f64], stds: &[f64], search: &[(f64, f64)]) -> bool {
    !values.is_empty()
        && values.len() == stds.len()
        && values.len() == search.len()
        && stds.iter().all(|s| !s.is_finite())
        && values.iter().zip(search).all(|(&v, &(lo, hi))| {
            same_search_point(v, lo, (lo, hi)) || same_search_point(v, hi, (lo, hi))
        })
}

/// The candidate the verdict rests on, and what was judged on the way.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Choice {
    /// Index of the chosen candidate (the first of the order when none tells itself from the
    /// nominal: the report still reads it first).
    pub best: Option<usize>,
    /// Whether the chosen one's values tell it from the nominal ([`tells_from_nominal`]).
    pub distinct: Option<bool>,
    /// Candidates that explained the gap with values that do not, in the order judged.
    pub not_distinct: Vec<usize>,
}

/// Chooses the candidate the verdict rests on: the first of `order` (best first), unless it
/// explains the gap with values that do not tell it from the nominal; then the next ones that
/// explain it, up to `max_tries` of them, the first whose values do. `distinct` judges one
/// candidate (it may refit it first) and is called once for the first and once per candidate
/// tried after it.
pub fn choose(
    order: &[usize],
    explains: impl Fn(usize) -> bool,
    mut distinct: impl FnMut(usize) -> Option<bool>,
    max_tries: usize,
) -> Choice {
    let Some(&first) = order.first() else {
        return Choice {
            best: None,
            distinct: None,
            not_distinct: Vec::new(),
        };
    };
    let tells = distinct(first);
    let mut choice = Choice {
        best: Some(first),
        distinct: tells,
        not_distinct: Vec::new(),
    };
    if !(explains(first) && tells == Some(false)) {
        return choice;
    }
    choice.not_distinct.push(first);
    for &next in order
        .iter()
        .skip(1)
        .filter(|&&i| explains(i))
        .take(max_tries)
    {
        let tells = distinct(next);
        if tells == Some(false) {
            choice.not_distinct.push(next);
            continue;
        }
        choice.best = Some(next);
        choice.distinct = tells;
        return choice;
    }
    choice
}

/// The verdict from the nominal comparison's significant cells and the best outcome (single or
/// pair), with whether its fitted values tell it from the nominal ([`tells_from_nominal`]; only
/// `Some(false)` counts against it; a candidate that failed the held-out check,
/// [`super::holdout`], is set aside the same way).
pub fn verdict(
    significant_nominal: usize,
    d0: f64,
    best: Option<&Outcome>,
    distinct: Option<bool>,
) -> Verdict {
    if significant_nominal == 0 {
        return Verdict::NoGap;
    }
    match best {
        Some(o) if explains(d0, o) && distinct != Some(false) => Verdict::Explained,
        _ => Verdict::Unexplained,
    }
}

/// Why a verdict is what it is, one of a fixed list: `diagnosis.json`'s `remainder.reason`, for a
/// program that reads the verdict, and the case `diagnosis.md`'s answer states in words.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum VerdictReason {
    /// `no_gap`: no compared cell differs significantly.
    NoSignificantCell,
    /// `explained`: the best candidate closes enough and leaves no significant cell.
    Explained,
    /// `unexplained`: the candidate that closed the gap has fitted values that do not tell it
    /// from the nominal (its seeds closed the gap, not the effect).
    NotDistinctFromNominal,
    /// `unexplained`: the candidate that closed the gap measured no value
    /// ([`undetermined_at_search_end`]): its switch closed it.
    Undetermined,
    /// `unexplained`: the candidate that closed the gap did not predict what its fit did not use
    /// ([`super::holdout`]).
    NotPredictedHeldOut,
    /// `unexplained`: the best closed the gap and left no cell, but the gap is smaller than its
    /// parameters' penalty ([`too_small_to_attribute`]).
    TooSmallToAttribute,
    /// `unexplained`: the best candidate closes too little or leaves a significant cell.
    NotClosed,
    /// `unexplained`: no candidate was fitted (none has a signature in the differing cells).
    NoCandidate,
}

impl VerdictReason {
    pub fn as_str(self) -> &'static str {
        match self {
            VerdictReason::NoSignificantCell => "no_significant_cell",
            VerdictReason::Explained => "explained",
            VerdictReason::NotDistinctFromNominal => "not_distinct_from_nominal",
            VerdictReason::Undetermined => "undetermined_at_search_end",
            VerdictReason::NotPredictedHeldOut => "not_predicted_held_out",
            VerdictReason::TooSmallToAttribute => "too_small_to_attribute",
            VerdictReason::NotClosed => "not_closed",
            VerdictReason::NoCandidate => "no_candidate",
        }
    }
}

/// Why the candidate a verdict rests on was set aside ([`choose`]'s `not_distinct`).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum SetAside {
    /// Its values lie within [`DISTINCT_Z`] uncertainties of the nominal's.
    NotDistinct,
    /// Its fit measured no value ([`undetermined_at_search_end`]).
    Undetermined,
    /// It closed the gap but did not predict what its fit did not use ([`super::holdout`]).
    NotPredicted,
}

/// The reason for verdict `v` on a gap of total `d0`, given the outcome of the candidate it rests
/// on (none when no candidate was fitted) and why that candidate was set aside, if it was.
pub fn reason(
    v: Verdict,
    d0: f64,
    best: Option<&Outcome>,
    set_aside: Option<SetAside>,
) -> VerdictReason {
    match (v, best) {
        (Verdict::NoGap, _) => VerdictReason::NoSignificantCell,
        (Verdict::Explained, Some(_)) => VerdictReason::Explained,
        (_, Some(_)) if set_aside == Some(SetAside::Undetermined) => VerdictReason::Undetermined,
        (_, Some(_)) if set_aside == Some(SetAside::NotDistinct) => {
            VerdictReason::NotDistinctFromNominal
        }
        (_, Some(_)) if set_aside == Some(SetAside::NotPredicted) => {
            VerdictReason::NotPredictedHeldOut
        }
        (_, Some(o)) if too_small_to_attribute(d0, o) => VerdictReason::TooSmallToAttribute,
        (_, Some(_)) => VerdictReason::NotClosed,
        (_, None) => VerdictReason::NoCandidate,
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
        assert_eq!(verdict(0, 0.0, None, None), Verdict::NoGap);
        assert_eq!(
            verdict(3, 100.0, Some(&o(5.0, 1, 0)), None),
            Verdict::Explained
        );
        assert_eq!(
            verdict(3, 100.0, Some(&o(5.0, 1, 0)), Some(true)),
            Verdict::Explained
        );
        // Closes 95 %, but its values do not tell it from the nominal.
        assert_eq!(
            verdict(3, 100.0, Some(&o(5.0, 1, 0)), Some(false)),
            Verdict::Unexplained
        );
        // Closes 95 % but leaves a significant cell.
        assert_eq!(
            verdict(3, 100.0, Some(&o(5.0, 1, 1)), None),
            Verdict::Unexplained
        );
        // No cell left but closes only half.
        assert_eq!(
            verdict(3, 100.0, Some(&o(50.0, 1, 0)), None),
            Verdict::Unexplained
        );
        assert_eq!(verdict(3, 100.0, None, None), Verdict::Unexplained);
        assert_eq!(verdict(0, 0.0, None, Some(false)), Verdict::NoGap);
    }

    /// Each reason is the one its verdict and best outcome call for, checked against the
    /// verdict those same inputs give.
    #[test]
    fn every_verdict_states_its_reason() {
        let d0 = 100.0;
        let aside = Some(SetAside::NotDistinct);
        let cases = [
            (0, None, None, VerdictReason::NoSignificantCell),
            (3, Some(o(5.0, 1, 0)), None, VerdictReason::Explained),
            (
                3,
                Some(o(5.0, 1, 0)),
                aside,
                VerdictReason::NotDistinctFromNominal,
            ),
            (
                3,
                Some(o(5.0, 1, 0)),
                Some(SetAside::Undetermined),
                VerdictReason::Undetermined,
            ),
            (
                3,
                Some(o(5.0, 1, 0)),
                Some(SetAside::NotPredicted),
                VerdictReason::NotPredictedHeldOut,
            ),
            (3, Some(o(5.0, 1, 1)), None, VerdictReason::NotClosed),
            (3, Some(o(50.0, 1, 0)), None, VerdictReason::NotClosed),
            (3, None, None, VerdictReason::NoCandidate),
        ];
        for (significant, best, set_aside, want) in cases {
            let distinct = set_aside.map(|_| false);
            let v = verdict(significant, d0, best.as_ref(), distinct);
            assert_eq!(reason(v, d0, best.as_ref(), set_aside), want, "{want:?}");
        }
        // null-24 of `reports/diagnosis-nulls/`: D₀ 4.8, closed all of it with one parameter, no cell left.
        let small = o(0.0, 1, 0);
        let v = verdict(1, 4.8, Some(&small), None);
        assert_eq!(v, Verdict::Unexplained);
        assert_eq!(
            reason(v, 4.8, Some(&small), None),
            VerdictReason::TooSmallToAttribute
        );
        let names: Vec<&str> = [
            VerdictReason::NoSignificantCell,
            VerdictReason::Explained,
            VerdictReason::NotDistinctFromNominal,
            VerdictReason::Undetermined,
            VerdictReason::NotPredictedHeldOut,
            VerdictReason::TooSmallToAttribute,
            VerdictReason::NotClosed,
            VerdictReason::NoCandidate,
        ]
        .map(VerdictReason::as_str)
        .to_vec();
        for (i, n) in names.iter().enumerate() {
            assert!(!names[..i].contains(n), "{n} twice");
        }
    }

    /// A fit is undetermined only with every value at a search end and no finite ±.
    #[test]
    fn a_fit_without_curvature_at_its_search_end_is_undetermined() {
        let friction = [(0.003, 0.3)];
        assert!(undetermined_at_search_end(
            &[0.29999999999999993],
            &[f64::INFINITY],
            &friction
        ));
        assert!(undetermined_at_search_end(&[0.003], &[f64::NAN], &friction));
        // A finite ±, or a value inside the range: the data measured it.
        assert!(!undetermined_at_search_end(&[0.3], &[0.01], &friction));
        assert!(!undetermined_at_search_end(
            &[0.2],
            &[f64::INFINITY],
            &friction
        ));
        // A valley: one value inside its range, both without ±.
        assert!(!undetermined_at_search_end(
            &[2031.0, 185.0],
            &[f64::INFINITY, f64::INFINITY],
            &[(200.0, 20000.0), (1.0, 185.0)]
        ));
        assert!(!undetermined_at_search_end(&[], &[], &[]));
        assert!(!undetermined_at_search_end(&[0.3], &[], &friction));
    }

    fn fv(value: f64, std: f64, nominal: f64) -> FromNominal {
        FromNominal {
            value,
            std,
            nominal,
        }
    }

    #[test]
    fn an_explanation_must_differ_from_the_nominal() {
        // A lens fitted at k1 = 0.006 ± 0.0103 against a nominal 0: no effect.
        assert_eq!(tells_from_nominal(&[fv(0.00595, 0.0103, 0.0)]), Some(false));
        // A weak compression 1.9 σ below quality 98 is an effect.
        assert_eq!(tells_from_nominal(&[fv(88.0, 5.2, 98.0)]), Some(true));
        // One parameter off the nominal is enough (a tilt about x only).
        assert_eq!(
            tells_from_nominal(&[fv(0.55, 0.18, 0.0), fv(0.05, 0.21, 0.0)]),
            Some(true)
        );
        assert_eq!(
            tells_from_nominal(&[fv(0.1, 0.18, 0.0), fv(0.05, 0.21, 0.0)]),
            Some(false)
        );
        // A refit at the nominal's stated value restates it.
        assert_eq!(tells_from_nominal(&[fv(0.71, 0.05, 0.7)]), Some(false));
        // Undetermined values cannot be judged, nor can nothing.
        assert_eq!(
            tells_from_nominal(&[fv(2e5, f64::INFINITY, 1e6), fv(0.0, 1.0, 0.0)]),
            None
        );
        assert_eq!(tells_from_nominal(&[]), None);
        // An exact value: off the nominal's is distinct, at it is not.
        assert_eq!(tells_from_nominal(&[fv(0.3, 0.0, 0.0)]), Some(true));
        assert_eq!(tells_from_nominal(&[fv(0.0, 0.0, 0.0)]), Some(false));
        // The boundary belongs to the distinct side.
        assert_eq!(tells_from_nominal(&[fv(1.0, 1.0, 0.0)]), Some(true));
        // At another threshold: the weak tilt's first-fit readout, 1.10 ± 0.50 ms against
        // 0.5 ms (1.2 σ), tells at 1 σ, not at 2.
        let readout = [fv(1.099e-3, 4.96e-4, 5e-4)];
        assert_eq!(tells_from_nominal_at(&readout, 1.0), Some(true));
        assert_eq!(tells_from_nominal_at(&readout, 2.0), Some(false));
        assert_eq!(tells_from_nominal_at(&[fv(2.0, 1.0, 0.0)], 2.0), Some(true));
        assert_eq!(tells_from_nominal_at(&[], 2.0), None);
    }

    #[test]
    fn the_verdict_rests_on_the_first_candidate_that_differs_from_the_nominal() {
        let explains = |i: usize| i != 3;
        // The first tells itself apart: only it is judged.
        let mut judged = Vec::new();
        let c = choose(
            &[0, 1, 2],
            explains,
            |i| {
                judged.push(i);
                Some(true)
            },
            3,
        );
        assert_eq!((c.best, c.distinct, judged), (Some(0), Some(true), vec![0]));
        assert!(c.not_distinct.is_empty());
        // It does not: the next that explains and does is chosen (3 does not explain).
        let mut judged = Vec::new();
        let c = choose(
            &[0, 3, 1, 2],
            explains,
            |i| {
                judged.push(i);
                if i == 2 {
                    Some(true)
                } else {
                    Some(false)
                }
            },
            3,
        );
        assert_eq!((c.best, c.distinct), (Some(2), Some(true)));
        assert_eq!((c.not_distinct, judged), (vec![0, 1], vec![0, 1, 2]));
        // None does, or the tries run out: the first stays, not distinct.
        let c = choose(&[0, 1, 2], explains, |_| Some(false), 1);
        assert_eq!((c.best, c.distinct), (Some(0), Some(false)));
        assert_eq!(c.not_distinct, vec![0, 1]);
        // A first that does not explain is kept whatever its values.
        let c = choose(&[3, 0], explains, |_| Some(false), 3);
        assert_eq!(
            (c.best, c.distinct, c.not_distinct),
            (Some(3), Some(false), vec![])
        );
        // A next one that cannot be judged (undetermined values) is taken.
        let c = choose(&[0, 1], explains, |i| (i == 0).then_some(false), 3);
        assert_eq!((c.best, c.distinct), (Some(1), None));
        assert_eq!(choose(&[], explains, |_| None, 3).best, None);
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
