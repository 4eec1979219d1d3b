//! The diagnosis in words and as data: `diagnosis.md` (the answer, with its tables) and
//! `diagnosis.json` (machine-readable), formatted from a [`Diagnosis`] and nothing else. Pure:
//! `pipeline::diagnose::report` draws the charts and writes the files.

use super::bands::band_edges_hz;
use super::cells::CellKey;
use super::fit::Evaluated;
use super::fit_noise::FootageFits;
use super::gap::{fmt_sum_z2, CellGap, GapMap};
use super::holdout;
use super::holdout::judge::HeldOut;
use super::outcome::{
    candidate_name, Bootstrap, Diagnosis, NotDistinct, Ranked, Refit, SecondLook, SkipReason,
    SkippedPair,
};
use super::plan::SecondLookPair;
use super::verdict::{SetAside, VerdictReason};
use crate::io::json::finite_or_null;
use crate::scenario::effects::Effect;
use serde_json::{json, Map, Value};

/// A cell's band edges, rounded to 1 mHz: the edges are fractions of the Nyquist rate and
/// carry float noise (15.000000000000053) that means nothing to a reader.
fn band_hz(key: &CellKey, nyquist_hz: f64) -> [f64; 2] {
    let round = |v: f64| (v * 1e3).round() / 1e3;
    let [lo, hi] = match key.band {
        Some(b) => band_edges_hz(nyquist_hz)[b as usize],
        None => [0.0, nyquist_hz],
    };
    [round(lo), round(hi)]
}

fn cell_json(c: &CellGap, nyquist_hz: f64) -> Value {
    json!({
        "channel": c.key.channel,
        "phase": c.key.phase,
        "band_hz": band_hz(&c.key, nyquist_hz),
        "unit": c.key.spec().unit,
        "real": c.real,
        "sim_mean": c.sim_mean,
        "sim_std": c.sim_std,
        "z": c.z,
        "p": c.p,
        "significant": c.significant,
    })
}

/// A pair set aside, with its second effect's fitted values and why.
fn skipped_pair_json(p: &SkippedPair) -> Value {
    let second: Map<String, Value> = p
        .second
        .params()
        .iter()
        .zip(&p.values)
        .map(|(spec, v)| (spec.name.to_string(), json!(v)))
        .collect();
    let fit_objective = match p.why {
        SkipReason::AtNeutral => Value::Null,
        SkipReason::NoLowerThanNominal {
            fitted_sum_z2,
            nominal_sum_z2,
        } => {
            json!({"fitted": finite_or_null(fitted_sum_z2), "nominal": finite_or_null(nominal_sum_z2)})
        }
    };
    json!({
        "effects": [p.first.name(), p.second.name()],
        "second_params": second,
        "reason": skipped_reason(p.why),
        "fit_objective": fit_objective,
    })
}

/// Why the pair stage set a pair aside, in `diagnosis.json`, `diagnosis.md` and the progress
/// line: the pair would be the single under another name.
pub fn skipped_reason(why: SkipReason) -> String {
    match why {
        SkipReason::AtNeutral => "the second effect was fitted where it does nothing (every \
             parameter with a neutral at it, one of them its search's end)"
            .to_string(),
        SkipReason::NoLowerThanNominal {
            fitted_sum_z2,
            nominal_sum_z2,
        } => format!(
            "the second effect's fit did not lower the fit objective (Σ z² over both effects' \
             cells, fit seeds) by more than {} per parameter below the effect as the nominal \
             has it ({} against {})",
            crate::diagnose::plan::SECOND_DROP_PER_PARAM,
            fmt_sum_z2(fitted_sum_z2),
            fmt_sum_z2(nominal_sum_z2)
        ),
    }
}

/// `diagnosis.md`'s line on the pairs set aside; empty when there are none.
fn skipped_pairs_text(pairs: &[SkippedPair]) -> String {
    if pairs.is_empty() {
        return String::new();
    }
    let listed = pairs
        .iter()
        .map(|p| {
            let values = p
                .second
                .params()
                .iter()
                .zip(&p.values)
                .map(|(spec, v)| format!("{} = {} {}", spec.name, fmt(*v), spec.unit))
                .collect::<Vec<_>>()
                .join(", ");
            format!(
                "`{} + {}` ({values}): {}",
                p.first.name(),
                p.second.name(),
                skipped_reason(p.why)
            )
        })
        .collect::<Vec<_>>()
        .join("; ");
    format!("Pairs set aside, each a single under another name: {listed}.\n\n")
}

/// How the headline says a pair was found: past a single that did not explain the gap, or by
/// a second look past one that did.
fn pair_found_text(look: Option<&SecondLook>) -> String {
    match look {
        Some(look) => format!(
            " `{}` alone closed the gap but left more than noise leaves; the second effect, \
             fitted on top of it and it refitted on top of the second, closes what it left (the \
             second look below).",
            look.first.name()
        ),
        None => " One effect alone was not enough; the pair was found greedily (the second \
                 effect fitted on top of the first, then the first refitted on top of it)."
            .to_string(),
    }
}

/// `diagnosis.json`'s record of a second look (null without one).
fn second_look_json(look: Option<&SecondLook>) -> Value {
    let Some(look) = look else {
        return Value::Null;
    };
    json!({
        "first": look.first.name(),
        "remainder": look.remainder,
        "threshold": crate::diagnose::plan::SECOND_LOOK_REMAINDER,
        "keep_at_most": (1.0 - crate::diagnose::plan::SECOND_LOOK_CLOSE) * look.remainder,
        "tried": look.tried.iter().map(|(e, remaining, judged)| json!({
            "second": e.name(),
            "remaining": remaining,
            "kept": judged.kept(),
            "set_aside": set_aside_reason(*judged),
        })).collect::<Vec<_>>(),
    })
}

/// Why a second look set a pair aside, in words (None for a pair it kept); the progress line
/// and `diagnosis.md` say the same.
pub fn set_aside_reason(judged: SecondLookPair) -> Option<&'static str> {
    match judged {
        SecondLookPair::Kept => None,
        SecondLookPair::ClosesTooLittle => Some("it left more than half"),
        SecondLookPair::SecondAtNominal => Some(
            "its second effect's first-fit values lie within two standard uncertainties of the \
             nominal's",
        ),
    }
}

/// `diagnosis.md`'s paragraph on a second look; empty without one.
fn second_look_text(look: Option<&SecondLook>) -> String {
    let Some(look) = look else {
        return String::new();
    };
    let tried = if look.tried.is_empty() {
        "no pair could be judged (each second effect did nothing: see the pairs set aside)"
            .to_string()
    } else {
        look.tried
            .iter()
            .map(|(e, remaining, judged)| {
                format!(
                    "`{} + {}` left {remaining:.1} ({})",
                    look.first.name(),
                    e.name(),
                    set_aside_reason(*judged)
                        .map_or("kept".to_string(), |why| format!("set aside: {why}"))
                )
            })
            .collect::<Vec<_>>()
            .join("; ")
    };
    format!(
        "Second look: `{}` alone closed the gap with no significant cell left, yet left a \
         remaining gap of {:.1}, above the {} that a comparison in agreement leaves (about the \
         99.9th percentile over a hundred cells), in cells another candidate moves. Pairs were \
         fitted for a second cause and kept only when they left at most {:.1} (half of it) with a \
         second effect whose first-fit values lie at least {} standard uncertainties from the \
         nominal's: {tried}.\n\n",
        look.first.name(),
        look.remainder,
        crate::diagnose::plan::SECOND_LOOK_REMAINDER,
        (1.0 - crate::diagnose::plan::SECOND_LOOK_CLOSE) * look.remainder,
        crate::diagnose::plan::SECOND_LOOK_DISTINCT_Z,
    )
}

/// Why a candidate that closed the gap is not the explanation, in `diagnosis.json` and
/// `diagnosis.md`.
const NOT_DISTINCT_REASON: &str = "every fitted value lies within one standard uncertainty of \
     the value at which the effect would leave the nominal as it is: the data cannot tell it from \
     the nominal, so what it closed on fresh seeds was closed by those seeds, not by the effect";

/// Why a candidate that closed the gap measured no value ([`super::Undetermined`]).
const NOT_PREDICTED_REASON: &str = "it did not predict the footage's slow angle waveform, which \
                                    its fit did not use";
const UNDETERMINED_REASON: &str = "its fit measured no value: each lies at an end of its search \
     range with no finite uncertainty, so switching the effect on, not a value the footage \
     measured, closed the gap";

/// One candidate's fitted values against the nominal's, in words: `k1 = 0.006 ± 0.010 against
/// 0 (0.6 σ)`; a value its fit did not determine as `mu_kinetic = 0.3000, at the end of its
/// search range 0.0030–0.3000, no ±`.
fn not_distinct_values_text(n: &NotDistinct) -> String {
    if let Some(HeldOut::Judged(c)) = &n.held_out {
        return format!(
            "its prediction leaves {:.0} % of the footage's slow angle waveform beyond the seeds' \
             scatter",
            100.0 * c.left.unwrap_or(f64::NAN)
        );
    }
    n.values
        .iter()
        .map(|(_, name, v)| {
            format!(
                "{name} = {} ± {} against {} ({:.1} σ)",
                fmt(v.value),
                fmt(v.std),
                fmt(v.nominal),
                v.z()
            )
        })
        .chain(n.undetermined.iter().map(|u| {
            format!(
                "{} = {}, at the end of its search range {}–{}, no ±",
                u.param,
                fmt(u.value),
                fmt(u.search.0),
                fmt(u.search.1)
            )
        }))
        .collect::<Vec<_>>()
        .join(", ")
}

/// The reason `n` was set aside: its values restate the nominal, or its fit measured none.
fn not_distinct_reason(n: &NotDistinct) -> &'static str {
    match n.set_aside() {
        SetAside::NotDistinct => NOT_DISTINCT_REASON,
        SetAside::Undetermined => UNDETERMINED_REASON,
        SetAside::NotPredicted => NOT_PREDICTED_REASON,
    }
}

fn not_distinct_json(n: &NotDistinct, ranking: &[Ranked]) -> Value {
    json!({
        "candidate": ranking.get(n.ranked).map(|r| candidate_name(&r.evaluated)),
        "values": n.values.iter().map(|(e, name, v)| json!({
            "effect": e.name(),
            "param": name,
            "value": v.value,
            "std": finite_or_null(v.std),
            "nominal": v.nominal,
            "z": v.z(),
        })).collect::<Vec<_>>(),
        "undetermined": n.undetermined.iter().map(|u| json!({
            "effect": u.effect.name(),
            "param": u.param,
            "value": u.value,
            "search": [u.search.0, u.search.1],
        })).collect::<Vec<_>>(),
        "reason": not_distinct_reason(n),
        "held_out": held_out_json(n.held_out.as_ref()),
    })
}

/// `diagnosis.md`'s line on the candidates set aside for restating the nominal; empty when
/// there are none.
fn not_distinct_text(not_distinct: &[NotDistinct], ranking: &[Ranked]) -> String {
    if not_distinct.is_empty() {
        return String::new();
    }
    let mut text = String::new();
    for reason in [
        NOT_DISTINCT_REASON,
        UNDETERMINED_REASON,
        NOT_PREDICTED_REASON,
    ] {
        let listed = not_distinct
            .iter()
            .filter(|n| not_distinct_reason(n) == reason)
            .filter_map(|n| {
                ranking.get(n.ranked).map(|r| {
                    format!(
                        "`{}` ({})",
                        candidate_name(&r.evaluated),
                        not_distinct_values_text(n)
                    )
                })
            })
            .collect::<Vec<_>>()
            .join("; ");
        if !listed.is_empty() {
            text.push_str(&format!(
                "Closed the gap but not taken as its cause ({reason}): {listed}.\n\n"
            ));
        }
    }
    text
}

/// The reason for `d`'s verdict ([`VerdictReason`]), with the candidate the verdict rests on
/// when there is one.
pub fn verdict_reason(d: &Diagnosis) -> (VerdictReason, Option<&Ranked>) {
    let best = d.best.and_then(|b| d.ranking.get(b));
    let set_aside = d
        .best
        .and_then(|b| d.not_distinct.iter().find(|n| n.ranked == b))
        .map(NotDistinct::set_aside);
    let reason = crate::diagnose::verdict::reason(
        d.verdict,
        d.nominal_gap.total,
        best.map(|r| &r.evaluated.outcome),
        set_aside,
    );
    (reason, best)
}

/// Whether the verdict's candidate is one that was set aside: its values restate the nominal,
/// its fit measured none or its prediction of what its fit did not use failed (then no
/// candidate explains the gap).
fn best_not_distinct(d: &Diagnosis) -> bool {
    d.best
        .is_some_and(|b| d.not_distinct.iter().any(|n| n.ranked == b))
}

/// `diagnosis.json`'s `held_out`: the check of the candidate the verdict rests on.
fn held_out_json(h: Option<&HeldOut>) -> Value {
    match h {
        None => Value::Null,
        Some(HeldOut::NotJudged(why)) => json!({"judged": false, "why": why}),
        Some(HeldOut::Judged(c)) => json!({
            "judged": true,
            "what": "slow angle residual, frame by frame",
            "frames": c.frames,
            "nominal_rms_rad": c.nominal_rms_rad,
            "candidate_rms_rad": c.candidate_rms_rad,
            "scatter_rms_rad": c.scatter_rms_rad,
            "left": c.left,
            "left_max": holdout::LEFT_MAX,
            "gap_over_scatter_min": holdout::GAP_OVER_SCATTER,
            "fails": c.fails(),
        }),
    }
}

/// `diagnosis.md`'s sentence on the held-out check; empty when none ran.
fn held_out_text(h: Option<&HeldOut>) -> String {
    match h {
        None => String::new(),
        Some(HeldOut::NotJudged(why)) => {
            format!(" Not checked on what its fit did not use: {why}.")
        }
        Some(HeldOut::Judged(c)) => match c.left {
            None => format!(
                " Its fit did not use the slow angle residual frame by frame; the footage's \
                 departs from the nominal's by {} rad RMS, within {:.0}× the seeds' scatter ({} \
                 rad), so there was no waveform to predict.",
                fmt(c.nominal_rms_rad),
                holdout::GAP_OVER_SCATTER,
                fmt(c.scatter_rms_rad)
            ),
            Some(left) => format!(
                " Held out of its fit, the slow angle residual frame by frame: the footage's \
                 departs from the nominal's by {} rad RMS and from this candidate's prediction \
                 by {} rad RMS (seeds' scatter {} rad), so it leaves {:.0} % of that waveform \
                 beyond the scatter ({:.0} % is the most an explanation may leave).",
                fmt(c.nominal_rms_rad),
                fmt(c.candidate_rms_rad),
                fmt(c.scatter_rms_rad),
                100.0 * left,
                100.0 * holdout::LEFT_MAX
            ),
        },
    }
}

fn ranked_json(r: &Ranked, nyquist_hz: f64) -> Value {
    let e = &r.evaluated;
    let (params, stds) = params_json(e, None);
    // An axis runout's form, beside its amplitude: the order and phase it took from the
    // footage (not parameters of the vocabulary's effect, so not in `params`).
    let runout_form = e.effects.iter().find_map(|f| f.runout_form).map(|f| {
        json!({
            "cycles_per_wheel_rev": f.cycles_per_wheel_rev,
            "phase_rad": f.phase_rad,
            "phase_std_rad": finite_or_null(f.phase_std_rad),
        })
    });
    let cell_shrink: Vec<Value> = r
        .cell_shrink
        .iter()
        .map(|(k, s)| json!({"cell": k.label(nyquist_hz), "shrink": s}))
        .collect();
    let mut entry = json!({
        "effect": e.effects[0].effect.name(),
        "effects": e.effects.iter().map(|f| f.effect.name()).collect::<Vec<_>>(),
        "group": r.group,
        "params": params,
        "params_std": stds,
        "units": e.effects.iter().flat_map(|f| f.effect.params().iter().map(|p| p.unit)).collect::<Vec<_>>(),
        "shrink": r.shrink,
        "score": r.score,
        "remaining_gap": e.outcome.remaining,
        "significant_cells_left": e.outcome.significant_left,
        "method": e.effects.iter().map(|f| format!("{}: {}", f.effect.name(), f.method)).collect::<Vec<_>>(),
        "cell_shrink": cell_shrink,
    });
    if let Some(form) = runout_form {
        entry["runout_form"] = form;
    }
    if let Some(refit) = &r.refit {
        entry["refit"] = refit_json(refit, e);
    }
    if let Some(bootstrap) = &r.bootstrap {
        entry["bootstrap"] = bootstrap_json(bootstrap, e);
    }
    let (ci95, dof) = intervals_json(r);
    entry["params_ci95"] = Value::Object(ci95);
    entry["params_ci95_dof"] = Value::Object(dof);
    entry
}

/// [`Ranked::intervals95`] in `diagnosis.json`, keyed as `params`: `[low, high]` and the effective
/// degrees of freedom (null where infinite, or where the parameter is undetermined).
fn intervals_json(r: &Ranked) -> (Map<String, Value>, Map<String, Value>) {
    let single = r.evaluated.effects.len() == 1;
    let mut ci95 = Map::new();
    let mut dofs = Map::new();
    for (f, of_effect) in r.evaluated.effects.iter().zip(r.intervals95()) {
        for (spec, interval) in f.effect.params().iter().zip(of_effect) {
            let key = param_key(f.effect, spec.name, single);
            ci95.insert(
                key.clone(),
                interval.map_or(Value::Null, |i| json!([i.low, i.high])),
            );
            dofs.insert(key, interval.map_or(Value::Null, |i| finite_or_null(i.dof)));
        }
    }
    (ci95, dofs)
}

/// The best candidate's 95 % intervals in words ([`Ranked::intervals95`]), with the coverage factor
/// each one took and why.
fn intervals_text(r: &Ranked) -> String {
    let single = r.evaluated.effects.len() == 1;
    let mut parts = Vec::new();
    let mut any_estimated = false;
    for (f, of_effect) in r.evaluated.effects.iter().zip(r.intervals95()) {
        for (spec, interval) in f.effect.params().iter().zip(of_effect) {
            let Some(i) = interval else { continue };
            // Refits that give a value back but for rounding leave a part of 10⁻³⁶ σ² and a ν
            // of 10⁶² whose digits say nothing: k is the normal's there.
            let dof = if i.dof > 1e6 && i.dof.is_finite() {
                any_estimated = true;
                "ν > 10⁶".to_string()
            } else if i.dof.is_finite() {
                any_estimated = true;
                format!("ν = {:.1}", i.dof)
            } else {
                "ν = ∞".to_string()
            };
            let clipped = if i.clipped {
                ", cut at the values it can take"
            } else {
                ""
            };
            parts.push(format!(
                "{} {} … {} {} (k = {:.3}, {dof}{clipped})",
                param_key(f.effect, spec.name, single),
                fmt(i.low),
                fmt(i.high),
                spec.unit,
                i.k
            ));
        }
    }
    if parts.is_empty() {
        return String::new();
    }
    let why = if any_estimated {
        "k is Student's t on the ±'s effective degrees of freedom ν (Welch–Satterthwaite): \
         the refits' spread counts on n − 1 and, where they widened the ±, the simulated \
         footages' on B − 1, because a σ \
         estimated from a few draws makes ±1.96σ cover less than 95 %"
    } else {
        "no part of the ± was estimated from a few draws here, so k is the normal's 1.96, and \
         the interval holds only as far as the fit's curvature states the noise"
    };
    format!(
        "95 % intervals of {}: {}. {why}.\n\n",
        candidate_name(&r.evaluated),
        parts.join("; ")
    )
}

/// The fits on footages simulated at the stated values (`Ranked::bootstrap`) in
/// `diagnosis.json`, keyed as the entry's own `params`: each footage's data seed and values,
/// per parameter the spread they show, the fit's bias there (with its standard error and
/// p-value, and whether it was taken off), and the values and ± before.
fn bootstrap_json(bootstrap: &Bootstrap, e: &Evaluated) -> Value {
    match bootstrap {
        Bootstrap::Done {
            seeds,
            values,
            found,
            values_before,
            stds_before,
            short,
        } => {
            let runs: Vec<Value> = seeds
                .iter()
                .zip(values)
                .map(|(seed, v)| {
                    let (params, _) = params_json(e, Some((v, v)));
                    json!({"data_seed": seed, "params": params})
                })
                .collect();
            let of = |get: fn(&FootageFits) -> f64| -> Vec<Vec<f64>> {
                found
                    .iter()
                    .map(|l| l.iter().map(|f| f.as_ref().map_or(f64::NAN, get)).collect())
                    .collect()
            };
            let keyed = |lists: &[Vec<f64>]| params_json(e, Some((lists, lists))).1;
            // Whether each parameter's bias was taken off (null where nothing was stated).
            let single = e.effects.len() == 1;
            let mut corrected = Map::new();
            for ((f, found), before) in e.effects.iter().zip(found).zip(values_before) {
                for ((spec, fits), b) in f.effect.params().iter().zip(found).zip(before) {
                    corrected.insert(
                        param_key(f.effect, spec.name, single),
                        fits.map_or(Value::Null, |x| json!(x.value != *b)),
                    );
                }
            }
            json!({
                "status": "done",
                "footages": runs,
                "footage_std": keyed(&of(|f| f.spread)),
                "bias": keyed(&of(|f| f.bias)),
                "bias_std": keyed(&of(|f| f.bias_std)),
                "bias_p": keyed(&of(|f| f.bias_p)),
                "footage_fits_at_search_end": keyed(&of(|f| f.at_search_end as f64)),
                "bias_corrected": corrected,
                "params_before": params_json(e, Some((values_before, values_before))).0,
                "params_std_before": keyed(stds_before),
                "short": short,
            })
        }
        Bootstrap::TimeCap => json!({"status": "not_run", "why": "time cap (--max-minutes)"}),
        Bootstrap::Off => json!({"status": "not_run", "why": "switched off (--bootstrap 0)"}),
        Bootstrap::Failed(why) => json!({"status": "failed", "why": why}),
    }
}

/// The parameters of `r` whose footage fits `label` has words for: each one's key followed by
/// those words.
fn footage_fit_params(
    r: &Ranked,
    found: &[Vec<Option<FootageFits>>],
    label: impl Fn(&FootageFits) -> Option<String>,
) -> Vec<String> {
    let single = r.evaluated.effects.len() == 1;
    r.evaluated
        .effects
        .iter()
        .zip(found)
        .flat_map(|(f, of_effect)| {
            f.effect
                .params()
                .iter()
                .zip(of_effect)
                .filter_map(|(p, fit)| {
                    let words = fit.as_ref().and_then(&label)?;
                    Some(format!("{}{words}", param_key(f.effect, p.name, single)))
                })
                .collect::<Vec<_>>()
        })
        .collect()
}

/// What the best candidate's fits on simulated footages say, in words: what they found and
/// how they widened the ±, or, when none ran, that the ± hold the footage's noise only as the
/// fit's curvature states it.
fn bootstrap_text(r: &Ranked) -> String {
    let name = candidate_name(&r.evaluated);
    let unmeasured = "its ± hold the footage's own noise only as the fit's curvature states \
                      it, which undercounts it when the compared statistics move together (a \
                      random camera shake's stated value spread 2.3× its ± over four footages, \
                      docs/diagnosis-findings.md); `--bootstrap 3` measures it";
    match &r.bootstrap {
        None => String::new(),
        Some(Bootstrap::Done {
            values,
            found,
            values_before,
            stds_before,
            short,
            ..
        }) => {
            let fits: Vec<String> = values
                .iter()
                .map(|v| values_text(&r.evaluated, Some((v, &[]))))
                .collect();
            let spread: Vec<Vec<f64>> = found
                .iter()
                .map(|l| l.iter().map(|f| f.map_or(f64::NAN, |f| f.spread)).collect())
                .collect();
            let corrected = found
                .iter()
                .flatten()
                .flatten()
                .zip(values_before.iter().flatten());
            let corrected = corrected.filter(|(f, b)| f.value != **b).count();
            let bias = if corrected > 0 {
                format!(
                    " Their mean lay off the values they were simulated at by more than their \
                     spread allows (t test, p < {}): the fit is biased there, and {corrected} \
                     value(s) above are stated with that bias taken off, its standard error \
                     added to their ±.",
                    crate::diagnose::fit_noise::BIAS_P
                )
            } else {
                " Their mean showed no significant bias of the fit (t test at p < 0.05); the \
                 values stand."
                    .to_string()
            };
            let given_back = footage_fit_params(r, found, |fit| {
                (fit.spread == 0.0 && fit.bias == 0.0).then(String::new)
            });
            let given_back = if given_back.is_empty() {
                String::new()
            } else {
                format!(
                    " Every footage gave {} back to rounding: their fit does not see the \
                     footage's own noise (the frame timing is read off the frame times, at \
                     which every footage is simulated), so it is not measured here, and their \
                     ± stand.",
                    given_back.join(", ")
                )
            };
            let at_end = footage_fit_params(r, found, |fit| {
                (fit.at_search_end > 0)
                    .then(|| format!(" ({} of {})", fit.at_search_end, fit.footages))
            });
            let at_end = if at_end.is_empty() {
                String::new()
            } else {
                format!(
                    " Footage fits stopped at an end of the search for {}: a fit clamped there \
                     says only that the footage asked for at least that much (at the lower end, \
                     at most), so their spread and mean bound the footage's noise and the fit's bias instead of measuring \
                     them, and no bias is taken off those values.",
                    at_end.join(", ")
                )
            };
            let short = short
                .as_ref()
                .map(|why| format!(" Fewer footages than asked: {why}."))
                .unwrap_or_default();
            format!(
                "Footages simulated at {} on {} fresh data seeds, each measured and fitted as \
                 this one was, gave {}: a spread (the footage's own noise) of {}. Where it \
                 exceeds what the fit's curvature states, the ± above are widened by the \
                 difference (before: {}).{given_back}{at_end}{}{short}\n\n",
                values_text(&r.evaluated, Some((values_before, &[]))),
                values.len(),
                fits.join("; "),
                values_text(&r.evaluated, Some((&spread, &[]))),
                values_text(&r.evaluated, Some((stds_before, &[]))),
                // Fits stopped at the search's end withhold the correction: "no significant
                // bias" would say more than they measured.
                if corrected == 0 && !at_end.is_empty() {
                    ""
                } else {
                    bias.as_str()
                },
            )
        }
        Some(Bootstrap::TimeCap) => format!(
            "{name} was not fitted on simulated footages (time cap reached): {unmeasured}.\n\n"
        ),
        Some(Bootstrap::Off) => format!("For {name}, {unmeasured}.\n\n"),
        Some(Bootstrap::Failed(why)) => {
            format!("Fitting {name} on simulated footages failed ({why}): {unmeasured}.\n\n")
        }
    }
}

/// Values and ± of a candidate's fit, one list per effect in [`Effect::params`] order.
type PerEffect<'v> = (&'v [Vec<f64>], &'v [Vec<f64>]);

/// Each effect of `e` with the values and ± of `lists` (`None`: the candidate's own stated
/// ones); a list that is missing reads as empty.
fn per_effect<'v>(
    e: &'v Evaluated,
    lists: Option<PerEffect<'v>>,
) -> impl Iterator<Item = (Effect, &'v [f64], &'v [f64])> + 'v {
    let get = |l: &'v [Vec<f64>], i: usize| l.get(i).map_or(&[][..], Vec::as_slice);
    e.effects.iter().enumerate().map(move |(i, f)| match lists {
        None => (f.effect, f.values.as_slice(), f.stds.as_slice()),
        Some((values, stds)) => (f.effect, get(values, i), get(stds, i)),
    })
}

/// A candidate's parameter values and their ± (`lists`, as [`per_effect`]) as
/// `diagnosis.json` keys them ([`param_key`]).
fn params_json(
    e: &Evaluated,
    lists: Option<PerEffect<'_>>,
) -> (Map<String, Value>, Map<String, Value>) {
    let single = e.effects.len() == 1;
    let mut params = Map::new();
    let mut stds = Map::new();
    for (effect, values, sds) in per_effect(e, lists) {
        for ((spec, v), s) in effect.params().iter().zip(values).zip(sds) {
            let key = param_key(effect, spec.name, single);
            params.insert(key.clone(), json!(v));
            stds.insert(key, finite_or_null(*s));
        }
    }
    (params, stds)
}

/// A parameter's name in `diagnosis.json` and in words: `name` for a single effect,
/// `effect.name` for a pair (`single` false), so two effects' parameters never read alike.
fn param_key(effect: Effect, name: &str, single: bool) -> String {
    if single {
        name.to_string()
    } else {
        format!("{}.{name}", effect.name())
    }
}

/// The refits on fresh seeds (`Ranked::refit`) in `diagnosis.json`, each one's parameters
/// keyed as the entry's own `params` are (`name`, or `effect.name` for a pair), beside the
/// first fit's values and ± that the entry's pooled ones replaced.
fn refit_json(refit: &Refit, e: &Evaluated) -> Value {
    match refit {
        Refit::Done {
            runs,
            first_values,
            stds_before,
            short,
        } => {
            let runs: Vec<Value> = runs
                .iter()
                .map(|run| {
                    let (params, stds) = params_json(e, Some((&run.values, &run.stds)));
                    json!({"seeds": run.seeds, "params": params, "params_std": stds})
                })
                .collect();
            let (first, before) = params_json(e, Some((first_values, stds_before)));
            json!({
                "status": "done",
                "runs": runs,
                "params_first_fit": first,
                "params_std_first_fit": before,
                "short": short,
            })
        }
        Refit::TimeCap => json!({"status": "not_run", "why": "time cap (--max-minutes)"}),
        Refit::Off => json!({"status": "not_run", "why": "switched off (--refits 0)"}),
        Refit::Failed(why) => json!({"status": "failed", "why": why}),
    }
}

/// A candidate's values in words, `name = v ± σ unit` (`lists` as [`per_effect`], named as
/// [`param_key`]); no ± where a list has none or the data do not determine the parameter.
fn values_text(e: &Evaluated, lists: Option<PerEffect<'_>>) -> String {
    let single = e.effects.len() == 1;
    per_effect(e, lists)
        .flat_map(|(effect, values, stds)| {
            effect
                .params()
                .iter()
                .zip(values)
                .enumerate()
                .map(move |(j, (p, v))| {
                    let name = param_key(effect, p.name, single);
                    match stds.get(j) {
                        Some(s) if s.is_finite() => {
                            format!("{name} = {} ± {} {}", fmt(*v), fmt(*s), p.unit)
                        }
                        _ => format!("{name} = {} {}", fmt(*v), p.unit),
                    }
                })
        })
        .collect::<Vec<_>>()
        .join(", ")
}

/// What the best candidate's refits on fresh seeds say, in words (empty when none was tried).
fn refit_text(r: &Ranked) -> String {
    let name = candidate_name(&r.evaluated);
    let not_held = "its values and ± are the first fit's, and its ± do not hold the fit's own \
                    seed noise, which can be several times larger";
    match &r.refit {
        None => String::new(),
        Some(Refit::Done {
            runs,
            first_values,
            short,
            ..
        }) => {
            let again: Vec<String> = runs
                .iter()
                .map(|run| values_text(&r.evaluated, Some((&run.values, &[]))))
                .collect();
            let how = if r.evaluated.effects.len() > 1 {
                " (the first effect alone, the second beside it, then the first again beside the second, as the pair was fitted)"
            } else {
                ""
            };
            let seeds = runs.first().map_or(0, |run| run.seeds.len());
            let short = short
                .as_ref()
                .map(|why| format!(" Fewer refits than asked: {why}."))
                .unwrap_or_default();
            format!(
                "Fitted again on {} set(s) of {seeds} fresh simulation seeds{how}, {name} gave \
                 {}. The values and ± above pool all {} fits: their mean, with the footage's \
                 noise (the fits' mean variance) and the seed noise their spread shows, divided \
                 by the number of fits. The first fit gave {}; the ranking and the shrink \
                 judged those.{short}\n\n",
                runs.len(),
                again.join("; "),
                runs.len() + 1,
                values_text(&r.evaluated, Some((first_values, &[]))),
            )
        }
        Some(Refit::TimeCap) => format!(
            "{name} was not fitted again on fresh seeds (time cap reached): {not_held}.\n\n"
        ),
        Some(Refit::Off) => {
            format!("{name} was not fitted again on fresh seeds (`--refits 0`): {not_held}.\n\n")
        }
        Some(Refit::Failed(why)) => {
            format!("Fitting {name} again on fresh seeds failed ({why}): {not_held}.\n\n")
        }
    }
}

/// `diagnosis.json` as a value.
pub fn to_json(d: &Diagnosis) -> Value {
    let a = &d.aligned;
    let m = &a.motion;
    let mean_speed = crate::scenario::effects::mean_crank_speed_rad_s(&a.scenario.drive_speed);
    let nuisance = json!({
        "theta1_start_rad": m.theta1_start_rad,
        "crank_speed_scale": m.speed_scale,
        "mean_crank_speed_rad_s": mean_speed,
        "angle_offset_rad": m.offset_rad,
        "time_shift_s": d.real_time_shift_s,
        "angle_rms_residual_rad": m.rms_residual_rad,
        "angle_rms_residual_with_nominal_phase_and_speed_rad": m.nominal_rms_residual_rad,
        "rotation_centre_px": a.geometry.rotation_centre_px,
        "rotation_centre_sigma_px": a.geometry.rotation_centre_sigma_px,
        "marker_radius_px": a.geometry.marker_radius_px,
        "marker_side_px": a.geometry.marker_side_px,
        "mm_per_px": a.geometry.mm_per_px,
        "marker_radius_mm": a.geometry.marker_radius_mm,
        "marker_angle_on_disc_deg": a.geometry.angle_on_disc_deg,
        "marker_orientation_deg": a.geometry.orientation_deg,
        "screen_sign": a.screen_sign,
    });
    let (reason, best) = verdict_reason(d);
    let mut remainder = match best {
        Some(_) if best_not_distinct(d) => json!({
            "after": Value::Null,
            "total": d.nominal_gap.total,
            "cells": d.nominal_gap.significant().map(|c| cell_json(c, d.nyquist_hz)).collect::<Vec<_>>(),
            "best_partial": d.ranking.iter().take(3).map(|r| candidate_name(&r.evaluated)).collect::<Vec<_>>(),
        }),
        Some(r) => {
            let cells: Vec<Value> = r
                .evaluated
                .gap
                .significant()
                .map(|c| cell_json(c, d.nyquist_hz))
                .collect();
            json!({
                "after": candidate_name(&r.evaluated),
                "total": r.evaluated.gap.total,
                "cells": cells,
                "best_partial": d.ranking.iter().take(3).map(|r| candidate_name(&r.evaluated)).collect::<Vec<_>>(),
            })
        }
        None => json!({
            "after": Value::Null,
            "total": d.nominal_gap.total,
            "cells": d.nominal_gap.significant().map(|c| cell_json(c, d.nyquist_hz)).collect::<Vec<_>>(),
            "best_partial": Vec::<String>::new(),
        }),
    };
    remainder["reason"] = json!(reason.as_str());
    json!({
        "verdict": d.verdict.as_str(),
        "nuisance": nuisance,
        "gap": {
            "total": d.nominal_gap.total,
            "significant": d.nominal_gap.n_significant(),
            "fdr_q": d.nominal_gap.options.fdr_q,
            "dead_zone_z": d.nominal_gap.options.dead_zone_z,
            "cells": d.nominal_gap.cells.iter().map(|c| cell_json(c, d.nyquist_hz)).collect::<Vec<_>>(),
        },
        "ranking": d.ranking.iter().map(|r| ranked_json(r, d.nyquist_hz)).collect::<Vec<_>>(),
        "remainder": remainder,
        "held_out": held_out_json(d.held_out.as_ref()),
        "screened_out": d.screened_out.iter().map(|(e, s)| json!({"effect": e.name(), "gap_share": s})).collect::<Vec<_>>(),
        "bounded_out": d.bounded_out.iter().map(|(e, s)| json!({"effect": e.name(), "gap_share": s})).collect::<Vec<_>>(),
        "not_tried": d.not_tried.iter().map(|e| e.name()).collect::<Vec<_>>(),
        "not_judged": d.not_judged.iter().map(|e| e.name()).collect::<Vec<_>>(),
        "pair_tried": d.pair_tried,
        "skipped_pairs": d.skipped_pairs.iter().map(skipped_pair_json).collect::<Vec<_>>(),
        "second_look": second_look_json(d.second_look.as_ref()),
        "not_distinct": d.not_distinct.iter().map(|n| not_distinct_json(n, &d.ranking)).collect::<Vec<_>>(),
        "seed_limited": d.seed_limited().iter().map(|c| cell_json(c, d.nyquist_hz)).collect::<Vec<_>>(),
        "thresholds": {
            "explained_shrink": crate::diagnose::verdict::EXPLAINED_SHRINK,
            "penalty_per_param": crate::diagnose::verdict::PENALTY_PER_PARAM,
            "group_margin": crate::diagnose::verdict::GROUP_MARGIN,
            "distinct_z": crate::diagnose::verdict::DISTINCT_Z,
        },
        "run": {
            "frames": d.frames,
            "detected": d.detected,
            "frames_seen": d.has_images,
            "nyquist_hz": d.nyquist_hz,
            "seeds": d.seeds,
            "fit_seeds": d.fit_seeds,
            "escalation": d.escalation.as_ref().map(|e| json!({
                "from_seeds": e.from_seeds,
                "to_seeds": e.to_seeds,
                "cells_on_from_seeds": e.cells.iter().map(|c| cell_json(c, d.nyquist_hz)).collect::<Vec<_>>(),
            })),
            "simulations": d.simulations,
            "elapsed_s": d.elapsed_s,
        },
    })
}

/// The first few cells as `label at z = …`.
fn cells_text(cells: &[CellGap], nyquist_hz: f64) -> String {
    let mut t: Vec<String> = cells
        .iter()
        .take(3)
        .map(|c| format!("{} at z = {:.1}", c.key.label(nyquist_hz), c.z))
        .collect();
    if cells.len() > 3 {
        t.push(format!("{} more", cells.len() - 3));
    }
    t.join(", ")
}

fn fmt(v: f64) -> String {
    if v == 0.0 {
        "0".into()
    } else if v.abs() >= 1e4 || v.abs() < 1e-3 {
        format!("{v:.3e}")
    } else {
        format!("{v:.4}")
    }
}

/// A candidate's stated values and ± in words ([`values_text`]).
fn params_text(r: &Ranked) -> String {
    values_text(&r.evaluated, None)
}

/// The answer for a gap too small to attribute ([`verdict::too_small_to_attribute`]): what
/// the best candidate `r` of `ranking` did, why the penalty decides, how many others closed the
/// gap as well, and what would tell chance from a real mismatch (the same cells differing in
/// another recording).
///
/// [`verdict::too_small_to_attribute`]: crate::diagnose::verdict::too_small_to_attribute
fn too_small_to_attribute_text(
    r: &Ranked,
    ranking: &[Ranked],
    gap: &GapMap,
    nyquist_hz: f64,
) -> String {
    use crate::diagnose::verdict::{best_possible_shrink, EXPLAINED_SHRINK, PENALTY_PER_PARAM};
    let d0 = gap.total;
    let best_possible = best_possible_shrink(d0, &r.evaluated.outcome);
    let closing_too = ranking
        .iter()
        .filter(|o| {
            !std::ptr::eq(*o, r)
                && o.shrink >= EXPLAINED_SHRINK
                && o.evaluated.outcome.significant_left == 0
        })
        .count();
    let q = gap.options.fdr_q;
    format!(
        "**Unexplained: a gap too small to attribute.** The best candidate, `{}` ({}), closes \
         {:.0} % of the gap and leaves no significant cell, but the whole gap (D₀ = {:.1}) is \
         small against the penalty of {} per fitted parameter that an explanation must earn: \
         its {} parameter(s) cost {:.0} % of D₀, so that even closing all of it scores at most \
         {:.2}, under the {:.2} an explanation needs (its score: {:.2}). {} other candidate(s) \
         closed the gap as well: a gap this small cannot single out one effect. The cells are \
         judged at a false-discovery rate of {}, so about one footage in {:.0} that has no gap \
         at all shows such a cell by chance: treat it as chance or a small mismatch of the \
         nominal unless the same cell differs again in another recording. The gap: {}.",
        candidate_name(&r.evaluated),
        params_text(r),
        100.0 * r.shrink,
        d0,
        PENALTY_PER_PARAM,
        r.evaluated.outcome.params,
        100.0 * (1.0 - best_possible),
        best_possible,
        EXPLAINED_SHRINK,
        r.score,
        closing_too,
        q,
        1.0 / q,
        cells_text(&gap.significant().cloned().collect::<Vec<_>>(), nyquist_hz)
    )
}

/// `diagnosis.md`.
pub fn markdown(d: &Diagnosis, figures: &[String]) -> String {
    let mut s = String::new();
    s.push_str("# Sim-to-real diagnosis\n\n");
    let (reason, best) = verdict_reason(d);
    let answer = match (reason, best) {
        (VerdictReason::NoSignificantCell, _) => format!(
            "**No gap.** The real measurement lies within the nominal simulation's spread: none of \
             the {} compared cells differs significantly (false-discovery rate {}).",
            d.nominal_gap.cells.len(),
            d.nominal_gap.options.fdr_q
        ),
        (VerdictReason::Explained, Some(r)) => {
            let mut t = format!(
                "**Explained by `{}`** ({}): adding it closes {:.0} % of the gap and leaves no \
                 significant difference.",
                candidate_name(&r.evaluated),
                params_text(r),
                100.0 * r.shrink
            );
            if !r.group.is_empty() {
                t.push_str(&format!(
                    " The data cannot tell it apart from {}: they are reported together.",
                    r.group
                        .iter()
                        .map(|g| format!("`{g}`"))
                        .collect::<Vec<_>>()
                        .join(", ")
                ));
            }
            if r.evaluated.effects.len() > 1 {
                t.push_str(&pair_found_text(d.second_look.as_ref()));
            }
            t.push_str(&held_out_text(d.held_out.as_ref()));
            t
        }
        (VerdictReason::NotPredictedHeldOut, Some(r)) => format!(
            "**Unexplained: the best candidate does not predict what it did not fit.** `{}` \
             ({}) closes {:.0} % of the gap: its fit matched the cells' magnitudes.{} \
             Something outside the vocabulary (or an effect in a form its candidate does not \
             take) made the gap; the candidate is a stand-in for it. The gap: {}.",
            candidate_name(&r.evaluated),
            params_text(r),
            100.0 * r.shrink,
            held_out_text(d.held_out.as_ref()),
            cells_text(
                &d.nominal_gap.significant().cloned().collect::<Vec<_>>(),
                d.nyquist_hz
            )
        ),
        (VerdictReason::Undetermined | VerdictReason::NotDistinctFromNominal, Some(r)) => {
            let values = d
                .not_distinct
                .iter()
                .find(|n| Some(n.ranked) == d.best)
                .map(not_distinct_values_text)
                .unwrap_or_default();
            let why = if reason == VerdictReason::Undetermined {
                format!(
                    "its fit measured no value: {values}. Switching it on closed the gap, not a \
                     value the footage determines, and no other candidate that closes it \
                     measured values that differ from the nominal"
                )
            } else {
                format!(
                    "its fitted values do not tell it from the nominal: {values}. Those seeds \
                     closed the gap, not the effect, and no candidate that closes it differs \
                     from the nominal"
                )
            };
            format!(
                "**Unexplained.** `{}` closes {:.0} % of the gap on fresh seeds, but {why}. The \
                 gap: {}.",
                candidate_name(&r.evaluated),
                100.0 * r.shrink,
                cells_text(
                    &d.nominal_gap.significant().cloned().collect::<Vec<_>>(),
                    d.nyquist_hz
                )
            )
        }
        (VerdictReason::TooSmallToAttribute, Some(r)) => {
            too_small_to_attribute_text(r, &d.ranking, &d.nominal_gap, d.nyquist_hz)
        }
        (_, Some(r)) => format!(
            "**Unexplained.** No candidate closes enough of the gap: the best, `{}` ({}), closes \
             {:.0} % and leaves {} significant cell(s). What is left is listed under Remainder.",
            candidate_name(&r.evaluated),
            params_text(r),
            100.0 * r.shrink,
            r.evaluated.outcome.significant_left
        ),
        (_, None) => "**Unexplained.** There is a gap, but no candidate effect has a signature \
                      in the cells that differ."
            .to_string(),
    };
    s.push_str(&answer);
    let seed_limited = d.seed_limited();
    if !seed_limited.is_empty() {
        s.push_str(&format!(
            " But {} cell(s) fall short of significance only for lack of simulated seeds ({}): \
             with unlimited seeds they would be significant. Run again with more seeds \
             (e.g. `--seeds {}`) before trusting this verdict.",
            seed_limited.len(),
            cells_text(&seed_limited, d.nyquist_hz),
            2 * d.seeds.len()
        ));
    }
    s.push_str("\n\n");
    s.push_str(&format!(
        "Compared: {} real frames ({} with the marker{}), against the nominal simulated at the \
         same frame times on {} seeds; {} simulations in {:.0} s. Frequency bands up to the \
         footage's Nyquist rate of {:.2} Hz.\n\n",
        d.frames,
        d.detected,
        if d.has_images {
            ""
        } else {
            "; corner track only, no image channels"
        },
        d.seeds.len(),
        d.simulations,
        d.elapsed_s,
        d.nyquist_hz
    ));
    if let Some(e) = &d.escalation {
        s.push_str(&format!(
            "On the first {} seeds no cell was significant, but {} would have been with unlimited \
             seeds ({}); the nominal was therefore simulated on {} seeds, and every candidate \
             judged on them.\n\n",
            e.from_seeds,
            e.cells.len(),
            cells_text(&e.cells, d.nyquist_hz),
            e.to_seeds
        ));
    }
    let a = &d.aligned;
    s.push_str(&appearance_text(&a.scenario.scene.appearance));
    s.push_str("## Nuisance fitted first (not effects)\n\n| what | value |\n|---|---|\n");
    s.push_str(&format!(
        "| crank angle at t = 0 | {:.4} rad |\n| crank speed | {:.4} × nominal (mean {:.4} rad/s) |\n\
         | angle residual after alignment | {:.2e} rad RMS (with the nominal's phase and speed: {:.2e}) |\n\
         | rotation centre | ({:.2}, {:.2}) ± ({:.2}, {:.2}) px |\n| marker radius | {:.2} px = {:.2} mm |\n\
         | image scale | {:.5} mm/px (marker side {:.2} px) |\n| marker on the disc | at {:.2}°, turned {:.2}° |\n\n",
        a.motion.theta1_start_rad,
        a.motion.speed_scale,
        crate::scenario::effects::mean_crank_speed_rad_s(&a.scenario.drive_speed),
        a.motion.rms_residual_rad,
        a.motion.nominal_rms_residual_rad,
        a.geometry.rotation_centre_px[0],
        a.geometry.rotation_centre_px[1],
        a.geometry.rotation_centre_sigma_px[0],
        a.geometry.rotation_centre_sigma_px[1],
        a.geometry.marker_radius_px,
        a.geometry.marker_radius_mm,
        a.geometry.mm_per_px,
        a.geometry.marker_side_px,
        a.geometry.angle_on_disc_deg,
        a.geometry.orientation_deg
    ));
    s.push_str(&format!(
        "## Where the gap lies\n\nTotal gap D₀ = {:.1} (Σ over cells of max(0, |z| − {})²), {} of {} \
         cells significant. z = (real − simulated mean) / √(seed variance·(1 + 1/N) + model \
         tolerance²).\n\n",
        d.nominal_gap.total,
        d.nominal_gap.options.dead_zone_z,
        d.nominal_gap.n_significant(),
        d.nominal_gap.cells.len()
    ));
    s.push_str(&gap_table(&d.nominal_gap, d.nyquist_hz, 12));
    s.push_str("\n## Which effect causes it\n\n");
    if d.ranking.is_empty() {
        s.push_str("No candidate was fitted");
        s.push_str(if d.nominal_gap.n_significant() == 0 {
            " (there is no gap).\n\n"
        } else {
            ".\n\n"
        });
    } else {
        s.push_str("| rank | candidate | fitted parameters | shrink | score (penalised) | significant cells left |\n|---|---|---|---|---|---|\n");
        for (i, r) in d.ranking.iter().enumerate() {
            s.push_str(&format!(
                "| {} | `{}` | {} | {:.0} % | {:.2} | {} |\n",
                i + 1,
                candidate_name(&r.evaluated),
                params_text(r),
                100.0 * r.shrink,
                r.score,
                r.evaluated.outcome.significant_left
            ));
        }
        s.push_str(&format!(
            "\nshrink = 1 − D_k / D₀ on fresh seeds (the fit used other seeds); the score \
             subtracts {} per fitted parameter from D_k first. `explained` needs a score ≥ {} \
             and no significant cell left. ± is one standard uncertainty of the fit on this \
             footage: the footage's and the seeds' scatter (for a searched parameter also each \
             channel's renderer tolerance, counted once per channel, and for the noise the \
             noise channels'; for a compression matched on its blockiness, that channel's \
             tolerance; for a blur or a rolling shutter matched on edges also {:.0} % of its \
             value, as two renderers' edges differed); otherwise it does not hold how \
             differently the footage's camera draws edges from the simulation's renderer, which the self-check \
             measures (`reports/diagnosis-independent/`: parameters within 2 ± of the truth).\n\n",
            crate::diagnose::verdict::PENALTY_PER_PARAM,
            crate::diagnose::verdict::EXPLAINED_SHRINK,
            100.0 * crate::diagnose::fit::EDGE_RENDER_DISCREPANCY_REL
        ));
    }
    if let Some(r) = best {
        if r.evaluated.outcome.significant_left > 0 {
            s.push_str(&format!(
                "## Remainder after `{}`\n\n",
                candidate_name(&r.evaluated)
            ));
            s.push_str(&gap_table(&r.evaluated.gap, d.nyquist_hz, 10));
            s.push('\n');
        }
    }
    let list = |v: &[Effect]| {
        v.iter()
            .map(|e| format!("`{}`", e.name()))
            .collect::<Vec<_>>()
            .join(", ")
    };
    if !d.screened_out.is_empty() {
        s.push_str(&format!(
            "Screened out (no significant cell in their signature): {}.\n\n",
            d.screened_out
                .iter()
                .map(|(e, _)| format!("`{}`", e.name()))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    if !d.bounded_out.is_empty() {
        s.push_str(&format!(
            "Not fitted alone (their share of the gap, an upper bound on their shrink, is below \
             the best score by more than the group margin {}; a pair's second effect is chosen \
             on what the best leaves, among these too): {}.\n\n",
            crate::diagnose::verdict::GROUP_MARGIN,
            d.bounded_out
                .iter()
                .map(|(e, sh)| format!("`{}` ({:.0} %)", e.name(), 100.0 * sh))
                .collect::<Vec<_>>()
                .join(", ")
        ));
    }
    s.push_str(&skipped_pairs_text(&d.skipped_pairs));
    s.push_str(&second_look_text(d.second_look.as_ref()));
    s.push_str(&not_distinct_text(&d.not_distinct, &d.ranking));
    if !d.not_judged.is_empty() {
        let why = if d.has_images {
            "cannot act on these frames (a video codec codes 4:2:0, which needs an even frame \
             width and height)"
        } else {
            "act on the pixels and cannot be judged from a corner track"
        };
        s.push_str(&format!("Not judged: {} {why}.\n\n", list(&d.not_judged)));
    }
    if let Some(b) = best {
        s.push_str(&refit_text(b));
        s.push_str(&bootstrap_text(b));
        s.push_str(&intervals_text(b));
    }
    if !d.not_tried.is_empty() {
        s.push_str(&format!(
            "Not tried (time cap reached): {}.\n\n",
            list(&d.not_tried)
        ));
    }
    if !figures.is_empty() {
        s.push_str("## Figures\n\n");
        for f in figures {
            s.push_str(&format!("![{f}]({f})\n"));
        }
    }
    s
}

fn gap_table(g: &GapMap, nyquist_hz: f64, rows: usize) -> String {
    let mut cells: Vec<&CellGap> = g.cells.iter().collect();
    cells.sort_by(|a, b| b.z.abs().total_cmp(&a.z.abs()));
    let mut s =
        String::from("| cell | real | simulated | z | significant |\n|---|---|---|---|---|\n");
    for c in cells.iter().take(rows) {
        s.push_str(&format!(
            "| {} | {} {} | {} ± {} | {:+.1} | {} |\n",
            c.key.label(nyquist_hz),
            fmt(c.real),
            c.key.spec().unit,
            fmt(c.sim_mean),
            fmt(c.sim_std),
            c.z,
            if c.significant { "yes" } else { "" }
        ));
    }
    s
}

/// Where the nominal's appearance comes from: the textures its scenario names, or uniform
/// radiances.
fn appearance_text(a: &crate::scene::AppearanceConfig) -> String {
    let parts: Vec<String> = [
        ("the disc", &a.disc_file),
        ("the marker", &a.marker_file),
        ("the background", &a.background_file),
    ]
    .iter()
    .map(|(what, file)| match file {
        // The file's name: a shown scenario names it by an absolute path that says nothing
        // about the diagnosis.
        Some(f) => {
            let name = std::path::Path::new(f)
                .file_name()
                .map_or_else(|| f.clone(), |n| n.to_string_lossy().into_owned());
            format!("{what} from `{name}`")
        }
        None => format!("{what} uniform"),
    })
    .collect();
    let levels = match a.marker_levels.len() {
        0 => String::new(),
        n => format!(
            ", the marker's level changing with the wheel's angle ({n} angle(s) in \
             `marker_levels`)"
        ),
    };
    format!(
        "The nominal draws {}{levels} (`scene.appearance`; `geneva calibrate` writes the \
         marker's texture and levels when the footage shows them).\n\n",
        parts.join(", ")
    )
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::diagnose::outcome::tests::{evaluated, fitted};
    use crate::diagnose::outcome::{pool_refits, widen_by_footages, RefitRun, Undetermined};

    #[test]
    fn the_report_says_which_textures_the_nominal_draws_and_which_parts_are_uniform() {
        let mut a = crate::scene::AppearanceConfig::default();
        assert_eq!(
            appearance_text(&a),
            "The nominal draws the disc uniform, the marker uniform, the background uniform \
             (`scene.appearance`; `geneva calibrate` writes the marker's texture and levels when \
             the footage shows them).\n\n"
        );
        a.marker_file = Some("/home/user/rig/cal/marker.png".into());
        let t = appearance_text(&a);
        assert!(
            t.contains("the disc uniform, the marker from `marker.png`, the background uniform"),
            "{t}"
        );
        a.marker_levels = vec![crate::scene::MarkerLevelAt {
            angle_deg: 10.0,
            gain: 1.0,
            offset: 0.1,
        }];
        let t = appearance_text(&a);
        assert!(
            t.contains(
                "the background uniform, the marker's level changing with the wheel's \
                        angle (1 angle(s) in `marker_levels`)"
            ),
            "{t}"
        );
    }

    #[test]
    fn a_pair_set_aside_is_listed_with_its_second_effects_values_and_why() {
        let pair = SkippedPair {
            first: Effect::MotionBlur,
            second: Effect::Compression,
            values: vec![98.0],
            why: SkipReason::AtNeutral,
        };
        let j = skipped_pair_json(&pair);
        assert_eq!(j["effects"], json!(["motion_blur", "compression"]));
        assert_eq!(j["second_params"], json!({"quality": 98.0}));
        assert!(j["reason"]
            .as_str()
            .is_some_and(|r| r.contains("does nothing")));
        assert_eq!(j["fit_objective"], Value::Null);
        let no_drop = SkippedPair {
            first: Effect::AxisRunout,
            second: Effect::DriveSpeed,
            values: vec![0.0288],
            why: SkipReason::NoLowerThanNominal {
                fitted_sum_z2: 79.98,
                nominal_sum_z2: f64::INFINITY,
            },
        };
        let j = skipped_pair_json(&no_drop);
        assert_eq!(
            j["fit_objective"],
            json!({"fitted": 79.98, "nominal": null})
        );
        assert!(j["reason"]
            .as_str()
            .is_some_and(|r| r.contains("by more than 2 per parameter")
                && r.contains("(80.0 against failed)")));
        let text = skipped_pairs_text(&[pair, no_drop]);
        assert!(
            text.starts_with("Pairs set aside, each a single under another name: ")
                && text.contains("`motion_blur + compression` (quality = 98")
                && text.contains("): the second effect was fitted where it does nothing")
                && text.contains("`axis_runout + drive_speed` (variation_frac = ")
                && text.ends_with(".\n\n"),
            "{text}"
        );
        assert_eq!(skipped_pairs_text(&[]), "");
    }

    #[test]
    fn a_second_look_is_written_with_each_pair_tried_and_whether_it_was_kept() {
        let look = SecondLook {
            first: Effect::Compression,
            remainder: 11.46,
            tried: vec![
                (Effect::OpticalBlur, 0.8, SecondLookPair::Kept),
                (Effect::MotionBlur, 9.0, SecondLookPair::ClosesTooLittle),
                (Effect::RollingShutter, 1.2, SecondLookPair::SecondAtNominal),
            ],
        };
        let j = second_look_json(Some(&look));
        assert_eq!(j["first"], "compression");
        assert_eq!(
            j["tried"][0],
            json!({"second": "optical_blur", "remaining": 0.8, "kept": true, "set_aside": null})
        );
        assert_eq!(j["tried"][1]["kept"], false);
        assert_eq!(j["tried"][1]["set_aside"], "it left more than half");
        assert_eq!(j["tried"][2]["kept"], false);
        assert!(j["tried"][2]["set_aside"]
            .as_str()
            .is_some_and(|s| s.contains("nominal")));
        assert!((j["keep_at_most"].as_f64().unwrap() - 5.73).abs() < 1e-9);
        let text = second_look_text(Some(&look));
        assert!(
            text.contains("remaining gap of 11.5, above the 8")
                && text.contains("`compression + optical_blur` left 0.8 (kept)")
                && text.contains("`compression + motion_blur` left 9.0 (set aside: it left more than half)")
                && text.contains("`compression + rolling_shutter` left 1.2 (set aside: its second effect's first-fit values lie within two standard uncertainties of the nominal's)")
                && text.contains("at least 2 standard uncertainties from the nominal's"),
            "{text}"
        );
        assert!(pair_found_text(Some(&look)).contains("`compression` alone closed the gap"));
        assert!(pair_found_text(None).contains("One effect alone was not enough"));
        assert_eq!(second_look_json(None), Value::Null);
        assert_eq!(second_look_text(None), "");
    }

    /// The one false alarm of the 96 null cases (`reports/diagnosis-nulls/`, own renderer,
    /// null-24): one cell at z = 4.2, D₀ = 4.83, a backlash closing it all with one
    /// parameter, scored 0.59. The answer says the best closed it and why that is no
    /// explanation, not that no candidate closes enough.
    #[test]
    fn a_gap_smaller_than_one_parameters_penalty_is_called_too_small_to_attribute() {
        use crate::diagnose::gap::GapOptions;
        use crate::diagnose::verdict::{shrink, too_small_to_attribute};
        let d0 = 4.83;
        let cell = CellGap {
            key: CellKey {
                channel: "theta",
                phase: "entry",
                band: Some(0),
            },
            real: 4.68e-4,
            sim_mean: 1.21e-4,
            sim_std: 1.76e-5,
            sims: 4,
            z: 4.2,
            p: 9.0e-5,
            significant: true,
        };
        let gap = GapMap {
            cells: vec![cell],
            total: d0,
            options: GapOptions::default(),
        };
        let candidate = |effect: Effect, values: Vec<f64>, remaining: f64| {
            let stds = vec![0.001; values.len()];
            let mut r = ranked(vec![fitted(effect, values, stds)], Refit::Off);
            r.evaluated.outcome.remaining = remaining;
            r.shrink = 1.0 - remaining / d0;
            r.score = shrink(d0, &r.evaluated.outcome);
            r
        };
        let ranking = vec![
            candidate(Effect::Backlash, vec![0.0207], 0.0),
            candidate(Effect::Timebase, vec![30.0], 0.0),
            // Closes less than the bar: not counted among those that closed it as well.
            candidate(Effect::Overrotation, vec![0.1], 0.5 * d0),
        ];
        assert!(too_small_to_attribute(d0, &ranking[0].evaluated.outcome));
        let text = too_small_to_attribute_text(&ranking[0], &ranking, &gap, 15.0);
        assert!(
            text.starts_with(
                "**Unexplained: a gap too small to attribute.** The best candidate, `backlash` ("
            ) && text.contains("closes 100 % of the gap and leaves no significant cell")
                && text.contains("(D₀ = 4.8)")
                && text.contains("its 1 parameter(s) cost 41 % of D₀")
                && text.contains("scores at most 0.59, under the 0.70")
                && text.contains("(its score: 0.59)")
                && text.contains("1 other candidate(s) closed the gap as well")
                && text.contains("false-discovery rate of 0.01, so about one footage in 100")
                && text.contains("theta")
                && text.contains("z = 4.2"),
            "{text}"
        );
        // A gap large enough that a perfect fit would explain it: the penalty does not decide,
        // so it is not this case (even where this candidate's shrink falls short).
        let mut short = candidate(Effect::Backlash, vec![0.0207], 0.25 * 40.0);
        short.shrink = 0.75;
        short.score = 0.75 - 2.0 / 40.0 * 4.0;
        assert!(!too_small_to_attribute(40.0, &short.evaluated.outcome));
        // A significant cell left, or a shrink short of the bar: not this case either.
        let mut left = ranking[0].clone();
        left.evaluated.outcome.significant_left = 1;
        assert!(!too_small_to_attribute(d0, &left.evaluated.outcome));
        assert!(!too_small_to_attribute(d0, &ranking[2].evaluated.outcome));
        assert!(!too_small_to_attribute(0.0, &ranking[0].evaluated.outcome));
    }

    /// A second rig's lens (commit `617faef`), k1 = 0.006 ± 0.0103, set aside as 0.6 σ from
    /// the nominal's 0.
    fn lens_not_distinct() -> NotDistinct {
        NotDistinct {
            ranked: 0,
            values: vec![(
                Effect::LensDistortion,
                "k1",
                crate::diagnose::verdict::FromNominal {
                    value: 0.006,
                    std: 0.0103,
                    nominal: 0.0,
                },
            )],
            undetermined: Vec::new(),
            held_out: None,
        }
    }

    /// A crank-speed variation that closed a creeping marker's cells but left 287 % of its slow
    /// angle waveform is set aside for that, in the words and the JSON, apart from the others.
    #[test]
    fn a_candidate_that_failed_its_held_out_check_is_listed_with_what_it_left() {
        let check = crate::diagnose::holdout::WaveformCheck {
            frames: 240,
            nominal_rms_rad: 0.0173,
            candidate_rms_rad: 0.0293,
            scatter_rms_rad: 4.4e-4,
            left: Some(2.87),
        };
        let n = NotDistinct {
            held_out: Some(HeldOut::Judged(check)),
            ..lens_not_distinct()
        };
        assert_eq!(n.set_aside(), SetAside::NotPredicted);
        assert_eq!(
            not_distinct_values_text(&n),
            "its prediction leaves 287 % of the footage's slow angle waveform beyond the seeds' \
             scatter"
        );
        let j = not_distinct_json(&n, &[]);
        assert_eq!(j["reason"], json!(NOT_PREDICTED_REASON));
        assert_eq!(j["held_out"]["left"], json!(2.87));
        assert_eq!(j["held_out"]["fails"], json!(true));
        let lens = ranked(
            vec![fitted(Effect::LensDistortion, vec![0.006], vec![0.0103])],
            Refit::Off,
        );
        let text = not_distinct_text(&[lens_not_distinct(), n], &[lens.clone(), lens]);
        assert_eq!(
            text.matches("Closed the gap but not taken as its cause")
                .count(),
            2
        );
        assert!(text.contains(NOT_PREDICTED_REASON), "{text}");
        assert_eq!(held_out_json(None), Value::Null);
        assert!(held_out_text(Some(&HeldOut::NotJudged(
            crate::diagnose::holdout::judge::PHASE_NOT_FITTED
        )))
        .contains("states no phase"));
    }

    #[test]
    fn a_candidate_not_told_from_the_nominal_is_listed_with_its_values_and_why() {
        let n = lens_not_distinct();
        let text = not_distinct_values_text(&n);
        assert_eq!(text, "k1 = 0.0060 ± 0.0103 against 0 (0.6 σ)");
        let j = not_distinct_json(&n, &[]);
        assert_eq!(j["candidate"], Value::Null);
        assert_eq!(j["values"][0]["param"], json!("k1"));
        assert_eq!(j["values"][0]["effect"], json!("lens_distortion"));
        assert!((j["values"][0]["z"].as_f64().unwrap_or(0.0) - 0.006 / 0.0103).abs() < 1e-12);
        assert!(j["reason"]
            .as_str()
            .is_some_and(|r| r.contains("cannot tell it from the nominal")));
        let lens = ranked(
            vec![fitted(Effect::LensDistortion, vec![0.006], vec![0.0103])],
            Refit::Off,
        );
        let text = not_distinct_text(std::slice::from_ref(&n), std::slice::from_ref(&lens));
        assert!(
            text.starts_with("Closed the gap but not taken as its cause (")
                && text
                    .ends_with("`lens_distortion` (k1 = 0.0060 ± 0.0103 against 0 (0.6 σ)).\n\n"),
            "{text}"
        );
        assert_eq!(not_distinct_text(&[], &[lens]), "");
    }

    /// An overrotation whose friction the fit left at its search end with no ±
    /// (commit `7284926`) is set aside for measuring no value, listed apart from the
    /// candidates that restate the nominal, in the words and the JSON.
    #[test]
    fn a_candidate_whose_fit_measured_no_value_is_listed_apart_with_its_search_range() {
        let over = NotDistinct {
            ranked: 1,
            values: Vec::new(),
            undetermined: vec![Undetermined {
                effect: Effect::Overrotation,
                param: "mu_kinetic",
                value: 0.3,
                search: (0.003, 0.3),
            }],
            held_out: None,
        };
        assert_eq!(
            not_distinct_values_text(&over),
            "mu_kinetic = 0.3000, at the end of its search range 0.0030–0.3000, no ±"
        );
        let j = not_distinct_json(&over, &[]);
        assert_eq!(j["values"], json!([]));
        assert_eq!(j["undetermined"][0]["effect"], json!("overrotation"));
        assert_eq!(j["undetermined"][0]["search"], json!([0.003, 0.3]));
        assert!(j["reason"]
            .as_str()
            .is_some_and(|r| r.contains("measured no value") && !r.contains("  ")));
        let lens_aside = lens_not_distinct();
        let ranking = [
            ranked(
                vec![fitted(Effect::LensDistortion, vec![0.006], vec![0.0103])],
                Refit::Off,
            ),
            ranked(
                vec![fitted(Effect::Overrotation, vec![0.3], vec![f64::INFINITY])],
                Refit::Off,
            ),
        ];
        let text = not_distinct_text(&[lens_aside, over], &ranking);
        let parts: Vec<&str> = text.split("\n\n").filter(|p| !p.is_empty()).collect();
        assert_eq!(parts.len(), 2, "{text}");
        assert!(
            parts[0].contains("cannot tell it from the nominal")
                && parts[0].contains("`lens_distortion`"),
            "{text}"
        );
        assert!(
            parts[1].contains("measured no value")
                && parts[1].ends_with(
                    "`overrotation` (mu_kinetic = 0.3000, at the end of its search range \
                     0.0030–0.3000, no ±)."
                ),
            "{text}"
        );
    }

    fn ranked(effects: Vec<crate::diagnose::fit::Fitted>, refit: Refit) -> Ranked {
        Ranked {
            evaluated: evaluated(effects),
            shrink: 1.0,
            score: 1.0,
            group: Vec::new(),
            cell_shrink: Vec::new(),
            refit: Some(refit),
            bootstrap: None,
        }
    }

    /// A pair's fits on simulated footages, through `widen_by_footages` into the JSON and the
    /// words: the clearance's footages sit 0.1 mm below the value they were simulated at with a
    /// spread far smaller (taken off, its standard error added to a ± the spread does not
    /// widen); the full well's scatter about it (no bias, kept); the read noise is undetermined.
    /// A second rig's 15.9 ms exposure's three footage fits all stopped at a 60 fps rig's frame
    /// interval, the end of the search there: a spread of 0 and a "bias" at p = 0, which is
    /// not taken off, and the report says why.
    #[test]
    fn footage_fits_at_the_search_end_take_no_bias_off_and_say_so() {
        let mut best = ranked(
            vec![fitted(Effect::MotionBlur, vec![0.0159], vec![0.00126])],
            Refit::Off,
        );
        let done: Vec<(u64, Vec<crate::diagnose::fit::Fitted>)> = (0..3)
            .map(|k| {
                let fits = vec![fitted(Effect::MotionBlur, vec![1.0 / 60.0], vec![0.001])];
                (5007 + k as u64, fits)
            })
            .collect();
        let bootstrap = widen_by_footages(&mut best, done, None, 60.0);
        assert_eq!(best.evaluated.effects[0].values[0], 0.0159);
        let json = bootstrap_json(&bootstrap, &best.evaluated);
        assert_eq!(json["bias_corrected"]["exposure_s"], false);
        assert_eq!(json["footage_fits_at_search_end"]["exposure_s"], 3.0);
        best.bootstrap = Some(bootstrap);
        let text = bootstrap_text(&best);
        assert!(
            text.contains("stopped at an end of the search for exposure_s (3 of 3)")
                && !text.contains("no significant bias")
                && !text.contains("taken off,"),
            "{text}"
        );
        // At 30 fps the same fits lie inside the search (33.3 ms): the bias is measured.
        let mut best = ranked(
            vec![fitted(Effect::MotionBlur, vec![0.0159], vec![0.00126])],
            Refit::Off,
        );
        let done = (0..3)
            .map(|k| {
                let fits = vec![fitted(Effect::MotionBlur, vec![1.0 / 60.0], vec![0.001])];
                (5007 + k as u64, fits)
            })
            .collect();
        let bootstrap = widen_by_footages(&mut best, done, None, 30.0);
        let json = bootstrap_json(&bootstrap, &best.evaluated);
        assert_eq!(json["footage_fits_at_search_end"]["exposure_s"], 0.0);
        assert_eq!(json["bias_corrected"]["exposure_s"], true);
    }

    #[test]
    fn footage_fits_take_a_significant_bias_off_and_say_so() {
        let noise = Effect::PixelNoise;
        let n = noise.params().len();
        let noise_values: Vec<f64> = (0..n).map(|i| 100.0 + i as f64).collect();
        let mut noise_stds = vec![3.0; n];
        noise_stds[1] = f64::INFINITY;
        let mut best = ranked(
            vec![
                fitted(Effect::Backlash, vec![0.5], vec![0.01]),
                fitted(noise, noise_values.clone(), noise_stds.clone()),
            ],
            Refit::Done {
                runs: vec![RefitRun {
                    seeds: vec![3007],
                    values: vec![vec![0.5], noise_values.clone()],
                    stds: vec![vec![0.03], vec![1.0; n]],
                }],
                first_values: vec![vec![0.5], noise_values.clone()],
                stds_before: vec![vec![0.01], noise_stds.clone()],
                short: None,
            },
        );
        let done: Vec<(u64, Vec<crate::diagnose::fit::Fitted>)> = [0.40, 0.41, 0.39, 0.40]
            .iter()
            .enumerate()
            .map(|(k, &c)| {
                let wiggle = if k % 2 == 0 { 0.5 } else { -0.5 };
                let v: Vec<f64> = noise_values.iter().map(|v| v + wiggle).collect();
                let fits = vec![
                    fitted(Effect::Backlash, vec![c], vec![0.01]),
                    fitted(noise, v, vec![1.0; n]),
                ];
                (5007 + k as u64, fits)
            })
            .collect();
        let bootstrap = widen_by_footages(&mut best, done, None, 30.0);
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs();
        // Clearance: value 0.5 − (−0.1); the spread (var 0.0001·2/3) is below the curvature's
        // (the first fit's 0.01 and the refit's 0.03), so only the bias's standard error adds.
        let clearance = &best.evaluated.effects[0];
        assert!(close(clearance.values[0], 0.6), "{clearance:?}");
        let var = 0.0002f64 / 3.0;
        assert!(
            close(clearance.stds[0], (0.0001 + var / 4.0).sqrt()),
            "{clearance:?}"
        );
        let pixel = &best.evaluated.effects[1];
        assert_eq!((pixel.values[0], pixel.stds[0]), (100.0, 3.0));
        assert_eq!(pixel.stds[1], f64::INFINITY);
        let json = bootstrap_json(&bootstrap, &best.evaluated);
        let (full_well, read_noise) = (
            format!("pixel_noise.{}", noise.params()[0].name),
            format!("pixel_noise.{}", noise.params()[1].name),
        );
        assert_eq!(json["status"], "done");
        assert_eq!(json["footages"][3]["data_seed"], 5010);
        assert_eq!(json["footages"][1]["params"]["backlash.clearance_mm"], 0.41);
        assert_eq!(json["bias_corrected"]["backlash.clearance_mm"], true);
        assert_eq!(json["bias_corrected"][&full_well], false);
        assert!(json["bias_corrected"][&read_noise].is_null(), "{json}");
        assert_eq!(json["params_before"]["backlash.clearance_mm"], 0.5);
        assert_eq!(json["params_std_before"]["backlash.clearance_mm"], 0.01);
        let bias = json["bias"]["backlash.clearance_mm"]
            .as_f64()
            .unwrap_or(0.0);
        assert!(close(bias, -0.1), "{json}");
        best.bootstrap = Some(bootstrap);
        let text = bootstrap_text(&best);
        assert!(text.contains("on 4 fresh data seeds"), "{text}");
        assert!(
            text.contains("1 value(s) above are stated with that bias taken off"),
            "{text}"
        );
    }

    /// The frame timing fitted from the timestamps every footage shares: the footages give
    /// its values back but for the last bit of some, which is no bias to take off (before, a
    /// t test on that rounding took "a significant bias" off two of them). The last parameter
    /// comes back 0.5 ms off in every footage: no spread, but a bias, taken off and not named.
    #[test]
    fn footages_that_give_the_values_back_are_said_to_and_take_nothing_off() {
        let timing = Effect::FrameTiming;
        let n = timing.params().len();
        // jitter_s, first_interval_s, rate_error_ppm, drop_probability, pair_alternation_s
        // as the self-check's strong frame timing was fitted.
        let values = vec![4.7e-4, 0.0549, -4513.6, 0.0227, 0.00106];
        assert_eq!(values.len(), n);
        let stds = vec![2e-5; n];
        let mut best = ranked(
            vec![fitted(timing, values.clone(), stds.clone())],
            Refit::Off,
        );
        let done: Vec<(u64, Vec<crate::diagnose::fit::Fitted>)> = (0..4)
            .map(|k| {
                let mut v: Vec<f64> = values
                    .iter()
                    .map(|v| f64::from_bits(v.to_bits() + (k % 2)))
                    .collect();
                v[n - 1] = values[n - 1] + 0.0005;
                (5007 + k, vec![fitted(timing, v, stds.clone())])
            })
            .collect();
        let bootstrap = widen_by_footages(&mut best, done, None, 30.0);
        assert_eq!(best.evaluated.effects[0].values[..n - 1], values[..n - 1]);
        assert_eq!(best.evaluated.effects[0].stds, stds);
        let last = best.evaluated.effects[0].values[n - 1];
        assert!((last - (values[n - 1] - 0.0005)).abs() < 1e-15, "{last}");
        let json = bootstrap_json(&bootstrap, &best.evaluated);
        let names: Vec<&str> = timing.params().iter().map(|p| p.name).collect();
        for (j, name) in names.iter().enumerate() {
            assert_eq!(json["bias_corrected"][name], j == n - 1, "{json}");
            assert_eq!(json["footage_std"][name], 0.0, "{json}");
        }
        best.bootstrap = Some(bootstrap);
        let text = bootstrap_text(&best);
        assert!(
            text.contains(&format!(
                "Every footage gave {} back",
                names[..n - 1].join(", ")
            )),
            "{text}"
        );
        assert!(
            text.contains("1 value(s) above are stated with that bias taken off"),
            "{text}"
        );
    }

    /// One refit per clearance, each ± 0.01 on its own seed, as `pool_refits` takes them.
    fn backlash_refit_runs(
        clearances_mm: &[f64],
    ) -> Vec<(Vec<u64>, Vec<crate::diagnose::fit::Fitted>)> {
        clearances_mm
            .iter()
            .enumerate()
            .map(|(k, &v)| {
                let fits = vec![fitted(Effect::Backlash, vec![v], vec![0.01])];
                (vec![3007 + k as u64], fits)
            })
            .collect()
    }

    /// A clearance pooled from three fits (0.50, 0.53, 0.47, each ± 0.01: σ² = 0.0001 +
    /// 0.0009/3, the seed part 0.0003 on 2 degrees of freedom), then widened by eight footages
    /// at 0.45 and 0.55 (s_b² = 0.02/7 in place of the curvature's 0.0001, on 7): its interval
    /// takes Student's t on the Welch–Satterthwaite ν of those two parts, in the JSON and in
    /// words. Without refits or footages, nothing is estimated: the normal's 1.96.
    #[test]
    fn the_best_candidates_intervals_take_t_on_the_dof_of_its_refits_and_footages() {
        let mut best = ranked(
            vec![fitted(Effect::Backlash, vec![0.50], vec![0.01])],
            Refit::Off,
        );
        best.refit = Some(pool_refits(
            &mut best.evaluated,
            backlash_refit_runs(&[0.53, 0.47]),
            None,
        ));
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * b.abs();
        assert!(close(best.evaluated.effects[0].stds[0], 0.02));
        let done: Vec<(u64, Vec<crate::diagnose::fit::Fitted>)> = (0..8)
            .map(|k| {
                let v = if k % 2 == 0 { 0.45 } else { 0.55 };
                (
                    5007 + k,
                    vec![fitted(Effect::Backlash, vec![v], vec![0.01])],
                )
            })
            .collect();
        best.bootstrap = Some(widen_by_footages(&mut best, done, None, 30.0));
        // σ'² = 0.0004 − 0.0001 + s_b²: the footages' spread replaced the curvature's.
        let footage_var = 0.02 / 7.0;
        let var = 0.0003 + footage_var;
        let (value, std) = (
            best.evaluated.effects[0].values[0],
            best.evaluated.effects[0].stds[0],
        );
        assert!(
            close(value, 0.5) && close(std * std, var),
            "{value} ± {std}"
        );
        let dof = var * var / (0.0003f64.powi(2) / 2.0 + footage_var * footage_var / 7.0);
        assert_eq!(dof.floor(), 8.0, "{dof}");
        let k = crate::numeric::dist::t975(8);
        let json = ranked_json(&best, 15.0);
        let ci = &json["params_ci95"]["clearance_mm"];
        assert!(
            close(ci[0].as_f64().unwrap_or(0.0), 0.5 - k * std),
            "{json}"
        );
        assert!(
            close(ci[1].as_f64().unwrap_or(0.0), 0.5 + k * std),
            "{json}"
        );
        let got = json["params_ci95_dof"]["clearance_mm"].as_f64();
        assert!(got.is_some_and(|d| close(d, dof)), "{json}");
        let text = intervals_text(&best);
        assert!(
            text.starts_with("95 % intervals of backlash: clearance_mm ")
                && text.contains("(k = 2.306, ν = 8.2)")
                && text.contains("Welch–Satterthwaite): the refits' spread")
                && !text.contains("  "),
            "{text}"
        );

        let alone = ranked(
            vec![fitted(Effect::Backlash, vec![0.50], vec![0.01])],
            Refit::Off,
        );
        let json = ranked_json(&alone, 15.0);
        assert!(json["params_ci95_dof"]["clearance_mm"].is_null(), "{json}");
        let hi = json["params_ci95"]["clearance_mm"][1]
            .as_f64()
            .unwrap_or(0.0);
        assert!(close(hi, 0.5 + 1.959964 * 0.01), "{json}");
        let text = intervals_text(&alone);
        assert!(
            text.contains("(k = 1.960, ν = ∞)") && text.contains("normal's 1.96"),
            "{text}"
        );
        // Refits that give the value back to the last bit: ν beyond a million, not its digits.
        let mut back = ranked(
            vec![fitted(Effect::Backlash, vec![0.5], vec![0.01])],
            Refit::Off,
        );
        let last_bit = f64::from_bits(0.5f64.to_bits() + 1);
        back.refit = Some(pool_refits(
            &mut back.evaluated,
            backlash_refit_runs(&[0.5, last_bit]),
            None,
        ));
        let text = intervals_text(&back);
        assert!(text.contains("(k = 1.960, ν > 10⁶)"), "{text}");
    }

    #[test]
    fn refits_are_keyed_as_their_candidates_own_params_single_or_pair() -> Result<(), String> {
        let noise = Effect::PixelNoise;
        let n = noise.params().len();
        let run = |clearance: f64, seeds: Vec<u64>| RefitRun {
            seeds,
            values: vec![vec![clearance], vec![104.0; n]],
            stds: vec![vec![0.02], vec![f64::INFINITY; n]],
        };
        let pair = ranked(
            vec![
                fitted(Effect::Backlash, vec![0.52], vec![0.015]),
                fitted(noise, vec![100.0; n], vec![f64::INFINITY; n]),
            ],
            Refit::Done {
                runs: vec![run(0.53, vec![3007, 3008]), run(0.51, vec![3009, 3010])],
                first_values: vec![vec![0.5], vec![100.0; n]],
                stds_before: vec![vec![0.01], vec![f64::INFINITY; n]],
                short: None,
            },
        );
        let json = ranked_json(&pair, 15.0);
        let keys = |v: &Value| -> Result<Vec<String>, String> {
            let map = v.as_object().ok_or_else(|| format!("not an object: {v}"))?;
            Ok(map.keys().cloned().collect())
        };
        let own = keys(&json["params"])?;
        let refit = &json["refit"];
        for key in ["params_first_fit", "params_std_first_fit"] {
            assert_eq!(own, keys(&refit[key])?, "{key}: {json}");
        }
        for run in 0..2 {
            assert_eq!(own, keys(&refit["runs"][run]["params"])?, "{json}");
            assert_eq!(own, keys(&refit["runs"][run]["params_std"])?, "{json}");
        }
        assert!(own.iter().any(|k| *k == "backlash.clearance_mm"), "{json}");
        assert_eq!(json["params"]["backlash.clearance_mm"], 0.52, "{json}");
        assert_eq!(refit["params_first_fit"]["backlash.clearance_mm"], 0.5);
        assert_eq!(refit["runs"][1]["params"]["backlash.clearance_mm"], 0.51);
        assert_eq!(refit["runs"][1]["seeds"], json!([3009, 3010]));
        assert_eq!(refit["params_std_first_fit"]["backlash.clearance_mm"], 0.01);
        assert!(refit["params_std_first_fit"]["pixel_noise.full_well_e"].is_null());
        assert!(refit["short"].is_null());
        // In words, a pair's parameters carry their effect's name, as in the JSON.
        let text = refit_text(&pair);
        for want in [
            "2 set(s) of 2 fresh simulation seeds",
            "backlash+pixel_noise gave backlash.clearance_mm = 0.53",
            "; backlash.clearance_mm = 0.51",
            "pool all 3 fits",
            "The first fit gave backlash.clearance_mm = 0.5",
            "as the pair was fitted",
        ] {
            assert!(text.contains(want), "{want}: {text}");
        }

        // The stated values and ±, named the same way; an undetermined parameter without ±.
        let stated = params_text(&pair);
        assert!(
            stated.starts_with("backlash.clearance_mm = 0.5200 ± 0.0150 mm, pixel_noise."),
            "{stated}"
        );
        assert!(
            stated.contains("pixel_noise.full_well_e = 100.0000 ")
                && !stated.contains("pixel_noise.full_well_e = 100.0000 ±"),
            "{stated}"
        );

        let single = ranked(
            vec![fitted(Effect::Backlash, vec![0.515], vec![0.01])],
            Refit::Done {
                runs: vec![RefitRun {
                    seeds: vec![3007, 3008],
                    values: vec![vec![0.53]],
                    stds: vec![vec![0.01]],
                }],
                first_values: vec![vec![0.5]],
                stds_before: vec![vec![0.01]],
                short: Some("refit 2 of 2 failed: no detection".into()),
            },
        );
        let json = ranked_json(&single, 15.0);
        assert_eq!(json["refit"]["runs"][0]["params"]["clearance_mm"], 0.53);
        assert_eq!(json["refit"]["params_first_fit"]["clearance_mm"], 0.5);
        assert_eq!(json["refit"]["short"], "refit 2 of 2 failed: no detection");
        let text = refit_text(&single);
        assert!(!text.contains("pair"), "{text}");
        assert!(text.contains("gave clearance_mm = 0.53"), "{text}");
        assert_eq!(params_text(&single), "clearance_mm = 0.5150 ± 0.0100 mm");
        assert!(
            text.contains("Fewer refits than asked: refit 2 of 2 failed"),
            "{text}"
        );
        // Not run: the report says its ± do not hold the seed noise, naming the candidate.
        let off = ranked(
            vec![fitted(Effect::Backlash, vec![0.5], vec![0.01])],
            Refit::Off,
        );
        assert!(refit_text(&off).contains("backlash was not fitted again"));
        assert!(refit_text(&off).contains("do not hold"));
        Ok(())
    }
}
