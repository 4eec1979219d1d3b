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
    #[error("{file}: {message}")]
    Io { file: PathBuf, message: String },
    #[error("{file}: written by a different sweep: header\n  {found}\nexpected\n  {expected}\n(use another output folder or delete the file)")]
    HeaderMismatch {
        file: PathBuf,
        expected: String,
        found: String,
    },
    #[error("{file}: point `{point}` is not a valid scenario (a mistake in the sweep file: nothing was run)")]
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

    pub(crate) fn io(file: &std::path::Path, e: impl std::fmt::Display) -> Self {
        SweepError::Io {
            file: file.to_path_buf(),
            message: e.to_string(),
        }
    }
}
