//! `geneva montecarlo`, `geneva decompose`, `geneva reports`: error budgets over seeds, the
//! per-source decomposition, and the reproducible reports under `reports/`.

use anyhow::{Context, Result};
use clap::{Args, Subcommand};
use geneva_vision::budget::decompose::SeedRule;
use geneva_vision::budget::report::Budget;
use geneva_vision::pipeline::decompose::{
    decompose_effects, markdown_table, write_outputs, DecomposeOptions,
};
use geneva_vision::pipeline::montecarlo::{merge_monte_carlo, monte_carlo_study, MonteCarloRun};
use geneva_vision::pipeline::reports::{reports, ReportsOptions};
use geneva_vision::scenario;
use geneva_vision::shard::{Control, Shard};
use std::path::{Path, PathBuf};

#[derive(Args, Debug)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub struct MonteCarloArgs {
    #[command(subcommand)]
    action: Option<MonteCarloAction>,
    /// Scenario file or built-in name.
    #[arg(required = true)]
    scenario: Option<String>,
    #[arg(long, default_value_t = 10)]
    seeds: usize,
    #[arg(long, default_value = "out/montecarlo")]
    out: PathBuf,
    #[arg(long)]
    full_frame: bool,
    /// Run only shard I of N (0-based) into DIR/shards/I/; `geneva montecarlo merge DIR`
    /// combines them.
    #[arg(long, value_parser = super::sweep_cmd::parse_shard)]
    shard: Option<Shard>,
    /// Discard seeds computed from other inputs instead of refusing them.
    #[arg(long)]
    restart: bool,
    /// Run even when the estimated time or memory is above the limits.
    #[arg(long)]
    yes: bool,
}

#[derive(Subcommand, Debug)]
enum MonteCarloAction {
    /// Merge DIR/shards/* into budget.json, per_seed.csv, the histograms and seed0/.
    Merge { dir: PathBuf },
}

pub fn montecarlo(a: MonteCarloArgs) -> Result<()> {
    let spec = match (a.action, a.scenario) {
        (Some(MonteCarloAction::Merge { dir }), _) => {
            let out =
                merge_monte_carlo(&dir).with_context(|| format!("merge {}", dir.display()))?;
            println!(
                "merged {} seeds into {}",
                out.report.units_total,
                dir.display()
            );
            if let Some(mc) = &out.budget {
                print_budget(mc);
            }
            return Ok(());
        }
        (None, Some(s)) => s,
        (None, None) => anyhow::bail!("give a scenario, or `merge DIR`"),
    };
    super::refuse_inputs_inside(&a.out, &super::scenario_inputs("", &spec))?;
    let s = scenario::load_any(&spec)?;
    let shards = a.shard.map_or(1, |s| s.count.max(1));
    let seeds_here = a.seeds.div_ceil(shards) as f64;
    let work = geneva_vision::pipeline::workload::Workload::of(&s, !a.full_frame).times(seeds_here);
    super::work::confirm(&format!("{} seeds of {}", a.seeds, s.name), &work, a.yes)?;
    let bar = super::sweep_cmd::bar("montecarlo");
    let progress = |done: usize, total: usize| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    };
    let control = Control {
        progress: &progress,
        stop: &|| false,
    };
    let run = MonteCarloRun {
        seeds: a.seeds,
        roi: !a.full_frame,
        shard: a.shard,
        restart: a.restart,
        control: &control,
    };
    let started = std::time::Instant::now();
    let out =
        monte_carlo_study(&s, &a.out, &run).with_context(|| format!("scenario {}", s.name))?;
    bar.finish_and_clear();
    let r = &out.report;
    println!(
        "scenario {}: {} seeds{}: {} already done (resumed), {} run now in {:.1} s",
        s.name,
        r.units_total,
        a.shard
            .map(|x| format!(" in shard {x}"))
            .unwrap_or_default(),
        r.units_resumed,
        r.units_run,
        started.elapsed().as_secs_f64()
    );
    match (r.complete, a.shard) {
        (false, _) => println!("incomplete: run the same command again to resume"),
        (true, Some(_)) => println!(
            "shard complete; when every shard is: geneva montecarlo merge {}",
            a.out.display()
        ),
        (true, None) if r.already_complete => {
            println!("already complete: {}", a.out.join("budget.json").display())
        }
        (true, None) => {}
    }
    if let Some(mc) = &out.budget {
        print_budget(mc);
    }
    for f in &r.files {
        println!("wrote {}", f.display());
    }
    Ok(())
}

fn print_budget(mc: &geneva_vision::pipeline::montecarlo::MonteCarloBudget) {
    let line = |name: &str, unit: &str, f: &dyn Fn(&Budget) -> f64| {
        let m = mc.metric(f);
        println!(
            "  {name} RMS {:.3e} {unit} (95 % CI {:.3e} .. {:.3e})",
            m.mean, m.ci95_low, m.ci95_high
        );
    };
    println!("seeds {:?}; fused signal:", mc.seeds);
    line("theta2", "rad", &|b| b.theta.rms);
    line("omega2", "rad/s", &|b| b.omega.rms);
    line("alpha2", "rad/s^2", &|b| b.alpha.rms);
}

#[derive(Args, Debug)]
pub struct DecomposeArgs {
    /// Scenario file or built-in name.
    scenario: String,
    /// Seeds of the first round (at least 2).
    #[arg(long, default_value_t = 4)]
    seeds: usize,
    /// Largest number of seeds.
    #[arg(long, default_value_t = 64)]
    max_seeds: usize,
    /// Stop when every share's 95 % CI half-width is below this many percentage points.
    #[arg(long, default_value_t = 5.0)]
    target_pp: f64,
    #[arg(long, default_value = "out/decompose")]
    out: PathBuf,
    #[arg(long)]
    full_frame: bool,
    /// Run even when the first round's estimated time or memory is above the limits.
    #[arg(long)]
    yes: bool,
}

pub fn decompose(a: DecomposeArgs) -> Result<()> {
    super::refuse_inputs_inside(&a.out, &super::scenario_inputs("", &a.scenario))?;
    let s = scenario::load_any(&a.scenario)?;
    // The first round: every configuration that runs, times the first seeds (more rounds may
    // follow, up to --max-seeds; each is printed as it ends).
    let configurations = geneva_vision::pipeline::decompose::Plan::new(&s)
        .distinct()
        .len();
    let work = geneva_vision::pipeline::workload::Workload::of(&s, !a.full_frame)
        .times((configurations * a.seeds.max(1)) as f64);
    super::work::confirm(
        &format!(
            "the first round of the decomposition of {} ({configurations} configurations × {} \
             seeds)",
            s.name, a.seeds
        ),
        &work,
        a.yes,
    )?;
    let options = DecomposeOptions {
        rule: SeedRule {
            initial: a.seeds,
            cap: a.max_seeds,
            target_half_width: a.target_pp / 100.0,
        },
        roi: !a.full_frame,
    };
    let staged = geneva_vision::io::output_dir::OutputDir::create(&a.out)?;
    let d = decompose_effects(&s, &options, &|line| eprintln!("{line}"))
        .with_context(|| format!("scenario {}", s.name))?;
    write_outputs(&d, staged.path())?;
    println!("{}", markdown_table(&d));
    eprintln!("{} runs of the pipeline in {:.0} s", d.runs, d.elapsed_s);
    super::run_cmd::print_files(&staged.commit()?);
    Ok(())
}

pub fn write_reports(out: &Path, seeds: usize, fast_only: bool, only: Vec<String>) -> Result<()> {
    let options = ReportsOptions {
        seeds,
        fast_only,
        only,
        ..ReportsOptions::default()
    };
    let files = reports(out, &options)?;
    for f in files {
        println!("wrote {}", f.display());
    }
    Ok(())
}
