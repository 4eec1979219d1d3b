//! `geneva run SCENARIO --out DIR`: the synthetic pipeline end to end.

use anyhow::{Context, Result};
use geneva_vision::io::output_dir::OutputDir;
use geneva_vision::pipeline::run::{run as run_pipeline, RunOptions, RunOutput};
use geneva_vision::scenario;
use indicatif::{ProgressBar, ProgressStyle};
use std::path::Path;

pub fn progress_bar(total: usize, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(total as u64);
    bar.set_style(
        ProgressStyle::with_template(&format!(
            "{what} {{bar:40}} {{pos}}/{{len}} frames ({{per_sec}}, eta {{eta}})"
        ))
        .unwrap_or_else(|_| ProgressStyle::default_bar()),
    );
    bar
}

/// `geneva run`: the run written into `out` all at once.
pub fn run(spec: &str, out: &Path, full_frame: bool) -> Result<RunOutput> {
    let staged = OutputDir::create(out)?;
    let output = run_into(spec, staged.path(), full_frame)?;
    print_files(&staged.commit()?);
    Ok(output)
}

/// Prints the paths of the files written.
pub fn print_files(files: &[std::path::PathBuf]) {
    for f in files {
        println!("wrote {}", f.display());
    }
}

/// The run, written into `out` as it is (the caller commits the folder).
pub fn run_into(spec: &str, out: &Path, full_frame: bool) -> Result<RunOutput> {
    let s = scenario::load_any(spec)?;
    let options = RunOptions {
        roi: !full_frame,
        ..RunOptions::default()
    };
    let bar = progress_bar(0, "render+detect");
    let output = run_pipeline(&s, out, &options, &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    })
    .with_context(|| format!("scenario {}", s.name))?;
    bar.finish_and_clear();
    print_summary(&s.name, &output);
    Ok(output)
}

pub fn print_summary(name: &str, o: &RunOutput) {
    let b = &o.budget;
    println!(
        "scenario {name}: {} frames, {} detected ({} ROI, {} full frame), {:.1} frames/s",
        b.frames.total,
        b.frames.detected,
        o.roi_frames,
        o.full_frames,
        o.frames_per_s()
    );
    println!("fused signal errors (RMS / p95 / max):");
    println!(
        "  theta2 {:.3e} / {:.3e} / {:.3e} rad",
        b.theta.rms, b.theta.p95, b.theta.max
    );
    println!(
        "  omega2 {:.3e} / {:.3e} / {:.3e} rad/s",
        b.omega.rms, b.omega.p95, b.omega.max
    );
    println!(
        "  alpha2 {:.3e} / {:.3e} / {:.3e} rad/s^2",
        b.alpha.rms, b.alpha.p95, b.alpha.max
    );
    if let Some(bound) = b.bounds.get("centre") {
        let hp = &bound.half_pixel;
        println!(
            "half-pixel bound (centre, r = {:.0} px): theta {:.2e} rad exceeded in {:.1} % of frames; seed's doubled omega {:.3} rad/s exceeded in {:.1} %, alpha {:.2} rad/s^2 in {:.1} %",
            hp.radius_px,
            hp.theta_rad,
            100.0 * bound.theta_exceedance.fraction,
            hp.seed_omega_doubled_rad_s,
            100.0 * bound.omega_seed_doubled_exceedance.fraction,
            hp.seed_alpha_doubled_rad_s2,
            100.0 * bound.alpha_seed_doubled_exceedance.fraction
        );
    }
}
