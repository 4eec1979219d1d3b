//! All-or-nothing output folders. A command writes into a staging folder beside its output
//! folder `DIR` (`.DIR.partial`, same file system) and [`OutputDir::commit`] swaps it into place
//! only once everything is written and synced: a crash, a kill or a full disk leaves either the
//! previous folder or the new one, never a mix, and never destroys the previous good results.
//!
//! - A lock file beside `DIR` (`.DIR.lock`, `flock`) keeps two processes from writing the same
//!   folder; it is released by the kernel when a process dies, so a killed run never leaves a
//!   stale lock.
//! - The committed folder carries a marker, [`MARKER`], listing the files written together. A
//!   folder is only replaced when it is absent, empty, or carries a marker and holds nothing
//!   else; anything else (a folder of the user's own files, `--out .`) is refused before any work.
//! - The swap is one `renameat2(RENAME_EXCHANGE)` where the file system has it; elsewhere (e.g.
//!   NFS) two renames, and the next run finishes an interrupted swap (the new folder wins only if
//!   its marker was written, i.e. it was complete).
//! - Resumable commands ([`OutputDir::resume`]) keep the staging folder across runs: it holds
//!   their finished work units until the output is complete.

use rustix::fs::{flock, FlockOperation};
use std::collections::BTreeSet;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Name of the marker file in a committed output folder.
pub const MARKER: &str = ".geneva-output";
const MARKER_HEADER: &str =
    "# written by geneva: the files below were written together and committed all at once\n";

#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    #[error("{path}: cannot {action}")]
    Io {
        path: PathBuf,
        action: &'static str,
        source: std::io::Error,
    },
    #[error("{dir}: in use by another geneva process ({holder}; lock file {lock}); wait for it to finish or use another folder")]
    Busy {
        dir: PathBuf,
        lock: PathBuf,
        holder: String,
    },
    #[error("{dir}: holds files geneva did not write ({}); it would be replaced as a whole, so remove them or choose another folder", list_some(files))]
    Foreign { dir: PathBuf, files: Vec<String> },
    #[error("{dir}: not a folder name an output can have")]
    NoName { dir: PathBuf },
    #[error("{what} {} lies inside {} ({}), which this command replaces as a whole: the input would be deleted with it; choose another output folder, or move the input out of it first", path.display(), dir.display(), place)]
    InputInside {
        /// The input as the command names it (`--tracks`, `scenario`, `its extend base`).
        what: String,
        path: PathBuf,
        dir: PathBuf,
        /// Which part of the output is in the way: the folder itself or its staging folder.
        place: String,
    },
}

/// A file or folder a command reads, named as the command's user knows it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Input {
    /// `--tracks`, `scenario`, `its frame_timing.model.file`…
    pub what: String,
    pub path: PathBuf,
}

impl Input {
    pub fn new(what: impl Into<String>, path: impl Into<PathBuf>) -> Self {
        Self {
            what: what.into(),
            path: path.into(),
        }
    }
}

/// `p` made absolute with every symbolic link and `.`/`..` resolved, as far as it exists; the
/// part that does not exist yet is appended as written, its `.` and `..` resolved by name.
pub fn resolved_path(p: &Path) -> PathBuf {
    let abs = std::path::absolute(p).unwrap_or_else(|_| p.to_path_buf());
    let mut existing = abs.as_path();
    let mut rest: Vec<std::ffi::OsString> = Vec::new();
    let base = loop {
        if let Ok(c) = existing.canonicalize() {
            break c;
        }
        match (existing.parent(), existing.file_name()) {
            (Some(parent), Some(name)) => {
                rest.push(name.to_os_string());
                existing = parent;
            }
            // `..` or the root: resolve the remainder by name below.
            _ => break existing.to_path_buf(),
        }
    };
    let mut out = base;
    for part in rest.iter().rev() {
        match part.to_str() {
            Some(".") => {}
            Some("..") => {
                out.pop();
            }
            _ => out.push(part),
        }
    }
    out
}

/// Refuses, naming it, any input that lies inside `dir` or inside the folders beside it that
/// replacing `dir` deletes (its staging folder and the swapped-out old folder): a command that
/// read its input from there and then committed would destroy it. Paths are compared resolved
/// ([`resolved_path`]), so a symbolic link or `..` does not hide an input, and an input that is
/// the folder itself is refused too. Every command runs it before any work.
pub fn refuse_inputs_inside(dir: &Path, inputs: &[Input]) -> Result<(), OutputError> {
    // What a commit replaces are the entries named NAME, .NAME.partial and .NAME.old in DIR's
    // parent (a link there is replaced, not followed); what DIR resolves to is refused too.
    let (_, parent, name) = split(dir)?;
    let parent = resolved_path(&parent);
    let mut places: Vec<(PathBuf, String)> = vec![
        (parent.join(&name), "the output folder".to_string()),
        (
            parent.join(format!(".{name}.partial")),
            "its staging folder".to_string(),
        ),
        (
            parent.join(format!(".{name}.old")),
            "the previous output, removed at the commit".to_string(),
        ),
    ];
    if let Ok(target) = dir.canonicalize() {
        places.push((target, "the output folder".to_string()));
    }
    for input in inputs {
        let path = resolved_path(&input.path);
        if let Some((_, place)) = places.iter().find(|(p, _)| path.starts_with(p)) {
            return Err(OutputError::InputInside {
                what: input.what.clone(),
                path: input.path.clone(),
                dir: dir.to_path_buf(),
                place: place.clone(),
            });
        }
    }
    Ok(())
}

fn list_some(files: &[String]) -> String {
    let mut s: Vec<String> = files.iter().take(5).map(|f| format!("`{f}`")).collect();
    if files.len() > 5 {
        s.push(format!("and {} more", files.len() - 5));
    }
    s.join(", ")
}

fn io_err<'a>(
    path: &'a Path,
    action: &'static str,
) -> impl FnOnce(std::io::Error) -> OutputError + 'a {
    move |source| OutputError::Io {
        path: path.to_path_buf(),
        action,
        source,
    }
}

/// `DIR` made absolute, with its parent and name.
fn split(dir: &Path) -> Result<(PathBuf, PathBuf, String), OutputError> {
    let abs = std::path::absolute(dir).map_err(io_err(dir, "resolve the path"))?;
    let name = abs
        .file_name()
        .and_then(|n| n.to_str())
        .filter(|n| !n.is_empty() && *n != "." && *n != "..")
        .ok_or_else(|| OutputError::NoName { dir: dir.into() })?
        .to_string();
    let parent = abs
        .parent()
        .ok_or_else(|| OutputError::NoName { dir: dir.into() })?
        .to_path_buf();
    Ok((abs, parent, name))
}

/// The sibling `.NAME.SUFFIX` of `DIR`.
pub fn sibling(dir: &Path, suffix: &str) -> Result<PathBuf, OutputError> {
    let (_, parent, name) = split(dir)?;
    Ok(parent.join(format!(".{name}.{suffix}")))
}

/// An advisory lock (`flock`) on a lock file, released when dropped or when the process dies.
#[derive(Debug)]
pub struct DirLock {
    path: PathBuf,
    file: Option<File>,
    exclusive: bool,
}

impl DirLock {
    /// Takes the lock of `DIR` (`.DIR.lock` beside it) without waiting.
    pub fn of_dir(dir: &Path, exclusive: bool) -> Result<Self, OutputError> {
        let lock = sibling(dir, "lock")?;
        Self::at(&lock, dir, exclusive)
    }

    /// Takes the lock file `lock` (guarding `what`) without waiting: exclusive for a writer of
    /// the whole folder, shared for the many writers of parts of it (shards).
    pub fn at(lock: &Path, what: &Path, exclusive: bool) -> Result<Self, OutputError> {
        if let Some(parent) = lock.parent() {
            std::fs::create_dir_all(parent).map_err(io_err(parent, "create the folder"))?;
        }
        let op = if exclusive {
            FlockOperation::NonBlockingLockExclusive
        } else {
            FlockOperation::NonBlockingLockShared
        };
        loop {
            let mut file = OpenOptions::new()
                .read(true)
                .write(true)
                .create(true)
                .truncate(false)
                .open(lock)
                .map_err(io_err(lock, "open the lock file"))?;
            match flock(&file, op) {
                Ok(()) => {}
                Err(e) if e == rustix::io::Errno::WOULDBLOCK => {
                    let holder = std::fs::read_to_string(lock)
                        .ok()
                        .map(|s| s.trim().to_string())
                        .filter(|s| !s.is_empty())
                        .unwrap_or_else(|| "shard runs".into());
                    return Err(OutputError::Busy {
                        dir: what.into(),
                        lock: lock.into(),
                        holder,
                    });
                }
                Err(e) => {
                    return Err(OutputError::Io {
                        path: lock.into(),
                        action: "lock",
                        source: e.into(),
                    })
                }
            }
            // An exclusive holder unlinks the file when it is done; if that happened between our
            // open and our lock, we hold a lock on a file nobody else will see: take it again.
            let same = match (file.metadata(), std::fs::metadata(lock)) {
                (Ok(a), Ok(b)) => {
                    use std::os::unix::fs::MetadataExt;
                    a.ino() == b.ino() && a.dev() == b.dev()
                }
                _ => false,
            };
            if !same {
                continue;
            }
            if exclusive {
                let host = rustix::system::uname()
                    .nodename()
                    .to_string_lossy()
                    .into_owned();
                let _ = file.set_len(0);
                let _ = writeln!(file, "pid {} on {host}", std::process::id());
            }
            return Ok(Self {
                path: lock.into(),
                file: Some(file),
                exclusive,
            });
        }
    }
}

impl Drop for DirLock {
    fn drop(&mut self) {
        if self.exclusive {
            // Unlinked while still held: a waiting process notices the new inode and retries.
            let _ = std::fs::remove_file(&self.path);
        }
        self.file.take();
    }
}

/// A folder being written all or nothing; see the module docs.
#[derive(Debug)]
pub struct OutputDir {
    dir: PathBuf,
    staging: PathBuf,
    old: PathBuf,
    keep_staging: bool,
    committed: bool,
    carry: Vec<String>,
    _lock: DirLock,
}

impl OutputDir {
    /// Locks `dir`, checks that it may be replaced, and starts a fresh, empty staging folder
    /// (discarding the leftovers of a killed run).
    pub fn create(dir: &Path) -> Result<Self, OutputError> {
        let mut out = Self::open(dir, &[])?;
        out.clear_staging()?;
        Ok(out)
    }

    /// Like [`create`](Self::create) but keeps an existing staging folder: resumable commands
    /// find their finished work units there. The staging folder also survives an error.
    pub fn resume(dir: &Path) -> Result<Self, OutputError> {
        let mut out = Self::open(dir, &[])?;
        out.keep_staging = true;
        std::fs::create_dir_all(&out.staging).map_err(io_err(&out.staging, "create the folder"))?;
        Ok(out)
    }

    /// Like [`create`](Self::create), and the top-level entries named in `carry` (e.g.
    /// `shards`) already in `dir` are part of the output: they are hard-linked into the new
    /// folder at commit (copied where links are impossible).
    pub fn create_carrying(dir: &Path, carry: &[&str]) -> Result<Self, OutputError> {
        let mut out = Self::open(dir, carry)?;
        out.clear_staging()?;
        Ok(out)
    }

    fn open(dir: &Path, carry: &[&str]) -> Result<Self, OutputError> {
        let (abs, parent, name) = split(dir)?;
        std::fs::create_dir_all(&parent).map_err(io_err(&parent, "create the folder"))?;
        let lock = DirLock::of_dir(&abs, true)?;
        let out = Self {
            staging: parent.join(format!(".{name}.partial")),
            old: parent.join(format!(".{name}.old")),
            dir: abs,
            keep_staging: false,
            committed: false,
            carry: carry.iter().map(|s| s.to_string()).collect(),
            _lock: lock,
        };
        out.recover()?;
        if out.dir.exists() && !out.dir.is_dir() {
            return Err(OutputError::Io {
                path: out.dir.clone(),
                action: "use it as an output folder",
                source: std::io::Error::other("it is a file"),
            });
        }
        let foreign = out.foreign_files(&BTreeSet::new())?;
        if !foreign.is_empty() {
            return Err(OutputError::Foreign {
                dir: out.dir.clone(),
                files: foreign,
            });
        }
        Ok(out)
    }

    /// Finishes a swap that a crash interrupted (we hold the lock, so nobody else is in it).
    fn recover(&self) -> Result<(), OutputError> {
        let staged_complete = self.staging.join(MARKER).is_file();
        if !self.dir.exists() {
            if staged_complete {
                rename(&self.staging, &self.dir)?;
            } else if self.old.exists() {
                rename(&self.old, &self.dir)?;
            }
        } else if staged_complete {
            // A complete staging folder beside a present DIR is the old output swapped out.
            remove_tree(&self.staging)?;
        }
        if self.old.exists() {
            remove_tree(&self.old)?;
        }
        Ok(())
    }

    fn clear_staging(&mut self) -> Result<(), OutputError> {
        if self.staging.exists() {
            remove_tree(&self.staging)?;
        }
        std::fs::create_dir(&self.staging).map_err(io_err(&self.staging, "create the folder"))
    }

    /// Where to write: the staging folder.
    pub fn path(&self) -> &Path {
        &self.staging
    }

    /// The final folder (absolute).
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Where a path written under [`path`](Self::path) will be after the commit.
    pub fn final_path(&self, p: &Path) -> PathBuf {
        match p.strip_prefix(&self.staging) {
            Ok(rel) => self.dir.join(rel),
            Err(_) => p.to_path_buf(),
        }
    }

    /// Nothing to write after all (the output is already complete): the staging folder is
    /// removed when this is dropped, even for a resumable command.
    pub fn abandon(&mut self) {
        self.keep_staging = false;
    }

    /// Empties the staging folder (a resumable command restarting from scratch).
    pub fn restart(&mut self) -> Result<(), OutputError> {
        self.clear_staging()
    }

    /// Files in `DIR` that are neither listed in its marker, nor carried, nor in `new`.
    fn foreign_files(&self, new: &BTreeSet<String>) -> Result<Vec<String>, OutputError> {
        if !self.dir.is_dir() {
            return Ok(Vec::new());
        }
        let listed: BTreeSet<String> = match std::fs::read_to_string(self.dir.join(MARKER)) {
            Ok(text) => text
                .lines()
                .filter(|l| !l.starts_with('#') && !l.is_empty())
                .map(String::from)
                .collect(),
            Err(_) => BTreeSet::new(),
        };
        Ok(relative_files(&self.dir)?
            .into_iter()
            .filter(|f| {
                f != MARKER
                    && !listed.contains(f)
                    && !new.contains(f)
                    && !self
                        .carry
                        .iter()
                        .any(|c| f == c || f.starts_with(&format!("{c}/")))
            })
            .collect())
    }

    /// Writes the marker, syncs every file and swaps the staging folder into place. Returns the
    /// final paths of the files written.
    pub fn commit(mut self) -> Result<Vec<PathBuf>, OutputError> {
        for c in &self.carry {
            let from = self.dir.join(c);
            if from.exists() {
                link_tree(&from, &self.staging.join(c))?;
            }
        }
        let files = relative_files(&self.staging)?;
        let mut marker = String::from(MARKER_HEADER);
        for f in files.iter().filter(|f| *f != MARKER) {
            marker.push_str(f);
            marker.push('\n');
        }
        let marker_path = self.staging.join(MARKER);
        std::fs::write(&marker_path, marker).map_err(io_err(&marker_path, "write"))?;
        sync_tree(&self.staging)?;
        if self.dir.exists() {
            let new: BTreeSet<String> = files.iter().cloned().collect();
            let foreign = self.foreign_files(&new)?;
            if !foreign.is_empty() {
                return Err(OutputError::Foreign {
                    dir: self.dir.clone(),
                    files: foreign,
                });
            }
            swap(&self.staging, &self.dir, &self.old)?;
            remove_tree(&self.old)?;
        } else {
            rename(&self.staging, &self.dir)?;
        }
        if let Some(parent) = self.dir.parent() {
            sync_dir(parent);
        }
        self.committed = true;
        Ok(files
            .iter()
            .filter(|f| *f != MARKER)
            .map(|f| self.dir.join(f))
            .collect())
    }
}

impl Drop for OutputDir {
    fn drop(&mut self) {
        if !self.committed && !self.keep_staging {
            let _ = std::fs::remove_dir_all(&self.staging);
        }
    }
}

fn rename(from: &Path, to: &Path) -> Result<(), OutputError> {
    std::fs::rename(from, to).map_err(|source| OutputError::Io {
        path: to.to_path_buf(),
        action: "rename the staged folder into place",
        source,
    })
}

fn remove_tree(p: &Path) -> Result<(), OutputError> {
    match std::fs::remove_dir_all(p) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Ok(()),
        Err(source) => Err(OutputError::Io {
            path: p.to_path_buf(),
            action: "remove",
            source,
        }),
    }
}

/// `new` takes the place of `dir`; the previous `dir` ends at `old`.
fn swap(new: &Path, dir: &Path, old: &Path) -> Result<(), OutputError> {
    #[cfg(target_os = "linux")]
    {
        use rustix::fs::{renameat_with, RenameFlags, CWD};
        match renameat_with(CWD, new, CWD, dir, RenameFlags::EXCHANGE) {
            Ok(()) => return rename(new, old),
            Err(e)
                if e == rustix::io::Errno::INVAL
                    || e == rustix::io::Errno::NOSYS
                    || e == rustix::io::Errno::NOTSUP => {}
            Err(e) => {
                return Err(OutputError::Io {
                    path: dir.to_path_buf(),
                    action: "swap the staged folder into place",
                    source: e.into(),
                })
            }
        }
    }
    // Two renames; `recover` completes them if we are killed in between.
    rename(dir, old)?;
    rename(new, dir)
}

/// Every file under `root`, relative, with `/` separators, sorted.
pub fn relative_files(root: &Path) -> Result<Vec<String>, OutputError> {
    fn walk(root: &Path, dir: &Path, out: &mut Vec<String>) -> Result<(), OutputError> {
        let entries = std::fs::read_dir(dir).map_err(io_err(dir, "list"))?;
        for entry in entries {
            let entry = entry.map_err(io_err(dir, "list"))?;
            let path = entry.path();
            let kind = entry.file_type().map_err(io_err(&path, "inspect"))?;
            if kind.is_dir() {
                walk(root, &path, out)?;
            } else if let Ok(rel) = path.strip_prefix(root) {
                let parts: Vec<String> = rel
                    .components()
                    .map(|c| c.as_os_str().to_string_lossy().into_owned())
                    .collect();
                out.push(parts.join("/"));
            }
        }
        Ok(())
    }
    let mut out = Vec::new();
    walk(root, root, &mut out)?;
    out.sort();
    Ok(out)
}

/// Hard-links (or copies) the tree `from` to `to`.
pub fn link_tree(from: &Path, to: &Path) -> Result<(), OutputError> {
    if from.is_dir() {
        std::fs::create_dir_all(to).map_err(io_err(to, "create the folder"))?;
        for entry in std::fs::read_dir(from).map_err(io_err(from, "list"))? {
            let entry = entry.map_err(io_err(from, "list"))?;
            link_tree(&entry.path(), &to.join(entry.file_name()))?;
        }
        Ok(())
    } else {
        if std::fs::hard_link(from, to).is_err() {
            std::fs::copy(from, to).map_err(io_err(to, "copy"))?;
        }
        Ok(())
    }
}

fn sync_dir(dir: &Path) {
    // Directory fsync is best effort: some file systems refuse it.
    if let Ok(f) = File::open(dir) {
        let _ = f.sync_all();
    }
}

/// fsync of every file and folder under `root`: the data is on disk before the swap.
fn sync_tree(root: &Path) -> Result<(), OutputError> {
    for entry in std::fs::read_dir(root).map_err(io_err(root, "list"))? {
        let entry = entry.map_err(io_err(root, "list"))?;
        let path = entry.path();
        if path.is_dir() {
            sync_tree(&path)?;
        } else {
            let f = File::open(&path).map_err(io_err(&path, "open"))?;
            f.sync_all().map_err(io_err(&path, "sync to disk"))?;
        }
    }
    sync_dir(root);
    Ok(())
}

/// Writes `bytes` to `path` through a temporary file in the same folder and a rename: readers
/// see the old file or the new one, never a part.
pub fn write_file_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = path.with_file_name(format!(".{name}.tmp"));
    let mut f = File::create(&tmp).map_err(io_err(&tmp, "create"))?;
    f.write_all(bytes)
        .and_then(|_| f.sync_all())
        .map_err(io_err(&tmp, "write"))?;
    drop(f);
    std::fs::rename(&tmp, path).map_err(io_err(path, "rename into place"))
}

#[cfg(test)]
mod tests;
