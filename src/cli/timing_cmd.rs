//! `geneva timing show|fit LOG`: frame-timing statistics and the VFR model fitted to a log.

use anyhow::Result;
use clap::{Subcommand, ValueEnum};
use geneva_vision::io::timing_log::{fit_timing_log, read_timing_log};
use geneva_vision::timing::{LogFormat, TimingStats};
use std::path::PathBuf;

#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum FormatArg {
    Showinfo,
    ShowinfoPts,
    FfprobeCsv,
    FfprobeJson,
    FramesCsv,
}

impl From<FormatArg> for LogFormat {
    fn from(f: FormatArg) -> Self {
        match f {
            FormatArg::Showinfo => LogFormat::Showinfo,
            FormatArg::ShowinfoPts => LogFormat::ShowinfoPts,
            FormatArg::FfprobeCsv => LogFormat::FfprobeCsv,
            FormatArg::FfprobeJson => LogFormat::FfprobeJson,
            FormatArg::FramesCsv => LogFormat::FramesCsv,
        }
    }
}

#[derive(Subcommand, Debug)]
pub enum TimingCmd {
    /// Count, span, mean and jitter of the frame intervals of a timing log.
    Show {
        log: PathBuf,
        /// Log format (guessed from name and content when omitted).
        #[arg(long, value_enum)]
        format: Option<FormatArg>,
    },
    /// Fit the variable-frame-rate model to a log and print its parameters (and a TOML snippet).
    Fit {
        log: PathBuf,
        #[arg(long, value_enum)]
        format: Option<FormatArg>,
    },
}

pub fn run(cmd: TimingCmd) -> Result<()> {
    match cmd {
        TimingCmd::Show { log, format } => {
            let ts = read_timing_log(&log, format.map(Into::into))?;
            let stats =
                TimingStats::of(&ts).map_err(|e| anyhow::anyhow!("{}: {e}", log.display()))?;
            println!("{}", log.display());
            println!("{stats}");
            Ok(())
        }
        TimingCmd::Fit { log, format } => {
            // Streamed three times, never held whole: memory is flat in the log's length.
            let fit = fit_timing_log(&log, format.map(Into::into))?;
            println!("{}", log.display());
            println!("{fit}");
            println!("\n# as a scenario section:\n{}", fit.scenario_toml());
            Ok(())
        }
    }
}
