//! `geneva decompose`: which effect costs how much. Runs the scenario with no optional effect,
//! with all of the base scenario's effects, with each alone and with each left out, each for a
//! few seeds, and splits the fused ω2 and α2 error variance into per-source shares
//! ([`crate::budget::decompose`]). Writes `decomposition.csv`, `decomposition.md` and bar charts.

use super::montecarlo::{monte_carlo, MonteCarloError, MonteCarloOptions};
use crate::budget::decompose::{decompose, DecomposeError, Decomposition, VarianceRuns};
use crate::plot::bars_png;
use crate::scenario::effects::Effect;
use crate::scenario::{Scenario, ScenarioError};
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum DecompositionError {
    #[error(transparent)]
    Scenario(#[from] ScenarioError),
    #[error("run `{run}`: {source}")]
    Run {
        run: String,
        source: MonteCarloError,
    },
    #[error(transparent)]
    Decompose(#[from] DecomposeError),
    #[error("{file}: {message}")]
    Write { file: PathBuf, message: String },
}

/// Everything a decomposition computed.
#[derive(Debug, Clone)]
pub struct DecompositionOutput {
    /// Effects that are on in the base scenario (decomposed) and those that are off.
    pub effects_on: Vec<String>,
    pub effects_off: Vec<String>,
    pub omega_runs: VarianceRuns,
    pub alpha_runs: VarianceRuns,
    pub omega: Decomposition,
    pub alpha: Decomposition,
    pub seeds: usize,
    pub files: Vec<PathBuf>,
}

/// The effects of the registry that are on in `base`, grouped by shared switch (a group is
/// decomposed as one source, named `a+b`), in registry order.
pub fn active_effects(base: &Scenario) -> Vec<Vec<Effect>> {
    let mut groups: Vec<Vec<Effect>> = Vec::new();
    for e in Effect::ALL {
        if !e.is_on(base) || groups.iter().flatten().any(|g| *g == e) {
            continue;
        }
        let mut group = vec![e];
        group.extend(
            e.shares_switch_with()
                .iter()
                .copied()
                .filter(|o| o.is_on(base)),
        );
        groups.push(group);
    }
    groups
}

fn group_name(group: &[Effect]) -> String {
    group.iter().map(|e| e.name()).collect::<Vec<_>>().join("+")
}

/// Mean over seeds of the fused ω2 and α2 error variances of one configuration.
fn variances(
    scenario: &Scenario,
    seeds: usize,
    run: &str,
) -> Result<(f64, f64), DecompositionError> {
    let options = MonteCarloOptions {
        seeds,
        write_files: false,
        ..MonteCarloOptions::default()
    };
    let mc = monte_carlo(scenario, Path::new(""), &options).map_err(|source| {
        DecompositionError::Run {
            run: run.into(),
            source,
        }
    })?;
    Ok((
        mc.metric(|b| b.omega.std * b.omega.std).mean,
        mc.metric(|b| b.alpha.std * b.alpha.std).mean,
    ))
}

/// Runs the decomposition of `base` with `seeds` seeds per configuration, writing into `out_dir`
/// when `write_files`.
pub fn decompose_effects(
    base: &Scenario,
    seeds: usize,
    out_dir: &Path,
    write_files: bool,
) -> Result<DecompositionOutput, DecompositionError> {
    let active = active_effects(base);
    let on_names: Vec<String> = active.iter().map(|g| group_name(g)).collect();
    let effects_off: Vec<String> = Effect::ALL
        .iter()
        .filter(|e| !active.iter().flatten().any(|a| a == *e))
        .map(|e| e.name().to_string())
        .collect();
    let mut none = base.clone();
    for e in active.iter().flatten() {
        e.switch_off(&mut none);
    }
    let (w_none, a_none) = variances(&none, seeds, "none")?;
    let (w_all, a_all) = variances(base, seeds, "all")?;
    let mut w_runs = VarianceRuns {
        none: w_none,
        all: w_all,
        alone: vec![],
        left_out: vec![],
    };
    let mut a_runs = VarianceRuns {
        none: a_none,
        all: a_all,
        alone: vec![],
        left_out: vec![],
    };
    for group in &active {
        let name = group_name(group);
        let mut alone = none.clone();
        group[0].copy_section(base, &mut alone);
        let (w, a) = variances(&alone, seeds, &format!("{name} alone"))?;
        w_runs.alone.push((name.clone(), w));
        a_runs.alone.push((name.clone(), a));
        let mut out = base.clone();
        group[0].switch_off(&mut out);
        let (w, a) = variances(&out, seeds, &format!("{name} left out"))?;
        w_runs.left_out.push((name.clone(), w));
        a_runs.left_out.push((name, a));
    }
    let omega = decompose(&w_runs)?;
    let alpha = decompose(&a_runs)?;
    let mut output = DecompositionOutput {
        effects_on: on_names,
        effects_off,
        omega_runs: w_runs,
        alpha_runs: a_runs,
        omega,
        alpha,
        seeds,
        files: vec![],
    };
    if write_files {
        output.files = write_outputs(&output, &base.name, out_dir)?;
    }
    Ok(output)
}

fn write_err(file: &Path, e: impl ToString) -> DecompositionError {
    DecompositionError::Write {
        file: file.to_path_buf(),
        message: e.to_string(),
    }
}

/// The markdown table of a decomposition (numbers formatted from the results).
pub fn markdown_table(d: &DecompositionOutput) -> String {
    let mut s = String::new();
    s.push_str(&format!(
        "Error variance of the fused signal, mean over {} seed(s) per configuration. \
         V(none) = {:.3e} (rad/s)², V(all) = {:.3e} (rad/s)² for ω2; \
         V(none) = {:.3e} (rad/s²)², V(all) = {:.3e} (rad/s²)² for α2.\n\n",
        d.seeds, d.omega_runs.none, d.omega_runs.all, d.alpha_runs.none, d.alpha_runs.all
    ));
    for (symbol, runs) in [("ω2", &d.omega_runs), ("α2", &d.alpha_runs)] {
        let added = (runs.all - runs.none) / runs.none;
        if added.abs() < 0.2 {
            s.push_str(&format!(
                "The effects together change the {symbol} error variance by only {:.1} % of \
                 V(none) (the error without any optional effect: quantisation of the corners), \
                 comparable with the seed-to-seed scatter, so the {symbol} shares below are not \
                 meaningful.\n\n",
                100.0 * added
            ));
        }
    }
    s.push_str("| effect | ω2 alone (rad/s)² | ω2 left out (rad/s)² | ω2 share | α2 alone (rad/s²)² | α2 left out (rad/s²)² | α2 share |\n");
    s.push_str("|---|---|---|---|---|---|---|\n");
    for (w, a) in d.omega.sources.iter().zip(&d.alpha.sources) {
        s.push_str(&format!(
            "| {} | {:.3e} | {:.3e} | {:.1} % | {:.3e} | {:.3e} | {:.1} % |\n",
            w.effect,
            w.alone_contribution,
            w.left_out_contribution,
            100.0 * w.share,
            a.alone_contribution,
            a.left_out_contribution,
            100.0 * a.share
        ));
    }
    s.push_str(&format!(
        "| interaction | | | {:.1} % | | | {:.1} % |\n",
        100.0 * d.omega.interaction_share,
        100.0 * d.alpha.interaction_share
    ));
    if !d.effects_off.is_empty() {
        s.push_str(&format!(
            "\nEffects off in the base scenario (not decomposed): {}.\n",
            d.effects_off.join(", ")
        ));
    }
    s
}

fn write_outputs(
    d: &DecompositionOutput,
    name: &str,
    out_dir: &Path,
) -> Result<Vec<PathBuf>, DecompositionError> {
    std::fs::create_dir_all(out_dir).map_err(|e| write_err(out_dir, e))?;
    let csv_path = out_dir.join("decomposition.csv");
    let mut w = csv::Writer::from_path(&csv_path).map_err(|e| write_err(&csv_path, e))?;
    w.write_record([
        "effect",
        "omega_alone_contribution_rad2_s2",
        "omega_left_out_contribution_rad2_s2",
        "omega_share",
        "alpha_alone_contribution_rad2_s4",
        "alpha_left_out_contribution_rad2_s4",
        "alpha_share",
    ])
    .map_err(|e| write_err(&csv_path, e))?;
    for (o, a) in d.omega.sources.iter().zip(&d.alpha.sources) {
        w.write_record([
            o.effect.clone(),
            format!("{:e}", o.alone_contribution),
            format!("{:e}", o.left_out_contribution),
            format!("{:e}", o.share),
            format!("{:e}", a.alone_contribution),
            format!("{:e}", a.left_out_contribution),
            format!("{:e}", a.share),
        ])
        .map_err(|e| write_err(&csv_path, e))?;
    }
    w.write_record([
        "interaction".to_string(),
        String::new(),
        String::new(),
        format!("{:e}", d.omega.interaction_share),
        String::new(),
        String::new(),
        format!("{:e}", d.alpha.interaction_share),
    ])
    .map_err(|e| write_err(&csv_path, e))?;
    w.flush().map_err(|e| write_err(&csv_path, e))?;

    let md_path = out_dir.join("decomposition.md");
    let md = format!("# Error decomposition: {name}\n\n{}", markdown_table(d));
    std::fs::write(&md_path, md).map_err(|e| write_err(&md_path, e))?;

    let mut files = vec![csv_path, md_path];
    for (quantity, dec) in [("omega", &d.omega), ("alpha", &d.alpha)] {
        let path = out_dir.join(format!("decomposition_{quantity}.png"));
        let mut bars: Vec<(String, f64)> = dec
            .sources
            .iter()
            .map(|s| (s.effect.clone(), s.share))
            .collect();
        bars.push(("interaction".into(), dec.interaction_share));
        let symbol = if quantity == "omega" { "ω2" } else { "α2" };
        bars_png(
            &path,
            &format!("{name}: share of the {symbol} error variance per effect"),
            "share of V(all) − V(none)",
            &bars,
        )
        .map_err(|e| write_err(&path, e.message))?;
        files.push(path);
    }
    Ok(files)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn active_effects_of_fast_are_its_enabled_effects() {
        let s = crate::scenario::load_any("fast").unwrap();
        let names: Vec<String> = active_effects(&s).iter().map(|g| group_name(g)).collect();
        assert!(names.contains(&"pixel_noise".to_string()));
        assert!(
            !names.contains(&"motion_blur".to_string()),
            "fast switches it off"
        );
        assert!(
            !names.contains(&"frame_timing".to_string()),
            "fast has constant timing"
        );
    }

    #[test]
    fn effects_sharing_a_switch_are_one_source() {
        let s = crate::scenario::load_any("seed-internal-4k").unwrap();
        let names: Vec<String> = active_effects(&s).iter().map(|g| group_name(g)).collect();
        assert!(
            names.contains(&"backlash+overrotation".to_string()),
            "{names:?}"
        );
        assert!(!names.contains(&"overrotation".to_string()));
    }
}
