//! What a diagnosis found, as data: the ranked candidates with their refits and bootstrap, the
//! pairs set aside, the second look, the candidates not told from the nominal, and the
//! [`Diagnosis`] that holds them; and the pure steps that fill a candidate's uncertainty from its
//! refits ([`pool_refits`]) and from footages simulated at its values ([`widen_by_footages`]).
//! The diagnosis's run (`pipeline::diagnose`) fills these; `diagnose::report` writes them.

use super::cells::Cells;
use super::fit::{self, Evaluated};
use super::gap::{seed_limited, CellGap, GapMap};
use super::nominal::Aligned;
use super::plan;
use super::verdict::{self, Verdict};
use crate::scenario::effects::Effect;

/// The evaluation seeds were raised because the first comparison was short of seeds.
#[derive(Debug, Clone)]
pub struct SeedEscalation {
    pub from_seeds: usize,
    pub to_seeds: usize,
    /// The cells that were significant only in the limit of unlimited seeds, on `from_seeds`.
    pub cells: Vec<CellGap>,
}

/// One ranked candidate.
#[derive(Debug, Clone)]
pub struct Ranked {
    pub evaluated: Evaluated,
    /// 1 − D_k / D₀.
    pub shrink: f64,
    /// Penalised shrink (the ranking score).
    pub score: f64,
    /// Other candidates the data cannot tell apart from this one (filled for the best).
    pub group: Vec<String>,
    /// Per-cell shrink for the cells with a gap.
    pub cell_shrink: Vec<(crate::diagnose::cells::CellKey, f64)>,
    /// The second fit on fresh seeds that measured the fit's own noise (the best candidate
    /// only, single or pair; its stated ± include it).
    pub refit: Option<Refit>,
    /// The footages simulated at its stated values that measured the footage's own noise (the
    /// best candidate only; its stated ± include it).
    pub bootstrap: Option<Bootstrap>,
}

impl Ranked {
    /// Each stated value's 95 % interval, one list per effect in [`Effect::params`] order
    /// ([`crate::diagnose::fit_noise::interval95`]): its σ² holds the refits' spread (s²/n on
    /// n − 1 degrees of freedom, `Ranked::refit`) and, where the bootstrap widened it, the
    /// footages' spread (on B − 1, `Ranked::bootstrap`); the rest, the fits' curvature, counts
    /// as known.
    pub fn intervals95(&self) -> Vec<Vec<Option<crate::diagnose::fit_noise::Interval95>>> {
        self.evaluated
            .effects
            .iter()
            .enumerate()
            .map(|(i, f)| {
                let pools = match &self.refit {
                    Some(Refit::Done {
                        runs,
                        first_values,
                        stds_before,
                        ..
                    }) => {
                        let runs: Vec<(&[f64], &[f64])> = runs
                            .iter()
                            .map(|run| (of_effect(&run.values, i), of_effect(&run.stds, i)))
                            .collect();
                        crate::diagnose::fit_noise::pools(
                            (of_effect(first_values, i), of_effect(stds_before, i)),
                            &runs,
                        )
                    }
                    _ => Vec::new(),
                };
                let found = match &self.bootstrap {
                    Some(Bootstrap::Done { found, .. }) => {
                        found.get(i).cloned().unwrap_or_default()
                    }
                    _ => Vec::new(),
                };
                f.effect
                    .params()
                    .iter()
                    .zip(f.values.iter().zip(&f.stds))
                    .enumerate()
                    .map(|(j, (spec, (&value, &std)))| {
                        let mut estimated = Vec::with_capacity(2);
                        if let Some(pool) = pools.get(j) {
                            estimated.push((pool.seed_var, pool.seed_dof));
                        }
                        if let Some(Some(fits)) = found.get(j) {
                            estimated.push((fits.estimated_var, fits.footages.saturating_sub(1)));
                        }
                        crate::diagnose::fit_noise::interval95(value, std, &estimated, spec.valid)
                    })
                    .collect()
            })
            .collect()
    }
}

/// The `i`-th effect's list of `lists` (empty when missing).
fn of_effect(lists: &[Vec<f64>], i: usize) -> &[f64] {
    lists.get(i).map_or(&[], Vec::as_slice)
}

/// The best candidate fitted on footages simulated at its stated values on fresh data seeds,
/// each measured and fitted as the real footage was (on the same fit seeds): the parametric
/// bootstrap of the footage's own noise ([`crate::diagnose::fit_noise::from_footage_fits`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Bootstrap {
    /// At least two footages fitted: their data seeds and values (one list per effect, in
    /// [`Effect::params`] order, per footage); per parameter what they show (`None` where
    /// nothing is stated: an undetermined parameter, fewer than two finite fits); and the
    /// values and ± before they changed them.
    Done {
        seeds: Vec<u64>,
        values: Vec<Vec<Vec<f64>>>,
        found: Vec<Vec<Option<crate::diagnose::fit_noise::FootageFits>>>,
        values_before: Vec<Vec<f64>>,
        stds_before: Vec<Vec<f64>>,
        /// Why fewer footages than asked were fitted (the time cap, a failed fit), if so.
        short: Option<String>,
    },
    /// Not run: the time cap (`--max-minutes`) was reached first.
    TimeCap,
    /// Not run: switched off (`--bootstrap 0`).
    Off,
    /// Fewer than two footages could be fitted: the ± stand without it.
    Failed(String),
}

/// A candidate fitted again on sets of fit seeds disjoint from the first fit's and from each
/// other's ([`crate::diagnose::fit_noise`]).
#[derive(Debug, Clone, PartialEq)]
pub enum Refit {
    /// The refits made (at least one), and the first fit's values and ± before they were
    /// pooled with them: one list per effect of the candidate, in [`Effect::params`] order.
    Done {
        runs: Vec<RefitRun>,
        first_values: Vec<Vec<f64>>,
        stds_before: Vec<Vec<f64>>,
        /// Why fewer refits than asked were made (the time cap, a failed fit), if so.
        short: Option<String>,
    },
    /// Not run: the time cap (`--max-minutes`) was reached first.
    TimeCap,
    /// Not run: switched off (`--refits 0`).
    Off,
    /// The first refit failed; the first fit's values and ± stand without it.
    Failed(String),
}

/// One refit: its fit seeds, and the values and ± it found, one list per effect.
#[derive(Debug, Clone, PartialEq)]
pub struct RefitRun {
    pub seeds: Vec<u64>,
    pub values: Vec<Vec<f64>>,
    pub stds: Vec<Vec<f64>>,
}

/// A pair fitted and set aside: its second effect's fitted `values` do nothing, so the pair
/// would be the single `first` under another name, judged on re-rolled seed noise.
#[derive(Debug, Clone, PartialEq)]
pub struct SkippedPair {
    pub first: Effect,
    pub second: Effect,
    /// The second effect's fitted values, in [`Effect::params`] order.
    pub values: Vec<f64>,
    pub why: SkipReason,
}

/// Why a second effect does nothing.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum SkipReason {
    /// Every parameter at its neutral, one of them its search's end
    /// ([`Effect::does_nothing_at`]).
    AtNeutral,
    /// Its fit did not lower the fit objective (Σ z² over both effects' signature cells, fit
    /// seeds) by more than [`plan::SECOND_DROP_PER_PARAM`] per parameter below the nominal's
    /// own setting of it, the first effect at its values in both ([`plan::second_lowers_fit`]).
    NoLowerThanNominal {
        fitted_sum_z2: f64,
        nominal_sum_z2: f64,
    },
}

/// A second look for a second cause ([`plan::second_look_effects`]): the single effect that
/// explained the gap, the remaining gap D it left (no significant cell, yet above
/// [`plan::SECOND_LOOK_REMAINDER`]), and each second effect tried with the remaining gap of
/// the pair and whether the pair was kept (it closed at least [`plan::SECOND_LOOK_CLOSE`] of
/// the single's remainder; a pair not kept is not ranked).
#[derive(Debug, Clone, PartialEq)]
pub struct SecondLook {
    pub first: Effect,
    pub remainder: f64,
    pub tried: Vec<(Effect, f64, plan::SecondLookPair)>,
}

impl SecondLook {
    /// Whether `r` is a pair led by this look's single (two effects, the single first): the
    /// only pairs a second look ranks are those it kept.
    pub fn is_pair_of_single(&self, r: &Ranked) -> bool {
        r.evaluated.effects.len() == 2 && r.evaluated.effects[0].effect == self.first
    }

    /// Index in `ranking` of the single this look started from, when `best` is a pair it kept:
    /// that single is told apart from the pair, since the pair closed what it left.
    pub fn single_behind(&self, ranking: &[Ranked], best: usize) -> Option<usize> {
        if !ranking.get(best).is_some_and(|r| self.is_pair_of_single(r)) {
            return None;
        }
        ranking.iter().position(|r| {
            r.evaluated.effects.len() == 1 && r.evaluated.effects[0].effect == self.first
        })
    }
}

/// A candidate that closed the gap with fitted values the data cannot tell from the nominal's
/// ([`verdict::tells_from_nominal`]): the verdict does not rest on it.
#[derive(Debug, Clone, PartialEq)]
pub struct NotDistinct {
    /// Index into [`Diagnosis::ranking`].
    pub ranked: usize,
    /// Each compared value: its effect, its parameter's name, and where it lies.
    pub values: Vec<(Effect, &'static str, verdict::FromNominal)>,
    /// The values of the effects whose fit measured none
    /// ([`verdict::undetermined_at_search_end`]).
    pub undetermined: Vec<Undetermined>,
    /// Its held-out check, when it failed it (the held-out check).
    pub held_out: Option<crate::diagnose::holdout::judge::HeldOut>,
}

impl NotDistinct {
    /// Why it was set aside: a fit that measured no value, values restating the nominal, else a
    /// prediction of what its fit did not use that failed.
    pub fn set_aside(&self) -> verdict::SetAside {
        if !self.undetermined.is_empty() {
            verdict::SetAside::Undetermined
        } else if self.held_out.is_some() {
            verdict::SetAside::NotPredicted
        } else {
            verdict::SetAside::NotDistinct
        }
    }
}

/// A fitted value the data did not determine, at an end of its search range (low, high).
#[derive(Debug, Clone, PartialEq)]
pub struct Undetermined {
    pub effect: Effect,
    pub param: &'static str,
    pub value: f64,
    pub search: (f64, f64),
}

/// Everything a diagnosis found.
#[derive(Debug, Clone)]
pub struct Diagnosis {
    pub verdict: Verdict,
    pub aligned: Aligned,
    pub nominal_gap: GapMap,
    pub real_cells: Cells,
    /// Best first; singles, and the best pair when one was tried.
    pub ranking: Vec<Ranked>,
    /// Index into `ranking` of the candidate the verdict rests on.
    pub best: Option<usize>,
    /// Candidates screened out (no significant cell in their signature), with their share of
    /// the gap.
    pub screened_out: Vec<(Effect, f64)>,
    /// Candidates not fitted because their share of the gap (an upper bound on their shrink) is
    /// below the best fitted score by more than the group margin, with that share.
    pub bounded_out: Vec<(Effect, f64)>,
    /// Candidates not tried because of `--max-minutes`.
    pub not_tried: Vec<Effect>,
    /// Candidates that cannot be judged from the input (image effects from a corner track, a
    /// video codec on frames with an odd side).
    pub not_judged: Vec<Effect>,
    pub pair_tried: bool,
    /// Pairs the pair stage fitted and set aside because their second effect came out where it
    /// does nothing ([`Effect::does_nothing_at`]).
    pub skipped_pairs: Vec<SkippedPair>,
    /// Set when the best single explained the gap yet left more than noise leaves, held by
    /// other candidates' cells, and pairs were tried for a second cause.
    pub second_look: Option<SecondLook>,
    /// Candidates that closed the gap with values the data cannot tell from the nominal's,
    /// in the order they were judged; when the last is [`Diagnosis::best`], no candidate
    /// explained the gap.
    pub not_distinct: Vec<NotDistinct>,
    /// Set when the evaluation seeds were raised before judging.
    pub escalation: Option<SeedEscalation>,
    pub seeds: Vec<u64>,
    pub fit_seeds: Vec<u64>,
    pub simulations: usize,
    pub frames: usize,
    pub detected: usize,
    pub has_images: bool,
    pub nyquist_hz: f64,
    /// Time shift between the real frames' timestamps and the aligned motion, s.
    pub real_time_shift_s: f64,
    /// The held-out check of the candidate the verdict rests on, when it explained the gap
    /// otherwise (the held-out check).
    pub held_out: Option<crate::diagnose::holdout::judge::HeldOut>,
    pub elapsed_s: f64,
}

impl Diagnosis {
    /// Cells of the nominal gap still short of significance only for lack of seeds (on the
    /// final seeds): with no gap found, the report names them and how many seeds might settle
    /// them.
    pub fn seed_limited(&self) -> Vec<CellGap> {
        seed_limited(&self.nominal_gap)
    }
}

/// Widens each stated ± of `best` by the spread of its fits on the bootstrap footages
/// (`done`, at least two), takes a significant bias they show off its value, and returns what
/// they found ([`crate::diagnose::fit_noise::from_footage_fits`]).
pub fn widen_by_footages(
    best: &mut Ranked,
    done: Vec<(u64, Vec<fit::Fitted>)>,
    short: Option<String>,
    fps_hz: f64,
) -> Bootstrap {
    let values_before: Vec<Vec<f64>> = best
        .evaluated
        .effects
        .iter()
        .map(|f| f.values.clone())
        .collect();
    let stds_before: Vec<Vec<f64>> = best
        .evaluated
        .effects
        .iter()
        .map(|f| f.stds.clone())
        .collect();
    let mut found = Vec::with_capacity(stds_before.len());
    for (i, f) in best.evaluated.effects.iter_mut().enumerate() {
        let mut of_effect = Vec::with_capacity(f.values.len());
        let specs = f.effect.params_on(fps_hz);
        for (j, (value, std)) in f.values.iter_mut().zip(f.stds.iter_mut()).enumerate() {
            // The σ pooled into the stated one: the first fit's and each refit's.
            let curvature: Vec<f64> = match &best.refit {
                Some(Refit::Done {
                    runs, stds_before, ..
                }) => std::iter::once(stds_before.get(i).and_then(|v| v.get(j)))
                    .chain(runs.iter().map(|r| r.stds.get(i).and_then(|v| v.get(j))))
                    .flatten()
                    .copied()
                    .collect(),
                _ => vec![*std],
            };
            let values: Vec<f64> = done
                .iter()
                .filter_map(|(_, fits)| fits.get(i).and_then(|g| g.values.get(j)).copied())
                .collect();
            let spec = specs.get(j);
            let valid = spec.map_or((f64::NEG_INFINITY, f64::INFINITY), |p| p.valid);
            let search = spec.map_or((f64::NEG_INFINITY, f64::INFINITY), |p| p.search);
            let fits = crate::diagnose::fit_noise::from_footage_fits(
                *value, *std, &curvature, &values, valid, search,
            );
            if let Some(fits) = fits {
                *value = fits.value;
                *std = fits.std;
            }
            of_effect.push(fits);
        }
        found.push(of_effect);
    }
    Bootstrap::Done {
        seeds: done.iter().map(|(seed, _)| *seed).collect(),
        values: done
            .into_iter()
            .map(|(_, fits)| fits.into_iter().map(|f| f.values).collect())
            .collect(),
        found,
        values_before,
        stds_before,
        short,
    }
}

/// Pools each effect's values and ± of `first` with the same candidate's refits on other
/// seeds (`runs`, at least one; [`crate::diagnose::fit_noise::pooled`]), and returns what the
/// refits found.
pub fn pool_refits(
    first: &mut Evaluated,
    runs: Vec<(Vec<u64>, Vec<fit::Fitted>)>,
    short: Option<String>,
) -> Refit {
    let first_values: Vec<Vec<f64>> = first.effects.iter().map(|f| f.values.clone()).collect();
    let stds_before: Vec<Vec<f64>> = first.effects.iter().map(|f| f.stds.clone()).collect();
    for (i, f) in first.effects.iter_mut().enumerate() {
        let refits: Vec<(&[f64], &[f64])> = runs
            .iter()
            .filter_map(|(_, fits)| fits.get(i))
            .inspect(|again| debug_assert_eq!(again.effect, f.effect))
            .map(|again| (again.values.as_slice(), again.stds.as_slice()))
            .collect();
        (f.values, f.stds) = crate::diagnose::fit_noise::pooled((&f.values, &f.stds), &refits);
    }
    Refit::Done {
        runs: runs
            .into_iter()
            .map(|(seeds, fits)| RefitRun {
                seeds,
                values: fits.iter().map(|f| f.values.clone()).collect(),
                stds: fits.into_iter().map(|f| f.stds).collect(),
            })
            .collect(),
        first_values,
        stds_before,
        short,
    }
}

/// Name of a candidate: `a` or `a+b`.
pub fn candidate_name(e: &Evaluated) -> String {
    e.effects
        .iter()
        .map(|f| f.effect.name())
        .collect::<Vec<_>>()
        .join("+")
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;
    use crate::diagnose::gap::GapOptions;
    use crate::diagnose::verdict::Outcome;

    /// `effect` fitted at `values` ± `stds`, as a candidate's fit reports it.
    pub(crate) fn fitted(effect: Effect, values: Vec<f64>, stds: Vec<f64>) -> fit::Fitted {
        assert_eq!(values.len(), effect.params().len());
        fit::Fitted {
            effect,
            values,
            stds,
            method: "by hand".into(),
            simulations: 0,
            runout_form: None,
            kind: fit::FitKind::Measured,
        }
    }

    /// A candidate of these fits, with no gap left.
    pub(crate) fn evaluated(effects: Vec<fit::Fitted>) -> Evaluated {
        let params = effects.iter().map(|f| f.values.len()).sum();
        Evaluated {
            effects,
            gap: GapMap {
                cells: Vec::new(),
                total: 0.0,
                options: GapOptions::default(),
            },
            outcome: Outcome {
                remaining: 0.0,
                params,
                significant_left: 0,
            },
        }
    }
}
