//! The candidate search of one diagnosis, once the nominal's gap is known: the single
//! candidates fitted in waves (screened, bounded by the best score so far, stopped by the time
//! cap), then pairs (a second effect beside the best single when it does not explain the gap,
//! or a second look when it does but leaves more than noise), then the choice the verdict rests
//! on (refits and bootstrap of the candidate read first, its values against the nominal's, the
//! held-out check).

use super::outlook::Outlook;
use super::shards::StoredFit;
use super::{
    candidate_name, fitting, from_nominal, plan, ranked, report, sort_ranking, to_front, verdict,
    Bootstrap, BootstrapPlan, DiagnoseError, DiagnoseOptions, NotDistinct, Progress, Ranked, Refit,
    RefitPlan, SecondLook, SkipReason, SkippedPair, CONCURRENT_FITS, MAX_DISTINCT_TRIES,
    MAX_SECOND_EFFECTS,
};
use crate::diagnose::fit::{Evaluated, FitError, Fitted, Fitter};
use crate::diagnose::gap::GapMap;
use crate::diagnose::holdout::judge;
use crate::diagnose::simulator::SimMeter;
use crate::diagnose::verdict::{Outcome, Verdict};
use crate::scenario::effects::Effect;
use crate::scenario::Scenario;
use std::cell::RefCell;
use std::time::Instant;

/// What every stage of the search reads: the fitter on the footage, the nominal's gap, the
/// options, the clock and where progress goes; and the outlook of the simulations still to
/// come, revised as the stages decide.
pub(super) struct Stage<'r, 'f, 'p> {
    pub fitter: &'r Fitter<'f>,
    pub nominal_gap: &'r GapMap,
    pub options: &'r DiagnoseOptions,
    pub progress: &'r Progress<'p>,
    pub started: Instant,
    pub meter: &'r SimMeter,
    pub outlook: RefCell<Outlook>,
}

impl Stage<'_, '_, '_> {
    fn d0(&self) -> f64 {
        self.nominal_gap.total
    }

    /// States on the meter that `fits` more candidate fits are planned, then what follows them:
    /// the refits and bootstrap footages of the candidate read first (about a fit each) and its
    /// held-out check (the nominal and it on the evaluation seeds).
    pub fn plan_tail(&self, fits: usize) {
        plan_tail(
            &self.outlook.borrow(),
            self.meter,
            self.nominal_gap,
            self.options,
            self.fitter.eval_seeds.len(),
            fits,
        );
    }

    fn fitted(&self, simulations: usize) {
        self.outlook.borrow_mut().fitted(simulations);
    }

    /// Whether `--max-minutes` has run out.
    fn past_deadline(&self) -> bool {
        self.options
            .max_minutes
            .is_some_and(|m| self.started.elapsed().as_secs_f64() > m * 60.0)
    }
}

/// [`Stage::plan_tail`] before the stage exists: `fits` more candidate fits on `eval_seeds`
/// evaluation seeds, then the refits, bootstrap footages and held-out check after them; nothing
/// when the nominal's gap has no significant cell.
pub(super) fn plan_tail(
    outlook: &Outlook,
    meter: &SimMeter,
    nominal_gap: &GapMap,
    options: &DiagnoseOptions,
    eval_seeds: usize,
    fits: usize,
) {
    if nominal_gap.n_significant() > 0 {
        let tail_fits = options.refits + options.bootstrap;
        outlook.plan(meter, fits + tail_fits, 2 * eval_seeds);
    } else {
        outlook.plan(meter, 0, 0);
    }
}

/// A wave of single candidates fitted (here, on forks) or looked up (in the shards' records).
pub(super) type FitWave<'w> =
    dyn Fn(&[Effect]) -> Vec<Result<(Evaluated, usize), DiagnoseError>> + 'w;

/// The candidates of a diagnosis against its nominal gap.
pub(super) struct Screening {
    /// Every candidate judged, with its share of the gap (an upper bound on its shrink),
    /// largest first.
    pub screened: Vec<(Effect, f64)>,
    /// Those with a significant cell in their signature: the ones fitted, and the work units
    /// of a shard.
    pub units: Vec<Effect>,
    /// Candidates that need the frames, on a corner track.
    pub not_judged: Vec<Effect>,
}

/// Screens the candidates `options` names (all by default) against `nominal_gap`: only
/// effects with a significant cell in their signature are fitted, largest possible share of
/// the gap first; those that need the frames are not judged on a corner track
/// (`has_images` false), nor those that cannot act on `nominal`'s frames
/// ([`Effect::can_act_on`]).
pub(super) fn screen(
    options: &DiagnoseOptions,
    has_images: bool,
    nominal: &Scenario,
    nominal_gap: &GapMap,
) -> Screening {
    let candidates: Vec<Effect> = options
        .effects
        .clone()
        .unwrap_or_else(|| Effect::ALL.to_vec());
    let (candidates, not_judged): (Vec<Effect>, Vec<Effect>) = candidates
        .into_iter()
        .partition(|e| (has_images || !e.needs_frames()) && e.can_act_on(nominal));
    let mut screened: Vec<(Effect, f64)> = candidates
        .iter()
        .map(|&e| (e, plan::screening_share(e, nominal_gap)))
        .collect();
    screened.sort_by(|a, b| b.1.total_cmp(&a.1));
    let units: Vec<Effect> = screened
        .iter()
        .map(|(e, _)| *e)
        .filter(|&e| nominal_gap.n_significant() > 0 && plan::signature_significant(e, nominal_gap))
        .collect();
    Screening {
        screened,
        units,
        not_judged,
    }
}

/// How a wave of single candidates is fitted: here, each on a fork of `fitter`, or looked up
/// in the shards' records (`stored`, when merging).
pub(super) fn wave_fitter<'w>(
    fitter: &'w Fitter<'_>,
    stored: Option<&'w [(Effect, StoredFit)]>,
) -> impl Fn(&[Effect]) -> Vec<Result<(Evaluated, usize), DiagnoseError>> + 'w {
    move |wave: &[Effect]| match stored {
        None => fitter.on_forks(wave, |fork, &e| {
            fork.fit_single(e).map_err(DiagnoseError::from)
        }),
        Some(stored) => wave
            .iter()
            .map(|&e| {
                stored
                    .iter()
                    .find(|(x, _)| *x == e)
                    .map(|(_, r)| r.clone())
                    .ok_or(DiagnoseError::MissingCandidate { effect: e.name() })
            })
            .collect(),
    }
}

/// The single candidates fitted, ranked, and those not fitted with why.
#[derive(Default)]
pub(super) struct Singles {
    pub ranking: Vec<Ranked>,
    pub screened_out: Vec<(Effect, f64)>,
    pub bounded_out: Vec<(Effect, f64)>,
    pub not_tried: Vec<Effect>,
    pub simulations: usize,
}

/// Fits `screened` (candidates with their share of the gap, largest first) in waves of up to
/// [`CONCURRENT_FITS`], each candidate judged against the best score of the waves before it.
pub(super) fn fit_singles(
    st: &Stage,
    screened: Vec<(Effect, f64)>,
    fit_wave: &FitWave,
    from_shards: bool,
) -> Result<Singles, DiagnoseError> {
    let mut out = Singles::default();
    let total = screened.len();
    let mut best_score = f64::NEG_INFINITY;
    let mut queue = screened.into_iter().enumerate().peekable();
    let mut done = 0usize;
    while queue.peek().is_some() {
        let mut wave: Vec<Effect> = Vec::with_capacity(CONCURRENT_FITS);
        let before = done;
        while wave.len() < CONCURRENT_FITS {
            let Some((i, (e, share))) = queue.next() else {
                break;
            };
            done = i + 1;
            if !plan::signature_significant(e, st.nominal_gap) {
                out.screened_out.push((e, share));
                continue;
            }
            // A candidate moves only its signature cells, so its shrink is at most its share;
            // below the best score by more than the group margin it can neither win nor join
            // the best's group.
            if share < best_score - verdict::GROUP_MARGIN {
                out.bounded_out.push((e, share));
                continue;
            }
            if st.past_deadline() {
                out.not_tried.push(e);
                continue;
            }
            wave.push(e);
        }
        if wave.is_empty() {
            continue;
        }
        (st.progress)(&fitting(wave.iter().map(|e| e.name())), before, total);
        for result in fit_wave(&wave) {
            let (evaluated, simulations) = result?;
            out.simulations += simulations;
            if !from_shards {
                st.fitted(simulations);
            }
            let r = ranked(st.nominal_gap, evaluated);
            (st.progress)(
                &format!(
                    "{}: shrink {:.2}, score {:.2}",
                    candidate_name(&r.evaluated),
                    r.shrink,
                    r.score
                ),
                done,
                total,
            );
            best_score = best_score.max(r.score);
            out.ranking.push(r);
        }
        let left = queue
            .clone()
            .filter(|(_, (e, _))| plan::signature_significant(*e, st.nominal_gap))
            .count();
        st.plan_tail(left);
    }
    sort_ranking(st.d0(), &mut out.ranking);
    Ok(out)
}

/// The pairs tried beside the best single.
#[derive(Default)]
pub(super) struct Pairs {
    pub tried: bool,
    pub skipped: Vec<SkippedPair>,
    pub second_look: Option<SecondLook>,
    pub simulations: usize,
}

/// A second effect beside the best single of `ranking` (sorted, best first): when the single
/// does not explain the gap, or when it does but leaves more than noise leaves in another
/// candidate's cells (a second look). The pairs kept join `ranking`, sorted again.
pub(super) fn fit_pairs(
    st: &Stage,
    units: &[Effect],
    ranking: &mut Vec<Ranked>,
) -> Result<Pairs, DiagnoseError> {
    let mut out = Pairs::default();
    let pairs = st.options.pairs;
    let best_explains = ranking
        .first()
        .is_some_and(|r| verdict::explains(st.d0(), &r.evaluated.outcome));
    let look = match ranking.first() {
        Some(r) if pairs && best_explains && r.evaluated.effects.len() == 1 => {
            plan::second_look_effects(
                r.evaluated.effects[0].effect,
                units,
                &r.evaluated.gap,
                MAX_SECOND_EFFECTS,
            )
        }
        _ => Vec::new(),
    };
    // The second look does not need another fitted single: an explaining single that scored
    // high bounds the others out of the single fits, the second cause among them.
    let wanted = pairs && ((!best_explains && ranking.len() >= 2) || !look.is_empty());
    if !wanted || st.past_deadline() {
        return Ok(out);
    }
    out.tried = true;
    let first = ranking[0].evaluated.effects[0].clone();
    let single_remainder = ranking[0].evaluated.gap.total;
    // Chosen on what the first leaves, not on the nominal gap it dominates.
    let others = if best_explains {
        out.second_look = Some(SecondLook {
            first: first.effect,
            remainder: single_remainder,
            tried: Vec::new(),
        });
        look
    } else {
        let mut chosen = plan::second_effects(
            first.effect,
            units,
            &ranking[0].evaluated.gap,
            MAX_SECOND_EFFECTS,
        );
        let singles: Vec<(Effect, f64)> = ranking
            .iter()
            .filter(|r| r.evaluated.effects.len() == 1)
            .map(|r| (r.evaluated.effects[0].effect, r.score))
            .collect();
        chosen.extend(plan::runner_up_second(first.effect, &singles, &chosen));
        chosen
    };
    let fps_hz = st.fitter.footage_fps_hz();
    for (k, wave) in others.chunks(CONCURRENT_FITS).enumerate() {
        st.plan_tail(others.len() - k * CONCURRENT_FITS);
        let at = (k * CONCURRENT_FITS, others.len());
        let names = wave
            .iter()
            .map(|e| format!("{} + {}", first.effect.name(), e.name()));
        (st.progress)(&fitting(names), at.0, at.1);
        let fits = st.fitter.on_forks(wave, |fork, &e| {
            (fit_pair(&fork, &first, e, fps_hz), fork.simulations())
        });
        for (evaluated, simulations) in fits {
            out.simulations += simulations;
            st.fitted(simulations);
            match evaluated? {
                Ok(evaluated) => match out.second_look.as_mut() {
                    Some(look) => keep_after_second_look(st, look, evaluated, ranking, at),
                    None => ranking.push(ranked(st.nominal_gap, evaluated)),
                },
                Err(skipped) => {
                    (st.progress)(
                        &format!(
                            "{} + {}: set aside, {}",
                            skipped.first.name(),
                            skipped.second.name(),
                            report::skipped_reason(skipped.why)
                        ),
                        at.0,
                        at.1,
                    );
                    out.skipped.push(skipped);
                }
            }
        }
    }
    sort_ranking(st.d0(), ranking);
    Ok(out)
}

/// `e` fitted beside `first` (kept at its values), `first` refitted once beside it, and the
/// pair evaluated; set aside when `e` fitted where it does nothing: no second cause, but the
/// single under another name, whose evaluation differs from the single's by seed noise alone
/// (a motion blur and a JPEG quality clamped at 98 "closed" the single's one cell left).
fn fit_pair(
    fork: &Fitter,
    first: &Fitted,
    e: Effect,
    fps_hz: f64,
) -> Result<Result<Evaluated, SkippedPair>, FitError> {
    let prior = vec![(first.effect, first.values.clone())];
    let second = fork.fit(e, &prior)?;
    let skipped = |why| SkippedPair {
        first: first.effect,
        second: second.effect,
        values: second.values.clone(),
        why,
    };
    if second.effect.does_nothing_at(&second.values, fps_hz) {
        return Ok(Err(skipped(SkipReason::AtNeutral)));
    }
    let (fitted, nominal) = fork.objective_beside(&prior, second.effect, &second.values);
    if !plan::second_lowers_fit(nominal, fitted, second.values.len()) {
        return Ok(Err(skipped(SkipReason::NoLowerThanNominal {
            fitted_sum_z2: fitted,
            nominal_sum_z2: nominal,
        })));
    }
    let pair = fork.backfit_first(vec![first.clone(), second])?;
    fork.evaluate(pair).map(Ok)
}

/// A second look keeps a pair only when it closes a good part of what the explaining single
/// left; the pair is recorded on `look` either way, ranked only when kept.
fn keep_after_second_look(
    st: &Stage,
    look: &mut SecondLook,
    evaluated: Evaluated,
    ranking: &mut Vec<Ranked>,
    (done, total): (usize, usize),
) {
    let remaining = evaluated.gap.total;
    let second_tells = evaluated.effects.get(1).and_then(|second| {
        super::fitted_from_nominal(st.fitter, second, plan::SECOND_LOOK_DISTINCT_Z).1
    });
    let judged = plan::judge_second_look_pair(look.remainder, remaining, second_tells);
    if let Some(second) = evaluated.effects.get(1) {
        look.tried.push((second.effect, remaining, judged));
    }
    let why = report::set_aside_reason(judged).map(|why| {
        format!(
            "{why} ({remaining:.1} of the {:.1} {} left)",
            look.remainder,
            look.first.name()
        )
    });
    match why {
        None => ranking.push(ranked(st.nominal_gap, evaluated)),
        Some(why) => (st.progress)(
            &format!("{}: set aside, {why}", candidate_name(&evaluated)),
            done,
            total,
        ),
    }
}

/// The candidate the verdict rests on, and what choosing it found.
pub(super) struct Chosen {
    pub best: Option<usize>,
    pub verdict: Verdict,
    pub not_distinct: Vec<NotDistinct>,
    pub held_out: Option<judge::HeldOut>,
    pub simulations: usize,
}

/// Chooses among `ranking` (sorted, best first) the candidate the verdict rests on: the first
/// in the verdict's order whose values tell it from the nominal and, when it explains the gap,
/// that predicts what its fit did not use. Each one judged is settled first (refits on fresh
/// seeds, bootstrap footages). The chosen one moves to the front of `ranking`, with its group.
pub(super) fn choose(
    st: &Stage,
    ranking: &mut Vec<Ranked>,
    second_look: Option<&SecondLook>,
) -> Result<Chosen, DiagnoseError> {
    let d0 = st.d0();
    let outcomes: Vec<Outcome> = ranking
        .iter()
        .map(|r| r.evaluated.outcome.clone())
        .collect();
    let order = verdict::rank(d0, &outcomes);
    let group = verdict::group_of_best(d0, &outcomes, &order);
    st.plan_tail(0);
    let mut simulations = 0usize;
    let mut not_distinct = Vec::new();
    let mut held_out = judge::Judge::new(st.fitter);
    let choice = {
        let explains = |i: usize| verdict::explains(d0, &outcomes[i]);
        let mut judged = 0usize;
        verdict::choose(
            &order,
            explains,
            |i| {
                if judged > 0 {
                    (st.progress)(
                        &format!(
                            "the values fitted so far do not tell their candidate from the \
                             nominal; judging {}",
                            candidate_name(&ranking[i].evaluated)
                        ),
                        judged,
                        MAX_DISTINCT_TRIES + 1,
                    );
                }
                judged += 1;
                simulations += settle(st, &mut ranking[i]);
                let (mut judged, tells) = from_nominal(st.fitter, i, &ranking[i]);
                if tells == Some(false) {
                    not_distinct.push(judged);
                    return tells;
                }
                // Values that tell it from the nominal: now what its fit did not use.
                if !(st.nominal_gap.n_significant() > 0 && explains(i)) {
                    return tells;
                }
                (st.progress)(
                    &format!(
                        "checking {} on what its fit did not use",
                        candidate_name(&ranking[i].evaluated)
                    ),
                    0,
                    1,
                );
                match held_out.failed(i, &ranking[i].evaluated) {
                    Some(check) => {
                        judged.held_out = Some(check);
                        not_distinct.push(judged);
                        Some(false)
                    }
                    None => tells,
                }
            },
            MAX_DISTINCT_TRIES,
        )
    };
    // The held-out check of the candidate the verdict rests on (the first one tried when none
    // passed).
    let (held_out, held_out_simulations) = held_out.finish(choice.best)?;
    simulations += held_out_simulations;
    // Every candidate judged and set aside is recorded; one that was not chosen because it did
    // not explain the gap is not among them.
    not_distinct.retain(|n| choice.not_distinct.contains(&n.ranked));
    if let Some(b) = choice.best {
        // A pair a second look kept closed what its first effect alone left: that single is
        // told apart from it, however close their scores against the whole gap.
        let looked_single = second_look.and_then(|look| look.single_behind(ranking, b));
        // Its group: the others the data cannot tell apart from it, less those set aside.
        ranking[b].group = group
            .iter()
            .filter(|&&i| i != b && !choice.not_distinct.contains(&i) && Some(i) != looked_single)
            .map(|&i| candidate_name(&ranking[i].evaluated))
            .collect();
    }
    // `ranking` is best first: a candidate chosen over those set aside moves to the front.
    let best = choice.best.map(|b| to_front(ranking, &mut not_distinct, b));
    let verdict = verdict::verdict(
        st.nominal_gap.n_significant(),
        d0,
        best.map(|b| &ranking[b].evaluated.outcome),
        choice.distinct,
    );
    Ok(Chosen {
        best,
        verdict,
        not_distinct,
        held_out,
        simulations,
    })
}

/// The fit's own noise, measured on a candidate a user reads: its parameters fitted again on
/// fresh fit seeds and stated as the mean of all its fits (the footage's noise too with
/// `--bootstrap`). The ranking does not change (it judged the first fit's values); only the
/// values and ± the report states do. Returns the simulations it ran.
fn settle(st: &Stage, r: &mut Ranked) -> usize {
    let nominal_seed = st.fitter.nominal.seed;
    let capped = || st.past_deadline();
    let (refit, refit_simulations) = if st.options.refits == 0 {
        (Refit::Off, 0)
    } else if capped() {
        (Refit::TimeCap, 0)
    } else {
        let plan = RefitPlan {
            nominal_seed,
            seeds_per_run: st.fitter.fit_seeds.len(),
            runs: st.options.refits,
        };
        super::refit_on_fresh_seeds(st.fitter, r, &plan, capped, st.progress)
    };
    r.refit = Some(refit);
    let (bootstrap, bootstrap_simulations) = if st.options.bootstrap == 0 {
        (Bootstrap::Off, 0)
    } else if capped() {
        (Bootstrap::TimeCap, 0)
    } else {
        let plan = BootstrapPlan {
            nominal_seed,
            footages: st.options.bootstrap,
        };
        super::bootstrap_footage(st.fitter, r, &plan, capped, st.progress)
    };
    r.bootstrap = Some(bootstrap);
    refit_simulations + bootstrap_simulations
}
