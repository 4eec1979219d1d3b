//! Error text for people: an error and its `source()` causes joined with ": ", each once.
//! Library errors either show their cause in their own message (`#[error(transparent)]`) or
//! return it from `source()` — never both — so this (and anyhow's `{:#}`) prints every cause
//! exactly once; use it wherever an error becomes a string (a results row, another message).

use std::error::Error;
use std::path::{Path, PathBuf};

/// A file or folder that could not be read, written or encoded; the path first, the cause as
/// `source()`. Library errors that write outputs hold it as `File(#[from] FileError)` so that
/// `.map_err(FileError::io(path))?` works in all of them.
#[derive(Debug, thiserror::Error)]
pub enum FileError {
    #[error("{}", file.display())]
    Io {
        file: PathBuf,
        source: std::io::Error,
    },
    #[error("{}", file.display())]
    Csv { file: PathBuf, source: csv::Error },
    #[error("{}", file.display())]
    Json {
        file: PathBuf,
        source: serde_json::Error,
    },
}

impl FileError {
    pub fn io(file: &Path) -> impl FnOnce(std::io::Error) -> FileError + '_ {
        move |source| FileError::Io {
            file: file.to_path_buf(),
            source,
        }
    }

    pub fn csv(file: &Path) -> impl FnOnce(csv::Error) -> FileError + '_ {
        move |source| FileError::Csv {
            file: file.to_path_buf(),
            source,
        }
    }

    pub fn json(file: &Path) -> impl FnOnce(serde_json::Error) -> FileError + '_ {
        move |source| FileError::Json {
            file: file.to_path_buf(),
            source,
        }
    }
}

/// The text of `error` and of each of its causes, outermost first.
pub fn chain<E: Error + ?Sized>(error: &E) -> Vec<String> {
    let mut out = vec![error.to_string()];
    let mut cause = error.source();
    while let Some(c) = cause {
        out.push(c.to_string());
        cause = c.source();
    }
    out
}

/// `error` with its causes on one line, as `{:#}` of anyhow prints it.
pub fn full<E: Error + ?Sized>(error: &E) -> String {
    chain(error)
        .into_iter()
        .filter(|s| !s.is_empty())
        .collect::<Vec<_>>()
        .join(": ")
}

/// The first segment of a cause chain whose text another segment contains, if any: that text
/// would be printed twice.
pub fn repeated_segment(segments: &[String]) -> Option<String> {
    segments.iter().enumerate().find_map(|(i, s)| {
        let s_trim = s.trim();
        (!s_trim.is_empty()
            && segments
                .iter()
                .enumerate()
                .any(|(j, other)| i != j && other.contains(s_trim)))
        .then(|| s.clone())
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::validation::Problem;
    use std::path::{Path, PathBuf};

    /// `{:#}` of anyhow, as the binary prints errors, with a context of the binary's kind.
    fn printed<E: std::error::Error + Send + Sync + 'static>(e: E) -> (String, Vec<String>) {
        let e = anyhow::Error::from(e).context("geneva run");
        let segments: Vec<String> = e.chain().map(|c| c.to_string()).collect();
        (format!("{e:#}"), segments)
    }

    fn assert_once<E: std::error::Error + Send + Sync + 'static>(e: E) -> String {
        let (text, segments) = printed(e);
        assert!(repeated_segment(&segments).is_none(), "repeats: {text}");
        for s in &segments {
            assert_eq!(
                text.matches(s.as_str()).count(),
                1,
                "`{s}` twice in: {text}"
            );
        }
        text
    }

    /// A path under a regular file: "Not a directory (os error 20)", the example.
    fn under_a_file() -> (tempfile::TempDir, PathBuf) {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("plain");
        std::fs::write(&file, "x").unwrap();
        (dir, file.join("inner"))
    }

    /// Representative errors of every reader and job, printed as the binary prints them: no
    /// cause's text appears twice, and the cause is still there (printed once).
    #[test]
    fn printed_chains_never_repeat_a_cause() {
        let (_dir, bad) = under_a_file();
        let missing = Path::new("/nonexistent/geneva/x");
        let t = assert_once(crate::scenario::load(&bad.join("s.toml")).unwrap_err());
        assert!(t.contains("Not a directory (os error 20)"), "{t}");
        assert_once(crate::sweep::SweepSpec::load(missing).unwrap_err());
        let t = assert_once(crate::io::timing_log::read_timing_log(missing, None).unwrap_err());
        assert!(t.contains("No such file"), "{t}");
        assert_once(crate::io::tracks_csv::read_tracks(missing, None).unwrap_err());
        assert_once(crate::io::video::probe(missing).unwrap_err());
        assert_once(crate::io::images::read_gray(missing).unwrap_err());
        let t = assert_once(crate::io::output_dir::OutputDir::create(&bad).unwrap_err());
        assert!(t.contains("(os error "), "{t}");
        let base = crate::scenario::load(missing).unwrap_err();
        assert_once(crate::sweep::SweepError::Base {
            file: "sweep.toml".into(),
            source: base,
        });
        let point = crate::scenario::ScenarioError::Invalid {
            file: "sweep.toml".into(),
            problems: vec![Problem {
                field: "camera.distance_m".into(),
                message: "must be > 0".into(),
            }],
        };
        let t = assert_once(crate::sweep::SweepError::Point {
            file: "sweep.toml".into(),
            point: "d=0".into(),
            source: Box::new(point),
        });
        assert!(t.contains("camera.distance_m"), "{t}");
        let rig = crate::pipeline::rig::RigError::Timing(crate::timing::TimingError::MissingLog);
        let t = assert_once(rig);
        assert!(
            t.starts_with("geneva run: frame timing: frame_timing.model"),
            "{t}"
        );
    }

    #[test]
    fn full_joins_each_cause_once() {
        let e = crate::pipeline::rig::RigError::Timing(crate::timing::TimingError::TooFewFrames {
            needed: 3,
            got: 1,
        });
        assert_eq!(full(&e), "frame timing: need at least 3 frames, got 1");
    }
}
