//! Errors from loading a scenario: every one names the file and, where it applies, the field.

use crate::validation::{bullet_list, Problem};
use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum ScenarioError {
    #[error("{file}: cannot read")]
    Read {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{file}: is a directory, not a scenario file")]
    NotAFile { file: PathBuf },
    #[error("builtin:{name}: no such built-in scenario (built-ins: {known})")]
    UnknownBuiltin { name: String, known: String },
    #[error("{file}: not valid TOML: {message}")]
    Syntax { file: PathBuf, message: String },
    #[error("{file}: field `{field}`: {message}")]
    Field {
        file: PathBuf,
        field: String,
        message: String,
    },
    #[error("{file}: `extend = \"{target}\"`: {message}")]
    Extend {
        file: PathBuf,
        target: String,
        message: String,
    },
    #[error("{file}: {} invalid field(s):\n{}", problems.len(), bullet_list(problems))]
    Invalid {
        file: PathBuf,
        problems: Vec<Problem>,
    },
    #[error("{file}: field `{field}`: cannot load `{path}`: {message}")]
    External {
        file: PathBuf,
        field: String,
        path: PathBuf,
        message: String,
    },
}

impl ScenarioError {
    /// The invalid-field problems, when this error is a validation failure.
    pub fn problems(&self) -> &[Problem] {
        match self {
            ScenarioError::Invalid { problems, .. } => problems,
            _ => &[],
        }
    }
}
