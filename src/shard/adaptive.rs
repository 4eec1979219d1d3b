//! Adaptive studies: work units chosen in rounds, each round a pure function of the records of
//! the units chosen so far (e.g. more seeds for the sweep points whose decision is not settled).
//!
//! A unit's record depends only on the study's inputs ([`AdaptiveStudy::manifest`]) and on the
//! unit, never on the rule that picked it. So every logged record stays valid whatever the rule
//! becomes: a killed run resumes from its log, and a finished folder whose rule changed (a higher
//! seed cap, a tighter target) is extended from the records it kept (`units.tsv`) instead of being
//! redone. The rounds are replayed from the records in unit order, so the units picked, and hence
//! the outputs, are the same whatever the thread count or the number of interruptions.
//!
//! Runs on one machine (a round needs every record of the round before): shards and merges are
//! for fixed studies ([`super::Study`]).

use super::log::{read_records, write_records, UnitLog};
use super::study::{check, run_units_with};
use super::{io_err, Control, Manifest, ShardError, LOG, RECORDS};
use crate::io::output_dir::{OutputDir, MARKER};
use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

/// File of a finished adaptive study that holds its rule.
pub const RULE: &str = "rule.json";

/// A study whose units are chosen in rounds.
pub trait AdaptiveStudy: Sync {
    type Error: From<ShardError> + Send;

    /// The inputs that determine each record; `units` bounds the unit numbers.
    fn manifest(&self) -> &Manifest;

    /// The rule that picks the units (kept in `rule.json`; a change extends the study).
    fn rule(&self) -> serde_json::Value;

    /// The units of the first round.
    fn first_round(&self) -> Vec<usize>;

    /// Units to add given the records of exactly the units picked so far (unit → record);
    /// none: the study is finished.
    fn next_round(&self, records: &BTreeMap<usize, String>) -> Result<Vec<usize>, Self::Error>;

    fn run_unit(&self, unit: usize) -> Result<String, Self::Error>;

    /// Writes the outputs into `out_dir` from the records of the picked units. Must be a pure
    /// function of `records`.
    fn finalize(
        &self,
        records: &BTreeMap<usize, String>,
        out_dir: &Path,
    ) -> Result<(), Self::Error>;
}

/// What [`run_adaptive`] did.
#[derive(Debug, Clone, Default)]
pub struct AdaptiveReport {
    /// Units picked over all rounds.
    pub units_picked: usize,
    /// Picked units whose records were found (log or a finished folder).
    pub units_resumed: usize,
    /// Units run by this call.
    pub units_run: usize,
    /// Units picked after each round (cumulative).
    pub rounds: Vec<usize>,
    pub complete: bool,
    /// Already complete with the same inputs and rule: nothing was run or written.
    pub already_complete: bool,
    /// Records of an earlier finished folder (another rule) that were reused.
    pub extended_from: usize,
    pub files: Vec<PathBuf>,
}

/// Runs `study` into `dir` on this machine, round after round, resuming from the staging log
/// and extending a finished folder of the same inputs; commits `dir` all at once.
pub fn run_adaptive<S: AdaptiveStudy>(
    study: &S,
    dir: &Path,
    restart: bool,
    control: &Control,
) -> Result<AdaptiveReport, S::Error> {
    let now = study.manifest();
    let rule = study.rule();
    let mut out = OutputDir::resume(dir).map_err(ShardError::from)?;
    let mut report = AdaptiveReport::default();
    let mut earlier = BTreeMap::new();
    if out.dir().join(MARKER).is_file() {
        let existing = Manifest::read(out.dir())?;
        if existing.as_ref().is_some_and(|m| m.matches(now)) {
            if read_rule(out.dir())?.as_ref() == Some(&rule) {
                out.abandon();
                report.complete = true;
                report.already_complete = true;
                return Ok(report);
            }
            earlier = read_records(&out.dir().join(RECORDS), now.units, false)?;
        } else {
            check(existing, now, out.dir(), restart)?;
        }
    }
    let staging = out.path().to_path_buf();
    if check(Manifest::read(&staging)?, now, &staging, restart)? {
        out.restart().map_err(ShardError::from)?;
    }
    now.write(&staging)?;
    let log_path = staging.join(LOG);
    let (mut log, mut done) = UnitLog::open(&log_path, now.units)?;
    for (unit, record) in &earlier {
        if !done.contains_key(unit) {
            log.append(*unit, record)?;
            done.insert(*unit, record.clone());
            report.extended_from += 1;
        }
    }
    let mut picked: BTreeSet<usize> = BTreeSet::new();
    let mut round = study.first_round();
    let found_at_start: BTreeSet<usize> = done.keys().copied().collect();
    loop {
        picked.extend(round.iter().copied());
        report.rounds.push(picked.len());
        let todo: Vec<usize> = round
            .iter()
            .copied()
            .filter(|u| !done.contains_key(u))
            .collect();
        let already = picked.len() - todo.len();
        let ran = run_units_with(&todo, log, already, picked.len(), control, &|u| {
            study.run_unit(u)
        })?;
        report.units_run += ran;
        done = read_records(&log_path, now.units, true)?;
        if todo.iter().any(|u| !done.contains_key(u)) {
            // Stopped before the round was done: the log keeps what finished.
            report.units_picked = picked.len();
            return Ok(report);
        }
        let mine: BTreeMap<usize, String> = picked.iter().map(|u| (*u, done[u].clone())).collect();
        round = study
            .next_round(&mine)?
            .into_iter()
            .filter(|u| !picked.contains(u))
            .collect();
        if round.is_empty() {
            report.units_picked = picked.len();
            report.units_resumed = picked.intersection(&found_at_start).count();
            study.finalize(&mine, &staging)?;
            write_records(&staging.join(RECORDS), &mine)?;
            let rule_path = staging.join(RULE);
            let text = serde_json::to_string_pretty(&rule).unwrap_or_default() + "\n";
            crate::io::output_dir::write_file_atomic(&rule_path, text.as_bytes())
                .map_err(ShardError::from)?;
            std::fs::remove_file(&log_path).map_err(io_err(&log_path, "remove"))?;
            report.files = out.commit().map_err(ShardError::from)?;
            report.complete = true;
            return Ok(report);
        }
        let (l, _) = UnitLog::open(&log_path, now.units)?;
        log = l;
    }
}

fn read_rule(folder: &Path) -> Result<Option<serde_json::Value>, ShardError> {
    let path = folder.join(RULE);
    match std::fs::read_to_string(&path) {
        Ok(t) => Ok(serde_json::from_str(&t).ok()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(io_err(&path, "read")(e)),
    }
}
