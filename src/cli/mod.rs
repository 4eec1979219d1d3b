//! Command-line interface: one file per command family.

use anyhow::Result;
use clap::{Parser, Subcommand};
use std::path::PathBuf;

mod scenario_cmd;
mod timing_cmd;

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
    /// Frame-timing logs: statistics and VFR model fit.
    #[command(subcommand)]
    Timing(timing_cmd::TimingCmd),
}

pub fn main() -> Result<()> {
    let cli = Cli::parse();
    match cli.command {
        Command::Demo { out } => demo(&out),
        Command::Scenario(cmd) => scenario_cmd::run(cmd),
        Command::Timing(cmd) => timing_cmd::run(cmd),
    }
}

fn demo(out: &std::path::Path) -> Result<()> {
    let scenario =
        geneva_vision::scenario::load_builtin(geneva_vision::scenario::DEFAULT_SCENARIO)?;
    std::fs::create_dir_all(out)?;
    println!(
        "scenario {} resolved; output in {}",
        scenario.name,
        out.display()
    );
    Ok(())
}
