//! All-or-nothing outputs through the real binary: a Monte Carlo killed mid-way leaves the
//! previous results untouched, keeps its finished seeds, resumes without redoing them, and ends
//! with the bytes of an uninterrupted run; a folder of the user's own files is never replaced.

#![cfg(feature = "opencv-detector")]

use std::path::Path;
use std::process::Command;
use std::time::{Duration, Instant};

fn geneva() -> Command {
    Command::new(env!("CARGO_BIN_EXE_geneva"))
}

fn ok(cmd: &mut Command) -> String {
    let out = cmd.output().expect("geneva runs");
    let text = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(
        out.status.success(),
        "{cmd:?}: {text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    text
}

fn files(dir: &Path) -> Vec<(String, Vec<u8>)> {
    [
        "budget.json",
        "per_seed.csv",
        "error_histograms.png",
        "seed0/tracks.csv",
    ]
    .iter()
    .map(|f| (f.to_string(), std::fs::read(dir.join(f)).unwrap()))
    .collect()
}

#[test]
fn a_killed_montecarlo_keeps_the_old_results_and_its_finished_seeds_and_resumes() {
    let root = tempfile::tempdir().unwrap();
    let reference = root.path().join("reference");
    ok(geneva()
        .args(["montecarlo", "fast", "--seeds", "4", "--out"])
        .arg(&reference)
        .env("RAYON_NUM_THREADS", "1"));
    // Previous good results of a 2-seed study in the folder the killed run targets.
    let dir = root.path().join("mc");
    ok(geneva()
        .args(["montecarlo", "fast", "--seeds", "2", "--out"])
        .arg(&dir));
    let before = files(&dir);
    let log = root.path().join(".mc.partial/units.log");
    let mut child = geneva()
        .args(["montecarlo", "fast", "--seeds", "4", "--restart", "--out"])
        .arg(&dir)
        .env("RAYON_NUM_THREADS", "1")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .unwrap();
    // Hang guard, not a speed check: a seed of `fast` takes about a second.
    let deadline = Instant::now() + Duration::from_secs(600);
    // Complete record lines only (not the log's header): a record being written when we look
    // (or when the kill lands) is a line without its end, which the resumed run rightly does
    // again (`shard::log`).
    let seeds_done = || {
        std::fs::read_to_string(&log)
            .map(|t| {
                t.split_inclusive('\n')
                    .filter(|l| l.ends_with('\n') && !l.starts_with('#'))
                    .count()
            })
            .unwrap_or(0)
    };
    while seeds_done() < 1 {
        assert!(
            Instant::now() < deadline,
            "hang guard: no seed finished in 600 s"
        );
        assert!(
            child.try_wait().unwrap().is_none(),
            "finished before the kill"
        );
        std::thread::sleep(Duration::from_millis(20));
    }
    child.kill().unwrap(); // SIGKILL: no clean-up of any kind
    child.wait().unwrap();
    let kept = seeds_done();
    assert!((1..4).contains(&kept), "{kept} seeds logged");
    assert_eq!(files(&dir), before, "the previous results are untouched");
    // The resumed run does only the missing seeds and gives the uninterrupted run's bytes.
    let text = ok(geneva()
        .args(["montecarlo", "fast", "--seeds", "4", "--restart", "--out"])
        .arg(&dir)
        .env("RAYON_NUM_THREADS", "2"));
    assert!(
        text.contains(&format!(
            "{kept} already done (resumed), {} run now",
            4 - kept
        )),
        "{text}"
    );
    assert_eq!(files(&dir), files(&reference));
    assert!(!log.exists(), "no staging left once committed");
}

#[test]
fn a_folder_of_the_users_files_is_refused_and_left_alone() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("mine");
    std::fs::create_dir(&dir).unwrap();
    std::fs::write(dir.join("thesis.tex"), "keep").unwrap();
    let out = geneva()
        .args(["run", "fast", "--out"])
        .arg(&dir)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("thesis.tex") && err.contains("did not write"),
        "{err}"
    );
    let names: Vec<_> = std::fs::read_dir(&dir)
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(names, vec!["thesis.tex"]);
}

#[test]
fn a_video_asked_inside_the_output_folder_ends_up_in_it() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("render");
    for _ in 0..2 {
        ok(geneva()
            .args(["render", "fast", "--frames", "0..3", "--out"])
            .arg(&dir)
            .arg("--video")
            .arg(dir.join("v.mp4")));
        assert!(std::fs::metadata(dir.join("v.mp4")).unwrap().len() > 0);
        assert!(dir.join("timestamps.csv").exists());
    }
}
