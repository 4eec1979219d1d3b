//! The `geneva` binary's messages (issue #14): every error names what is wrong once, a folder
//! named like a built-in never shadows it, frame ranges say what they hold.
#![cfg(feature = "opencv-detector")]

use std::path::Path;
use std::process::{Command, Output};

fn geneva(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_geneva"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Segments of a message (split at ": ") longer than a few characters that occur twice.
fn repeated(text: &str) -> Vec<String> {
    let parts: Vec<&str> = text.trim().split(": ").collect();
    parts
        .iter()
        .enumerate()
        .filter(|(k, p)| p.len() > 6 && parts[..*k].contains(p))
        .map(|(_, p)| p.to_string())
        .collect()
}

#[test]
fn a_run_into_a_folder_named_like_its_builtin_can_be_repeated() {
    // Issue #14: `geneva run fast --out fast` failed the second time ("fast: cannot read: Is a
    // directory (os error 21): Is a directory (os error 21)").
    let dir = tempfile::tempdir().unwrap();
    for attempt in 0..2 {
        let o = geneva(dir.path(), &["run", "fast", "--out", "fast"]);
        assert!(o.status.success(), "attempt {attempt}: {}", stderr(&o));
    }
    // `builtin:NAME` always means the built-in, even beside a file of that name.
    std::fs::write(dir.path().join("fast"), "not toml [").ok();
    let o = geneva(dir.path(), &["scenario", "check", "builtin:fast"]);
    assert!(o.status.success(), "{}", stderr(&o));
}

#[test]
fn an_empty_frame_range_says_so() {
    // Issue #14: `render fast --frames 5..5` said "outside the scenario's 60 frames".
    let dir = tempfile::tempdir().unwrap();
    let o = geneva(dir.path(), &["render", "fast", "--frames", "5..5"]);
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("holds no frame") && !e.contains("outside"),
        "{e}"
    );
    let o = geneva(
        dir.path(),
        &["render", "fast", "--frames", "5", "--out", "one"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(dir.path().join("one/frame_000005.png").is_file());
}

#[test]
fn error_messages_state_each_cause_once() {
    // Issue #14: 62 of about 1,000 messages repeated their text ("Not a directory (os error
    // 20): Not a directory (os error 20)").
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir(dir.path().join("adir")).unwrap();
    std::fs::write(dir.path().join("empty.csv"), "").unwrap();
    let cases: &[&[&str]] = &[
        &["run", "fast", "--out", "/dev/null/x"],
        &["render", "fast", "--out", "/dev/null/x"],
        &["kinematics", "fast", "--out", "/dev/null/x"],
        &["scenario", "check", "adir"],
        &["scenario", "check", "missing.toml"],
        &["timing", "show", "adir"],
        &["timing", "fit", "missing.log"],
        &["analyze", "--tracks", "missing.csv", "--out", "o1"],
        &["analyze", "--tracks", "empty.csv", "--out", "o2"],
        &["analyze", "--frames", "adir", "--timestamps", "empty.csv"],
        &["analyze", "--video", "missing.mp4", "--out", "o3"],
    ];
    for args in cases {
        let o = geneva(dir.path(), args);
        let e = stderr(&o);
        assert_eq!(o.status.code(), Some(1), "{args:?}: {e}");
        assert!(e.starts_with("error: "), "{args:?}: {e}");
        assert!(!e.contains("panicked"), "{args:?}: {e}");
        assert!(
            repeated(&e).is_empty(),
            "{args:?} repeats {:?}: {e}",
            repeated(&e)
        );
    }
}
