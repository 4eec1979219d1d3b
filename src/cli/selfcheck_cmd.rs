//! `geneva diagnose-selfcheck --out DIR [--base SCENARIO] [--quick] [--seeds-per-case K] [--effects a,b]
//! [--levels strong|weak|form|both|LIST] [--nulls N] [--flicker N] [--excluded N] [--pairs N] [--novel N]
//! [--renderer own|independent]
//! [--shard I/N] [--restart]`: the diagnosis self-check (withheld effects, null and
//! out-of-vocabulary cases), resumable and shardable like a sweep.

use anyhow::Result;
use clap::Args;
use geneva_vision::pipeline::diagnose::DiagnoseOptions;
use geneva_vision::pipeline::render_job::Renderer;
use geneva_vision::pipeline::selfcheck::{
    cases, phone_logs, suite_base, suite_base_from, Level, SelfCheck, SoFar, SuitePlan,
};
use geneva_vision::scenario::effects::Effect;
use geneva_vision::shard::{self, Control, Shard};
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
pub struct SelfCheckArgs {
    #[arg(long, default_value = "reports/diagnosis")]
    out: PathBuf,
    /// The rig every case starts from: a scenario file (e.g. `geneva calibrate`'s) or a built-in
    /// name, its effects kept on in data and nominal, filmed for its own duration unless
    /// `--duration-s` says otherwise (default: the built-in `fast` rig, 1280×720 at 30 fps).
    #[arg(long)]
    base: Option<String>,
    /// A small suite (one withheld effect, one null, one flicker case; 4 s of footage).
    #[arg(long)]
    quick: bool,
    /// Seeds per withheld effect and level (the whole suite).
    #[arg(long, default_value_t = 3)]
    seeds_per_case: usize,
    /// Withheld effects (default: the vocabulary).
    #[arg(long, value_delimiter = ',')]
    effects: Option<Vec<String>>,
    /// Levels of the withheld effects: `strong`, `weak`, `form` (the strong level in a form the
    /// candidate does not parametrise, for the effects that have one), a comma list of them, or
    /// `both` (strong and weak).
    #[arg(long, default_value = "both")]
    levels: String,
    /// Null cases (default 6; 1 with --quick).
    #[arg(long)]
    nulls: Option<usize>,
    /// Mains-flicker cases (default 2; 1 with --quick).
    #[arg(long)]
    flicker: Option<usize>,
    /// Excluded-candidate cases (default 3; 0 with --quick).
    #[arg(long)]
    excluded: Option<usize>,
    /// Two-effect cases (default 0): pairs of effects a real rig has together, both at the
    /// strong level (`selfcheck::withheld_pairs`, taken in order). `--seeds-per-case 0` runs
    /// them without the single-effect cases.
    #[arg(long)]
    pairs: Option<usize>,
    /// Novel-effect cases (default 0): effects outside the vocabulary drawn onto the footage
    /// (a marker creeping on the wheel, a mount that steps, autofocus breathing, a glare, a
    /// cable across the marker's path, autofocus hunting, duplicated frames, rolling-shutter
    /// banding: `render::novel::KINDS`, taken in order).
    #[arg(long)]
    novel: Option<usize>,
    /// Footage length, s.
    #[arg(long)]
    duration_s: Option<f64>,
    /// Run only these cases of the plan (names as in `cases.csv`, comma separated): each keeps
    /// the footage it has in the whole plan, so one case can be re-run alone.
    #[arg(long, value_delimiter = ',')]
    only: Option<Vec<String>>,
    /// Simulated seeds per configuration of each diagnosis.
    #[arg(long, default_value_t = 4, value_parser = super::diagnose_cmd::parse_count)]
    seeds: usize,
    /// Evaluation seeds to raise `--seeds` to when no cell is significant on `--seeds` but some
    /// would be with unlimited seeds (0: never).
    #[arg(long, default_value_t = geneva_vision::pipeline::diagnose::ESCALATE_SEEDS, value_parser = super::diagnose_cmd::parse_count)]
    escalate_seeds: usize,
    /// Simulated seeds per objective evaluation in each case's candidate fits (at least 2;
    /// `geneva diagnose` uses 3): 2 keeps the suite affordable, at the price of fitted values
    /// that depend more on the fit's own noise than a user's diagnosis does.
    #[arg(long, default_value_t = 2, value_parser = super::diagnose_cmd::parse_fit_seeds)]
    fit_seeds: usize,
    /// Refits of each case's best candidate on fresh fit seeds, pooled with its first fit
    /// (`geneva diagnose --refits`; 0: its first fit alone, with ± that do not hold the fit
    /// seeds' noise).
    #[arg(long, default_value_t = geneva_vision::pipeline::diagnose::REFITS, value_parser = super::diagnose_cmd::parse_count)]
    refits: usize,
    /// Footages simulated at each case's best candidate's stated values, fitted to measure
    /// the footage's own noise (`geneva diagnose --bootstrap`; 0: off).
    #[arg(long, default_value_t = 0, value_parser = super::diagnose_cmd::parse_bootstrap)]
    bootstrap: usize,
    /// Renderer of the footage: `own`, or `independent` (a second renderer that differs from
    /// the nominal's simulations in anti-aliasing, compositing, blur kernel and noise).
    #[arg(long, default_value = "own", value_parser = ["own", "independent"])]
    renderer: String,
    #[arg(long, value_parser = super::sweep_cmd::parse_shard)]
    shard: Option<Shard>,
    /// Start over when the folder holds another plan's cases.
    #[arg(long)]
    restart: bool,
    /// Run even when the cases' renders and nominal simulations alone are estimated above the
    /// time or memory limits.
    #[arg(long)]
    yes: bool,
    /// Run nothing: write the report of the cases that the run of this plan into `--out` has
    /// finished so far (the run may go on) into this folder, saying how many of the plan's
    /// cases it holds. Give the plan's options as that run was started with.
    #[arg(long, conflicts_with_all = ["shard", "restart"])]
    report_so_far: Option<std::path::PathBuf>,
}

pub fn run(a: SelfCheckArgs) -> Result<()> {
    if let Some(spec) = &a.base {
        super::refuse_inputs_inside(&a.out, &super::scenario_inputs("--base", spec))?;
    }
    let effects = super::effects_arg::parse_effects(a.effects.as_deref())?;
    let base = match &a.base {
        Some(spec) => suite_base_from(spec, a.duration_s)?,
        None => suite_base(a.duration_s.unwrap_or(if a.quick { 4.0 } else { 8.0 }))?,
    };
    let mut plan = if a.quick {
        SuitePlan::quick(Effect::PixelNoise)
    } else {
        SuitePlan::full(a.seeds_per_case)
    };
    if let Some(e) = effects {
        plan.effects = e;
    }
    plan.levels = match a.levels.as_str() {
        "both" if !a.quick => vec![Level::Strong, Level::Weak],
        "both" => plan.levels,
        list => list
            .split(',')
            .map(|l| match l.trim() {
                "strong" => Ok(Level::Strong),
                "weak" => Ok(Level::Weak),
                "form" => Ok(Level::OtherForm),
                other => anyhow::bail!(
                    "--levels {list}: `{other}` is no level (expected strong, weak, form, a \
                     comma list of them, or both)"
                ),
            })
            .collect::<Result<Vec<_>>>()?,
    };
    plan.null_cases = a.nulls.unwrap_or(plan.null_cases);
    plan.flicker_cases = a.flicker.unwrap_or(plan.flicker_cases);
    plan.excluded_cases = a.excluded.unwrap_or(plan.excluded_cases);
    plan.pair_cases = a.pairs.unwrap_or(plan.pair_cases);
    plan.novel_cases = a.novel.unwrap_or(plan.novel_cases);
    if a.renderer == "independent" {
        plan.renderer = Renderer::Independent;
    }
    let options = DiagnoseOptions {
        seeds: a.seeds,
        escalate_seeds: a.escalate_seeds,
        fit_seeds: a.fit_seeds,
        refits: a.refits,
        bootstrap: a.bootstrap,
        ..Default::default()
    };
    let repo = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut all = cases(&base, &plan, &phone_logs(repo)?);
    if let Some(only) = &a.only {
        if let Some(unknown) = only.iter().find(|n| !all.iter().any(|c| &c.name == *n)) {
            anyhow::bail!(
                "--only {unknown}: no such case in this plan (its cases: {})",
                all.iter()
                    .map(|c| c.name.as_str())
                    .collect::<Vec<_>>()
                    .join(", ")
            );
        }
        all.retain(|c| only.contains(&c.name));
    }
    let text = plan.describe(&base, &options);
    if let Some(into) = &a.report_so_far {
        return report_so_far(&SelfCheck::new(all, options, text), &a.out, into);
    }
    // A lower bound: each case's footage rendered once and its nominal simulated per seed.
    let work = geneva_vision::pipeline::workload::Workload::of(&base, true)
        .times((all.len() * (1 + options.seeds)) as f64);
    super::work::confirm(
        &format!(
            "the self-check's renders and nominal simulations alone ({} cases)",
            all.len()
        ),
        &work,
        a.yes,
    )?;
    eprintln!("diagnose-selfcheck: {} case(s). {text}", all.len());
    let study = SelfCheck::new(all, options, text);
    // The time left at the mean time of the cases this run has finished (cases found done in
    // the folder cost nothing now, and the first report counts them).
    let started = std::time::Instant::now();
    let resumed = std::sync::Mutex::new(None::<usize>);
    let progress = |done: usize, total: usize| {
        let mut resumed = resumed.lock().unwrap_or_else(|p| p.into_inner());
        let before = *resumed.get_or_insert(done.saturating_sub(1));
        let eta = super::eta::left(
            started.elapsed().as_secs_f64(),
            // Units finish in parallel: a count reported out of order may lie below the first.
            done.saturating_sub(before),
            total.saturating_sub(before),
        );
        eprintln!(
            "diagnose-selfcheck: {done}/{total} cases, {} so far, {eta}",
            super::eta::duration(started.elapsed().as_secs_f64())
        );
    };
    let control = Control {
        progress: &progress,
        stop: &|| false,
    };
    let report = match a.shard {
        Some(s) => shard::run_shard(&study, &a.out, s, a.restart, &control)?,
        None => shard::run_whole(&study, &a.out, a.restart, &control)?,
    };
    for f in &report.files {
        println!("wrote {}", f.display());
    }
    Ok(())
}

/// `--report-so-far INTO`: the report of the cases the run into `run_dir` has finished.
fn report_so_far(study: &SelfCheck, run_dir: &Path, into: &Path) -> Result<()> {
    match study.report_so_far(run_dir, into)? {
        SoFar::Complete => eprintln!(
            "diagnose-selfcheck: {} is complete for this plan: its report is {}",
            run_dir.display(),
            run_dir.join("README.md").display()
        ),
        SoFar::Written {
            finished,
            total,
            files,
        } => {
            eprintln!(
                "diagnose-selfcheck: {finished} of {total} cases finished so far in {}",
                run_dir.display()
            );
            for f in &files {
                println!("wrote {}", f.display());
            }
        }
    }
    Ok(())
}
