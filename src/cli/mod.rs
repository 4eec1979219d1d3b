//! Command-line interface: one file per command family.

use anyhow::Result;
use clap::{Parser, Subcommand};
use std::path::PathBuf;

mod analyze_cmd;
mod budget_cmd;
mod calibrate_cmd;
mod diagnose_cmd;
mod effects_arg;
mod eta;
mod kinematics_cmd;
mod render_cmd;
mod run_cmd;
mod scenario_cmd;
mod score_cmd;
mod selfcheck_cmd;
mod slurm_cmd;
mod source_args;
mod sweep_cmd;
mod timing_cmd;
mod work;

/// Validates camera-based motion measurement of Geneva drives with synthetic data.
#[derive(Parser, Debug)]
#[command(name = "geneva", version, about)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Run the main job on the embedded default scenario.
    Demo {
        /// Output directory.
        #[arg(long, default_value = "out/demo")]
        out: PathBuf,
    },
    /// Check or print scenario files.
    #[command(subcommand)]
    Scenario(scenario_cmd::ScenarioCmd),
    /// Write the truth trajectory (truth.csv) and plots of omega2 and alpha2.
    Kinematics {
        /// Scenario file or built-in name.
        scenario: String,
        #[arg(long, default_value = "out/kinematics")]
        out: PathBuf,
        /// Only the motion at these instants: a file with one time in seconds per line (an
        /// optional `t_s` header); writes truth.csv with the ideal and actual columns, one row
        /// per time in the file's order, and no plots (for a renderer outside the project that
        /// draws the rig at sub-frame instants).
        #[arg(long)]
        times: Option<PathBuf>,
        /// Run even when the estimated time or memory is above the limits.
        #[arg(long)]
        yes: bool,
    },
    /// Render, detect, estimate and judge a synthetic scenario end to end.
    Run {
        /// Scenario file or built-in name.
        scenario: String,
        #[arg(long, default_value = "out/run")]
        out: PathBuf,
        /// Render and search whole frames instead of the region of interest.
        #[arg(long)]
        full_frame: bool,
        /// Run even when the estimated time or memory is above the limits.
        #[arg(long)]
        yes: bool,
    },
    /// Render frames (PNG) or a video with variable timestamps, plus timestamps.csv and truth.csv.
    Render {
        scenario: String,
        #[arg(long, default_value = "out/render")]
        out: PathBuf,
        /// Frame range A..B (end exclusive), A..=B (end inclusive) or A (one frame).
        #[arg(long)]
        frames: Option<String>,
        /// Render only a window around the marker, grown by this many pixels.
        #[arg(long)]
        roi: Option<usize>,
        /// Write an MP4 (through ffmpeg) that keeps the variable timestamps instead of PNGs.
        #[arg(long)]
        video: Option<PathBuf>,
        /// `own` (exact area coverage in linear radiance) or `independent` (a second renderer:
        /// tiny-skia anti-aliasing in display space, pixel-integrated blur; for checking that a
        /// diagnosis does not alarm on footage from another renderer).
        #[arg(long, default_value = "own", value_parser = ["own", "independent"])]
        renderer: String,
        /// Run even when the estimated time or memory is above the limits.
        #[arg(long)]
        yes: bool,
    },
    /// Measure real data (video, frames + timestamps, or a corner track) with the same pipeline.
    Analyze(analyze_cmd::AnalyzeArgs),
    /// Fit a scenario to real footage: scenario.toml (extends --base), calibration.md, overlay.png.
    Calibrate(calibrate_cmd::CalibrateArgs),
    /// Where the sim-to-real gap lies, which effect causes it, how far it shrinks once added.
    Diagnose(diagnose_cmd::DiagnoseArgs),
    /// The diagnosis self-check: withheld effects, null and out-of-vocabulary cases, scored.
    DiagnoseSelfcheck(selfcheck_cmd::SelfCheckArgs),
    /// Score diagnoses of footage that no renderer of this project drew (a folder of cases, each
    /// with `case.json` and `diagnosis/diagnosis.json`): top-1, false alarms, fitted values in
    /// their 95 % interval, out of vocabulary → `unexplained`.
    DiagnoseScore(score_cmd::ScoreArgs),
    /// Design sweep over scenario fields: tidy CSV, heatmaps and a recommended setup (resumable,
    /// shardable: --shard I/N, then `sweep merge DIR`).
    Sweep(sweep_cmd::SweepArgs),
    /// Error budget over N seeds (Monte Carlo) with 95 % confidence intervals: budget.json,
    /// per_seed.csv, error histograms, and the first seed's full run in seed0/ (resumable,
    /// shardable: --shard I/N, then `montecarlo merge DIR`).
    Montecarlo(budget_cmd::MonteCarloArgs),
    /// Per-source decomposition of the omega2 and alpha2 mean square error (the estimator on
    /// exact corners, corner quantisation, each effect alone and left out, interaction) with paired 95 % CIs; seeds are added until
    /// every share's CI is narrow enough or a cap is hit.
    Decompose(budget_cmd::DecomposeArgs),
    /// Regenerate the reports (fast, seed-internal-4k, seed-external-4k, decomposition, seed-camera, dynamics, defaults) deterministically.
    Reports {
        #[arg(long, default_value = "reports")]
        out: PathBuf,
        #[arg(long, default_value_t = 3)]
        seeds: usize,
        /// Only reports/fast (seconds instead of minutes).
        #[arg(long)]
        fast_only: bool,
        /// Only these report folders, comma-separated (e.g. `defaults,fast`).
        #[arg(long, value_delimiter = ',')]
        only: Vec<String>,
    },
    /// Frame-timing logs: statistics and VFR model fit.
    #[command(subcommand)]
    Timing(timing_cmd::TimingCmd),
    /// Cluster runs: sbatch array scripts for a sweep (one shard per task) and its merge.
    #[command(subcommand)]
    Slurm(slurm_cmd::SlurmCmd),
}

pub fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Demo { out } => demo(&out),
        Command::Scenario(cmd) => scenario_cmd::run(cmd),
        Command::Timing(cmd) => timing_cmd::run(cmd),
        Command::Slurm(cmd) => slurm_cmd::run(cmd),
        Command::Kinematics {
            scenario,
            out,
            times,
            yes,
        } => kinematics_cmd::run(&scenario, &out, times.as_deref(), yes),
        Command::Analyze(args) => analyze_cmd::run(args),
        Command::Calibrate(args) => calibrate_cmd::run(args),
        Command::Diagnose(args) => diagnose_cmd::run(args),
        Command::DiagnoseSelfcheck(args) => selfcheck_cmd::run(args),
        Command::DiagnoseScore(args) => score_cmd::run(args),
        Command::Montecarlo(args) => budget_cmd::montecarlo(args),
        Command::Decompose(args) => budget_cmd::decompose(args),
        Command::Reports {
            out,
            seeds,
            fast_only,
            only,
        } => budget_cmd::write_reports(&out, seeds, fast_only, only),
        Command::Sweep(args) => sweep_cmd::run(args),
        Command::Render {
            scenario,
            out,
            frames,
            roi,
            video,
            renderer,
            yes,
        } => render_cmd::run(
            &scenario,
            &out,
            frames.as_deref(),
            roi,
            video,
            renderer == "independent",
            yes,
        ),
        Command::Run {
            scenario,
            out,
            full_frame,
            yes,
        } => run_cmd::run(&scenario, &out, full_frame, yes).map(|_| ()),
    }
}

/// Refuses to run a command whose inputs lie inside its output folder `out` (they would be
/// deleted when it is replaced), naming the input: before any work, through the one check of
/// the output-folder layer.
pub fn refuse_inputs_inside(
    out: &std::path::Path,
    inputs: &[geneva_vision::io::output_dir::Input],
) -> Result<()> {
    geneva_vision::io::output_dir::refuse_inputs_inside(out, inputs)?;
    Ok(())
}

/// The files a scenario argument reads (the file, its extend chain, its data files), named
/// after `option` (`--scenario`, `--base`; empty for a positional argument).
pub fn scenario_inputs(option: &str, spec: &str) -> Vec<geneva_vision::io::output_dir::Input> {
    geneva_vision::scenario::files_read(spec)
        .into_iter()
        .map(|(what, path)| {
            let what = match (option, what.as_str()) {
                ("", _) => what,
                (o, "scenario") => o.to_string(),
                (o, _) => format!("{o} {what}"),
            };
            geneva_vision::io::output_dir::Input::new(what, path)
        })
        .collect()
}

/// The error and its causes joined with ": ", as anyhow's `{:#}`. Library errors return their
/// cause from `source()` without repeating it in their message (`geneva_vision::errors`); a
/// cause whose text a context added here already states is still left out, so that nothing is
/// printed twice ("Not a directory (os error 20): Not a directory (os error 20)").
pub fn error_text(error: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in error.chain() {
        let c = cause.to_string();
        if c.is_empty() || text.contains(&c) {
            continue;
        }
        if !text.is_empty() {
            text.push_str(": ");
        }
        text.push_str(&c);
    }
    text
}

/// The main job on the embedded default scenario: the truth trajectory and its plots, then the
/// whole synthetic measurement (render → detect → estimate → budget) in the same folder.
fn demo(out: &std::path::Path) -> Result<()> {
    // One folder, committed once both jobs are done.
    let staged = geneva_vision::io::output_dir::OutputDir::create(out)?;
    kinematics_cmd::run_into(geneva_vision::scenario::DEFAULT_SCENARIO, staged.path())?;
    println!();
    run_cmd::run_into(
        geneva_vision::scenario::DEFAULT_SCENARIO,
        staged.path(),
        false,
    )?;
    run_cmd::print_files(&staged.commit()?);
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::error_text;
    use anyhow::Context;
    use geneva_vision::scenario;

    /// Segments (split at ": ") longer than a few characters that occur twice.
    fn repeated(text: &str) -> Vec<&str> {
        let parts: Vec<&str> = text.split(": ").collect();
        parts
            .iter()
            .enumerate()
            .filter(|(k, p)| p.len() > 6 && parts[..*k].contains(p))
            .map(|(_, p)| *p)
            .collect()
    }

    #[test]
    fn causes_already_in_the_message_are_not_repeated() {
        // Regression: "Is a directory (os error 21): Is a directory (os error 21)".
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("nope.toml");
        let e = anyhow::Error::from(scenario::load(&missing).unwrap_err());
        let text = error_text(&e);
        assert!(repeated(&text).is_empty(), "{text}");
        assert!(text.contains("nope.toml"), "{text}");
        // The same through a context layer, and through a wrapper whose message embeds its
        // source (thiserror `#[from]` with "{0}" in the message).
        let wrapped = Err::<(), _>(e).context("scenario x").unwrap_err();
        let text = error_text(&wrapped);
        assert!(
            repeated(&text).is_empty() && text.starts_with("scenario x: "),
            "{text}"
        );
        let rig = geneva_vision::pipeline::rig::RigError::Timing(
            geneva_vision::timing::TimingError::MissingLog,
        );
        let text = error_text(&anyhow::Error::from(rig));
        assert!(repeated(&text).is_empty(), "{text}");
        // Distinct causes are all kept.
        let chain = anyhow::anyhow!("inner").context("outer");
        assert_eq!(error_text(&chain), "outer: inner");
    }
}
