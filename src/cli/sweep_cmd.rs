//! `geneva sweep SWEEP.toml --out DIR [--shard I/N] [--restart]`: a resumable, parallel design
//! sweep, committed all at once; `geneva sweep merge DIR`: the shards of a sweep merged into the
//! outputs one machine would have written.

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use geneva_vision::pipeline::sweep_eval::PipelineEvaluator;
use geneva_vision::shard::{Control, Shard};
use geneva_vision::sweep::{merge_sweep, run_sweep_with, sweep_file_of, SweepRun, SweepSpec};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct SweepArgs {
    #[command(subcommand)]
    action: Option<SweepAction>,
    /// Sweep file (see scenarios/sweeps/README.md).
    #[arg(required = true)]
    sweep: Option<PathBuf>,
    #[arg(long, default_value = "out/sweep")]
    out: PathBuf,
    /// Run only shard I of N (0-based) into DIR/shards/I/; `geneva sweep merge DIR` combines them.
    #[arg(long, value_parser = parse_shard)]
    shard: Option<Shard>,
    /// Discard rows computed from other inputs (changed base scenario or axes) instead of
    /// refusing them.
    #[arg(long)]
    restart: bool,
    /// Run even when the estimated time or memory is above the limits.
    #[arg(long)]
    yes: bool,
}

#[derive(Subcommand, Debug)]
enum SweepAction {
    /// Merge DIR/shards/* into results.csv, summary.csv, recommendation.md and heatmaps
    /// (byte-identical to a one-machine run; idempotent).
    Merge {
        dir: PathBuf,
        /// The sweep file (default: the one recorded by the shards).
        #[arg(long)]
        sweep: Option<PathBuf>,
    },
}

/// The files a sweep reads: the sweep file, and its base scenario's files when the base is a
/// file (found beside the sweep file, as the sweep finds it).
pub fn sweep_inputs(spec_path: &Path) -> Vec<geneva_vision::io::output_dir::Input> {
    let mut inputs = vec![geneva_vision::io::output_dir::Input::new(
        "sweep file",
        spec_path,
    )];
    if let Ok(spec) = SweepSpec::load(spec_path) {
        let beside = spec_path.parent().unwrap_or(Path::new("")).join(&spec.base);
        let base = if beside.is_file() {
            beside.to_string_lossy().into_owned()
        } else {
            spec.base.clone()
        };
        inputs.extend(super::scenario_inputs("the sweep's base", &base));
    }
    inputs
}

pub fn parse_shard(text: &str) -> Result<Shard, String> {
    Shard::parse(text).map_err(|e| e.to_string())
}

pub fn bar(what: &str) -> ProgressBar {
    let bar = ProgressBar::new(0);
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{what} {{bar:40}} {{pos}}/{{len}} runs (eta {{eta}})"
        ))
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

pub fn run(args: SweepArgs) -> Result<()> {
    match (args.action, args.sweep) {
        (Some(SweepAction::Merge { dir, sweep }), _) => merge(&dir, sweep),
        (None, Some(spec_path)) => sweep(&spec_path, &args.out, args.shard, args.restart, args.yes),
        (None, None) => anyhow::bail!("give a sweep file, or `merge DIR`"),
    }
}

fn sweep(
    spec_path: &Path,
    out: &Path,
    shard: Option<Shard>,
    restart: bool,
    yes: bool,
) -> Result<()> {
    super::refuse_inputs_inside(out, &sweep_inputs(spec_path))?;
    let spec = SweepSpec::load(spec_path)?;
    let base = geneva_vision::sweep::grid::load_base(&spec, spec_path)?;
    let shards = shard.map_or(1.0, |s| s.count.max(1) as f64);
    let mut work = super::work::sweep_workload(&spec, &base, spec_path);
    work.runs = (work.runs / shards).ceil();
    super::work::confirm(&format!("sweep {}", spec_path.display()), &work, yes)?;
    let bar = bar("sweep");
    let progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    };
    let control = Control {
        progress: &progress,
        stop: &|| false,
    };
    let run = SweepRun {
        shard,
        restart,
        control: &control,
    };
    let outcome = run_sweep_with(&spec, spec_path, out, &PipelineEvaluator, &run)
        .with_context(|| format!("sweep {}", spec_path.display()))?;
    bar.finish_and_clear();
    let what = match shard {
        Some(s) => format!("shard {s}"),
        None => "the sweep".into(),
    };
    println!(
        "{} runs in {what}: {} already done (resumed), {} run now",
        outcome.jobs_total, outcome.jobs_resumed, outcome.jobs_run
    );
    match (outcome.complete, shard) {
        (false, _) => println!("incomplete: run the same command again to resume"),
        (true, Some(s)) => println!(
            "shard {s} complete in {}; when every shard is: geneva sweep merge {}",
            out.join("shards").join(s.index.to_string()).display(),
            out.display()
        ),
        (true, None) => {
            println!("results in {}", out.join("results.csv").display());
            println!("\n{}", outcome.recommendation_md);
        }
    }
    Ok(())
}

fn merge(dir: &Path, sweep: Option<PathBuf>) -> Result<()> {
    let spec_path = match sweep {
        Some(p) => p,
        None => sweep_file_of(dir)?,
    };
    super::refuse_inputs_inside(dir, &sweep_inputs(&spec_path))?;
    let spec = SweepSpec::load(&spec_path)?;
    let outcome = merge_sweep(&spec, &spec_path, dir)
        .with_context(|| format!("merge {} (sweep {})", dir.display(), spec_path.display()))?;
    println!(
        "merged {} runs into {}",
        outcome.jobs_total,
        dir.join("results.csv").display()
    );
    println!("\n{}", outcome.recommendation_md);
    Ok(())
}
