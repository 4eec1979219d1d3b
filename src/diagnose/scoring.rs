//! Scoring of the diagnosis self-check: how a diagnosis of footage with a known cause is
//! judged (top-1/top-3, false alarms, out-of-vocabulary recall, shrink, parameter errors) and
//! the confusion matrix. Pure: the cases' outcomes in, the figures out.

use crate::numeric::robust::median_finite as median;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// What a self-check case holds back from the nominal.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Expectation {
    /// One effect of the vocabulary is on in the data and off in the nominal; `also` are the
    /// names that count as the same answer (effects that share its switch).
    Withheld {
        effect: String,
        also: Vec<String>,
        strong: bool,
        /// The effect is on in a form its candidate does not parametrise (another runout order
        /// and phase, a sinusoidal shake, two vibration modes, …): what another renderer's or
        /// a real rig's version of the effect looks like. Scored on its own.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        form: bool,
    },
    /// Two effects of the vocabulary are on in the data and off in the nominal, as a real rig
    /// has more than one cause at once: the answer sought is an `explained` verdict whose best
    /// candidate names both (the pair stage of the diagnosis); an `unexplained` one is honest,
    /// an `explained` one naming one or neither of them is a wrong account.
    WithheldPair { members: Vec<PairMember> },
    /// Nothing is withheld: the verdict must be `no_gap`.
    Null,
    /// The cause is outside the candidates: the verdict must be `unexplained` (or `no_gap` when
    /// the perturbation is below what the footage shows, counted separately).
    OutOfVocabulary,
}

/// One effect of a two-effect case: its name and the names that count as the same answer.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PairMember {
    pub effect: String,
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub also: Vec<String>,
}

/// A pair's effects as reports name them: `a + b`.
pub fn pair_label(members: &[PairMember]) -> String {
    members
        .iter()
        .map(|m| m.effect.as_str())
        .collect::<Vec<_>>()
        .join(" + ")
}

impl PairMember {
    fn named_by(&self, candidate: &[String]) -> bool {
        candidate
            .iter()
            .any(|n| *n == self.effect || self.also.contains(n))
    }
}

/// How a two-effect case was answered: a partition of such cases.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PairAnswer {
    /// `explained`, the best candidate (with its group) names both effects.
    Both,
    /// `explained`, the best candidate names one of them: half an account stated as whole.
    One,
    /// `explained` by neither.
    Neither,
    /// `unexplained`: the gap is found and stated as not accounted for.
    Unexplained,
    /// `no_gap` or a failed diagnosis.
    Missed,
}

/// One diagnosed case, as the scoring sees it.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct CaseOutcome {
    pub name: String,
    pub expectation: Expectation,
    pub verdict: String,
    /// Ranked candidates, best first: each the effect names of the candidate (one, or two for a
    /// pair) together with the names of the group the data cannot tell apart from it.
    pub ranked: Vec<Vec<String>>,
    /// The same candidates as reports write them, keeping what `ranked` flattens: a pair's
    /// effects joined by `+`, each member of its group after ` ≈ ` (`a+b ≈ c+d`). Records of
    /// older runs have none; [`CaseOutcome::ranking_labels`] falls back on `ranked`.
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub ranked_labels: Vec<String>,
    /// Shrink of the best candidate (1 − D_k / D₀ on fresh seeds); `None` without one.
    pub best_shrink: Option<f64>,
    /// Relative errors |fitted − true| / |true| of the withheld effect's identifiable
    /// parameters, when the best candidate is that effect.
    pub param_rel_errors: Vec<f64>,
    /// The same parameters' errors in their stated standard uncertainties, |fitted − true| / σ
    /// (an honest σ puts about 95 % of them within 2); infinite where a zero σ claimed the exact
    /// value and missed it (JSON null). Records of older runs have none.
    #[serde(default, deserialize_with = "infinite_if_null")]
    pub param_errors_in_sd: Vec<f64>,
    /// Whether each of those parameters' truth lies in its stated 95 % interval (Student's t
    /// on the ±'s degrees of freedom, `diagnosis.json`'s `params_ci95`). Records of older runs
    /// have none.
    #[serde(default)]
    pub params_in_ci95: Vec<bool>,
    /// Evaluation seeds the diagnosis judged on (more than asked when it escalated); 0 when
    /// it failed. Records of older runs have none.
    #[serde(default)]
    pub eval_seeds: usize,
}

/// A list of f64 whose infinite members JSON wrote as null.
fn infinite_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<Vec<f64>, D::Error> {
    let v: Vec<Option<f64>> = Vec::deserialize(d)?;
    Ok(v.into_iter().map(|x| x.unwrap_or(f64::INFINITY)).collect())
}

impl CaseOutcome {
    fn rank_of(&self, names: &[String]) -> Option<usize> {
        self.ranked
            .iter()
            .position(|cand| cand.iter().any(|n| names.contains(n)))
    }

    /// One of the k best candidates names the withheld effect, and the diagnosis explains the
    /// gap. An `unexplained` verdict names no cause, whatever heads its list of partial
    /// candidates: a weak lens whose candidate was fitted at k1 = 0 with shrink 0.00 headed
    /// such a list and had counted as identified.
    pub fn top_k(&self, k: usize) -> bool {
        match &self.expectation {
            Expectation::Withheld { effect, also, .. } => {
                let mut names = also.clone();
                names.push(effect.clone());
                self.verdict == "explained" && self.rank_of(&names).is_some_and(|r| r < k)
            }
            _ => false,
        }
    }

    /// How a two-effect case was answered; `None` for the other cases.
    pub fn pair_answer(&self) -> Option<PairAnswer> {
        let Expectation::WithheldPair { members } = &self.expectation else {
            return None;
        };
        Some(match self.verdict.as_str() {
            "explained" => {
                let best = self.ranked.first().map(Vec::as_slice).unwrap_or_default();
                match members.iter().filter(|m| m.named_by(best)).count() {
                    0 => PairAnswer::Neither,
                    n if n >= members.len() => PairAnswer::Both,
                    _ => PairAnswer::One,
                }
            }
            "unexplained" => PairAnswer::Unexplained,
            _ => PairAnswer::Missed,
        })
    }

    /// The ranked candidates as reports write them (see `ranked_labels`); an older record's
    /// flattened names joined by `/`.
    pub fn ranking_labels(&self) -> Vec<String> {
        if self.ranked_labels.len() == self.ranked.len() {
            self.ranked_labels.clone()
        } else {
            self.ranked.iter().map(|c| c.join("/")).collect()
        }
    }

    /// What the best candidate is called (`none` without a candidate, `no_gap` when no gap).
    pub fn answer(&self) -> String {
        if self.verdict == "no_gap" {
            return "no_gap".into();
        }
        match self.ranked.first().and_then(|c| c.first()) {
            Some(n) => n.clone(),
            None => "none".into(),
        }
    }
}

/// A rate with its count, k of n.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rate {
    pub k: usize,
    pub n: usize,
}

impl Rate {
    pub fn value(&self) -> Option<f64> {
        (self.n > 0).then(|| self.k as f64 / self.n as f64)
    }

    /// 95 % Wilson score interval.
    pub fn wilson95(&self) -> Option<(f64, f64)> {
        crate::numeric::dist::wilson_interval(self.k, self.n, 1.96)
    }
}

/// A rate as the reports print it: "97 % (31/32; 95 % CI 84–99 %)", or "– (no case)".
pub fn pct(r: &Rate) -> String {
    match (r.value(), r.wilson95()) {
        (Some(v), Some((lo, hi))) => format!(
            "{:.0} % ({}/{}; 95 % CI {:.0}–{:.0} %)",
            100.0 * v,
            r.k,
            r.n,
            100.0 * lo,
            100.0 * hi
        ),
        _ => "– (no case)".into(),
    }
}

/// The self-check's figures.
#[derive(Debug, Clone, PartialEq)]
pub struct Scores {
    pub top1_strong: Rate,
    pub top3_strong: Rate,
    pub top1_weak: Rate,
    pub top3_weak: Rate,
    /// Withheld cases where a gap was found at all.
    pub detected_strong: Rate,
    pub detected_weak: Rate,
    /// Withheld effects in another form than their candidate's: top-1 and gap found.
    pub top1_form: Rate,
    pub detected_form: Rate,
    /// Null cases with any verdict but `no_gap`.
    pub false_alarms: Rate,
    /// Out-of-vocabulary cases judged `unexplained`.
    pub unexplained_recall: Rate,
    pub median_shrink_strong: Option<f64>,
    pub median_param_rel_error_strong: Option<f64>,
    /// Identifiable fitted parameters within 2 standard uncertainties of the truth (strong,
    /// top-1 cases): whether the stated uncertainties can be believed.
    pub params_within_2sd_strong: Rate,
    /// The same parameters whose truth lies in their stated 95 % interval (Student's t on the
    /// ±'s degrees of freedom): the interval a user reads, checked.
    pub params_within_ci95_strong: Rate,
    /// The same three figures near the detection limit (weak, top-1 cases): fewer and noisier
    /// data, so larger errors and ± carried by few draws, where a t interval and ± 1.96 σ part.
    pub median_param_rel_error_weak: Option<f64>,
    pub params_within_2sd_weak: Rate,
    pub params_within_ci95_weak: Rate,
    /// Two-effect cases, by answer: both named, one named, neither named (each with an
    /// `explained` verdict), `unexplained`, and a gap found at all.
    pub pair_both: Rate,
    pub pair_one: Rate,
    pub pair_neither: Rate,
    pub pair_unexplained: Rate,
    pub pair_detected: Rate,
    /// The fitted parameters of two-effect cases whose best candidate names both: their median
    /// relative error and the share whose truth lies in the stated 95 % interval.
    pub median_param_rel_error_pair: Option<f64>,
    pub params_within_ci95_pair: Rate,
    /// Withheld effect → (answer → count).
    pub confusion: BTreeMap<String, BTreeMap<String, usize>>,
}

/// How a withheld case's level is named in reports.
pub fn level_name(strong: bool, form: bool) -> &'static str {
    match (form, strong) {
        (true, _) => "other form",
        (false, true) => "strong",
        (false, false) => "weak",
    }
}

/// Scores the outcomes of a self-check.
pub fn score(outcomes: &[CaseOutcome]) -> Scores {
    let rate = |keep: &dyn Fn(&CaseOutcome) -> bool, hit: &dyn Fn(&CaseOutcome) -> bool| {
        let cases: Vec<&CaseOutcome> = outcomes.iter().filter(|o| keep(o)).collect();
        Rate {
            k: cases.iter().filter(|o| hit(o)).count(),
            n: cases.len(),
        }
    };
    let strong = |o: &CaseOutcome| {
        matches!(
            o.expectation,
            Expectation::Withheld {
                strong: true,
                form: false,
                ..
            }
        )
    };
    let form = |o: &CaseOutcome| matches!(o.expectation, Expectation::Withheld { form: true, .. });
    let weak =
        |o: &CaseOutcome| matches!(o.expectation, Expectation::Withheld { strong: false, .. });
    let is_pair = |o: &CaseOutcome| o.pair_answer().is_some();
    let mut confusion: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    for o in outcomes {
        let row = match &o.expectation {
            Expectation::Withheld {
                effect,
                strong,
                form,
                ..
            } => format!("{effect} ({})", level_name(*strong, *form)),
            Expectation::WithheldPair { members } => format!("{} (pair)", pair_label(members)),
            Expectation::Null => "null".into(),
            Expectation::OutOfVocabulary => "out-of-vocabulary".into(),
        };
        // A pair's answer is the whole best candidate (`a+b ≈ c`), not its first name.
        let best = match &o.expectation {
            Expectation::WithheldPair { .. } => o
                .ranking_labels()
                .first()
                .cloned()
                .unwrap_or_else(|| "none".into()),
            _ => o.answer(),
        };
        let answer = match (&o.expectation, o.verdict.as_str()) {
            (_, "no_gap") => "no_gap".to_string(),
            (_, "unexplained") => format!("unexplained ({best})"),
            _ => best,
        };
        *confusion.entry(row).or_default().entry(answer).or_default() += 1;
    }
    Scores {
        top1_strong: rate(&strong, &|o| o.top_k(1)),
        top3_strong: rate(&strong, &|o| o.top_k(3)),
        top1_weak: rate(&weak, &|o| o.top_k(1)),
        top3_weak: rate(&weak, &|o| o.top_k(3)),
        detected_strong: rate(&strong, &|o| o.verdict != "no_gap"),
        detected_weak: rate(&weak, &|o| o.verdict != "no_gap"),
        top1_form: rate(&form, &|o| o.top_k(1)),
        detected_form: rate(&form, &|o| o.verdict != "no_gap"),
        false_alarms: rate(&|o| o.expectation == Expectation::Null, &|o| {
            o.verdict != "no_gap"
        }),
        unexplained_recall: rate(&|o| o.expectation == Expectation::OutOfVocabulary, &|o| {
            o.verdict == "unexplained"
        }),
        median_shrink_strong: median(
            outcomes
                .iter()
                .filter(|o| strong(o))
                .filter_map(|o| o.best_shrink)
                .collect(),
        ),
        median_param_rel_error_strong: top1_median_rel_error(outcomes, strong),
        params_within_2sd_strong: top1_params_rate(outcomes, strong, within_2sd),
        params_within_ci95_strong: top1_params_rate(outcomes, strong, in_ci95),
        median_param_rel_error_weak: top1_median_rel_error(outcomes, weak),
        params_within_2sd_weak: top1_params_rate(outcomes, weak, within_2sd),
        params_within_ci95_weak: top1_params_rate(outcomes, weak, in_ci95),
        pair_both: rate(&is_pair, &|o| o.pair_answer() == Some(PairAnswer::Both)),
        pair_one: rate(&is_pair, &|o| o.pair_answer() == Some(PairAnswer::One)),
        pair_neither: rate(&is_pair, &|o| o.pair_answer() == Some(PairAnswer::Neither)),
        pair_unexplained: rate(&is_pair, &|o| {
            o.pair_answer() == Some(PairAnswer::Unexplained)
        }),
        pair_detected: rate(&is_pair, &|o| o.pair_answer() != Some(PairAnswer::Missed)),
        median_param_rel_error_pair: median(
            outcomes
                .iter()
                .filter(|o| o.pair_answer() == Some(PairAnswer::Both))
                .flat_map(|o| o.param_rel_errors.iter().copied())
                .collect(),
        ),
        params_within_ci95_pair: {
            let flags: Vec<bool> = outcomes
                .iter()
                .filter(|o| o.pair_answer() == Some(PairAnswer::Both))
                .flat_map(in_ci95)
                .collect();
            Rate {
                k: flags.iter().filter(|i| **i).count(),
                n: flags.len(),
            }
        },
        confusion,
    }
}

fn within_2sd(o: &CaseOutcome) -> Vec<bool> {
    o.param_errors_in_sd.iter().map(|z| *z <= 2.0).collect()
}

fn in_ci95(o: &CaseOutcome) -> Vec<bool> {
    o.params_in_ci95.clone()
}

/// The median relative error of the identifiable parameters of the cases `keep` selects that
/// were answered top-1 (a parameter of another effect is no error of the withheld one).
fn top1_median_rel_error(
    outcomes: &[CaseOutcome],
    keep: impl Fn(&CaseOutcome) -> bool,
) -> Option<f64> {
    median(
        outcomes
            .iter()
            .filter(|o| keep(o) && o.top_k(1))
            .flat_map(|o| o.param_rel_errors.iter().copied())
            .collect(),
    )
}

/// The share of the identifiable parameters of the cases `keep` selects, answered top-1, for
/// which `inside` holds (one flag per parameter).
fn top1_params_rate(
    outcomes: &[CaseOutcome],
    keep: impl Fn(&CaseOutcome) -> bool,
    inside: impl Fn(&CaseOutcome) -> Vec<bool>,
) -> Rate {
    let flags: Vec<bool> = outcomes
        .iter()
        .filter(|o| keep(o) && o.top_k(1))
        .flat_map(inside)
        .collect();
    Rate {
        k: flags.iter().filter(|i| **i).count(),
        n: flags.len(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn case(
        expectation: Expectation,
        verdict: &str,
        ranked: &[&[&str]],
        shrink: f64,
    ) -> CaseOutcome {
        CaseOutcome {
            name: "c".into(),
            expectation,
            verdict: verdict.into(),
            ranked: ranked
                .iter()
                .map(|c| c.iter().map(|s| s.to_string()).collect())
                .collect(),
            ranked_labels: Vec::new(),
            best_shrink: Some(shrink),
            param_rel_errors: vec![0.1],
            param_errors_in_sd: vec![1.5, 2.5],
            // 2.5 σ lies inside an interval of k = 2.57 (t on 5 degrees of freedom).
            params_in_ci95: vec![true, true],
            eval_seeds: 4,
        }
    }

    fn withheld(effect: &str, strong: bool) -> Expectation {
        Expectation::Withheld {
            effect: effect.into(),
            also: if effect == "backlash" {
                vec!["overrotation".into()]
            } else {
                vec![]
            },
            strong,
            form: false,
        }
    }

    #[test]
    fn top_k_counts_ranks_groups_and_shared_switches() {
        let rs = case(
            withheld("rolling_shutter", true),
            "explained",
            &[&["motion_blur"], &["pixel_noise", "rolling_shutter"]],
            0.9,
        );
        assert!(!rs.top_k(1));
        assert!(rs.top_k(2));
        let bl = case(
            withheld("backlash", true),
            "explained",
            &[&["overrotation"]],
            0.9,
        );
        assert!(bl.top_k(1), "a shared switch is the same answer");
        let missed = case(withheld("lighting", true), "no_gap", &[&["lighting"]], 0.9);
        assert!(!missed.top_k(3), "no gap found is no identification");
        let partial = case(
            withheld("lens_distortion", false),
            "unexplained",
            &[&["lens_distortion"]],
            0.0,
        );
        assert!(!partial.top_k(3), "an unexplained gap names no cause");
    }

    #[test]
    fn rates_and_confusion_count_each_case_once() {
        let outcomes = vec![
            case(
                withheld("pixel_noise", true),
                "explained",
                &[&["pixel_noise"]],
                0.9,
            ),
            case(
                withheld("pixel_noise", true),
                "explained",
                &[&["optical_blur"], &["pixel_noise"]],
                0.5,
            ),
            case(withheld("pixel_noise", false), "no_gap", &[], 0.0),
            CaseOutcome {
                param_rel_errors: vec![0.4, 0.2],
                param_errors_in_sd: vec![2.3, 0.5],
                params_in_ci95: vec![false, true],
                ..case(
                    withheld("lighting", false),
                    "explained",
                    &[&["lighting"]],
                    0.95,
                )
            },
            case(Expectation::Null, "no_gap", &[], 0.0),
            case(Expectation::Null, "unexplained", &[&["lighting"]], 0.1),
            case(
                Expectation::OutOfVocabulary,
                "unexplained",
                &[&["lighting"]],
                0.2,
            ),
        ];
        let s = score(&outcomes);
        assert_eq!(s.top1_strong, Rate { k: 1, n: 2 });
        assert_eq!(s.top3_strong, Rate { k: 2, n: 2 });
        assert_eq!(s.detected_weak, Rate { k: 1, n: 2 });
        assert_eq!(s.top1_weak, Rate { k: 1, n: 2 });
        assert_eq!(s.false_alarms, Rate { k: 1, n: 2 });
        assert_eq!(s.unexplained_recall, Rate { k: 1, n: 1 });
        assert_eq!(s.median_shrink_strong, Some(0.7));
        assert_eq!(s.median_param_rel_error_strong, Some(0.1));
        // The one top-1 strong case's two parameters: 1.5 σ and 2.5 σ off.
        assert_eq!(s.params_within_2sd_strong, Rate { k: 1, n: 2 });
        assert_eq!(s.params_within_ci95_strong, Rate { k: 2, n: 2 });
        // Near the limit, the one top-1 case's own parameters, not the strong cases'.
        assert!(s
            .median_param_rel_error_weak
            .is_some_and(|m| (m - 0.3).abs() < 1e-12));
        assert_eq!(s.params_within_2sd_weak, Rate { k: 1, n: 2 });
        assert_eq!(s.params_within_ci95_weak, Rate { k: 1, n: 2 });
        assert_eq!(s.confusion["pixel_noise (strong)"]["optical_blur"], 1);
        assert_eq!(s.confusion["null"]["unexplained (lighting)"], 1);
        assert_eq!(s.top1_form, Rate { k: 0, n: 0 });
        let total: usize = s.confusion.values().flat_map(|r| r.values()).sum();
        assert_eq!(total, outcomes.len());
    }

    #[test]
    fn ranking_labels_keep_pairs_and_groups_and_read_older_records() {
        let mut o = case(
            withheld("backlash", true),
            "explained",
            &[
                &["drive_speed", "axis_runout", "backlash", "overrotation"],
                &["axis_runout"],
            ],
            0.9,
        );
        assert_eq!(
            o.ranking_labels(),
            [
                "drive_speed/axis_runout/backlash/overrotation",
                "axis_runout"
            ],
            "a record without labels keeps the flattened names"
        );
        o.ranked_labels = vec![
            "drive_speed+axis_runout ≈ backlash+overrotation".into(),
            "axis_runout".into(),
        ];
        assert_eq!(o.ranking_labels(), o.ranked_labels);
        let json = serde_json::to_string(&o).unwrap();
        let back: CaseOutcome = serde_json::from_str(&json).unwrap();
        assert_eq!(back, o);
        let old: CaseOutcome =
            serde_json::from_str(&json.replace("\"ranked_labels\"", "\"unknown_field\"")).unwrap();
        assert!(old.ranked_labels.is_empty(), "older records parse");
    }

    #[test]
    fn another_form_is_scored_apart_from_the_strong_level() {
        let form = Expectation::Withheld {
            effect: "axis_runout".into(),
            also: vec![],
            strong: true,
            form: true,
        };
        let outcomes = vec![
            case(form.clone(), "explained", &[&["axis_runout"]], 0.9),
            case(form, "unexplained", &[&["backlash"], &["axis_runout"]], 0.8),
            case(
                withheld("axis_runout", true),
                "explained",
                &[&["axis_runout"]],
                1.0,
            ),
        ];
        let s = score(&outcomes);
        assert_eq!(s.top1_form, Rate { k: 1, n: 2 });
        assert_eq!(s.detected_form, Rate { k: 2, n: 2 });
        assert_eq!(s.top1_strong, Rate { k: 1, n: 1 });
        assert_eq!(s.median_shrink_strong, Some(1.0));
        assert_eq!(s.confusion["axis_runout (other form)"]["axis_runout"], 1);
        // Records of the strong and weak levels serialise as before.
        let json = serde_json::to_string(&withheld("lighting", true)).unwrap();
        assert!(!json.contains("form"), "{json}");
    }

    #[test]
    fn a_pair_counts_as_found_when_the_best_candidate_names_both() {
        let pair = || Expectation::WithheldPair {
            members: vec![
                PairMember {
                    effect: "motion_blur".into(),
                    also: vec![],
                },
                PairMember {
                    effect: "backlash".into(),
                    also: vec!["overrotation".into()],
                },
            ],
        };
        let both = CaseOutcome {
            ranked_labels: vec!["motion_blur+overrotation".into(), "motion_blur".into()],
            param_rel_errors: vec![0.1, 0.3],
            params_in_ci95: vec![true, false],
            ..case(
                pair(),
                "explained",
                &[&["motion_blur", "overrotation"], &["motion_blur"]],
                0.9,
            )
        };
        let one = case(
            pair(),
            "explained",
            &[&["motion_blur"], &["motion_blur", "backlash"]],
            0.8,
        );
        let neither = case(pair(), "explained", &[&["lighting"]], 0.8);
        let honest = case(pair(), "unexplained", &[&["motion_blur", "backlash"]], 0.9);
        let missed = case(pair(), "no_gap", &[], 0.0);
        let outcomes = [both, one, neither, honest, missed];
        let answers: Vec<_> = outcomes.iter().map(|o| o.pair_answer()).collect();
        assert_eq!(
            answers,
            [
                Some(PairAnswer::Both),
                Some(PairAnswer::One),
                Some(PairAnswer::Neither),
                Some(PairAnswer::Unexplained),
                Some(PairAnswer::Missed)
            ],
            "an unexplained verdict names no cause, whatever it ranks first"
        );
        let s = score(&outcomes);
        assert_eq!(s.pair_both, Rate { k: 1, n: 5 });
        assert_eq!(s.pair_one, Rate { k: 1, n: 5 });
        assert_eq!(s.pair_neither, Rate { k: 1, n: 5 });
        assert_eq!(s.pair_unexplained, Rate { k: 1, n: 5 });
        assert_eq!(s.pair_detected, Rate { k: 4, n: 5 });
        // Only the case that named both gives parameter figures.
        assert!(s
            .median_param_rel_error_pair
            .is_some_and(|m| (m - 0.2).abs() < 1e-12));
        assert_eq!(s.params_within_ci95_pair, Rate { k: 1, n: 2 });
        // Pairs are no single withheld effect: the single figures count none of them.
        assert_eq!(s.top1_strong.n + s.top1_weak.n + s.false_alarms.n, 0);
        assert_eq!(
            s.confusion["motion_blur + backlash (pair)"]["motion_blur+overrotation"],
            1
        );
        assert_eq!(
            s.confusion["motion_blur + backlash (pair)"]["unexplained (motion_blur/backlash)"],
            1
        );
        assert_eq!(
            case(Expectation::Null, "no_gap", &[], 0.0).pair_answer(),
            None
        );
        let json = serde_json::to_string(&outcomes[0]).unwrap();
        let back: CaseOutcome = serde_json::from_str(&json).unwrap();
        assert_eq!(back, outcomes[0]);
    }

    #[test]
    fn wilson_interval_contains_the_rate_and_shrinks_with_n() {
        let a = Rate { k: 9, n: 10 }.wilson95().unwrap();
        let b = Rate { k: 90, n: 100 }.wilson95().unwrap();
        assert!(a.0 < 0.9 && 0.9 < a.1 && b.0 < 0.9 && 0.9 < b.1);
        assert!(b.1 - b.0 < a.1 - a.0);
        assert_eq!(Rate { k: 0, n: 0 }.wilson95(), None);
    }

    #[test]
    fn a_record_with_an_infinite_error_in_sd_reads_back() {
        let mut o = case(
            withheld("timebase", true),
            "explained",
            &[&["timebase"]],
            1.0,
        );
        o.param_errors_in_sd = vec![0.5, f64::INFINITY];
        let json = serde_json::to_string(&o).unwrap();
        let back: CaseOutcome = serde_json::from_str(&json).unwrap();
        assert_eq!(back, o);
        // Records written before the field existed.
        let old = json.replace(",\"param_errors_in_sd\":[0.5,null]", "");
        assert_ne!(old, json);
        let back: CaseOutcome = serde_json::from_str(&old).unwrap();
        assert!(back.param_errors_in_sd.is_empty());
    }
}
