//! Tests of all-or-nothing output folders: commit, replacement, failures before the commit,
//! foreign folders, locks, and the recovery of an interrupted swap.

use super::*;

fn write(dir: &Path, name: &str, text: &str) {
    let p = dir.join(name);
    std::fs::create_dir_all(p.parent().unwrap()).unwrap();
    std::fs::write(p, text).unwrap();
}

fn read(dir: &Path, name: &str) -> String {
    std::fs::read_to_string(dir.join(name)).unwrap()
}

fn entries(parent: &Path) -> Vec<String> {
    let mut v: Vec<String> = std::fs::read_dir(parent)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    v.sort();
    v
}

#[test]
fn a_commit_puts_every_file_in_place_with_a_marker_and_leaves_no_staging() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("out");
    let out = OutputDir::create(&dir).unwrap();
    assert!(!dir.exists(), "nothing final before the commit");
    write(out.path(), "a.csv", "1\n");
    write(out.path(), "sub/b.png", "png");
    let files = out.commit().unwrap();
    assert_eq!(files, vec![dir.join("a.csv"), dir.join("sub/b.png")]);
    assert_eq!(read(&dir, "a.csv"), "1\n");
    assert_eq!(
        read(&dir, MARKER),
        format!("{MARKER_HEADER}a.csv\nsub/b.png\n")
    );
    assert_eq!(
        entries(root.path()),
        vec!["out"],
        "no staging or lock left beside"
    );
}

#[test]
fn a_new_output_replaces_the_old_one_whole() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("out");
    let out = OutputDir::create(&dir).unwrap();
    write(out.path(), "a.csv", "old\n");
    write(out.path(), "only_old.png", "x");
    out.commit().unwrap();
    let out = OutputDir::create(&dir).unwrap();
    write(out.path(), "a.csv", "new\n");
    out.commit().unwrap();
    assert_eq!(read(&dir, "a.csv"), "new\n");
    assert!(!dir.join("only_old.png").exists(), "no mix of generations");
    assert_eq!(entries(root.path()), vec!["out"]);
}

#[test]
fn a_failure_before_the_commit_keeps_the_previous_results_untouched() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("out");
    let out = OutputDir::create(&dir).unwrap();
    write(out.path(), "a.csv", "good\n");
    write(out.path(), "b.json", "{}\n");
    out.commit().unwrap();
    {
        // A run that writes half of its files and then fails (full disk, bad input, panic).
        let out = OutputDir::create(&dir).unwrap();
        write(out.path(), "a.csv", "half");
    }
    assert_eq!(read(&dir, "a.csv"), "good\n");
    assert_eq!(read(&dir, "b.json"), "{}\n");
    assert_eq!(
        entries(root.path()),
        vec!["out"],
        "the half staging is removed"
    );
    // A killed run leaves its staging folder; the next run discards it.
    let stale = sibling(&dir, "partial").unwrap();
    write(&stale, "a.csv", "killed");
    let out = OutputDir::create(&dir).unwrap();
    assert!(entries(out.path()).is_empty());
}

#[test]
fn a_folder_of_other_files_is_refused_before_any_work() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("mine");
    write(&dir, "notes.txt", "keep me");
    let e = OutputDir::create(&dir).unwrap_err();
    assert!(
        matches!(&e, OutputError::Foreign { files, .. } if files == &["notes.txt"]),
        "{e}"
    );
    assert!(e.to_string().contains("notes.txt"), "{e}");
    assert_eq!(read(&dir, "notes.txt"), "keep me");
    // Empty folders are fine; a committed folder with a file added by hand is refused at commit.
    let empty = root.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    OutputDir::create(&empty).unwrap().commit().unwrap();
    write(&empty, "added.txt", "x");
    assert!(OutputDir::create(&empty).is_err());
    assert!(matches!(
        OutputDir::create(Path::new("/")),
        Err(OutputError::NoName { .. })
    ));
}

#[test]
fn a_carried_folder_survives_the_swap() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("out");
    write(&dir, "shards/0/units.tsv", "0\tx\n");
    let out = OutputDir::create_carrying(&dir, &["shards"]).unwrap();
    write(out.path(), "results.csv", "r\n");
    out.commit().unwrap();
    assert_eq!(read(&dir, "shards/0/units.tsv"), "0\tx\n");
    assert!(read(&dir, MARKER).contains("shards/0/units.tsv"));
}

#[test]
fn locks_keep_writers_apart_and_die_with_their_holder() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("out");
    let first = OutputDir::create(&dir).unwrap();
    let e = OutputDir::create(&dir).unwrap_err();
    assert!(matches!(e, OutputError::Busy { .. }), "{e}");
    assert!(
        e.to_string()
            .contains(&format!("pid {}", std::process::id())),
        "{e}"
    );
    assert!(
        DirLock::of_dir(&dir, false).is_err(),
        "a shard cannot start during a commit"
    );
    drop(first);
    // Shards share the folder; a whole-folder writer waits for all of them.
    let a = DirLock::of_dir(&dir, false).unwrap();
    let b = DirLock::of_dir(&dir, false).unwrap();
    assert!(OutputDir::create(&dir).is_err());
    drop((a, b));
    OutputDir::create(&dir).unwrap();
}

#[test]
fn resume_keeps_the_staging_folder_across_runs() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("out");
    {
        let out = OutputDir::resume(&dir).unwrap();
        write(out.path(), "units.log", "0\ta\n");
    }
    let mut out = OutputDir::resume(&dir).unwrap();
    assert_eq!(read(out.path(), "units.log"), "0\ta\n");
    out.restart().unwrap();
    assert!(entries(out.path()).is_empty());
}

#[test]
fn an_interrupted_two_rename_swap_is_finished_by_the_next_run() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("out");
    let staging = sibling(&dir, "partial").unwrap();
    let old = sibling(&dir, "old").unwrap();
    // Killed after `DIR → old` with a complete staging folder: the new output wins.
    write(&old, "a.csv", "old\n");
    write(&old, MARKER, "a.csv\n");
    write(&staging, "a.csv", "new\n");
    write(&staging, MARKER, "a.csv\n");
    drop(OutputDir::resume(&dir).unwrap());
    assert_eq!(read(&dir, "a.csv"), "new\n");
    assert!(!old.exists());
    // Killed after `DIR → old` while staging was incomplete: the old output comes back.
    std::fs::rename(&dir, &old).unwrap();
    write(&staging, "a.csv", "half");
    drop(OutputDir::create(&dir).unwrap());
    assert_eq!(read(&dir, "a.csv"), "new\n");
    assert!(!old.exists() && !staging.exists());
}

#[test]
fn write_file_atomic_replaces_whole_files() {
    let root = tempfile::tempdir().unwrap();
    let p = root.path().join("m.json");
    write_file_atomic(&p, b"one").unwrap();
    write_file_atomic(&p, b"two").unwrap();
    assert_eq!(read(root.path(), "m.json"), "two");
    assert_eq!(entries(root.path()), vec!["m.json"]);
}

#[test]
fn an_input_inside_the_folder_or_its_staging_folder_is_refused_by_name() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("out");
    write(&dir, "tracks.csv", "x");
    write(root.path(), "elsewhere/s.toml", "x");
    let inside = |what: &str, p: &Path| {
        let e = refuse_inputs_inside(
            &dir,
            &[
                Input::new("--other", root.path().join("elsewhere/s.toml")),
                Input::new(what, p),
            ],
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains(what) && e.contains(&p.display().to_string()),
            "{e}"
        );
        e
    };
    // The folder's own file, the folder itself, a path through `..`, one not there yet.
    inside("--tracks", &dir.join("tracks.csv"));
    inside("--frames", &dir);
    inside(
        "--scenario",
        &root.path().join("elsewhere/../out/scenario.toml"),
    );
    inside("--timestamps", &dir.join("sub/none.csv"));
    // The staging folder and the swapped-out old folder beside it.
    let e = inside("--video", &root.path().join(".out.partial/v.mp4"));
    assert!(e.contains("staging"), "{e}");
    inside("--image", &root.path().join(".out.old/i.png"));
    // A link that leads into the folder, and an output folder named through a link.
    std::os::unix::fs::symlink(dir.join("tracks.csv"), root.path().join("link.csv")).unwrap();
    inside("--tracks", &root.path().join("link.csv"));
    std::os::unix::fs::symlink(&dir, root.path().join("alias")).unwrap();
    let e = refuse_inputs_inside(
        &root.path().join("alias"),
        &[Input::new("--tracks", dir.join("tracks.csv"))],
    )
    .unwrap_err();
    assert!(e.to_string().contains("--tracks"), "{e}");
    // Inputs beside the folder, or a folder that holds the output, pass.
    refuse_inputs_inside(
        &dir,
        &[
            Input::new("a", root.path().join("elsewhere/s.toml")),
            Input::new("b", root.path().join("out2/tracks.csv")),
            Input::new("c", root.path().join("outside.csv")),
            Input::new("d", root.path()),
        ],
    )
    .unwrap();
    assert_eq!(read(&dir, "tracks.csv"), "x");
}
