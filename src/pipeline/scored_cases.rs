//! Scoring of diagnoses of footage that no renderer of the project drew (a path tracer's, a
//! real rig's with a known cause): each case folder holds `case.json` (what the footage holds:
//! the scoring's [`Expectation`] and the true values of a withheld effect) and the
//! `diagnosis/diagnosis.json` that `geneva diagnose` wrote for it, or a `failed.json` saying
//! which step of the chain failed on it. The diagnosis is read back as the self-check reads its
//! own ([`CaseOutcome`]) and scored by [`crate::diagnose::scoring`]; a failed chain is a miss
//! (verdict `error`, no candidate), as the self-check scores a diagnosis that fails. Nothing here
//! judges anything itself.

use crate::diagnose::scoring::{pct, score, CaseOutcome, Expectation, Rate, Scores};
use crate::scenario::effects::Effect;
use serde::Deserialize;
use serde_json::Value;
use std::path::{Path, PathBuf};

/// What one case's footage holds, as `case.json` states it (other fields are the renderer's).
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct ExternalCase {
    pub name: String,
    pub expectation: Expectation,
    /// The withheld effects' true parameter values, in the registry's order.
    #[serde(default)]
    pub truths: Vec<Truth>,
    /// A label the report counts separately (`null`, `vocabulary`, `novel`, …).
    #[serde(default)]
    pub group: String,
    /// One line saying what was rendered.
    #[serde(default)]
    pub description: String,
}

/// One withheld effect's true values.
#[derive(Debug, Clone, PartialEq, Deserialize)]
pub struct Truth {
    pub effect: String,
    pub values: Vec<f64>,
}

#[derive(Debug, thiserror::Error)]
pub enum ScoreError {
    #[error(transparent)]
    File(#[from] crate::errors::FileError),
    #[error("{}: {why}", file.display())]
    Content { file: PathBuf, why: String },
}

fn content(file: &Path, why: impl Into<String>) -> ScoreError {
    ScoreError::Content {
        file: file.to_path_buf(),
        why: why.into(),
    }
}

fn read_json(file: &Path) -> Result<Value, ScoreError> {
    let text = std::fs::read_to_string(file).map_err(crate::errors::FileError::io(file))?;
    serde_json::from_str(&text).map_err(|e| crate::errors::FileError::json(file)(e).into())
}

/// A case and, once it has been diagnosed, its outcome.
#[derive(Debug, Clone)]
pub struct Scored {
    /// The case's folder.
    pub folder: PathBuf,
    pub case: ExternalCase,
    pub outcome: Option<CaseOutcome>,
}

/// Every case folder under `dir` (a folder with a `case.json`), in name order, with the outcome
/// of its `diagnosis/diagnosis.json` when that exists.
pub fn read_cases(dir: &Path) -> Result<Vec<Scored>, ScoreError> {
    let entries = std::fs::read_dir(dir).map_err(crate::errors::FileError::io(dir))?;
    let mut folders: Vec<PathBuf> = entries
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.join("case.json").is_file())
        .collect();
    folders.sort();
    folders
        .iter()
        .map(|folder| {
            let file = folder.join("case.json");
            let case: ExternalCase = serde_json::from_value(read_json(&file)?)
                .map_err(|e| content(&file, format!("not a case description: {e}")))?;
            let plain = |c: char| c.is_ascii_alphanumeric() || "_.+-".contains(c);
            if case.name.is_empty() || case.name.starts_with('.') || !case.name.chars().all(plain) {
                return Err(content(
                    &file,
                    format!(
                        "name `{}`: a case's name is a folder name (letters, digits, _ . + -)",
                        case.name
                    ),
                ));
            }
            for t in &case.truths {
                let effect = Effect::from_name(&t.effect).ok_or_else(|| {
                    content(
                        &file,
                        format!("`{}` is not an effect of the vocabulary", t.effect),
                    )
                })?;
                if t.values.len() != effect.params().len() {
                    return Err(content(
                        &file,
                        format!(
                            "{} has {} parameters, the truth lists {}",
                            t.effect,
                            effect.params().len(),
                            t.values.len()
                        ),
                    ));
                }
            }
            let diagnosis = folder.join("diagnosis").join("diagnosis.json");
            let outcome = if diagnosis.is_file() {
                Some(
                    outcome_from_json(&case, &read_json(&diagnosis)?)
                        .map_err(|why| content(&diagnosis, why))?,
                )
            } else if folder.join("failed.json").is_file() {
                Some(failed_outcome(&case))
            } else {
                None
            };
            Ok(Scored {
                folder: folder.clone(),
                case,
                outcome,
            })
        })
        .collect()
}

/// The outcome of a case whose chain failed (calibration or diagnosis): verdict `error`.
fn failed_outcome(case: &ExternalCase) -> CaseOutcome {
    CaseOutcome {
        name: case.name.clone(),
        expectation: case.expectation.clone(),
        verdict: "error".into(),
        ranked: Vec::new(),
        ranked_labels: Vec::new(),
        best_shrink: None,
        param_rel_errors: Vec::new(),
        param_errors_in_sd: Vec::new(),
        params_in_ci95: Vec::new(),
        eval_seeds: 0,
    }
}

/// A number of `diagnosis.json`, infinite where JSON holds null (an undetermined ±).
fn number_or_inf(v: Option<&Value>) -> f64 {
    v.and_then(Value::as_f64).unwrap_or(f64::INFINITY)
}

/// The outcome of `case` from its `diagnosis.json`, as the self-check's own (`selfcheck::outcome`)
/// reads a diagnosis: the ranked candidates (each with its group), the best candidate (the
/// ranking's first) and, for each withheld effect it fitted, the errors of its identifiable
/// parameters (finite ±, truth not zero) against the truth and whether the truth lies in the
/// stated 95 % interval.
pub fn outcome_from_json(case: &ExternalCase, d: &Value) -> Result<CaseOutcome, String> {
    let verdict = d["verdict"].as_str().ok_or("no `verdict`")?.to_string();
    let ranking = d["ranking"].as_array().cloned().unwrap_or_default();
    let mut ranked = Vec::new();
    let mut ranked_labels = Vec::new();
    for r in &ranking {
        let effects: Vec<String> = r["effects"]
            .as_array()
            .ok_or("a ranked candidate without `effects`")?
            .iter()
            .filter_map(|e| e.as_str().map(str::to_string))
            .collect();
        let group: Vec<String> = r["group"]
            .as_array()
            .map(|g| {
                g.iter()
                    .filter_map(|x| x.as_str().map(str::to_string))
                    .collect()
            })
            .unwrap_or_default();
        let mut names = effects.clone();
        names.extend(group.iter().flat_map(|g| g.split('+').map(str::to_string)));
        ranked.push(names);
        ranked_labels.push(
            std::iter::once(effects.join("+"))
                .chain(group)
                .collect::<Vec<_>>()
                .join(" ≈ "),
        );
    }
    let best = ranking.first();
    let mut param_rel_errors = Vec::new();
    let mut param_errors_in_sd = Vec::new();
    let mut params_in_ci95 = Vec::new();
    if let Some(best) = best {
        let fitted: Vec<&str> = best["effects"]
            .as_array()
            .map(|a| a.iter().filter_map(Value::as_str).collect())
            .unwrap_or_default();
        let single = fitted.len() == 1;
        for truth in &case.truths {
            let Some(effect) = Effect::from_name(&truth.effect) else {
                return Err(format!("`{}` is not an effect", truth.effect));
            };
            if !fitted.contains(&effect.name()) {
                continue;
            }
            for (spec, &t) in effect.params().iter().zip(&truth.values) {
                let key = if single {
                    spec.name.to_string()
                } else {
                    format!("{}.{}", effect.name(), spec.name)
                };
                let Some(v) = best["params"][&key].as_f64() else {
                    continue;
                };
                let s = number_or_inf(best["params_std"].get(&key));
                if !(s.is_finite() && t.abs() > 0.0) {
                    continue;
                }
                param_rel_errors.push(((v - t) / t).abs());
                param_errors_in_sd.push(if s > 0.0 {
                    (v - t).abs() / s
                } else if v == t {
                    0.0
                } else {
                    f64::INFINITY
                });
                let interval = best["params_ci95"][&key].as_array();
                params_in_ci95.push(interval.is_some_and(|i| {
                    let (lo, hi) = (number_or_inf(i.first()), number_or_inf(i.get(1)));
                    lo <= t && t <= hi
                }));
            }
        }
    }
    Ok(CaseOutcome {
        name: case.name.clone(),
        expectation: case.expectation.clone(),
        verdict,
        ranked,
        ranked_labels,
        best_shrink: best.and_then(|b| b["shrink"].as_f64()),
        param_rel_errors,
        param_errors_in_sd,
        params_in_ci95,
        eval_seeds: d["run"]["seeds"].as_array().map_or(0, Vec::len),
    })
}

/// `unexplained` among the out-of-vocabulary cases of `group`.
fn unexplained_in(scored: &[Scored], group: &str) -> Rate {
    let cases: Vec<&CaseOutcome> = scored
        .iter()
        .filter(|s| s.case.group == group)
        .filter_map(|s| s.outcome.as_ref())
        .filter(|o| o.expectation == Expectation::OutOfVocabulary)
        .collect();
    Rate {
        k: cases.iter().filter(|o| o.verdict == "unexplained").count(),
        n: cases.len(),
    }
}

/// The figures table: each figure the issue states a target for, measured over the cases.
fn figures(s: &Scores, scored: &[Scored]) -> Vec<(String, String, &'static str)> {
    let opt = |v: Option<f64>| v.map_or("–".into(), |v| format!("{:.2} %", 100.0 * v));
    let mut rows = vec![
        (
            "false alarms on null cases".to_string(),
            pct(&s.false_alarms),
            "≤ 5 %",
        ),
        ("top-1, strong".into(), pct(&s.top1_strong), "≥ 90 %"),
        ("top-3, strong".into(), pct(&s.top3_strong), "–"),
        ("gap found, strong".into(), pct(&s.detected_strong), "–"),
        (
            "fitted values' truth inside their stated 95 % interval (strong, top-1 cases)".into(),
            pct(&s.params_within_ci95_strong),
            "≥ 90 %",
        ),
        (
            "median relative error of the fitted values (strong, top-1 cases)".into(),
            opt(s.median_param_rel_error_strong),
            "–",
        ),
        (
            "median shrink of the best candidate (strong)".into(),
            opt(s.median_shrink_strong),
            "–",
        ),
        (
            "out of vocabulary → `unexplained` (all such cases)".into(),
            pct(&s.unexplained_recall),
            "≥ 80 %",
        ),
    ];
    let mut groups: Vec<&str> = scored
        .iter()
        .filter(|c| c.case.expectation == Expectation::OutOfVocabulary)
        .map(|c| c.case.group.as_str())
        .filter(|g| !g.is_empty())
        .collect();
    groups.sort_unstable();
    groups.dedup();
    for g in groups {
        rows.push((
            format!("out of vocabulary → `unexplained`, group `{g}`"),
            pct(&unexplained_in(scored, g)),
            "≥ 80 %",
        ));
    }
    rows
}

/// Another source's figures to show beside these: a name and the `summary.json` of its
/// self-check (`geneva diagnose-selfcheck`) or of another scoring.
#[derive(Debug, Clone, PartialEq)]
pub struct Beside {
    pub name: String,
    pub summary: PathBuf,
}

/// The figures the sources are compared on: `summary.json`'s key and the row's name.
const COMPARED: [(&str, &str); 4] = [
    ("top1_strong", "top-1, strong"),
    ("false_alarms", "false alarms on null cases"),
    ("unexplained_recall", "out of vocabulary → `unexplained`"),
    (
        "params_within_ci95_strong",
        "fitted values' truth in their 95 % interval",
    ),
];

/// A rate of a `summary.json` (`{"k", "n"}`) in words.
fn rate_text(v: &Value) -> String {
    match (v["k"].as_u64(), v["n"].as_u64()) {
        (Some(k), Some(n)) if n > 0 => pct(&Rate {
            k: k as usize,
            n: n as usize,
        }),
        _ => "– (no case)".into(),
    }
}

/// The comparison table: this footage's figures beside each other source's.
fn beside_table(ours: &Value, beside: &[Beside]) -> Result<String, ScoreError> {
    let mut columns = vec![("this footage".to_string(), ours.clone())];
    for b in beside {
        columns.push((b.name.clone(), read_json(&b.summary)?));
    }
    let mut md = format!(
        "| figure | {} |\n|---|{}\n",
        columns
            .iter()
            .map(|c| c.0.as_str())
            .collect::<Vec<_>>()
            .join(" | "),
        "---|".repeat(columns.len())
    );
    for (key, name) in COMPARED {
        let cells: Vec<String> = columns.iter().map(|c| rate_text(&c.1[key])).collect();
        md.push_str(&format!("| {name} | {} |\n", cells.join(" | ")));
    }
    md.push_str(&format!(
        "\nThe other columns: {}.\n",
        beside
            .iter()
            .map(|b| format!("{} (`{}`)", b.name, b.summary.display()))
            .collect::<Vec<_>>()
            .join(", ")
    ));
    Ok(md)
}

/// The files of a case folder a report keeps, beside the figures: what was rendered, a look at
/// it, and what calibration and diagnosis said.
pub const KEPT_FILES: [&str; 6] = [
    "case.json",
    "failed.json",
    "preview.png",
    "calibrated/calibration.md",
    "diagnosis/diagnosis.md",
    "diagnosis/diagnosis.json",
];

/// Writes `README.md` (`about`, then the figures, the other sources' beside them, the confusion
/// matrix and every case), `cases.csv` and `summary.json` of the diagnosed cases into `out_dir`,
/// and each case's [`KEPT_FILES`] that exist under `cases/<name>/`; cases not diagnosed yet are
/// named as such and left out of the figures. Returns the number scored.
pub fn write_report(
    scored: &[Scored],
    about: &str,
    beside: &[Beside],
    out_dir: &Path,
) -> Result<usize, ScoreError> {
    let outcomes: Vec<CaseOutcome> = scored.iter().filter_map(|s| s.outcome.clone()).collect();
    let s = score(&outcomes);
    let mut md = about.trim_end().to_string();
    md.push_str("\n\n## Figures\n\n");
    let pending: Vec<&str> = scored
        .iter()
        .filter(|c| c.outcome.is_none())
        .map(|c| c.case.name.as_str())
        .collect();
    md.push_str(&format!(
        "Over the {} diagnosed case(s){}. A rate is k/n with its 95 % Wilson interval; top-k \
         counts a case when the verdict is `explained` and the withheld effect (or an effect \
         sharing its switch, or its group) is among the k best candidates \
         (`src/diagnose/scoring.rs`).\n\n| figure | measured | target |\n|---|---|---|\n",
        outcomes.len(),
        if pending.is_empty() {
            String::new()
        } else {
            format!("; not diagnosed yet: {}", pending.join(", "))
        }
    ));
    for (name, v, t) in figures(&s, scored) {
        md.push_str(&format!("| {name} | {v} | {t} |\n"));
    }
    let rate = |r: &Rate| serde_json::json!({"k": r.k, "n": r.n, "value": r.value()});
    let summary = serde_json::json!({
        "cases": outcomes.len(),
        "pending": pending,
        "false_alarms": rate(&s.false_alarms),
        "top1_strong": rate(&s.top1_strong),
        "top3_strong": rate(&s.top3_strong),
        "detected_strong": rate(&s.detected_strong),
        "params_within_ci95_strong": rate(&s.params_within_ci95_strong),
        "median_param_rel_error_strong": s.median_param_rel_error_strong,
        "median_shrink_strong": s.median_shrink_strong,
        "unexplained_recall": rate(&s.unexplained_recall),
    });
    if !beside.is_empty() {
        md.push_str("\n## Beside the project's renderers\n\n");
        md.push_str(&beside_table(&summary, beside)?);
    }
    md.push_str("\n## Confusion (rows: what the footage holds; columns: the answer)\n\n");
    let mut cols: Vec<String> = s
        .confusion
        .values()
        .flat_map(|r| r.keys().cloned())
        .collect();
    cols.sort();
    cols.dedup();
    md.push_str(&format!(
        "| case | {} |\n|---|{}\n",
        cols.join(" | "),
        "---|".repeat(cols.len())
    ));
    for (row, counts) in &s.confusion {
        let cells: Vec<String> = cols
            .iter()
            .map(|c| counts.get(c).map_or(String::new(), |n| n.to_string()))
            .collect();
        md.push_str(&format!("| {row} | {} |\n", cells.join(" | ")));
    }
    md.push_str(
        "\n## Cases\n\n| case | group | what the footage holds | verdict | ranking (best first) \
         | shrink | parameter errors | truth in 95 % interval |\n|---|---|---|---|---|---|---|---|\n",
    );
    let mut csv =
        String::from("case,group,verdict,ranking,best_shrink,param_rel_errors,params_in_ci95\n");
    for c in scored {
        let Some(o) = &c.outcome else {
            md.push_str(&format!(
                "| {} | {} | {} | not diagnosed yet | | | | |\n",
                c.case.name, c.case.group, c.case.description
            ));
            continue;
        };
        let ranking: Vec<String> = o.ranking_labels().into_iter().take(4).collect();
        let errs: Vec<String> = o
            .param_rel_errors
            .iter()
            .map(|e| format!("{:.0} %", 100.0 * e))
            .collect();
        let inside: Vec<&str> = o
            .params_in_ci95
            .iter()
            .map(|i| if *i { "yes" } else { "no" })
            .collect();
        md.push_str(&format!(
            "| {} | {} | {} | {} | {} | {} | {} | {} |\n",
            o.name,
            c.case.group,
            c.case.description,
            o.verdict,
            ranking.join(" > "),
            o.best_shrink.map_or("–".into(), |v| format!("{v:.2}")),
            errs.join(", "),
            inside.join(", "),
        ));
        csv.push_str(&format!(
            "{},{},{},{},{},{},{}\n",
            o.name,
            c.case.group,
            o.verdict,
            ranking.join(" > "),
            o.best_shrink.map_or(String::new(), |v| format!("{v:.4}")),
            o.param_rel_errors
                .iter()
                .map(|e| format!("{e:.4}"))
                .collect::<Vec<_>>()
                .join(" "),
            o.params_in_ci95
                .iter()
                .map(|i| if *i { "1" } else { "0" })
                .collect::<Vec<_>>()
                .join(" "),
        ));
    }
    let write = |name: &str, text: String| -> Result<(), ScoreError> {
        let path = out_dir.join(name);
        std::fs::write(&path, text).map_err(|e| crate::errors::FileError::io(&path)(e).into())
    };
    for c in scored {
        for name in KEPT_FILES {
            let from = c.folder.join(name);
            if !from.is_file() {
                continue;
            }
            let to = out_dir.join("cases").join(&c.case.name).join(name);
            if let Some(parent) = to.parent() {
                std::fs::create_dir_all(parent).map_err(crate::errors::FileError::io(parent))?;
            }
            std::fs::copy(&from, &to).map_err(crate::errors::FileError::io(&from))?;
        }
    }
    write("README.md", md)?;
    write("cases.csv", csv)?;
    write(
        "summary.json",
        serde_json::to_string_pretty(&summary).unwrap_or_default() + "\n",
    )?;
    Ok(outcomes.len())
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    fn withheld(effect: &str, values: Vec<f64>) -> ExternalCase {
        ExternalCase {
            name: format!("withheld-{effect}"),
            expectation: Expectation::Withheld {
                effect: effect.into(),
                also: vec![],
                strong: true,
                form: false,
            },
            truths: vec![Truth {
                effect: effect.into(),
                values,
            }],
            group: "vocabulary".into(),
            description: String::new(),
        }
    }

    fn diagnosis(verdict: &str, ranking: Value) -> Value {
        json!({"verdict": verdict, "ranking": ranking, "run": {"seeds": [1, 2, 3, 4]}})
    }

    #[test]
    fn a_found_effect_is_top_1_with_its_truth_in_the_interval() {
        let case = withheld("motion_blur", vec![0.02]);
        let d = diagnosis(
            "explained",
            json!([
                {"effects": ["motion_blur"], "group": ["optical_blur"], "shrink": 0.93,
                 "params": {"exposure_s": 0.021}, "params_std": {"exposure_s": 0.001},
                 "params_ci95": {"exposure_s": [0.019, 0.023]}},
                {"effects": ["optical_blur"], "group": [], "shrink": 0.5,
                 "params": {"sigma_px": 1.1}, "params_std": {"sigma_px": 0.1},
                 "params_ci95": {"sigma_px": [0.9, 1.3]}}
            ]),
        );
        let o = outcome_from_json(&case, &d).unwrap();
        assert!(o.top_k(1));
        assert_eq!(o.ranked[0], vec!["motion_blur", "optical_blur"]);
        assert_eq!(o.ranking_labels()[0], "motion_blur ≈ optical_blur");
        assert_eq!(o.params_in_ci95, vec![true]);
        assert!((o.param_rel_errors[0] - 0.05).abs() < 1e-12);
        assert!((o.param_errors_in_sd[0] - 1.0).abs() < 1e-9);
        assert_eq!(o.best_shrink, Some(0.93));
        assert_eq!(o.eval_seeds, 4);
    }

    #[test]
    fn a_truth_outside_its_interval_and_an_undetermined_value_are_told_apart() {
        let case = withheld("lighting", vec![90.0, 170.0, 1.0]);
        let d = diagnosis(
            "explained",
            json!([{"effects": ["lighting"], "group": [], "shrink": 0.9,
                "params": {"black_level_dn": 80.0, "white_level_dn": 171.0, "gamma": 1.2},
                "params_std": {"black_level_dn": 2.0, "white_level_dn": 1.0, "gamma": null},
                "params_ci95": {"black_level_dn": [76.0, 84.0], "white_level_dn": [169.0, 173.0],
                                "gamma": null}}]),
        );
        let o = outcome_from_json(&case, &d).unwrap();
        // The gamma's ± is undetermined: not counted, as in the self-check.
        assert_eq!(o.params_in_ci95, vec![false, true]);
    }

    #[test]
    fn a_pair_s_parameters_are_read_under_their_effect_s_name() {
        let case = withheld("rolling_shutter", vec![0.03]);
        let d = diagnosis(
            "explained",
            json!([{"effects": ["rolling_shutter", "lens_distortion"], "group": [], "shrink": 0.9,
                "params": {"rolling_shutter.readout_s": 0.031, "lens_distortion.k1": -0.1},
                "params_std": {"rolling_shutter.readout_s": 0.002, "lens_distortion.k1": 0.01},
                "params_ci95": {"rolling_shutter.readout_s": [0.027, 0.035],
                                "lens_distortion.k1": [-0.12, -0.08]}}]),
        );
        let o = outcome_from_json(&case, &d).unwrap();
        assert_eq!(o.params_in_ci95, vec![true]);
        assert_eq!(o.ranked_labels[0], "rolling_shutter+lens_distortion");
    }

    #[test]
    fn cases_are_read_from_folders_and_scored_with_pending_ones_named() {
        let dir = tempfile::tempdir().unwrap();
        let write_case = |name: &str, case: Value, diag: Option<Value>| {
            let folder = dir.path().join(name);
            std::fs::create_dir_all(folder.join("diagnosis")).unwrap();
            std::fs::write(folder.join("case.json"), case.to_string()).unwrap();
            if let Some(d) = diag {
                std::fs::write(folder.join("diagnosis/diagnosis.json"), d.to_string()).unwrap();
            }
        };
        write_case(
            "null-0",
            json!({"name": "null-0", "expectation": {"kind": "null"}, "group": "null",
                   "renderer": "anything else is the renderer's"}),
            Some(diagnosis("no_gap", json!([]))),
        );
        write_case(
            "novel-creep",
            json!({"name": "novel-creep", "expectation": {"kind": "out_of_vocabulary"},
                   "group": "novel"}),
            Some(diagnosis(
                "explained",
                json!([{"effects": ["overrotation"], "group": [], "shrink": 1.0,
                        "params": {}, "params_std": {}, "params_ci95": {}}]),
            )),
        );
        write_case(
            "novel-cable",
            json!({"name": "novel-cable", "expectation": {"kind": "out_of_vocabulary"},
                   "group": "novel"}),
            None,
        );
        std::fs::write(
            dir.path().join("novel-cable/failed.json"),
            json!({"step": "calibrate", "message": "no marker"}).to_string(),
        )
        .unwrap();
        write_case(
            "novel-glare",
            json!({"name": "novel-glare", "expectation": {"kind": "out_of_vocabulary"},
                   "group": "novel"}),
            None,
        );
        let scored = read_cases(dir.path()).unwrap();
        assert_eq!(scored.len(), 4);
        assert_eq!(scored[0].folder, dir.path().join("novel-cable"));
        assert_eq!(scored[0].outcome.as_ref().unwrap().verdict, "error");
        let out = tempfile::tempdir().unwrap();
        let other = dir.path().join("other.json");
        std::fs::write(
            &other,
            json!({"top1_strong": {"k": 9, "n": 10}, "false_alarms": {"k": 0, "n": 4},
                   "unexplained_recall": {"k": 1, "n": 2}})
            .to_string(),
        )
        .unwrap();
        let beside = [Beside {
            name: "own renderer".into(),
            summary: other,
        }];
        assert_eq!(
            write_report(&scored, "# about", &beside, out.path()).unwrap(),
            3
        );
        let md = std::fs::read_to_string(out.path().join("README.md")).unwrap();
        assert!(md.starts_with("# about"), "{md}");
        assert!(
            md.contains("| false alarms on null cases | 0 % (0/1; 95 % CI 0–79 %) | 0 % (0/4;"),
            "{md}"
        );
        assert!(
            md.contains("| top-1, strong | – (no case) | 90 % (9/10;"),
            "{md}"
        );
        assert!(md.contains("not diagnosed yet: novel-glare"), "{md}");
        assert!(
            md.contains("| false alarms on null cases | 0 % (0/1;"),
            "{md}"
        );
        assert!(
            md.contains("| out of vocabulary → `unexplained`, group `novel` | 0 % (0/2;"),
            "{md}"
        );
        let summary: Value = serde_json::from_str(
            &std::fs::read_to_string(out.path().join("summary.json")).unwrap(),
        )
        .unwrap();
        assert_eq!(summary["pending"], json!(["novel-glare"]));
        assert!(out.path().join("cases/null-0/case.json").is_file());
        assert!(out
            .path()
            .join("cases/null-0/diagnosis/diagnosis.json")
            .is_file());
        assert!(out.path().join("cases/novel-cable/failed.json").is_file());
    }

    #[test]
    fn a_truth_of_the_wrong_length_is_an_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let folder = dir.path().join("bad");
        std::fs::create_dir_all(&folder).unwrap();
        std::fs::write(
            folder.join("case.json"),
            json!({"name": "bad", "expectation": {"kind": "null"},
                   "truths": [{"effect": "lighting", "values": [1.0]}]})
            .to_string(),
        )
        .unwrap();
        let e = read_cases(dir.path()).unwrap_err().to_string();
        assert!(
            e.contains("case.json") && e.contains("lighting has 3 parameters"),
            "{e}"
        );
    }
}
