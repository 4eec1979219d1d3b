//! `geneva analyze (--video F | --frames DIR --timestamps F | --tracks F) [--scenario S] --out DIR`;
//! with a scenario, every sample gets an error bar (`pipeline::error_bars`).

use anyhow::{bail, Result};
use clap::Args;
use geneva_vision::estimate::{EstimatorConfig, Signal};
use geneva_vision::pipeline::analyze::{analyze, AnalyzeError, AnalyzeOptions, Source};
use geneva_vision::pipeline::defaults_study::defaults_reason;
use geneva_vision::pipeline::error_bars::{error_bars, write_error_bars, ErrorBarOptions};
use geneva_vision::scenario;
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct AnalyzeArgs {
    #[command(flatten)]
    source: super::source_args::SourceArgs,
    /// Scenario (file or built-in name) supplying detector and estimator settings.
    #[arg(long)]
    scenario: Option<String>,
    /// Positive angle sense: `cw` (clockwise on screen, the seed's convention) or `ccw`.
    #[arg(long, default_value = "cw")]
    angle_sense: String,
    /// Seeds of the rig simulated at the footage's frame times for the error bars (with
    /// --scenario; 0: no error bars).
    #[arg(long, default_value_t = ErrorBarOptions::default().seeds)]
    error_bar_seeds: usize,
    /// Flag a frame whose α2, or ω2 jump, departs from the modelled rig by more than this many
    /// standard deviations of its noise.
    #[arg(long, default_value_t = ErrorBarOptions::default().k_sigma)]
    k_sigma: f64,
    #[arg(long, default_value = "out/analyze")]
    out: PathBuf,
}

pub fn run(a: AnalyzeArgs) -> Result<()> {
    let source = a.source.source()?;
    let mut inputs = a.source.inputs();
    if let Some(spec) = &a.scenario {
        inputs.extend(super::scenario_inputs("--scenario", spec));
    }
    super::refuse_inputs_inside(&a.out, &inputs)?;
    if !(a.k_sigma.is_finite() && a.k_sigma > 0.0) {
        bail!("--k-sigma: expected a positive number, got {}", a.k_sigma);
    }
    if a.error_bar_seeds == 1 {
        bail!("--error-bar-seeds: an RMS needs at least 2 seeds (0 turns the error bars off)");
    }
    let rig = a.scenario.as_deref().map(scenario::load_any).transpose()?;
    let estimator_from = rig.as_ref().map(|s| s.name.clone());
    let angle_sign = match a.angle_sense.as_str() {
        "cw" => -1.0,
        "ccw" => 1.0,
        other => bail!("--angle-sense `{other}`: expected cw or ccw"),
    };
    let options = match &rig {
        Some(s) => AnalyzeOptions::from_scenario(s, angle_sign),
        None => AnalyzeOptions {
            angle_sign,
            ..AnalyzeOptions::default()
        },
    };
    let staged = geneva_vision::io::output_dir::OutputDir::create(&a.out)?;
    let bar = super::run_cmd::progress_bar(0, "detect");
    let analysed = analyze(&source, &options, staged.path(), &|done, total| {
        bar.set_length(total as u64);
        bar.set_position(done as u64);
    });
    bar.finish_and_clear();
    if let Err(AnalyzeError::Estimate { frames, tracks, .. }) = &analysed {
        // No detection at all is no estimator's failure: name what was looked for.
        let detected = geneva_vision::io::tracks_csv::read_tracks(tracks, None)
            .map(|rows| rows.iter().filter(|r| r.corners_px.is_some()).count());
        if matches!(detected, Ok(0)) && !matches!(source, Source::Tracks(_)) {
            let d = &options.detector;
            let whose = match &a.scenario {
                Some(spec) => format!("{spec}'s detector.marker_id and detector.dictionary"),
                None => "--scenario: without one the default detector looks for these".into(),
            };
            bail!(
                "marker id {} of dictionary {} was never found in the {frames} frames: check the \
                 marker id and dictionary ({whose}); nothing was written",
                d.marker_id,
                d.dictionary
            );
        }
    }
    let out = match analysed {
        Ok(out) => out,
        // The detections are the expensive part and are complete: they are kept (the folder
        // committed with tracks.csv) so that another estimator can be tried on them.
        Err(e @ AnalyzeError::Estimate { .. }) if staged.path().join("tracks.csv").is_file() => {
            staged.commit()?;
            let kept = a.out.join("tracks.csv");
            return Err(anyhow::Error::new(e).context(format!(
                "the detections are kept in {}: `geneva analyze --tracks {}` tries another \
                 estimator on them",
                kept.display(),
                kept.display()
            )));
        }
        Err(e) => return Err(e.into()),
    };
    let e = &out.estimate;
    let c = &e.rotation_centre;
    for line in input_summary(&out.input, e.detected) {
        if line.starts_with("warning:") {
            eprintln!("{line}");
        } else {
            println!("{line}");
        }
    }
    println!(
        "{}",
        estimator_line(&options.estimator, e, estimator_from.as_deref())
    );
    println!(
        "rotation centre ({:.2}, {:.2}) px ± ({:.2}, {:.2}) px [{:?}], rms residual {:.3} px",
        c.centre_px[0],
        c.centre_px[1],
        c.centre_sigma_px[0],
        c.centre_sigma_px[1],
        c.method,
        c.rms_residual_px
    );
    if let Some(s) = rig.filter(|_| a.error_bar_seeds > 0) {
        let bar = super::run_cmd::progress_bar(0, "simulate");
        let opts = ErrorBarOptions {
            seeds: a.error_bar_seeds,
            k_sigma: a.k_sigma,
        };
        let bars = error_bars(&s, &out, options.angle_sign, &opts, &|done, total| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        });
        bar.finish_and_clear();
        match bars {
            Ok(bars) => {
                for line in write_error_bars(staged.path(), &out, &bars)? {
                    println!("{line}");
                }
            }
            // The analysis stands without them: it is kept, and the reason said.
            Err(e) => eprintln!("warning: no error bars: {}", chain(&e)),
        }
    }
    super::run_cmd::print_files(&staged.commit()?);
    Ok(())
}

/// An error and its causes on one line.
fn chain(e: &dyn std::error::Error) -> String {
    let mut text = e.to_string();
    let mut source = e.source();
    while let Some(s) = source {
        text.push_str(&format!(": {s}"));
        source = s.source();
    }
    text
}

/// Which estimator the analysis used and why: the scenario's choice, or the defaults and what
/// chose them. A differentiator with a data-driven parameter (the Kalman λ) is shown as resolved
/// on the fused signal.
fn estimator_line(
    config: &EstimatorConfig,
    estimate: &geneva_vision::estimate::Estimate,
    scenario: Option<&str>,
) -> String {
    let resolved = estimate
        .signals
        .get(Signal::Fused.index())
        .map(|s| s.differentiator.clone())
        .unwrap_or_else(|| config.differentiator.clone());
    let used = EstimatorConfig {
        differentiator: resolved,
        ..config.clone()
    };
    let is_default = config.choice_name() == EstimatorConfig::default().choice_name();
    let why = match (scenario, is_default) {
        (None, _) => format!("no --scenario, so {}", defaults_reason()),
        (Some(name), true) => format!(
            "scenario `{name}` keeps the defaults: {}",
            defaults_reason()
        ),
        (Some(name), false) => format!("chosen by scenario `{name}`"),
    };
    format!(
        "estimator (differentiator / marker centre / rotation centre): {} — {why}",
        used.choice_name()
    )
}

/// The frame accounting of an analysis, one statement per line: what the input spans, what was
/// detected, and every frame that is missing for a reason other than a failed detection.
fn input_summary(
    input: &geneva_vision::pipeline::analyze::InputReport,
    detected: usize,
) -> Vec<String> {
    let span = input.last_frame - input.first_frame + 1;
    let unreadable = input.unreadable.len();
    let absent = input.absent();
    let undetected = input
        .frames_present
        .saturating_sub(unreadable)
        .saturating_sub(detected);
    let lost = input
        .lost_to_truncation()
        .map(|n| format!(", {n} listed by the video's container but cut off"))
        .unwrap_or_default();
    let mut lines = vec![format!(
        "{span} frames ({}–{}): {detected} with the marker, {undetected} without (never \
         interpolated), {unreadable} unreadable, {absent} absent from the input{lost}",
        input.first_frame, input.last_frame
    )];
    if !input.gaps.is_empty() {
        let shown: Vec<String> = input
            .gaps
            .iter()
            .take(5)
            .map(|g| format!("{}–{}", g.start(), g.end()))
            .collect();
        let more = input.gaps.len().saturating_sub(shown.len());
        lines.push(format!(
            "warning: the track skips {absent} frame numbers in {} gap(s): {}{}",
            input.gaps.len(),
            shown.join(", "),
            if more > 0 {
                format!(" and {more} more")
            } else {
                String::new()
            }
        ));
    }
    for f in input.unreadable.iter().take(5) {
        lines.push(format!(
            "warning: frame {} ({}) unreadable: {}",
            f.frame,
            f.file.display(),
            f.reason
        ));
    }
    if unreadable > 5 {
        lines.push(format!(
            "warning: and {} more unreadable frames (all listed in unreadable_frames.csv)",
            unreadable - 5
        ));
    }
    if let Some(n) = &input.numbering {
        lines.push(format!("warning: {n}"));
    }
    if let Some(t) = &input.truncation {
        let lost = input
            .lost_to_truncation()
            .map(|n| format!(" ({n} frames lost)"))
            .unwrap_or_default();
        lines.push(format!("warning: truncated video: {t}{lost}"));
    }
    lines
}
