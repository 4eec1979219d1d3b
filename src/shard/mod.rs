//! Work units, shards and merges: the layer that lets a study — a sweep, a Monte Carlo, later
//! the simulations of a diagnosis — run on one machine or as N independent shards (e.g. Slurm
//! array tasks) and end with the same bytes either way.
//!
//! A study ([`Study`]) is a fixed list of work units `0..U`; each unit produces one text record
//! (any text: the log escapes it), and a finaliser turns all records, in unit order, into the
//! output files. Because the output depends only on the records in unit order, whichever machine,
//! shard or thread produced a record does not change a byte. Shard `I/N` owns the units with
//! `unit % N == I` (round robin, so costly and cheap points spread evenly).
//!
//! - [`run_whole`]: one machine; finished units accumulate in the staging folder beside `DIR`
//!   (resumable), the finalised folder is committed all at once (`io::output_dir`).
//! - [`run_shard`]: shard `I/N` writes `DIR/shards/.I.partial/` while running and renames it to
//!   `DIR/shards/I/` when all its units are done (resumable the same way).
//! - [`merge`]: reads every complete shard, checks that they come from the same inputs, and
//!   commits the finalised folder (with `shards/` carried over), or names the missing units and
//!   writes nothing.
//!
//! Every folder of records carries a [`Manifest`]: the inputs that determine the records and
//! their fingerprint. Resuming or merging records of other inputs is refused, naming what changed.
//!
//! Files: `manifest` (inputs, fingerprint, differences), `log` (the append-only record log),
//! `study` (the three drivers), `adaptive` (studies whose units are picked in rounds from the
//! records so far: resumable and extensible, one machine).

pub mod adaptive;
mod log;
mod manifest;
pub mod slurm;
mod study;

#[cfg(test)]
mod tests;

pub use adaptive::{run_adaptive, AdaptiveReport, AdaptiveStudy};
pub use log::{parse_record_text, record_file_text, UnitLog};
pub use manifest::Manifest;
pub use study::{
    complete_shard_folders, merge, parse_shard_json, progress, run_shard, run_whole, shard_records,
    shard_records_with, Control, Progress, RunReport, Study, UnitDirs,
};

use std::path::PathBuf;

/// Folder of the shards inside `DIR`.
pub const SHARDS: &str = "shards";
/// The manifest file of a folder of records.
pub const MANIFEST: &str = "manifest.json";
/// Which shard a shard folder is (`{"index": I, "count": N}`).
pub const SHARD_INFO: &str = "shard.json";
/// The append-only log of a run in progress.
pub const LOG: &str = "units.log";
/// The records of a complete shard, in unit order.
pub const RECORDS: &str = "units.tsv";

/// Shard `index` of `count`: owns the units `u` with `u % count == index`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub struct Shard {
    pub index: usize,
    pub count: usize,
}

impl Shard {
    /// The whole study as one shard.
    pub const WHOLE: Shard = Shard { index: 0, count: 1 };

    pub fn new(index: usize, count: usize) -> Result<Self, ShardError> {
        if count == 0 || index >= count {
            return Err(ShardError::BadShard {
                text: format!("{index}/{count}"),
                message: "needs 0 ≤ I < N".into(),
            });
        }
        Ok(Self { index, count })
    }

    /// Parses `I/N` (`--shard 2/4`).
    pub fn parse(text: &str) -> Result<Self, ShardError> {
        let bad = |message: &str| ShardError::BadShard {
            text: text.into(),
            message: message.into(),
        };
        let (i, n) = text
            .split_once('/')
            .ok_or_else(|| bad("expected I/N, e.g. 0/4"))?;
        let i: usize = i
            .trim()
            .parse()
            .map_err(|_| bad("I is not a whole number"))?;
        let n: usize = n
            .trim()
            .parse()
            .map_err(|_| bad("N is not a whole number"))?;
        Self::new(i, n).map_err(|_| bad("needs 0 ≤ I < N"))
    }

    pub fn owns(&self, unit: usize) -> bool {
        unit % self.count == self.index
    }

    /// The units of a study of `total` units that this shard owns, ascending.
    pub fn units(&self, total: usize) -> Vec<usize> {
        (self.index..total).step_by(self.count).collect()
    }
}

impl std::fmt::Display for Shard {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}/{}", self.index, self.count)
    }
}

#[derive(Debug, thiserror::Error)]
pub enum ShardError {
    #[error("shard `{text}`: {message}")]
    BadShard { text: String, message: String },
    #[error(transparent)]
    Output(#[from] crate::io::output_dir::OutputError),
    #[error("{path}: cannot {action}")]
    Io {
        path: PathBuf,
        action: &'static str,
        source: std::io::Error,
    },
    #[error("{file}: line {line}: {message}")]
    Log {
        file: PathBuf,
        line: usize,
        message: String,
    },
    #[error("{place} holds results computed from other inputs: {}; use --restart to discard them, or another output folder", changes.join("; "))]
    Changed {
        place: PathBuf,
        changes: Vec<String>,
    },
    #[error("{dir}: cannot merge, {} of {units} work units missing ({}): {}; nothing was written", missing.len(), shards.join("; "), list_units(missing))]
    Missing {
        dir: PathBuf,
        units: usize,
        missing: Vec<String>,
        shards: Vec<String>,
    },
    #[error("{dir}: {message}")]
    Mixed { dir: PathBuf, message: String },
    #[error("{dir}: no run of this study has started there (no {staging}, no shard folders)")]
    NoRun { dir: PathBuf, staging: PathBuf },
    #[error("{place}: the run there has other inputs ({}): give the options that run was started with", changes.join("; "))]
    OtherRun {
        place: PathBuf,
        changes: Vec<String>,
    },
}

fn list_units(names: &[String]) -> String {
    let mut s: Vec<String> = names.iter().take(8).cloned().collect();
    if names.len() > 8 {
        s.push(format!("and {} more", names.len() - 8));
    }
    s.join(", ")
}

pub(crate) fn io_err<'a>(
    path: &'a std::path::Path,
    action: &'static str,
) -> impl FnOnce(std::io::Error) -> ShardError + 'a {
    move |source| ShardError::Io {
        path: path.to_path_buf(),
        action,
        source,
    }
}
