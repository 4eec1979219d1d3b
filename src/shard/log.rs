//! The append-only record log of a run in progress: one line `unit<TAB>record` per finished
//! unit, written with a single `write` and flushed, so a kill loses at most the line being
//! written. Records are escaped (`\\`, `\n`, `\r`, `\t`), so any text fits on one line.

use super::{io_err, ShardError};
use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

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
        let line = format!("{unit}\t{}\n", escape(record));
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

/// `unit<TAB>record` lines, each ended: a unit twice or out of range is an error.
fn parse_records(
    path: &Path,
    complete: &str,
    units: usize,
) -> Result<BTreeMap<usize, String>, ShardError> {
    let mut records = BTreeMap::new();
    for (i, line) in complete.lines().enumerate() {
        let bad = |message: String| ShardError::Log {
            file: path.into(),
            line: i + 1,
            message,
        };
        let (unit, record) = line
            .split_once('\t')
            .ok_or_else(|| bad("expected `unit<TAB>record`".into()))?;
        let unit: usize = unit
            .parse()
            .map_err(|_| bad(format!("unit `{unit}` is not a whole number")))?;
        if unit >= units {
            return Err(bad(format!(
                "unit {unit} is outside this study's {units} units"
            )));
        }
        if records.insert(unit, unescape(record)).is_some() {
            return Err(bad(format!("unit {unit} appears twice")));
        }
    }
    Ok(records)
}

/// Writes records as `unit<TAB>record` lines in unit order.
pub fn write_records(path: &Path, records: &BTreeMap<usize, String>) -> Result<(), ShardError> {
    let mut text = String::new();
    for (unit, record) in records {
        text.push_str(&format!("{unit}\t{}\n", escape(record)));
    }
    crate::io::output_dir::write_file_atomic(path, text.as_bytes())?;
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
