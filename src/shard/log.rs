//! The append-only record log of a run in progress: one line `unit<TAB>record<TAB>digest` per
//! finished unit, written with a single `write` and flushed, so a kill loses at most the line
//! being written. Records are escaped (`\\`, `\n`, `\r`, `\t`), so any text fits on one line.
//! The same lines, in unit order, are a complete shard's `units.tsv`.
//!
//! Integrity: a file begins with [`HEADER`], and every record then carries its digest
//! (FNV-1a 64 of `unit<TAB>escaped record`): an edited or corrupted record is refused, naming
//! the file, the line and the unit. A file without the header was written before records
//! carried digests: it is read as it is (the rule for older folders), and a log of that kind
//! is rewritten with digests when a run appends to it. Merges ask more: a complete shard's
//! files carry a digest each in its `shard.json` (`study`), so they refuse an older shard.
use super::{io_err, ShardError};
use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// First line of a record file whose records carry digests.
pub const HEADER: &str = "# geneva records: unit, record, fnv1a64 digest of both";

/// The digest of one record line's `unit<TAB>escaped record`.
fn line_digest(unit: usize, escaped: &str) -> String {
    let text = format!("{unit}\t{escaped}");
    format!("fnv1a64:{:016x}", super::manifest::fnv1a64(text.as_bytes()))
}

/// One record as a line of a file with digests.
fn record_line(unit: usize, record: &str) -> String {
    let escaped = escape(record);
    let digest = line_digest(unit, &escaped);
    format!("{unit}\t{escaped}\t{digest}\n")
}

/// An open log.
pub struct UnitLog {
    path: PathBuf,
    file: File,
}

impl UnitLog {
    /// Opens (creating) the log at `path` and returns the records already in it. A last line cut
    /// off by a kill (no newline) is removed from the file: that unit is done again.
    pub fn open(path: &Path, units: usize) -> Result<(Self, BTreeMap<usize, String>), ShardError> {
        let done = read_records(path, units, true)?;
        let has_header = read_log(path)?.is_some_and(|t| t.starts_with(HEADER));
        if !has_header {
            // A new log, or one of the older format: from now on, every record has a digest.
            write_records(path, &done)?;
        }
        let file = OpenOptions::new()
            .create(true)
            .append(true)
            .open(path)
            .map_err(io_err(path, "open for appending"))?;
        Ok((
            Self {
                path: path.into(),
                file,
            },
            done,
        ))
    }

    /// Appends the record of `unit`.
    pub fn append(&mut self, unit: usize, record: &str) -> Result<(), ShardError> {
        let line = record_line(unit, record);
        self.file
            .write_all(line.as_bytes())
            .and_then(|_| self.file.flush())
            .map_err(io_err(&self.path, "append to"))
    }
}

/// Reads `unit<TAB>record` lines (a log or a complete shard's records). With `repair`, a cut
/// last line is truncated away; without, it is an error. A unit twice or out of range is an error.
pub fn read_records(
    path: &Path,
    units: usize,
    repair: bool,
) -> Result<BTreeMap<usize, String>, ShardError> {
    let Some(text) = read_log(path)? else {
        return Ok(BTreeMap::new());
    };
    let complete = match text.rfind('\n') {
        Some(i) => &text[..=i],
        None => "",
    };
    if complete.len() != text.len() {
        if !repair {
            return Err(ShardError::Log {
                file: path.into(),
                line: complete.lines().count() + 1,
                message: "cut off (no end of line)".into(),
            });
        }
        let f = OpenOptions::new()
            .write(true)
            .open(path)
            .map_err(io_err(path, "open"))?;
        f.set_len(complete.len() as u64)
            .map_err(io_err(path, "truncate the cut last line of"))?;
    }
    parse_records(path, complete, units)
}

/// A record file's text read as a complete shard's `units.tsv` is (no repair: a cut last line
/// is an error); `path` names it in errors. What the fuzzing of the format calls.
pub fn parse_record_text(
    text: &str,
    path: &Path,
    units: usize,
) -> Result<BTreeMap<usize, String>, ShardError> {
    let complete = text.rfind('\n').map_or("", |i| &text[..=i]);
    if complete.len() != text.len() {
        return Err(ShardError::Log {
            file: path.into(),
            line: complete.lines().count() + 1,
            message: "cut off (no end of line)".into(),
        });
    }
    parse_records(path, complete, units)
}

/// The records of a log that another process may still be appending to, read without
/// changing it: a last line without its end of line is the record being written, left out.
pub fn read_finished_records(
    path: &Path,
    units: usize,
) -> Result<BTreeMap<usize, String>, ShardError> {
    let Some(text) = read_log(path)? else {
        return Ok(BTreeMap::new());
    };
    let complete = text.rfind('\n').map_or("", |i| &text[..=i]);
    parse_records(path, complete, units)
}

/// The log's text, `None` when there is no log yet.
fn read_log(path: &Path) -> Result<Option<String>, ShardError> {
    match std::fs::read_to_string(path) {
        Ok(t) => Ok(Some(t)),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(None),
        Err(e) => Err(io_err(path, "read")(e)),
    }
}

/// The lines of a record file (after its header, if any), each ended: a unit twice or out of
/// range, a digest missing or not matching its record (in a file with the header) is an error
/// naming the file and the line.
pub fn parse_records(
    path: &Path,
    complete: &str,
    units: usize,
) -> Result<BTreeMap<usize, String>, ShardError> {
    let mut records = BTreeMap::new();
    let digests = complete.starts_with(HEADER);
    for (i, line) in complete.lines().enumerate().skip(usize::from(digests)) {
        let bad = |message: String| ShardError::Log {
            file: path.into(),
            line: i + 1,
            message,
        };
        let (unit, rest) = line
            .split_once('\t')
            .ok_or_else(|| bad("expected `unit<TAB>record<TAB>digest`".into()))?;
        let unit: usize = unit
            .parse()
            .map_err(|_| bad(format!("unit `{unit}` is not a whole number")))?;
        if unit >= units {
            return Err(bad(format!(
                "unit {unit} is outside this study's {units} units"
            )));
        }
        let record = if digests {
            let (record, digest) = rest.rsplit_once('\t').ok_or_else(|| {
                bad(format!(
                    "unit {unit}: the record has no digest (every record of this file must)"
                ))
            })?;
            if digest != line_digest(unit, record) {
                return Err(bad(format!(
                    "unit {unit}: the record does not match its digest (edited or corrupted); \
                     delete this line to have the unit run again, or --restart"
                )));
            }
            record
        } else {
            rest
        };
        if records.insert(unit, unescape(record)).is_some() {
            return Err(bad(format!("unit {unit} appears twice")));
        }
    }
    Ok(records)
}

/// The text of a record file: the header, then the records with their digests in unit order.
pub fn record_file_text(records: &BTreeMap<usize, String>) -> String {
    let mut text = format!("{HEADER}\n");
    for (unit, record) in records {
        text.push_str(&record_line(*unit, record));
    }
    text
}

/// Writes [`record_file_text`] to `path` atomically.
pub fn write_records(path: &Path, records: &BTreeMap<usize, String>) -> Result<(), ShardError> {
    crate::io::output_dir::write_file_atomic(path, record_file_text(records).as_bytes())?;
    Ok(())
}

fn escape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    for c in s.chars() {
        match c {
            '\\' => out.push_str("\\\\"),
            '\n' => out.push_str("\\n"),
            '\r' => out.push_str("\\r"),
            '\t' => out.push_str("\\t"),
            c => out.push(c),
        }
    }
    out
}

fn unescape(s: &str) -> String {
    let mut out = String::with_capacity(s.len());
    let mut chars = s.chars();
    while let Some(c) = chars.next() {
        if c != '\\' {
            out.push(c);
            continue;
        }
        match chars.next() {
            Some('n') => out.push('\n'),
            Some('r') => out.push('\r'),
            Some('t') => out.push('\t'),
            Some(other) => out.push(other),
            None => out.push('\\'),
        }
    }
    out
}

#[cfg(test)]
pub(super) fn round_trip(s: &str) -> String {
    unescape(&escape(s))
}
