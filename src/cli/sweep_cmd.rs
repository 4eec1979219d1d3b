//! `geneva sweep SWEEP.toml --out DIR`: a resumable, parallel design sweep.

use anyhow::{Context, Result};
use geneva_vision::pipeline::sweep_eval::PipelineEvaluator;
use geneva_vision::sweep::{run_sweep, SweepSpec};
use indicatif::{ProgressBar, ProgressStyle};
use std::path::Path;

pub fn run(spec_path: &Path, out: &Path) -> Result<()> {
    let spec = SweepSpec::load(spec_path)?;
    let bar = ProgressBar::new(0);
    bar.set_style(
        ProgressStyle::with_template("sweep {bar:40} {pos}/{len} runs (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    let outcome = run_sweep(&spec, spec_path, out, &PipelineEvaluator, &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })
    .with_context(|| format!("sweep {}", spec_path.display()))?;
    bar.finish_and_clear();
    println!(
        "{} runs in the sweep: {} already done (resumed), {} run now; results in {}",
        outcome.jobs_total,
        outcome.jobs_resumed,
        outcome.jobs_run,
        out.join("results.csv").display()
    );
    if !outcome.recommendation_md.is_empty() {
        println!("\n{}", outcome.recommendation_md);
    }
    Ok(())
}
