//! `geneva run SCENARIO --out DIR`: the synthetic pipeline end to end.

use anyhow::{Context, Result};
use geneva_vision::budget::ErrorStats;
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
pub fn run(spec: &str, out: &Path, full_frame: bool, yes: bool) -> Result<RunOutput> {
    super::refuse_inputs_inside(out, &super::scenario_inputs("", spec))?;
    let s = scenario::load_any(spec)?;
    let work = geneva_vision::pipeline::workload::Workload::of(&s, !full_frame);
    super::work::confirm(&format!("scenario {}", s.name), &work, yes)?;
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
    let r = &b.resolvable;
    println!(
        "fused signal errors against the resolvable truth (RMS / p95 / max), with the errors \
         against the raw truth and the aliasing part beside them (RMS):"
    );
    type Pick = fn(&geneva_vision::budget::report::QuantityStats) -> &ErrorStats;
    let quantities: [(&str, &ErrorStats, Pick, &str); 3] = [
        ("theta2", &b.theta, |q| &q.theta, "rad"),
        ("omega2", &b.omega, |q| &q.omega, "rad/s"),
        ("alpha2", &b.alpha, |q| &q.alpha, "rad/s^2"),
    ];
    for (q, e, pick, unit) in quantities {
        println!(
            "  {q} {:.3e} / {:.3e} / {:.3e} {unit}   raw truth {:.3e}   aliasing part {:.3e}",
            e.rms,
            e.p95,
            e.max,
            pick(&b.raw.overall).rms,
            pick(&b.aliasing.overall).rms
        );
    }
    println!(
        "  resolvable truth: the actual motion averaged over each frame's {} ms exposure of the \
         marker and band-limited to {:.2} Hz (the Nyquist rate of {:.2} fps), defined for {} of {} \
         frames; aliasing part: the raw motion above {:.2} Hz, which no camera at this frame rate \
         can follow",
        r.exposure_s * 1e3,
        r.nyquist_hz,
        2.0 * r.nyquist_hz,
        r.frames_defined,
        b.frames.total,
        r.nyquist_hz
    );
    if r.marker_delay_max_s.abs() > 0.0 || r.marker_delay_min_s.abs() > 0.0 {
        println!(
            "  the frames saw the marker {:.2} ms (mean; {:.2}..{:.2}) after their timestamps \
             (timestamp convention and rolling shutter); measurements are labelled with the \
             timestamps, so that offset is in the raw-truth error, not in the resolvable one",
            r.marker_delay_mean_s * 1e3,
            r.marker_delay_min_s * 1e3,
            r.marker_delay_max_s * 1e3
        );
    }
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
