//! The input options shared by the commands that measure real data (`src/cli/source_args.rs`,
//! `src/cli/effects_arg.rs`): exactly one of `--video`, `--frames` with `--timestamps`, or the
//! command's own third input (`--tracks` for analyze and diagnose, `--image` for calibrate), and
//! `--effects` names checked against the vocabulary. Every case fails before any work.
#![cfg(feature = "opencv-detector")]

mod common;
use common::{geneva, stderr};

/// The commands with their own arguments (besides the source) and their third input.
const COMMANDS: [(&[&str], &str); 3] = [
    (&["analyze"], "--tracks"),
    (&["diagnose", "--scenario", "fast"], "--tracks"),
    (&["calibrate", "--base", "fast"], "--image"),
];

fn with(command: &[&str], extra: &[&str]) -> Vec<String> {
    command
        .iter()
        .chain(extra)
        .chain(&["--out", "out"])
        .map(|s| s.to_string())
        .collect()
}

fn fails_with(dir: &std::path::Path, args: &[String], wanted: &[&str]) {
    let a: Vec<&str> = args.iter().map(String::as_str).collect();
    let o = geneva(dir, &a);
    let e = stderr(&o);
    assert!(!o.status.success(), "{a:?} succeeded");
    for w in wanted {
        assert!(e.contains(w), "{a:?}: `{w}` not in: {e}");
    }
    assert!(!dir.join("out").exists(), "{a:?} wrote its output folder");
}

#[test]
fn exactly_one_source_is_required() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    for (command, third) in COMMANDS {
        // None at all: the command names its three choices.
        fails_with(
            d,
            &with(command, &[]),
            &[&format!(
                "give exactly one of --video, --frames (with --timestamps) or {third}"
            )],
        );
        // Two at once: refused by the argument parser, naming both.
        fails_with(
            d,
            &with(command, &["--video", "a.mp4", third, "b"]),
            &["--video", third, "cannot be used with"],
        );
        fails_with(
            d,
            &with(
                command,
                &["--frames", "f", "--timestamps", "t.csv", third, "b"],
            ),
            &["--frames", third, "cannot be used with"],
        );
        fails_with(
            d,
            &with(
                command,
                &["--video", "a.mp4", "--frames", "f", "--timestamps", "t.csv"],
            ),
            &["--video", "--frames", "cannot be used with"],
        );
        // Frames without their timestamps.
        fails_with(d, &with(command, &["--frames", "f"]), &["--timestamps"]);
    }
}

#[test]
fn effects_must_be_names_of_the_vocabulary() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let wanted = [
        "--effects: `backlashes` is not an effect; the vocabulary is:",
        "rolling_shutter",
    ];
    fails_with(
        d,
        &with(
            &["diagnose", "--scenario", "fast"],
            &["--tracks", "t.csv", "--effects", "pixel_noise,backlashes"],
        ),
        &wanted,
    );
    fails_with(
        d,
        &with(
            &["diagnose-selfcheck"],
            &["--quick", "--effects", "backlashes"],
        ),
        &wanted,
    );
}

#[test]
fn selfcheck_only_must_name_cases_of_its_plan() {
    // `--only` re-runs cases on their own footage; a misspelt name must not silently run
    // nothing (or everything): it is refused before any work, and the plan's cases are listed.
    let dir = tempfile::tempdir().unwrap();
    fails_with(
        dir.path(),
        &with(
            &["diagnose-selfcheck"],
            &[
                "--quick",
                "--only",
                "null-0,withheld-nothing-strong-0",
                "--yes",
            ],
        ),
        &[
            "--only withheld-nothing-strong-0: no such case in this plan",
            "its cases: ",
            "null-0",
        ],
    );
}

#[test]
fn selfcheck_base_must_be_a_scenario_and_its_duration_a_length() {
    // `--base` runs the self-check on the user's rig; a rig that cannot be read, or a length
    // that is none, is refused before any work, naming it.
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    fails_with(
        d,
        &with(
            &["diagnose-selfcheck"],
            &["--quick", "--base", "no-such-rig.toml", "--yes"],
        ),
        &["base scenario `no-such-rig.toml`"],
    );
    std::fs::write(
        d.join("rig.toml"),
        "extend = \"fast\"\nduration_s = 3.0\nfps = 30\n",
    )
    .unwrap();
    fails_with(
        d,
        &with(
            &["diagnose-selfcheck"],
            &["--quick", "--base", "rig.toml", "--yes"],
        ),
        &["base scenario `rig.toml`", "fps"],
    );
    fails_with(
        d,
        &with(
            &["diagnose-selfcheck"],
            &["--quick", "--base", "fast", "--duration-s", "0", "--yes"],
        ),
        &["duration 0 s"],
    );
}
