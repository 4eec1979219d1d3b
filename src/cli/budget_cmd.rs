//! `geneva montecarlo`, `geneva decompose`, `geneva reports`: error budgets over seeds, the
//! per-source decomposition, and the reproducible reports under `reports/`.

use anyhow::{Context, Result};
use geneva_vision::pipeline::decompose::{decompose_effects, markdown_table};
use geneva_vision::pipeline::montecarlo::{monte_carlo, MonteCarloOptions};
use geneva_vision::pipeline::reports::{reports, ReportsOptions};
use geneva_vision::scenario;
use std::path::Path;

pub fn montecarlo(spec: &str, seeds: usize, out: &Path, full_frame: bool) -> Result<()> {
    let s = scenario::load_any(spec)?;
    let options = MonteCarloOptions {
        seeds,
        roi: !full_frame,
        write_files: true,
        first_seed_files: true,
    };
    let mc = monte_carlo(&s, out, &options).with_context(|| format!("scenario {}", s.name))?;
    let line =
        |name: &str, unit: &str, f: &dyn Fn(&geneva_vision::budget::report::Budget) -> f64| {
            let m = mc.metric(f);
            println!(
                "  {name} RMS {:.3e} {unit} (95 % CI {:.3e} .. {:.3e})",
                m.mean, m.ci95_low, m.ci95_high
            );
        };
    println!(
        "scenario {}: seeds {:?} in {:.1} s; fused signal:",
        s.name, mc.seeds, mc.elapsed_s
    );
    line("theta2", "rad", &|b| b.theta.rms);
    line("omega2", "rad/s", &|b| b.omega.rms);
    line("alpha2", "rad/s^2", &|b| b.alpha.rms);
    for f in &mc.files {
        println!("wrote {}", f.display());
    }
    Ok(())
}

pub fn decompose(spec: &str, seeds: usize, out: &Path) -> Result<()> {
    let s = scenario::load_any(spec)?;
    let d =
        decompose_effects(&s, seeds, out, true).with_context(|| format!("scenario {}", s.name))?;
    println!("{}", markdown_table(&d));
    println!("wrote {}", out.display());
    Ok(())
}

pub fn write_reports(out: &Path, seeds: usize, fast_only: bool) -> Result<()> {
    let files = reports(out, &ReportsOptions { seeds, fast_only })?;
    for f in files {
        println!("wrote {}", f.display());
    }
    Ok(())
}
