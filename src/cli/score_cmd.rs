//! `geneva diagnose-score --cases DIR --out DIR [--about FILE]`: scores diagnoses of footage
//! from outside the project (`pipeline::scored_cases`).

use anyhow::{Context, Result};
use clap::Args;
use geneva_vision::pipeline::scored_cases::{read_cases, write_report, Beside};
use std::path::PathBuf;

#[derive(Args, Debug)]
pub struct ScoreArgs {
    /// A folder of case folders, each with `case.json` (the expectation and the withheld
    /// effect's true values) and, once diagnosed, `diagnosis/diagnosis.json`.
    #[arg(long)]
    cases: PathBuf,
    /// Markdown that opens the report (what the footage is, the command that made it).
    #[arg(long)]
    about: Option<PathBuf>,
    /// Another source's figures to put beside these, `NAME=SUMMARY.json` (a self-check's or
    /// another scoring's `summary.json`); repeatable.
    #[arg(long, value_name = "NAME=SUMMARY.json")]
    beside: Vec<String>,
    #[arg(long, default_value = "out/diagnose-score")]
    out: PathBuf,
}

pub fn run(args: ScoreArgs) -> Result<()> {
    let about = match &args.about {
        Some(path) => std::fs::read_to_string(path)
            .with_context(|| format!("{}: cannot read the report's opening", path.display()))?,
        None => format!("# Diagnoses of `{}`\n", args.cases.display()),
    };
    let scored = read_cases(&args.cases)?;
    anyhow::ensure!(
        !scored.is_empty(),
        "{}: no case folder (a folder with a case.json) in it",
        args.cases.display()
    );
    let beside = args
        .beside
        .iter()
        .map(|b| {
            let (name, path) = b
                .split_once('=')
                .with_context(|| format!("--beside {b}: write NAME=SUMMARY.json"))?;
            Ok(Beside {
                name: name.to_string(),
                summary: PathBuf::from(path),
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let staged = geneva_vision::io::output_dir::OutputDir::create(&args.out)?;
    let n = write_report(&scored, &about, &beside, staged.path())?;
    println!("{n} of {} cases diagnosed and scored", scored.len());
    super::run_cmd::print_files(&staged.commit()?);
    Ok(())
}
