//! Tests of the work-unit layer with a toy study: shards + merge equal the whole run byte for
//! byte, resumes repeat nothing, changed inputs and missing units are refused by name.

use super::study::seal;
use super::*;
use serde_json::json;
use std::collections::BTreeMap;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};

/// Unit u's record is a function of u and the input `k`; unit 0 also writes a file.
struct Toy {
    manifest: Manifest,
    k: u64,
    calls: AtomicUsize,
}

impl Toy {
    fn new(units: usize, k: u64) -> Self {
        let mut inputs = BTreeMap::new();
        inputs.insert("toy input".to_string(), json!({ "k": k }));
        Self {
            manifest: Manifest::new("toy", units, inputs),
            k,
            calls: AtomicUsize::new(0),
        }
    }
    fn calls(&self) -> usize {
        self.calls.load(Ordering::SeqCst)
    }
}

impl Study for Toy {
    type Error = ShardError;
    fn manifest(&self) -> &Manifest {
        &self.manifest
    }
    fn run_unit(&self, unit: usize, work_dir: &Path) -> Result<String, ShardError> {
        self.calls.fetch_add(1, Ordering::SeqCst);
        if unit == 0 {
            std::fs::write(work_dir.join("unit0.txt"), "extra").unwrap();
        }
        // Tabs, newlines and backslashes survive the log.
        Ok(format!(
            "unit {unit}\tk={}\nsquare \\ {}",
            self.k,
            unit * unit
        ))
    }
    fn finalize(&self, records: &[String], dirs: UnitDirs, out: &Path) -> Result<(), ShardError> {
        std::fs::write(out.join("out.txt"), records.join("|")).unwrap();
        // On one machine the unit's folder is the output folder itself.
        if dirs(0) != out {
            std::fs::copy(dirs(0).join("unit0.txt"), out.join("unit0.txt")).unwrap();
        }
        Ok(())
    }
    fn unit_name(&self, unit: usize) -> String {
        format!("toy unit {unit}")
    }
    fn required_files(&self, unit: usize) -> Vec<String> {
        match unit {
            0 => vec!["unit0.txt".into()],
            _ => Vec::new(),
        }
    }
}

/// `run` on one thread with a control that stops it once `toy` has run `calls` units in all
/// (on one thread, exactly that many).
fn on_one_thread_until<R: Send>(
    toy: &Toy,
    calls: usize,
    run: impl FnOnce(&Control) -> R + Send,
) -> Result<R, TestError> {
    let stop = || toy.calls() >= calls;
    let c = Control {
        progress: &|_, _| {},
        stop: &stop,
    };
    Ok(rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()?
        .install(|| run(&c)))
}

type TestError = Box<dyn std::error::Error>;

/// Shard 0 of `count` run to its end, then shard 1 stopped once `toy` has run `calls` units.
fn first_shard_then_second_until(
    toy: &Toy,
    dir: &Path,
    count: usize,
    calls: usize,
) -> Result<(), TestError> {
    run_shard(toy, dir, Shard::new(0, count)?, false, &Control::none())?;
    let second = Shard::new(1, count)?;
    on_one_thread_until(toy, calls, |c| run_shard(toy, dir, second, false, c))??;
    Ok(())
}

fn read(dir: &Path, f: &str) -> Vec<u8> {
    std::fs::read(dir.join(f)).unwrap_or_else(|e| panic!("{}: {e}", dir.join(f).display()))
}

#[test]
fn shards_parse_and_split_the_units_round_robin() {
    assert_eq!(Shard::parse("2/4").unwrap(), Shard { index: 2, count: 4 });
    for bad in ["4/4", "1", "a/2", "0/0", "-1/3"] {
        assert!(Shard::parse(bad).is_err(), "{bad}");
    }
    let all: Vec<Vec<usize>> = (0..3).map(|i| Shard::new(i, 3).unwrap().units(8)).collect();
    assert_eq!(all, vec![vec![0, 3, 6], vec![1, 4, 7], vec![2, 5]]);
}

#[test]
fn log_records_survive_escaping_and_a_cut_line() {
    for s in ["", "a\tb", "x\ny\r\n", "back\\slash\\n", "ü\\"] {
        assert_eq!(log::round_trip(s), s);
    }
    let dir = tempfile::tempdir().unwrap();
    let p = dir.path().join("units.log");
    let (mut log, done) = UnitLog::open(&p, 5).unwrap();
    assert!(done.is_empty());
    log.append(3, "three\nlines\t!").unwrap();
    log.append(1, "one").unwrap();
    drop(log);
    let mut text = std::fs::read_to_string(&p).unwrap();
    text.push_str("4\tcut mid-rec");
    std::fs::write(&p, &text).unwrap();
    let (_, done) = UnitLog::open(&p, 5).unwrap();
    assert_eq!(done.keys().copied().collect::<Vec<_>>(), vec![1, 3]);
    assert_eq!(done[&3], "three\nlines\t!");
    assert!(!std::fs::read_to_string(&p).unwrap().contains("cut"));
    std::fs::write(&p, "1\ta\n1\tb\n").unwrap();
    let e = UnitLog::open(&p, 5).err().unwrap();
    assert!(
        e.to_string().contains("line 2: unit 1 appears twice"),
        "{e}"
    );
}

#[test]
fn merged_shards_equal_the_whole_run_byte_for_byte_and_merging_is_idempotent() {
    let root = tempfile::tempdir().unwrap();
    let whole = root.path().join("whole");
    let toy = Toy::new(10, 7);
    let r = run_whole(&toy, &whole, false, &Control::none()).unwrap();
    assert!(r.complete && r.units_run == 10);
    for n in [1usize, 3, 4] {
        let dir = root.path().join(format!("sharded{n}"));
        let toy = Toy::new(10, 7);
        for i in (0..n).rev() {
            let r = run_shard(
                &toy,
                &dir,
                Shard::new(i, n).unwrap(),
                false,
                &Control::none(),
            )
            .unwrap();
            assert!(r.complete);
        }
        assert_eq!(toy.calls(), 10, "every unit once over all shards");
        assert!(!dir.join("out.txt").exists(), "shards write nothing final");
        merge(&toy, &dir).unwrap();
        for f in ["out.txt", "unit0.txt", MANIFEST] {
            assert_eq!(read(&dir, f), read(&whole, f), "{n} shards: {f}");
        }
        let first = read(&dir, "out.txt");
        merge(&toy, &dir).unwrap();
        assert_eq!(read(&dir, "out.txt"), first, "merge is idempotent");
        assert!(dir.join("shards/0").join(RECORDS).exists(), "shards kept");
    }
}

#[test]
fn a_missing_shard_names_the_missing_units_and_writes_nothing() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("d");
    let toy = Toy::new(10, 1);
    // Shard 1 stops after one unit; shard 2 never starts.
    first_shard_then_second_until(&toy, &dir, 3, 5).unwrap();
    let e = merge(&toy, &dir).unwrap_err();
    let msg = e.to_string();
    assert!(
        matches!(&e, ShardError::Missing { missing, .. } if missing.len() == 6),
        "{msg}"
    );
    for want in [
        "toy unit 4",
        "toy unit 2",
        "toy unit 8",
        "shard 1/3 unfinished, 1 of 3",
        "shard 2/3 not started",
        "nothing was written",
    ] {
        assert!(msg.contains(want), "`{want}` missing in: {msg}");
    }
    assert!(!dir.join("out.txt").exists() && !dir.join(MANIFEST).exists());
}

#[test]
fn an_interrupted_shard_resumes_without_repeating_a_unit() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("d");
    let shard = Shard::new(1, 2).unwrap();
    let first = Toy::new(11, 3);
    let stop = || first.calls() >= 2;
    let c = Control {
        progress: &|_, _| {},
        stop: &stop,
    };
    let r = rayon::ThreadPoolBuilder::new()
        .num_threads(1)
        .build()
        .unwrap()
        .install(|| run_shard(&first, &dir, shard, false, &c).unwrap());
    assert!(!r.complete && r.units_run == 2);
    let second = Toy::new(11, 3);
    let r = run_shard(&second, &dir, shard, false, &Control::none()).unwrap();
    assert!(r.complete);
    assert_eq!((r.units_resumed, r.units_run, second.calls()), (2, 3, 3));
    let again = run_shard(&second, &dir, shard, false, &Control::none()).unwrap();
    assert!(again.already_complete && second.calls() == 3);
}

#[test]
fn changed_inputs_are_refused_naming_the_change_unless_restarted() {
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("d");
    let stop = || true;
    let c = Control {
        progress: &|_, _| {},
        stop: &stop,
    };
    run_whole(&Toy::new(4, 1), &dir, false, &c).unwrap();
    let e = run_whole(&Toy::new(4, 2), &dir, false, &Control::none()).unwrap_err();
    let msg = e.to_string();
    assert!(
        msg.contains("toy input: `k` 1 → 2") && msg.contains("--restart"),
        "{msg}"
    );
    let e = run_whole(&Toy::new(5, 1), &dir, false, &Control::none()).unwrap_err();
    assert!(e.to_string().contains("work units: 4 → 5"), "{e}");
    let r = run_whole(&Toy::new(4, 2), &dir, true, &Control::none()).unwrap();
    assert!(r.complete && r.units_run == 4);
    // A complete folder of other inputs is refused too; the same inputs leave it untouched.
    assert!(run_whole(&Toy::new(4, 1), &dir, false, &Control::none()).is_err());
    let same = Toy::new(4, 2);
    assert!(
        run_whole(&same, &dir, false, &Control::none())
            .unwrap()
            .already_complete
    );
    assert_eq!(same.calls(), 0);
    // Shards of other inputs are refused at the merge.
    run_shard(&Toy::new(4, 9), &dir, Shard::WHOLE, false, &Control::none()).unwrap();
    let e = merge(&Toy::new(4, 2), &dir).unwrap_err();
    assert!(e.to_string().contains("`k` 9 → 2"), "{e}");
}

#[test]
fn progress_reads_a_run_without_touching_it_and_knows_a_complete_one() -> Result<(), TestError> {
    let root = tempfile::tempdir()?;
    let dir = root.path().join("d");
    let toy = Toy::new(5, 1);
    assert!(matches!(
        progress(&toy, &dir),
        Err(ShardError::NoRun { .. })
    ));
    on_one_thread_until(&toy, 2, |c| run_whole(&toy, &dir, false, c))??;
    let log = crate::io::output_dir::sibling(&dir, "partial")?.join(LOG);
    let before = std::fs::read(&log)?;
    let Progress::Running(records) = progress(&toy, &dir)? else {
        panic!("a run in progress")
    };
    assert_eq!(records.len(), 2);
    for (u, r) in &records {
        assert_eq!(*r, toy.run_unit(*u, root.path())?);
    }
    assert_eq!(std::fs::read(&log)?, before);
    let e = progress(&Toy::new(5, 2), &dir)
        .map(|_| ())
        .map_err(|e| e.to_string());
    assert!(
        e.as_ref()
            .is_err_and(|e| e.contains("`k` 1 → 2") && !e.contains("--restart")),
        "{e:?}"
    );
    run_whole(&toy, &dir, false, &Control::none())?;
    assert_eq!(progress(&toy, &dir)?, Progress::Complete);
    // That folder, complete, asked about for other inputs: what differs is named.
    let e = progress(&Toy::new(5, 4), &dir)
        .map(|_| ())
        .map_err(|e| e.to_string());
    assert!(e.as_ref().is_err_and(|e| e.contains("`k` 1 → 4")), "{e:?}");

    // A sharded run: shard 0 of 2 complete, shard 1 stopped after one unit; both counted.
    let sharded = root.path().join("s");
    let toy = Toy::new(5, 1);
    first_shard_then_second_until(&toy, &sharded, 2, 4)?;
    let Progress::Running(records) = progress(&toy, &sharded)? else {
        panic!("a sharded run in progress")
    };
    assert_eq!(records.keys().copied().collect::<Vec<_>>(), [0, 1, 2, 4]);
    let e = progress(&Toy::new(5, 3), &sharded)
        .map(|_| ())
        .map_err(|e| e.to_string());
    assert!(e.as_ref().is_err_and(|e| e.contains("`k` 1 → 3")), "{e:?}");
    Ok(())
}

/// Two complete shards of a toy study of 6 units in `root/d`.
fn two_shards(root: &Path) -> (Toy, std::path::PathBuf) {
    let dir = root.join("d");
    let toy = Toy::new(6, 5);
    for i in 0..2 {
        run_shard(
            &toy,
            &dir,
            Shard::new(i, 2).unwrap(),
            false,
            &Control::none(),
        )
        .unwrap();
    }
    (toy, dir)
}

fn merge_error(toy: &Toy, dir: &Path) -> String {
    let e = merge(toy, dir).unwrap_err().to_string();
    assert!(!dir.join("out.txt").exists(), "written despite: {e}");
    e
}

#[test]
fn a_merge_refuses_records_edited_moved_or_lost_naming_them() {
    // A unit of shard 0 recorded with another value in shard 1's units.tsv was merged and
    // changed the outputs; a shard that lost a unit's file merged without it; edited numbers
    // merged unnoticed.
    let root = tempfile::tempdir().unwrap();
    // A record edited in place.
    let (toy, dir) = two_shards(root.path());
    let tsv = dir.join("shards/1").join(RECORDS);
    let text = std::fs::read_to_string(&tsv).unwrap();
    std::fs::write(&tsv, text.replace("square \\\\ 9", "square \\\\ 8")).unwrap();
    assert_ne!(std::fs::read_to_string(&tsv).unwrap(), text);
    let e = merge_error(&toy, &dir);
    assert!(
        e.contains("units.tsv") && e.contains("changed after"),
        "{e}"
    );
    // The same edit with the shard's digests taken again: the record's own digest refuses it.
    seal(&dir.join("shards/1"), Shard::new(1, 2).unwrap()).unwrap();
    let e = merge_error(&toy, &dir);
    assert!(
        e.contains("line") && e.contains("unit 3") && e.contains("digest"),
        "{e}"
    );
    // Shard 0's unit 2 copied, with another value and a digest of its own, into shard 1.
    let (toy, dir) = two_shards(&root.path().join("moved"));
    let other = BTreeMap::from([
        (1, "x".to_string()),
        (2, "forged".to_string()),
        (3, "y".to_string()),
        (5, "z".to_string()),
    ]);
    log::write_records(&dir.join("shards/1").join(RECORDS), &other).unwrap();
    seal(&dir.join("shards/1"), Shard::new(1, 2).unwrap()).unwrap();
    let e = merge_error(&toy, &dir);
    assert!(e.contains("toy unit 2") && e.contains("shard 0/2"), "{e}");
    // A unit's file lost, with and without the digests taken again.
    let (toy, dir) = two_shards(&root.path().join("lost"));
    std::fs::remove_file(dir.join("shards/0/unit0.txt")).unwrap();
    let e = merge_error(&toy, &dir);
    assert!(e.contains("unit0.txt") && e.contains("missing"), "{e}");
    seal(&dir.join("shards/0"), Shard::new(0, 2).unwrap()).unwrap();
    let e = merge_error(&toy, &dir);
    assert!(e.contains("unit0.txt") && e.contains("toy unit 0"), "{e}");
    // A file added to a shard, and a shard written before shards carried digests.
    let (toy, dir) = two_shards(&root.path().join("added"));
    std::fs::write(dir.join("shards/1/extra.txt"), "x").unwrap();
    let e = merge_error(&toy, &dir);
    assert!(
        e.contains("extra.txt") && e.contains("not part of the shard"),
        "{e}"
    );
    let (toy, dir) = two_shards(&root.path().join("old"));
    std::fs::write(
        dir.join("shards/0").join(SHARD_INFO),
        "{\"index\":0,\"count\":2}\n",
    )
    .unwrap();
    let e = merge_error(&toy, &dir);
    assert!(e.contains("no digests") && e.contains("--restart"), "{e}");
    // Untouched, the same shards merge.
    let (toy, dir) = two_shards(&root.path().join("clean"));
    merge(&toy, &dir).unwrap();
}

#[test]
fn a_log_line_edited_is_refused_by_name_and_an_older_log_is_read_as_it_is() {
    let root = tempfile::tempdir().unwrap();
    let p = root.path().join("units.log");
    let (mut log, _) = UnitLog::open(&p, 5).unwrap();
    log.append(1, "one").unwrap();
    log.append(2, "two").unwrap();
    drop(log);
    let text = std::fs::read_to_string(&p).unwrap();
    assert!(text.starts_with(log::HEADER), "{text}");
    std::fs::write(&p, text.replace("two", "tw0")).unwrap();
    let e = UnitLog::open(&p, 5).err().unwrap().to_string();
    assert!(
        e.contains("units.log: line 3: unit 2") && e.contains("digest"),
        "{e}"
    );
    // A line whose digest was cut off (the separating tab lost).
    std::fs::write(&p, text.replacen("\tfnv1a64", "fnv1a64", 1)).unwrap();
    assert!(UnitLog::open(&p, 5).is_err());
    // A log of the older format: read as it is, then rewritten with digests.
    std::fs::write(&p, "1\tone\n3\tthree\n").unwrap();
    let (mut log, done) = UnitLog::open(&p, 5).unwrap();
    assert_eq!(done.len(), 2);
    log.append(4, "four").unwrap();
    drop(log);
    let (_, done) = UnitLog::open(&p, 5).unwrap();
    assert_eq!(
        done.values().cloned().collect::<Vec<_>>(),
        ["one", "three", "four"]
    );
    assert!(std::fs::read_to_string(&p)
        .unwrap()
        .starts_with(log::HEADER));
}
