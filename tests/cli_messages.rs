//! The `geneva` binary's messages: every error names what is wrong once, a folder
//! named like a built-in never shadows it, frame ranges say what they hold.
#![cfg(feature = "opencv-detector")]

mod common;
use common::{geneva, stderr};

/// Hang guard for a refusal that must come before the work it refuses (hours of it): generous,
/// so that a slow or loaded machine never fails it; speed is measured by `cargo xtask bench`.
const HANG_GUARD_S: u64 = 600;

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
    // Regression: `geneva run fast --out fast` failed the second time ("fast: cannot read: Is a
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
    // Regression: `render fast --frames 5..5` said "outside the scenario's 60 frames".
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
    // Regression: 62 of about 1,000 messages repeated their text ("Not a directory (os error
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

#[test]
fn check_reports_combinations_and_work_and_run_refuses_unbounded_work() {
    let dir = tempfile::tempdir().unwrap();
    let o = geneva(dir.path(), &["scenario", "check", "fast"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success(), "{}", stderr(&o));
    assert!(
        out.contains("work: 60 frames of 1280x720 px") && out.contains("rig: 60 frames"),
        "{out}"
    );
    // Regression: accepted by `check`, fatal in `run` (once with its message printed thrice).
    for (text, field) in [
        ("dynamics.wheel_mass_kg = 1e-300", "dynamics.wheel_mass_kg"),
        ("scene.disc_radius_mm = 1e308", "scene.disc_radius_mm"),
        ("detector.marker_id = 3", "detector.marker_id"),
        // 2 frames: nothing to fit a rotation centre to.
        ("duration_s = 0.05", "estimator.min_arc_deg"),
    ] {
        std::fs::write(
            dir.path().join("s.toml"),
            format!("extend = \"fast\"\n{text}\n"),
        )
        .unwrap();
        for cmd in [&["scenario", "check", "s.toml"][..], &["run", "s.toml"][..]] {
            let o = geneva(dir.path(), cmd);
            let e = stderr(&o);
            assert_eq!(o.status.code(), Some(1), "{cmd:?} {text}: {e}");
            assert!(e.contains(field) && repeated(&e).is_empty(), "{e}");
            assert!(!e.contains("panicked"), "{e}");
        }
    }
    // Every field in range, but hours of work: refused before any of it, unless --yes.
    std::fs::write(
        dir.path().join("huge.toml"),
        "extend = \"fast\"\nduration_s = 3600.0\nframe_timing.fps = 10000.0\n\
         camera.width_px = 20000\ncamera.height_px = 20000\n",
    )
    .unwrap();
    let started = std::time::Instant::now();
    let o = geneva(dir.path(), &["run", "huge.toml"]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("--yes") && e.contains("36000000 frames"), "{e}");
    let o = geneva(dir.path(), &["scenario", "check", "huge.toml"]);
    let out = String::from_utf8_lossy(&o.stdout);
    assert!(o.status.success() && out.contains("needs --yes"), "{out}");
    // Hang guard, not a speed check: the run refused does hours of work.
    assert!(started.elapsed().as_secs() < HANG_GUARD_S, "hang guard");
}

#[test]
fn a_million_point_sweep_is_refused_before_its_grid_is_built() {
    // Regression: a 10⁶-point grid was neither refused nor warned about (2.3 GB, 60 s before the
    // first row).
    let dir = tempfile::tempdir().unwrap();
    let values = |scale: f64| {
        (0..1000)
            .map(|k| format!("{}", scale * (1.0 + k as f64 / 1000.0)))
            .collect::<Vec<_>>()
            .join(", ")
    };
    std::fs::write(
        dir.path().join("big.toml"),
        format!(
            "base = \"fast\"\nseeds = 2\n[[axis]]\nname = \"d\"\nfield = \"camera.distance_m\"\n\
             values = [{}]\n[[axis]]\nname = \"fps\"\nfield = \"frame_timing.fps\"\nvalues = [{}]\n",
            values(0.3),
            values(30.0)
        ),
    )
    .unwrap();
    let started = std::time::Instant::now();
    let o = geneva(dir.path(), &["sweep", "big.toml", "--out", "sw"]);
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(e.contains("2000000 runs") && e.contains("--yes"), "{e}");
    // Hang guard, not a speed check: building the grid takes minutes and gigabytes.
    assert!(
        started.elapsed().as_secs() < HANG_GUARD_S,
        "hang guard: {:?}",
        started.elapsed()
    );
    assert!(!dir.path().join("sw/results.csv").exists());
}

#[test]
fn a_reader_that_goes_away_ends_the_process_quietly() {
    // Regression: `geneva … | head` exited 101 with "failed printing to stdout: Broken
    // pipe" once `head` had closed the pipe. The read end is closed before the child writes.
    use std::process::{Command, Stdio};
    let dir = tempfile::tempdir().unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_geneva"))
        .args(["scenario", "show", "seed-internal-4k"])
        .current_dir(dir.path())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let o = child.wait_with_output().unwrap();
    let e = stderr(&o);
    assert!(!e.contains("panicked") && !e.contains("Broken pipe"), "{e}");
    assert_ne!(o.status.code(), Some(101), "{e}");
}

#[test]
fn a_failed_estimation_keeps_the_detections_it_names() {
    // Regression: the error named tracks in a staging folder that had just been removed.
    let dir = tempfile::tempdir().unwrap();
    let o = geneva(
        dir.path(),
        &["render", "fast", "--frames", "0..2", "--out", "fr"],
    );
    assert!(o.status.success(), "{}", stderr(&o));
    let o = geneva(
        dir.path(),
        &[
            "analyze",
            "--frames",
            "fr",
            "--timestamps",
            "fr/timestamps.csv",
            "--out",
            "an",
        ],
    );
    let e = stderr(&o);
    assert_eq!(o.status.code(), Some(1), "{e}");
    assert!(
        e.contains("too few detected frames") && e.contains("an/tracks.csv"),
        "{e}"
    );
    assert!(!e.contains(".partial") && repeated(&e).is_empty(), "{e}");
    let tracks = std::fs::read_to_string(dir.path().join("an/tracks.csv")).unwrap();
    assert_eq!(tracks.lines().count(), 3, "{tracks}");
}

#[test]
fn a_self_check_report_so_far_names_what_is_missing_and_writes_nothing() {
    // No run started in `run`, and a report so far into the run's own folder: both refused,
    // naming the folder, before any work, and nothing is created.
    let dir = tempfile::tempdir().unwrap();
    let args = |into: &str| {
        [
            "diagnose-selfcheck",
            "--quick",
            "--out",
            "run",
            "--report-so-far",
            into,
        ]
        .map(String::from)
    };
    let o = geneva(dir.path(), &args("so-far").each_ref().map(String::as_str));
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(
        e.contains("run: no run of this study has started there"),
        "{e}"
    );
    assert!(repeated(&e).is_empty(), "{e}");
    let o = geneva(dir.path(), &args("run").each_ref().map(String::as_str));
    assert!(!o.status.success());
    let e = stderr(&o);
    assert!(e.contains("apart from the run's own"), "{e}");
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().flatten().collect();
    assert!(left.is_empty(), "{left:?}");
}
