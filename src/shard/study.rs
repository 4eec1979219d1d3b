//! The three drivers of a study: the whole study on one machine, one shard, and the merge of
//! the shards. All three finalise through the same [`Study::finalize`] from the same records in
//! unit order, which is what makes a merged folder byte-identical to a one-machine folder.

use super::log::{read_finished_records, read_records, write_records, UnitLog};
use super::{io_err, Manifest, Shard, ShardError, LOG, RECORDS, SHARDS, SHARD_INFO};
use crate::io::output_dir::{DirLock, OutputDir, MARKER};
use rayon::prelude::*;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Where each unit's extra files (if a unit writes any) are: unit → folder.
pub type UnitDirs<'a> = &'a (dyn Fn(usize) -> PathBuf + Sync);

/// A study made of work units.
pub trait Study: Sync {
    type Error: From<ShardError> + Send;

    /// The inputs that determine the records (checked on resume and merge).
    fn manifest(&self) -> &Manifest;

    /// Runs `unit` and returns its record; may also write files under `work_dir` (the same
    /// folder for every unit of a run: name them after the unit).
    fn run_unit(&self, unit: usize, work_dir: &Path) -> Result<String, Self::Error>;

    /// Writes the final outputs into `out_dir` from every record, in unit order. Must be a pure
    /// function of `records` (and of the files in `unit_dirs`): that is the byte-identity.
    fn finalize(
        &self,
        records: &[String],
        unit_dirs: UnitDirs,
        out_dir: &Path,
    ) -> Result<(), Self::Error>;

    /// A unit in words, for messages (`point 3 (fps=30|…) seed 1`).
    fn unit_name(&self, unit: usize) -> String;

    /// The files `unit` writes under its work folder that the outputs need (relative paths):
    /// a merge refuses a shard that lost one.
    fn required_files(&self, _unit: usize) -> Vec<String> {
        Vec::new()
    }
}

/// Hooks into a running study.
pub struct Control<'a> {
    /// Called after each unit with (units done, units of this run), resumed ones included.
    pub progress: &'a (dyn Fn(usize, usize) + Sync),
    /// Asked before each unit; `true` stops cleanly (running units finish and are kept).
    pub stop: &'a (dyn Fn() -> bool + Sync),
}

impl Control<'_> {
    pub fn none() -> Control<'static> {
        Control {
            progress: &|_, _| {},
            stop: &|| false,
        }
    }
}

/// What a driver did.
#[derive(Debug, Clone, Default)]
pub struct RunReport {
    /// Units of this run (the whole study, or the shard's share).
    pub units_total: usize,
    /// Units found done at start.
    pub units_resumed: usize,
    /// Units done by this call.
    pub units_run: usize,
    /// The output (folder or shard) is complete.
    pub complete: bool,
    /// It was already complete before this call: nothing was run or written.
    pub already_complete: bool,
    /// Final files written (whole study and merge).
    pub files: Vec<PathBuf>,
}

/// Refuses records of other inputs unless `restart`; returns whether `place` must be emptied.
pub(super) fn check(
    found: Option<Manifest>,
    now: &Manifest,
    place: &Path,
    restart: bool,
) -> Result<bool, ShardError> {
    match found {
        Some(m) if !m.matches(now) => {
            if restart {
                Ok(true)
            } else {
                Err(ShardError::Changed {
                    place: place.to_path_buf(),
                    changes: m.changes(now),
                })
            }
        }
        _ => Ok(false),
    }
}

/// Runs the units in `todo` in parallel (the current rayon pool), appending each record to
/// `log` as soon as it is done. Returns the number run.
fn run_units<S: Study>(
    study: &S,
    todo: &[usize],
    log: UnitLog,
    work_dir: &Path,
    already: usize,
    total: usize,
    control: &Control,
) -> Result<usize, S::Error> {
    run_units_with(todo, log, already, total, control, &|unit| {
        study.run_unit(unit, work_dir)
    })
}

/// [`run_units`] with the unit's work given as a function.
pub(super) fn run_units_with<E: From<ShardError> + Send>(
    todo: &[usize],
    log: UnitLog,
    already: usize,
    total: usize,
    control: &Control,
    unit_record: &(dyn Fn(usize) -> Result<String, E> + Sync),
) -> Result<usize, E> {
    let log = Mutex::new(log);
    let counter = AtomicUsize::new(already);
    let ran = AtomicUsize::new(0);
    todo.par_iter().try_for_each(|&unit| -> Result<(), E> {
        if (control.stop)() {
            return Ok(());
        }
        let record = unit_record(unit)?;
        // A poisoned lock means another unit panicked mid-append; its line is cut and redone.
        let mut log = log.lock().unwrap_or_else(|p| p.into_inner());
        log.append(unit, &record)?;
        drop(log);
        ran.fetch_add(1, Ordering::SeqCst);
        (control.progress)(counter.fetch_add(1, Ordering::SeqCst) + 1, total);
        Ok(())
    })?;
    Ok(ran.load(Ordering::SeqCst))
}

/// The whole study on this machine into `dir`: resumes from the staging folder beside `dir`,
/// and commits `dir` all at once when every unit is done. A `dir` already complete for the same
/// inputs is left as it is.
pub fn run_whole<S: Study>(
    study: &S,
    dir: &Path,
    restart: bool,
    control: &Control,
) -> Result<RunReport, S::Error> {
    let now = study.manifest();
    let mut out = OutputDir::resume(dir).map_err(ShardError::from)?;
    let total = now.units;
    if out.dir().join(MARKER).is_file() {
        let existing = Manifest::read(out.dir())?;
        if existing.as_ref().is_some_and(|m| m.matches(now)) {
            out.abandon();
            return Ok(RunReport {
                units_total: total,
                units_resumed: total,
                complete: true,
                already_complete: true,
                ..RunReport::default()
            });
        }
        check(existing, now, out.dir(), restart)?;
    }
    let staging = out.path().to_path_buf();
    if check(Manifest::read(&staging)?, now, &staging, restart)? {
        out.restart().map_err(ShardError::from)?;
    }
    now.write(&staging)?;
    let (log, done) = UnitLog::open(&staging.join(LOG), total)?;
    let todo: Vec<usize> = (0..total).filter(|u| !done.contains_key(u)).collect();
    let mut report = RunReport {
        units_total: total,
        units_resumed: done.len(),
        ..RunReport::default()
    };
    report.units_run = run_units(study, &todo, log, &staging, done.len(), total, control)?;
    let records = read_records(&staging.join(LOG), total, true)?;
    if records.len() < total {
        return Ok(report);
    }
    let records: Vec<String> = records.into_values().collect();
    study.finalize(&records, &|_| staging.clone(), &staging)?;
    let log_path = staging.join(LOG);
    std::fs::remove_file(&log_path).map_err(io_err(&log_path, "remove"))?;
    report.files = out.commit().map_err(ShardError::from)?;
    report.complete = true;
    Ok(report)
}

/// How far a whole run of a study into `DIR` has got: read without taking its lock or writing
/// anything, so that it can be asked while the run goes on.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Progress {
    /// `DIR` is complete for these inputs: its outputs are final.
    Complete,
    /// The records finished so far (unit → record); a record still being written is left out.
    Running(BTreeMap<usize, String>),
}

/// The records a run of `study` into `dir` has finished so far: a whole run's
/// ([`run_whole`]) and its shards' ([`run_shard`]: complete or still running), together. A
/// folder of other inputs (a different manifest) is an error naming what differs, and so is a
/// `dir` with no run started.
pub fn progress<S: Study>(study: &S, dir: &Path) -> Result<Progress, ShardError> {
    let now = study.manifest();
    let complete = match dir.join(MARKER).is_file() {
        true => Manifest::read(dir)?,
        false => None,
    };
    if complete.as_ref().is_some_and(|m| m.matches(now)) {
        return Ok(Progress::Complete);
    }
    let staging = crate::io::output_dir::sibling(dir, "partial")?;
    // (folder, its records): the whole run's log, then each shard's records or log.
    let mut folders = vec![(staging.clone(), staging.join(LOG))];
    let shards = dir.join(SHARDS);
    if let Ok(entries) = std::fs::read_dir(&shards) {
        let mut names: Vec<String> = entries
            .flatten()
            .filter_map(|e| e.file_name().to_str().map(str::to_string))
            .collect();
        names.sort();
        for name in names {
            let folder = shards.join(&name);
            if name.parse::<usize>().is_ok() {
                folders.push((folder.clone(), folder.join(RECORDS)));
            } else if name.starts_with('.') && name.ends_with(".partial") {
                folders.push((folder.clone(), folder.join(LOG)));
            }
        }
    }
    let mut records: BTreeMap<usize, String> = BTreeMap::new();
    let mut started = false;
    for (folder, file) in folders {
        // No manifest: nothing started there yet (or a folder being set up).
        let Some(m) = Manifest::read(&folder)? else {
            continue;
        };
        if !m.matches(now) {
            return Err(ShardError::OtherRun {
                place: folder,
                changes: m.changes(now),
            });
        }
        started = true;
        for (unit, record) in read_finished_records(&file, now.units)? {
            if records.get(&unit).is_some_and(|r| *r != record) {
                return Err(ShardError::Mixed {
                    dir: folder,
                    message: format!(
                        "{} has another record here than in another folder of this run",
                        study.unit_name(unit)
                    ),
                });
            }
            records.insert(unit, record);
        }
    }
    if !started {
        // No run of these inputs anywhere, but a finished one of others: name what differs.
        if let Some(m) = complete {
            return Err(ShardError::OtherRun {
                place: dir.to_path_buf(),
                changes: m.changes(now),
            });
        }
        return Err(ShardError::NoRun {
            dir: dir.to_path_buf(),
            staging,
        });
    }
    Ok(Progress::Running(records))
}

fn shard_dirs(dir: &Path, shard: Shard) -> (PathBuf, PathBuf, PathBuf) {
    let shards = dir.join(SHARDS);
    (
        shards.join(shard.index.to_string()),
        shards.join(format!(".{}.partial", shard.index)),
        shards.join(format!(".{}.lock", shard.index)),
    )
}

fn read_shard_info(folder: &Path) -> Result<Option<Shard>, ShardError> {
    let path = folder.join(SHARD_INFO);
    match std::fs::read_to_string(&path) {
        Ok(t) => serde_json::from_str(&t)
            .map(Some)
            .map_err(|e| ShardError::Log {
                file: path.clone(),
                line: e.line(),
                message: crate::errors::full(&e),
            }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(io_err(&path, "read")(e)),
    }
}

fn write_shard_info(folder: &Path, shard: Shard) -> Result<(), ShardError> {
    let text = serde_json::to_string(&shard).unwrap_or_default() + "\n";
    crate::io::output_dir::write_file_atomic(&folder.join(SHARD_INFO), text.as_bytes())?;
    Ok(())
}

/// A complete shard's `shard.json`: which shard it is and the digest of every other file in
/// its folder (its records, its manifest, the files its units wrote), taken when it completed.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
struct SealedShard {
    index: usize,
    count: usize,
    /// Relative path (`/` separators) → `fnv1a64:` digest of the file's bytes. Absent from
    /// shards written before shards carried digests.
    #[serde(default)]
    files: Option<BTreeMap<String, String>>,
}

fn file_digest(path: &Path) -> Result<String, ShardError> {
    let bytes = std::fs::read(path).map_err(io_err(path, "read"))?;
    Ok(format!("fnv1a64:{:016x}", super::manifest::fnv1a64(&bytes)))
}

/// Every file of `folder` but `shard.json`, with its digest.
fn digests(folder: &Path) -> Result<BTreeMap<String, String>, ShardError> {
    crate::io::output_dir::relative_files(folder)?
        .into_iter()
        .filter(|f| f != SHARD_INFO)
        .map(|f| {
            let d = file_digest(&folder.join(&f))?;
            Ok((f, d))
        })
        .collect()
}

/// Seals a complete shard's folder: `shard.json` with the digest of every other file.
pub(super) fn seal(folder: &Path, shard: Shard) -> Result<(), ShardError> {
    let sealed = SealedShard {
        index: shard.index,
        count: shard.count,
        files: Some(digests(folder)?),
    };
    let text = serde_json::to_string_pretty(&sealed).unwrap_or_default() + "\n";
    crate::io::output_dir::write_file_atomic(&folder.join(SHARD_INFO), text.as_bytes())?;
    Ok(())
}

/// A shard's `shard.json` text; `path` names it in errors. Returns the shard and whether it
/// carries its files' digests. What the fuzzing of the format calls.
pub fn parse_shard_json(text: &str, path: &Path) -> Result<(Shard, bool), ShardError> {
    let sealed = parse_seal(text, path)?;
    let shard = Shard::new(sealed.index, sealed.count).map_err(|_| ShardError::Log {
        file: path.to_path_buf(),
        line: 1,
        message: format!("shard {}/{} is no shard", sealed.index, sealed.count),
    })?;
    Ok((shard, sealed.files.is_some()))
}

fn parse_seal(text: &str, path: &Path) -> Result<SealedShard, ShardError> {
    serde_json::from_str(text).map_err(|e| ShardError::Log {
        file: path.to_path_buf(),
        line: e.line(),
        message: crate::errors::full(&e),
    })
}

/// Checks a complete shard's folder against its seal: every file listed there and unchanged,
/// none added. Returns the shard.
fn check_seal(folder: &Path) -> Result<Shard, ShardError> {
    let path = folder.join(SHARD_INFO);
    let mixed = |message: String| ShardError::Mixed {
        dir: folder.to_path_buf(),
        message,
    };
    let text = match std::fs::read_to_string(&path) {
        Ok(t) => t,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            return Err(mixed(format!("no {SHARD_INFO}: not a shard folder")))
        }
        Err(e) => return Err(io_err(&path, "read")(e)),
    };
    let sealed = parse_seal(&text, &path)?;
    let Some(listed) = sealed.files else {
        return Err(mixed(format!(
            "its {SHARD_INFO} holds no digests of its files (a shard written before shards \
             carried them): run that shard again with --restart"
        )));
    };
    let found = digests(folder)?;
    for (file, digest) in &listed {
        match found.get(file) {
            None => {
                return Err(mixed(format!(
                    "`{file}` is missing (listed in {SHARD_INFO})"
                )))
            }
            Some(d) if d != digest => {
                return Err(mixed(format!(
                    "`{file}` was changed after the shard completed (its digest is {d}, \
                     {SHARD_INFO} says {digest}); run that shard again with --restart"
                )))
            }
            Some(_) => {}
        }
    }
    if let Some(extra) = found.keys().find(|f| !listed.contains_key(*f)) {
        return Err(mixed(format!(
            "`{extra}` is not part of the shard (not in {SHARD_INFO}): remove it"
        )));
    }
    Shard::new(sealed.index, sealed.count).map_err(|_| {
        mixed(format!(
            "{SHARD_INFO} names shard {}/{}",
            sealed.index, sealed.count
        ))
    })
}

/// The complete shard folders of `dir/shards` (named by their index), sorted: what a merge and
/// the study's own readers consider, never a lock file or a folder still being written.
pub fn complete_shard_folders(dir: &Path) -> Result<Vec<PathBuf>, ShardError> {
    let shards = dir.join(SHARDS);
    let entries = match std::fs::read_dir(&shards) {
        Ok(e) => e,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(io_err(&shards, "list")(e)),
    };
    let mut out: Vec<(usize, PathBuf)> = entries
        .filter_map(Result::ok)
        .filter_map(|e| {
            let index = e.file_name().to_str()?.parse::<usize>().ok()?;
            e.path().is_dir().then(|| (index, e.path()))
        })
        .collect();
    out.sort();
    Ok(out.into_iter().map(|(_, p)| p).collect())
}

/// Shard `shard` of the study into `dir/shards/I/` (see the module docs). Other shards may run
/// at the same time on other machines; the merge may not.
pub fn run_shard<S: Study>(
    study: &S,
    dir: &Path,
    shard: Shard,
    restart: bool,
    control: &Control,
) -> Result<RunReport, S::Error> {
    let now = study.manifest();
    let _shared = DirLock::of_dir(dir, false).map_err(ShardError::from)?;
    let (done_dir, staging, lock) = shard_dirs(dir, shard);
    let _mine = DirLock::at(&lock, &done_dir, true).map_err(ShardError::from)?;
    let mine = shard.units(now.units);
    let mut report = RunReport {
        units_total: mine.len(),
        ..RunReport::default()
    };
    if done_dir.is_dir() {
        let same = Manifest::read(&done_dir)?.is_some_and(|m| m.matches(now))
            && read_shard_info(&done_dir)? == Some(shard);
        if same {
            report.units_resumed = mine.len();
            report.complete = true;
            report.already_complete = true;
            return Ok(report);
        }
        check(Manifest::read(&done_dir)?, now, &done_dir, restart)?;
        if read_shard_info(&done_dir)? != Some(shard) && !restart {
            return Err(ShardError::Mixed {
                dir: done_dir.clone(),
                message: format!("written as another shard than {shard}; use --restart to redo it"),
            }
            .into());
        }
        std::fs::remove_dir_all(&done_dir).map_err(io_err(&done_dir, "remove"))?;
    }
    let mut fresh = check(Manifest::read(&staging)?, now, &staging, restart)?;
    fresh |= read_shard_info(&staging)?.is_some_and(|s| s != shard);
    if fresh && staging.exists() {
        std::fs::remove_dir_all(&staging).map_err(io_err(&staging, "remove"))?;
    }
    std::fs::create_dir_all(&staging).map_err(io_err(&staging, "create"))?;
    now.write(&staging)?;
    write_shard_info(&staging, shard)?;
    let (log, done) = UnitLog::open(&staging.join(LOG), now.units)?;
    if let Some(stray) = done.keys().find(|u| !shard.owns(**u)) {
        return Err(ShardError::Mixed {
            dir: staging.clone(),
            message: format!("unit {stray} does not belong to shard {shard}"),
        }
        .into());
    }
    let todo: Vec<usize> = mine
        .iter()
        .copied()
        .filter(|u| !done.contains_key(u))
        .collect();
    report.units_resumed = done.len();
    report.units_run = run_units(study, &todo, log, &staging, done.len(), mine.len(), control)?;
    let records = read_records(&staging.join(LOG), now.units, true)?;
    if records.len() < mine.len() {
        return Ok(report);
    }
    write_records(&staging.join(RECORDS), &records)?;
    let log_path = staging.join(LOG);
    std::fs::remove_file(&log_path).map_err(io_err(&log_path, "remove"))?;
    seal(&staging, shard)?;
    std::fs::rename(&staging, &done_dir)
        .map_err(io_err(&done_dir, "rename the finished shard to"))?;
    report.complete = true;
    Ok(report)
}

/// Every record of the complete shards of `dir` (`dir/shards/I/`), in unit order, and the shard
/// count N. Refuses shards of other inputs than `now` or of different shard counts; with a unit
/// missing, names the missing units (with `unit_name`) and the unfinished shards.
pub fn shard_records(
    dir: &Path,
    now: &Manifest,
    unit_name: &dyn Fn(usize) -> String,
) -> Result<(Vec<String>, usize), ShardError> {
    shard_records_with(dir, now, unit_name, &|_| Vec::new())
}

/// [`shard_records`], and every file `required(unit)` names (relative to the unit's shard
/// folder) must be there: a shard that lost one is refused, naming it.
pub fn shard_records_with(
    dir: &Path,
    now: &Manifest,
    unit_name: &dyn Fn(usize) -> String,
    required: &dyn Fn(usize) -> Vec<String>,
) -> Result<(Vec<String>, usize), ShardError> {
    let shards_dir = dir.join(SHARDS);
    let mut complete: BTreeMap<usize, PathBuf> = BTreeMap::new();
    let mut partial: BTreeMap<usize, PathBuf> = BTreeMap::new();
    let mut count: Option<usize> = None;
    let entries = match std::fs::read_dir(&shards_dir) {
        Ok(e) => e
            .filter_map(Result::ok)
            .map(|e| e.path())
            .collect::<Vec<_>>(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
        Err(e) => return Err(io_err(&shards_dir, "list")(e)),
    };
    for path in entries {
        let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
        let (index, is_partial) = match name
            .strip_suffix(".partial")
            .and_then(|n| n.strip_prefix('.'))
        {
            Some(i) => (i.parse::<usize>().ok(), true),
            None => (name.parse::<usize>().ok(), false),
        };
        let Some(index) = index.filter(|_| path.is_dir()) else {
            continue;
        };
        if is_partial {
            partial.insert(index, path);
            continue;
        }
        check(Manifest::read(&path)?, now, &path, false)?;
        let info = check_seal(&path)?;
        if info.index != index || count.is_some_and(|c| c != info.count) {
            return Err(ShardError::Mixed {
                dir: shards_dir.clone(),
                message: format!(
                    "shards of different splits: `{}` is shard {info} but others are of {}",
                    path.display(),
                    count.unwrap_or(info.count)
                ),
            });
        }
        count = Some(info.count);
        complete.insert(index, path);
    }
    let Some(count) = count else {
        // No complete shard: what the unfinished ones (killed or still running) have done.
        let mut shards: Vec<String> = partial
            .values()
            .map(|p| {
                let n = read_records(&p.join(LOG), now.units, false).map_or(0, |r| r.len());
                let which = read_shard_info(p)
                    .ok()
                    .flatten()
                    .map_or_else(|| p.display().to_string(), |s| s.to_string());
                format!("shard {which} unfinished, {n} units done")
            })
            .collect();
        shards.insert(0, format!("no complete shard in {}", shards_dir.display()));
        return Err(ShardError::Missing {
            dir: dir.to_path_buf(),
            units: now.units,
            missing: (0..now.units).map(unit_name).collect(),
            shards,
        });
    };
    let mut records: BTreeMap<usize, String> = BTreeMap::new();
    for (index, path) in &complete {
        let shard = Shard {
            index: *index,
            count,
        };
        for (unit, record) in read_records(&path.join(RECORDS), now.units, false)? {
            if !shard.owns(unit) {
                return Err(ShardError::Mixed {
                    dir: path.clone(),
                    message: format!(
                        "{RECORDS} holds {} (unit {unit}), which is shard {}/{count}'s, not \
                         this shard's ({shard})",
                        unit_name(unit),
                        unit % count
                    ),
                });
            }
            for file in required(unit) {
                if !path.join(&file).is_file() {
                    return Err(ShardError::Mixed {
                        dir: path.clone(),
                        message: format!(
                            "`{file}`, written by {}, is missing: run that shard again with \
                             --restart",
                            unit_name(unit)
                        ),
                    });
                }
            }
            records.insert(unit, record);
        }
    }
    let missing: Vec<usize> = (0..now.units)
        .filter(|u| !records.contains_key(u))
        .collect();
    if !missing.is_empty() {
        let shards: Vec<String> = (0..count)
            .filter(|i| !complete.contains_key(i))
            .map(|i| match partial.get(&i) {
                Some(p) => {
                    let n = read_records(&p.join(LOG), now.units, false).map_or(0, |r| r.len());
                    format!(
                        "shard {i}/{count} unfinished, {n} of {} units done",
                        Shard { index: i, count }.units(now.units).len()
                    )
                }
                None => format!("shard {i}/{count} not started"),
            })
            .collect();
        return Err(ShardError::Missing {
            dir: dir.to_path_buf(),
            units: now.units,
            missing: missing.iter().map(|u| unit_name(*u)).collect(),
            shards,
        });
    }
    Ok((records.into_values().collect(), count))
}

/// Merges the complete shards of `dir` into the final outputs (idempotent). Refuses shards of
/// other inputs or of different shard counts; with a unit missing, names the missing units and
/// writes nothing.
pub fn merge<S: Study>(study: &S, dir: &Path) -> Result<RunReport, S::Error> {
    let now = study.manifest();
    let out = OutputDir::create_carrying(dir, &[SHARDS]).map_err(ShardError::from)?;
    let shards_dir = out.dir().join(SHARDS);
    let (records, count) = shard_records_with(out.dir(), now, &|u| study.unit_name(u), &|u| {
        study.required_files(u)
    })?;
    let staging = out.path().to_path_buf();
    let unit_dirs = |u: usize| shards_dir.join((u % count).to_string());
    study.finalize(&records, &unit_dirs, &staging)?;
    now.write(&staging)?;
    let files = out.commit().map_err(ShardError::from)?;
    Ok(RunReport {
        units_total: now.units,
        units_resumed: now.units,
        units_run: 0,
        complete: true,
        already_complete: false,
        files,
    })
}
