//! Errors of a sweep: every one names the file and, where it applies, the field or row.

use crate::validation::{bullet_list, Problem};
use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum SweepError {
    #[error("{file}: cannot read")]
    Read {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}: field `{field}`: {message}")]
    Field {
        file: PathBuf,
        field: String,
        message: String,
    },
    #[error("{file}: {} invalid field(s):\n{}", problems.len(), bullet_list(problems))]
    Invalid {
        file: PathBuf,
        problems: Vec<Problem>,
    },
    #[error("{file}: field `base`")]
    Base {
        file: PathBuf,
        source: crate::scenario::ScenarioError,
    },
    #[error("{file}: cannot write")]
    Write {
        file: PathBuf,
        source: std::io::Error,
    },
    /// A CSV file (or line) that could not be read or written; the cause names the record.
    #[error("{file}")]
    Csv { file: PathBuf, source: csv::Error },
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
    #[error("{file}: adaptive seeds ([adaptive]) pick each round's runs from the results of the round before, so the sweep runs on one machine: drop --shard, or drop [adaptive] to shard a fixed number of seeds")]
    AdaptiveSharded { file: PathBuf },
    #[error(
        "{file}: an adaptive sweep ([adaptive]) runs on one machine and has no shards to merge"
    )]
    AdaptiveMerge { file: PathBuf },
    #[error("{dir}: no shards to merge; run `geneva sweep SWEEP --out DIR --shard I/N` first")]
    NoShards {
        dir: PathBuf,
        source: std::io::Error,
    },
    #[error("{dir}: no shard records its sweep file; give it with --sweep")]
    NoSweepFile { dir: PathBuf },
    #[error("{file}: written by a different sweep: header\n  {found}\nexpected\n  {expected}\n(use another output folder or delete the file)")]
    HeaderMismatch {
        file: PathBuf,
        expected: String,
        found: String,
    },
    // No `{file}` here: the scenario error it holds names the sweep file already.
    #[error(
        "point `{point}` is not a valid scenario (a mistake in the sweep file: nothing was run)"
    )]
    Point {
        file: PathBuf,
        point: String,
        source: Box<crate::scenario::ScenarioError>,
    },
    #[error(transparent)]
    Shard(#[from] crate::shard::ShardError),
    #[error("{file}: line {line}: {message}")]
    Row {
        file: PathBuf,
        line: u64,
        message: String,
    },
}

impl SweepError {
    /// The invalid-field problems, when this error is a validation failure.
    pub fn problems(&self) -> &[Problem] {
        match self {
            SweepError::Invalid { problems, .. } => problems,
            _ => &[],
        }
    }

    /// `file` could not be written.
    pub(crate) fn write(file: &std::path::Path) -> impl FnOnce(std::io::Error) -> Self + '_ {
        move |source| SweepError::Write {
            file: file.to_path_buf(),
            source,
        }
    }

    /// A CSV error in `file`.
    pub(crate) fn csv(file: &std::path::Path) -> impl Fn(csv::Error) -> Self + Copy + '_ {
        move |source| SweepError::Csv {
            file: file.to_path_buf(),
            source,
        }
    }
}
