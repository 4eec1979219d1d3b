//! Tests of the sweep: spec parsing and validation, grid and overrides, the engine (complete,
//! deterministic across thread counts, resumable), and the recommendation.

use super::engine::{merge_sweep, sweep_file_of};
use super::*;
use crate::estimate::Differentiator;
use std::collections::HashSet;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicUsize, Ordering};

fn sweeps_dir() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("scenarios/sweeps")
}

fn fast_spec() -> (SweepSpec, PathBuf) {
    let path = sweeps_dir().join("fast.toml");
    (SweepSpec::load(&path).unwrap(), path)
}

/// Deterministic function of the scenario and the seed; counts its calls.
struct Fake {
    calls: AtomicUsize,
}

impl Fake {
    fn new() -> Self {
        Self {
            calls: AtomicUsize::new(0),
        }
    }
    fn calls(&self) -> usize {
        self.calls.load(Ordering::SeqCst)
    }
}

/// A run failure of the fakes.
#[derive(Debug, thiserror::Error)]
#[error("{0}")]
struct FakeFailure(&'static str);

impl Evaluator for Fake {
    type Error = FakeFailure;
    fn evaluate(
        &self,
        sc: &crate::scenario::Scenario,
        seed: u64,
    ) -> Result<PointMetrics, FakeFailure> {
        self.calls.fetch_add(1, Ordering::SeqCst);
        assert_eq!(sc.seed, seed, "the run's scenario carries the run's seed");
        let fps = sc.frame_timing.fps;
        let smooth = matches!(
            sc.estimator.differentiator,
            Differentiator::SavitzkyGolay { .. }
        );
        let jitter = 1.0 + (seed % 100) as f64 * 1e-4;
        let gain = if smooth { 0.5 } else { 1.0 };
        Ok(PointMetrics {
            theta_rms_rad: 1e-4 * jitter,
            omega_rms_rad_s: 0.9 / fps * gain * jitter,
            alpha_rms_rad_s2: 20.0 / fps * gain * jitter,
            omega_p95_rad_s: 1.8 / fps * gain,
            alpha_p95_rad_s2: 40.0 / fps * gain,
            frames_total: (fps * sc.duration_s) as usize,
            frames_detected: (fps * sc.duration_s) as usize,
            engaged_alpha_noise_rad_s2: if smooth { 0.01 } else { 0.1 },
            mean_frame_interval_s: 1.0 / fps,
            kalman_lambda_per_s6: f64::NAN,
        })
    }
}

struct AlwaysFails;
impl Evaluator for AlwaysFails {
    type Error = FakeFailure;
    fn evaluate(&self, _: &crate::scenario::Scenario, _: u64) -> Result<PointMetrics, FakeFailure> {
        Err(FakeFailure("detector lost the marker\nat frame 3"))
    }
}

fn no_progress() -> &'static (dyn Fn(usize, usize) + Sync) {
    &|_, _| {}
}

fn rows_in(dir: &Path) -> Vec<String> {
    std::fs::read_to_string(dir.join("results.csv"))
        .unwrap()
        .lines()
        .skip(1)
        .map(String::from)
        .collect()
}

fn pool(threads: usize) -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(threads)
        .build()
        .unwrap()
}

// ---------- spec ----------

#[test]
fn shipped_sweeps_parse_and_have_the_expected_grids() {
    let (fast, _) = fast_spec();
    assert_eq!(points(&fast).len(), 4);
    let seed = SweepSpec::load(&sweeps_dir().join("seed-camera.toml")).unwrap();
    assert_eq!(seed.base, "seed-camera-base.toml");
    // The base resolves (a file beside the sweep) and fixes the lens, so distance changes scale.
    let base = load_base(&seed, &sweeps_dir().join("seed-camera.toml")).unwrap();
    assert!(matches!(
        base.camera.focal,
        crate::camera::FocalConfig::FieldOfView { .. }
    ));
    assert_eq!(seed.seeds, 4);
    assert_eq!(seed.adaptive.as_ref().map(|a| a.max_seeds), Some(16));
    let grid = points(&seed);
    assert_eq!(grid.len(), 5 * 4 * 2);
    assert_eq!(grid[0].key, "distance_m=0.2|fps=24|resolution=1080p");
    assert_eq!(grid[1].key, "distance_m=0.2|fps=24|resolution=4k");
    assert_eq!(grid[2].key, "distance_m=0.2|fps=30|resolution=1080p");
    let p = grid
        .iter()
        .find(|p| p.key == "distance_m=0.3|fps=30|resolution=1080p")
        .unwrap();
    assert_eq!(p.levels, vec![1, 1, 0]);
    let keys: HashSet<&str> = grid.iter().map(|p| p.key.as_str()).collect();
    assert_eq!(keys.len(), grid.len(), "keys are unique");
    assert!(p
        .overrides
        .contains(&("camera.width_px".into(), toml::Value::Integer(1920))));
    assert!(p
        .overrides
        .contains(&("camera.distance_m".into(), toml::Value::Float(0.3))));
}

fn parse_err(text: &str) -> SweepError {
    SweepSpec::from_str(text, Path::new("s.toml")).unwrap_err()
}

fn fields(e: &SweepError) -> Vec<String> {
    e.problems().iter().map(|p| p.field.clone()).collect()
}

#[test]
fn spec_errors_name_the_file_and_field() {
    let axis = "[[axis]]\nname = \"fps\"\nfield = \"frame_timing.fps\"\nvalues = [30.0]\n";
    // Unknown and mistyped fields come from serde with their path.
    let e = parse_err(&format!("seedz = 2\n{axis}"));
    assert!(
        e.to_string().starts_with("s.toml: field `seedz`") || e.to_string().contains("seedz"),
        "{e}"
    );
    let e = parse_err(&format!("seeds = \"two\"\n{axis}"));
    assert!(
        matches!(&e, SweepError::Field { field, .. } if field == "seeds"),
        "{e}"
    );
    let e = parse_err(&format!("{axis}[impact]\nmin_snr = \"x\"\n"));
    assert!(
        matches!(&e, SweepError::Field { field, .. } if field == "impact.min_snr"),
        "{e}"
    );
    // Range problems: all at once, with the allowed range.
    let e = parse_err(&format!("seeds = 0\n{axis}[target]\nomega_rms_rad_s = -1.0\n[cost]\norder = [\"pixels\", \"price\"]\n"));
    let f = fields(&e);
    assert!(f.contains(&"seeds".into()), "{f:?}");
    assert!(f.contains(&"target.omega_rms_rad_s".into()), "{f:?}");
    assert!(f.contains(&"cost.order[1]".into()), "{f:?}");
    assert!(e.to_string().contains("must be in [1, 1000], got 0"), "{e}");
    assert!(e.to_string().starts_with("s.toml:"), "{e}");
    // Axis shape problems.
    let e = parse_err("[[axis]]\nname = \"a\"\nfield = \"x.y\"\n");
    assert_eq!(fields(&e), vec!["axis[0]".to_string()]);
    let e = parse_err("[[axis]]\nname = \"seed\"\nfield = \"x..y\"\nvalues = [1, 1]\n[[axis]]\nname = \"seed\"\nlevels = []\n");
    let f = fields(&e);
    for want in [
        "axis[0].name",
        "axis[0].field",
        "axis[0].values",
        "axis[1].levels",
        "axis[1].name",
    ] {
        assert!(f.contains(&want.to_string()), "{want} missing in {f:?}");
    }
    let e = parse_err("");
    assert_eq!(fields(&e), vec!["axis".to_string()]);
}

#[test]
fn overrides_reach_the_point_scenarios() {
    let (spec, path) = fast_spec();
    let base = load_base(&spec, &path).unwrap();
    let grid = points(&spec);
    assert_eq!(
        grid.iter().map(|p| p.key.as_str()).collect::<Vec<_>>(),
        vec![
            "fps=30|differentiator=central3",
            "fps=30|differentiator=sg9",
            "fps=60|differentiator=central3",
            "fps=60|differentiator=sg9"
        ]
    );
    let sc = point_scenario(&base, &grid[3], &path).unwrap();
    assert_eq!(sc.frame_timing.fps, 60.0);
    assert_eq!(
        sc.estimator.differentiator,
        Differentiator::SavitzkyGolay {
            window_frames: 9,
            window_s: None,
            order: 2
        }
    );
    assert_eq!(
        sc.duration_s, base.duration_s,
        "untouched fields keep the base values"
    );
    let sc0 = point_scenario(&base, &grid[0], &path).unwrap();
    assert_eq!(sc0.frame_timing.fps, 30.0);
    assert_eq!(sc0.estimator.differentiator, Differentiator::Central3);
}

/// Records the seed each run received.
struct SeedRecorder {
    seen: std::sync::Mutex<Vec<u64>>,
}

impl Evaluator for SeedRecorder {
    type Error = FakeFailure;
    fn evaluate(
        &self,
        sc: &crate::scenario::Scenario,
        seed: u64,
    ) -> Result<PointMetrics, FakeFailure> {
        self.seen.lock().unwrap().push(seed);
        Fake::new().evaluate(sc, seed)
    }
}

#[test]
fn run_seeds_are_shared_by_points_distinct_per_index_and_follow_the_base_seed() {
    // Through the engine: every point's k-th run gets the same seed (common random numbers),
    // the k-th and j-th runs differ, and the seeds are those written in results.csv.
    let (spec, path) = fast_spec();
    let dir = tempfile::tempdir().unwrap();
    let rec = SeedRecorder {
        seen: Default::default(),
    };
    run_sweep(&spec, &path, &dir.path().join("o"), &rec, no_progress()).unwrap();
    let base_seed = load_base(&spec, &path).unwrap().seed;
    let seen = rec.seen.into_inner().unwrap();
    assert_eq!(seen.len(), 8);
    let seeds: HashSet<u64> = seen.iter().copied().collect();
    assert_eq!(
        seeds.len(),
        2,
        "one seed per seed index, shared by the 4 points"
    );
    let expected: HashSet<u64> = (0..2).map(|k| run_seed(base_seed, k)).collect();
    assert_eq!(seeds, expected);
    for row in rows_in(&dir.path().join("o")) {
        let cells: Vec<&str> = row.split(',').collect();
        let k: usize = cells[4].parse().unwrap();
        assert_eq!(cells[5], run_seed(base_seed, k).to_string(), "{row}");
    }
    // Another base seed gives other run seeds.
    assert!(!expected.contains(&run_seed(base_seed + 1, 0)));
    assert!(!expected.contains(&run_seed(base_seed + 1, 1)));
}

// ---------- engine ----------

#[test]
fn a_sweep_completes_with_one_row_per_point_and_seed() {
    let (spec, path) = fast_spec();
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("out");
    let fake = Fake::new();
    let seen = AtomicUsize::new(0);
    let progress = |done: usize, total: usize| {
        assert_eq!(total, 8);
        seen.fetch_max(done, Ordering::SeqCst);
    };
    let out = run_sweep(&spec, &path, &dir, &fake, &progress).unwrap();
    assert!(out.complete);
    assert_eq!((out.jobs_total, out.jobs_resumed, out.jobs_run), (8, 0, 8));
    assert_eq!(fake.calls(), 8);
    assert_eq!(seen.load(Ordering::SeqCst), 8);
    assert_eq!(rows_in(&dir).len(), 8);
    assert_eq!(out.summary.len(), 4);
    assert!(out
        .summary
        .iter()
        .all(|s| s.status == "ok" && s.runs_ok == 2));
    let summary_csv = std::fs::read_to_string(dir.join("summary.csv")).unwrap();
    assert_eq!(summary_csv.lines().count(), 5);
    assert!(dir.join("recommendation.md").exists());
    // Rerunning a complete sweep evaluates nothing, touches nothing and gives the same summary.
    let again = Fake::new();
    let out2 = run_sweep(&spec, &path, &dir, &again, no_progress()).unwrap();
    assert_eq!(again.calls(), 0);
    assert_eq!(out2.jobs_resumed, 8);
    assert!(out2.files.is_empty());
    let beside: Vec<_> = std::fs::read_dir(root.path())
        .unwrap()
        .map(|e| e.unwrap().file_name())
        .collect();
    assert_eq!(
        beside,
        vec!["out"],
        "no staging or lock left beside the folder"
    );
    // Compared as text: a metric the evaluator leaves NaN (λ of a non-Kalman run) is NaN in both.
    assert_eq!(format!("{:?}", out2.summary), format!("{:?}", out.summary));
    assert_eq!(
        std::fs::read_to_string(dir.join("summary.csv")).unwrap(),
        summary_csv
    );
}

/// Every output file of a finished sweep folder.
fn outputs(dir: &Path) -> Vec<(String, Vec<u8>)> {
    [
        "results.csv",
        "summary.csv",
        "recommendation.md",
        "heatmap_alpha_rms.png",
        "heatmap_omega_rms.png",
        "manifest.json",
    ]
    .iter()
    .map(|f| {
        let bytes = std::fs::read(dir.join(f)).unwrap_or_else(|e| panic!("{f}: {e}"));
        (f.to_string(), bytes)
    })
    .collect()
}

/// Deterministic like `Fake`, but its runs take varying time, so that with several threads
/// they finish out of order.
struct Shuffled;
impl Evaluator for Shuffled {
    type Error = FakeFailure;
    fn evaluate(
        &self,
        sc: &crate::scenario::Scenario,
        seed: u64,
    ) -> Result<PointMetrics, FakeFailure> {
        std::thread::sleep(std::time::Duration::from_millis(
            (seed ^ sc.frame_timing.fps as u64) % 7,
        ));
        Fake::new().evaluate(sc, seed)
    }
}

#[test]
fn outputs_are_byte_identical_for_one_and_four_threads() {
    let (spec, path) = fast_spec();
    let run = |threads: usize| {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("out");
        pool(threads)
            .install(|| run_sweep(&spec, &path, &dir, &Shuffled, no_progress()))
            .unwrap();
        outputs(&dir)
    };
    let one = run(1);
    assert_eq!(one, run(4));
    let text = String::from_utf8(one[0].1.clone()).unwrap();
    let order: Vec<(usize, usize)> = text
        .lines()
        .skip(1)
        .map(|l| {
            let c: Vec<&str> = l.split(',').collect();
            (c[0].parse().unwrap(), c[4].parse().unwrap())
        })
        .collect();
    let mut sorted = order.clone();
    sorted.sort();
    assert_eq!(order, sorted, "rows in (point, seed) order");
}

#[test]
fn shards_merge_into_the_bytes_of_a_one_machine_sweep() {
    let (spec, path) = fast_spec();
    let root = tempfile::tempdir().unwrap();
    let whole = root.path().join("whole");
    run_sweep(&spec, &path, &whole, &Fake::new(), no_progress()).unwrap();
    for n in [2usize, 3, 8] {
        let dir = root.path().join(format!("sharded-{n}"));
        let fake = Fake::new();
        for i in 0..n {
            let run = SweepRun {
                shard: Some(crate::shard::Shard::new(i, n).unwrap()),
                restart: false,
                control: &Control::none(),
            };
            // Shards on machines with different core counts.
            let out = pool(1 + i % 3)
                .install(|| run_sweep_with(&spec, &path, &dir, &Shuffled, &run))
                .unwrap();
            assert!(out.complete && out.summary.is_empty());
            assert_eq!(
                out.jobs_run,
                crate::shard::Shard::new(i, n).unwrap().units(8).len()
            );
        }
        assert_eq!(fake.calls(), 0);
        assert!(
            !dir.join("results.csv").exists(),
            "shards write nothing final"
        );
        let merged = merge_sweep(&spec, &path, &dir).unwrap();
        assert_eq!(outputs(&dir), outputs(&whole), "{n} shards");
        assert_eq!(merged.summary.len(), 4);
        // Idempotent: a second merge rewrites the same bytes.
        merge_sweep(&spec, &path, &dir).unwrap();
        assert_eq!(outputs(&dir), outputs(&whole), "{n} shards, merged twice");
        assert_eq!(
            sweep_file_of(&dir).unwrap(),
            std::path::absolute(&path).unwrap()
        );
    }
}

#[test]
fn a_merge_with_a_shard_missing_names_the_missing_runs_and_writes_nothing() {
    let (spec, path) = fast_spec();
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("out");
    for i in [0usize, 2] {
        let run = SweepRun {
            shard: Some(crate::shard::Shard::new(i, 3).unwrap()),
            restart: false,
            control: &Control::none(),
        };
        run_sweep_with(&spec, &path, &dir, &Fake::new(), &run).unwrap();
    }
    let e = merge_sweep(&spec, &path, &dir).unwrap_err();
    let msg = e.to_string();
    // Shard 1 of 3 owns units 1, 4, 7: (point 0, seed 1), (point 2, seed 0), (point 3, seed 1).
    for want in [
        "3 of 8 work units missing",
        "shard 1/3 not started",
        "point 0 (fps=30|differentiator=central3) seed 1",
        "point 2 (fps=60|differentiator=central3) seed 0",
        "point 3 (fps=60|differentiator=sg9) seed 1",
    ] {
        assert!(msg.contains(want), "`{want}` missing in: {msg}");
    }
    for f in [
        "results.csv",
        "summary.csv",
        "recommendation.md",
        "manifest.json",
    ] {
        assert!(!dir.join(f).exists(), "{f}");
    }
}

#[test]
fn an_interrupted_sweep_resumes_without_repeats_or_losses_and_shows_nothing_half_done() {
    let (spec, path) = fast_spec();
    // Stopped after k of 8 runs began, on `threads` threads: up to k + threads − 1 runs may
    // have begun by the time every thread sees the stop, so the sweep is certainly incomplete
    // only while that is below 8. A late stop (k = 7) is therefore run on one thread; on four
    // it raced the last run and the sweep sometimes finished (CI, under load).
    for (threads, k) in [(4usize, 0usize), (4, 1), (4, 3), (4, 4), (1, 7)] {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("out");
        let (out, first_calls) = interrupted(&spec, &path, &dir, threads, k);
        assert!(!out.complete, "k = {k}");
        assert!(
            !dir.exists(),
            "k = {k}: nothing final before the sweep is complete"
        );
        assert_eq!(out.jobs_run, first_calls);
        let second = Fake::new();
        let out = pool(4)
            .install(|| run_sweep(&spec, &path, &dir, &second, no_progress()))
            .unwrap();
        assert!(out.complete);
        assert_eq!(out.jobs_resumed, first_calls);
        assert_eq!(first_calls + second.calls(), 8, "k = {k}: no job repeated");
        let axis_names: Vec<String> = spec.axes.iter().map(|a| a.name.clone()).collect();
        let parsed = results::read(&dir.join("results.csv"), &axis_names).unwrap();
        let pairs: HashSet<(String, usize)> = parsed
            .iter()
            .map(|r| (r.key.clone(), r.seed_index))
            .collect();
        assert_eq!(pairs.len(), 8, "k = {k}: none lost");
        assert_eq!(parsed.len(), 8);
    }
}

/// Runs the whole sweep on one thread and stops it once `k` runs are done (an interruption).
fn interrupted(
    spec: &SweepSpec,
    path: &Path,
    dir: &Path,
    threads: usize,
    k: usize,
) -> (SweepOutcome, usize) {
    let first = Fake::new();
    let stop = || first.calls() >= k;
    let control = Control {
        progress: no_progress(),
        stop: &stop,
    };
    let run = SweepRun {
        shard: None,
        restart: false,
        control: &control,
    };
    let out = pool(threads)
        .install(|| run_sweep_with(spec, path, dir, &first, &run))
        .unwrap();
    (out, first.calls())
}

#[test]
fn a_line_cut_by_an_interruption_is_redone() {
    let (spec, path) = fast_spec();
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("out");
    interrupted(&spec, &path, &dir, 1, 3);
    let log = root.path().join(".out.partial").join(crate::shard::LOG);
    let text = std::fs::read_to_string(&log).unwrap();
    assert_eq!(text.lines().filter(|l| !l.starts_with('#')).count(), 3);
    std::fs::write(&log, &text[..text.len() - 10]).unwrap(); // the last row loses its tail
    let fake = Fake::new();
    let out = run_sweep(&spec, &path, &dir, &fake, no_progress()).unwrap();
    assert_eq!(fake.calls(), 6, "the cut run is redone");
    assert!(out.complete);
    assert_eq!(rows_in(&dir).len(), 8);
}

#[test]
fn a_corrupted_log_line_is_refused_naming_the_log_and_its_line() {
    // A resumed sweep with a corrupted units.log blamed the staging folder's results.csv.
    let (spec, path) = fast_spec();
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("out");
    interrupted(&spec, &path, &dir, 1, 3);
    let log = root.path().join(".out.partial").join(crate::shard::LOG);
    let text = std::fs::read_to_string(&log).unwrap();
    let second = text.lines().nth(2).unwrap();
    let (unit, _) = second.split_once('\t').unwrap();
    let broken = second
        .replacen(",ok,", ",o,", 1)
        .replacen(",30,", ",3x,", 1);
    assert_ne!(broken, second);
    std::fs::write(&log, text.replacen(second, &broken, 1)).unwrap();
    let fake = Fake::new();
    let e = run_sweep(&spec, &path, &dir, &fake, no_progress())
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("units.log: line 3") && e.contains(&format!("unit {unit}")),
        "{e}"
    );
    assert!(!e.contains("results.csv"), "{e}");
    assert_eq!(fake.calls(), 0);
}

#[test]
fn results_of_other_inputs_are_refused_naming_what_changed() {
    let root = tempfile::tempdir().unwrap();
    let spec_path = root.path().join("s.toml");
    let base_path = root.path().join("base.toml");
    let sweep = "base = \"base.toml\"\nseeds = 2\n[[axis]]\nname = \"fps\"\nfield = \"frame_timing.fps\"\nvalues = [30.0, 60.0]\n";
    std::fs::write(&spec_path, sweep).unwrap();
    std::fs::write(&base_path, "extend = \"fast\"\nseed = 5\n").unwrap();
    let spec = SweepSpec::load(&spec_path).unwrap();
    let dir = root.path().join("out");
    // Interrupted after 2 runs, then the base scenario changes.
    interrupted(&spec, &spec_path, &dir, 1, 2);
    std::fs::write(&base_path, "extend = \"fast\"\nseed = 6\n").unwrap();
    let fake = Fake::new();
    let e = run_sweep(&spec, &spec_path, &dir, &fake, no_progress()).unwrap_err();
    assert_eq!(fake.calls(), 0);
    let msg = e.to_string();
    assert!(
        msg.contains("base scenario: `seed` 5 → 6") && msg.contains("--restart"),
        "{msg}"
    );
    // --restart discards the stale rows and redoes every run.
    let run = SweepRun {
        shard: None,
        restart: true,
        control: &Control::none(),
    };
    let out = run_sweep_with(&spec, &spec_path, &dir, &fake, &run).unwrap();
    assert!(out.complete && fake.calls() == 4 && out.jobs_resumed == 0);
    // A finished folder: other axis values are refused, naming the axis value.
    let mut other = spec.clone();
    other.axes[0].values = Some(vec![toml::Value::Float(24.0), toml::Value::Float(60.0)]);
    let e = run_sweep(&other, &spec_path, &dir, &Fake::new(), no_progress()).unwrap_err();
    assert!(
        e.to_string().contains("axes: `[0].values[0]` 30.0 → 24.0"),
        "{e}"
    );
    // Increasing the seeds changes the work units.
    other = spec.clone();
    other.seeds = 3;
    let e = run_sweep(&other, &spec_path, &dir, &Fake::new(), no_progress()).unwrap_err();
    assert!(e.to_string().contains("seeds: 2 → 3"), "{e}");
    // A folder written before the manifest named the metric columns (its column 8 held the
    // dwell σ_α, now the engaged α noise) is refused, not reread.
    let manifest_path = dir.join(crate::shard::MANIFEST);
    let mut m: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&manifest_path).unwrap()).unwrap();
    let inputs = m["inputs"].as_object_mut().unwrap();
    assert!(inputs.remove("metrics").is_some());
    m["fingerprint"] = serde_json::Value::from("fnv1a64:0000000000000000");
    std::fs::write(&manifest_path, m.to_string()).unwrap();
    let e = run_sweep(&spec, &spec_path, &dir, &Fake::new(), no_progress()).unwrap_err();
    assert!(
        e.to_string()
            .contains("metrics: `[0]` (absent) → \"theta_rms_rad\""),
        "{e}"
    );
    // A folder with a results.csv nobody committed is not taken over.
    let foreign = root.path().join("foreign");
    std::fs::create_dir(&foreign).unwrap();
    std::fs::write(foreign.join("results.csv"), "point,key\n").unwrap();
    let e = run_sweep(&spec, &spec_path, &foreign, &Fake::new(), no_progress()).unwrap_err();
    assert!(e.to_string().contains("did not write"), "{e}");
}

#[test]
fn two_sweeps_on_one_folder_cannot_run_at_once() {
    let (spec, path) = fast_spec();
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("out");
    let _other = crate::io::output_dir::DirLock::of_dir(&dir, true).unwrap();
    let fake = Fake::new();
    let e = run_sweep(&spec, &path, &dir, &fake, no_progress()).unwrap_err();
    assert!(
        e.to_string().contains("in use by another geneva process"),
        "{e}"
    );
    assert_eq!(fake.calls(), 0);
    // A shard cannot start either while a whole-folder writer holds it.
    let run = SweepRun {
        shard: Some(crate::shard::Shard::new(0, 2).unwrap()),
        restart: false,
        control: &Control::none(),
    };
    assert!(run_sweep_with(&spec, &path, &dir, &fake, &run).is_err());
}

#[test]
fn an_unknown_axis_field_is_an_error_before_any_run() {
    let text = "base = \"fast\"\nseeds = 2\n[[axis]]\nname = \"fps\"\nfield = \"frame_timing.fpss\"\nvalues = [30.0]\n";
    let path = sweeps_dir().join("inline.toml");
    let spec = SweepSpec::from_str(text, &path).unwrap();
    let root = tempfile::tempdir().unwrap();
    let fake = Fake::new();
    let e = run_sweep(&spec, &path, &root.path().join("o"), &fake, no_progress()).unwrap_err();
    assert!(matches!(e, SweepError::Point { .. }), "{e}");
    let msg = crate::errors::full(&e);
    assert!(
        msg.contains("fpss") && msg.contains("point `fps=30`"),
        "{msg}"
    );
    // The sweep file is named once, by the scenario error (three times).
    assert_eq!(msg.matches("inline.toml").count(), 1, "{msg}");
    assert_eq!(fake.calls(), 0);
    assert!(!root.path().join("o").exists());
    // A wrong type in a level is a mistake too.
    let text = "base = \"fast\"\n[[axis]]\nname = \"fps\"\nfield = \"frame_timing.fps\"\nvalues = [\"thirty\"]\n";
    let spec = SweepSpec::from_str(text, &path).unwrap();
    let e = run_sweep(&spec, &path, &root.path().join("o"), &fake, no_progress()).unwrap_err();
    assert!(crate::errors::full(&e).contains("frame_timing.fps"), "{e}");
}

#[test]
fn invalid_points_and_failed_runs_become_rows_not_aborts() {
    let text = "base = \"fast\"\nseeds = 2\n[[axis]]\nname = \"fps\"\nfield = \"frame_timing.fps\"\nvalues = [30.0, -5.0]\n";
    let path = sweeps_dir().join("inline.toml");
    let spec = SweepSpec::from_str(text, &path).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let fake = Fake::new();
    let out = run_sweep(&spec, &path, dir.path(), &fake, no_progress()).unwrap();
    assert!(out.complete);
    assert_eq!(fake.calls(), 2, "the invalid point is never evaluated");
    assert_eq!(rows_in(dir.path()).len(), 4);
    assert_eq!(out.summary[1].status, "invalid");
    assert!(
        out.summary[1].error.contains("frame_timing.fps"),
        "{}",
        out.summary[1].error
    );
    assert_eq!(out.summary[0].status, "ok");
    let dir = tempfile::tempdir().unwrap();
    let out = run_sweep(&spec, &path, dir.path(), &AlwaysFails, no_progress()).unwrap();
    assert_eq!(out.summary[0].status, "failed");
    assert_eq!(out.summary[0].error, "detector lost the marker at frame 3");
    assert!(out.recommendation.unwrap().chosen.is_none());
    assert!(out.recommendation_md.contains("No point qualifies"));
}

#[test]
fn the_engine_recommends_the_cheapest_qualifying_point() {
    // Fake: ω RMS = 0.9/fps, halved by SG; SG has 10× less dwell noise. At 30 fps central3 misses
    // the ω target (0.03 > 0.02), SG9 meets it (0.015): the cheapest is 30 fps + SG9; the
    // runner-up is the next by fps, then grid order: 60 fps + central3.
    let (spec, path) = fast_spec();
    let dir = tempfile::tempdir().unwrap();
    let out = run_sweep(&spec, &path, dir.path(), &Fake::new(), no_progress()).unwrap();
    let rec = out.recommendation.unwrap();
    let key = |i: Option<usize>| i.map(|i| out.summary[i].key.clone());
    assert_eq!(
        key(rec.chosen).as_deref(),
        Some("fps=30|differentiator=sg9")
    );
    assert_eq!(
        key(rec.runner_up).as_deref(),
        Some("fps=60|differentiator=central3")
    );
    assert!(!out.summary[0].meets_target);
    assert!(out.summary.iter().all(|s| s.impact.unwrap().detectable));
    assert!(out.recommendation_md.contains("fps=30|differentiator=sg9"));
    assert!(
        out.recommendation_md
            .contains("fps=30|differentiator=central3`: ω RMS 0.030"),
        "{}",
        out.recommendation_md
    );
}

fn hand_point(index: usize, cost: Vec<f64>, qualifies: bool, omega: f64) -> PointSummary {
    let mut metrics = vec![crate::budget::MeanCi::of(&[1e-3, 1e-3]); METRICS.len()];
    metrics[1] = crate::budget::MeanCi::of(&[omega, omega]);
    PointSummary {
        index,
        key: format!("p{index}"),
        labels: vec![],
        status: "ok".into(),
        runs_ok: 2,
        runs_expected: 2,
        metrics,
        impact: Some(crate::budget::detectability::Detectability {
            peak_alpha_rad_s2: 1.0,
            noise_alpha_rad_s2: 0.1,
            snr: 10.0,
            detectable: true,
        }),
        snr_ci95: (10.0, 10.0),
        meets_target: qualifies,
        qualifies,
        seed_rotation_centre: false,
        decision: if qualifies {
            summary::Decision::Qualifies
        } else {
            summary::Decision::Fails
        },
        cost,
        error: String::new(),
    }
}

#[test]
fn recommendation_ranks_by_cost_keys_in_priority_order() {
    let spec = SweepSpec::default();
    let grid = vec![
        hand_point(0, vec![8.3e6, 30.0], true, 0.01),
        hand_point(1, vec![2.1e6, 120.0], true, 0.01),
        hand_point(2, vec![2.1e6, 60.0], true, 0.01),
        hand_point(3, vec![2.1e6, 24.0], false, 0.05),
        hand_point(4, vec![2.1e6, 60.0], true, 0.01),
    ];
    let rec = recommend(&spec, &grid);
    assert_eq!(
        rec.chosen,
        Some(2),
        "fewest pixels, then lowest fps, then grid order"
    );
    assert_eq!(rec.runner_up, Some(4));
    assert_eq!(rec.closest, None);
    // Nothing qualifies: the closest is the smallest worst shortfall (ω 0.03 beats ω 0.05).
    let none = vec![
        hand_point(0, vec![1.0], false, 0.05),
        hand_point(1, vec![2.0], false, 0.03),
    ];
    let rec = recommend(&spec, &none);
    assert_eq!((rec.chosen, rec.closest), (None, Some(1)));
    let md = recommend::markdown(&spec, &none, &rec);
    assert!(md.contains("Closest") && md.contains("p1"), "{md}");
}

#[test]
fn heatmaps_hold_the_first_two_axes_at_the_recommended_slice() {
    let (spec, path) = fast_spec();
    let dir = tempfile::tempdir().unwrap();
    let out = run_sweep(&spec, &path, dir.path(), &Fake::new(), no_progress()).unwrap();
    for f in ["heatmap_alpha_rms.png", "heatmap_omega_rms.png"] {
        assert!(dir.path().join(f).exists(), "{f}");
    }
    let grid = points(&spec);
    let rec = out.recommendation.unwrap();
    let maps = heatmaps::heatmaps(&spec, &grid, &out.summary, &rec);
    let (_, omega) = maps.iter().find(|(s, _)| s == "heatmap_omega_rms").unwrap();
    assert_eq!(omega.x_ticks, vec!["30", "60"]);
    assert_eq!(omega.y_ticks, vec!["central3", "sg9"]);
    // values[row = differentiator][col = fps] is that point's mean ω RMS.
    let p = grid
        .iter()
        .find(|p| p.key == "fps=60|differentiator=sg9")
        .unwrap();
    assert_eq!(
        omega.values[1][1],
        out.summary[p.index].mean("omega_rms_rad_s")
    );
}

#[test]
fn an_automatic_kalman_lambda_is_reported_not_guessed() {
    let text = "base = \"fast\"\nseeds = 1\n[[axis]]\nname = \"diff\"\nlevels = [{ label = \"kalman\", set = { \"estimator.differentiator\" = { kind = \"kalman_rts\" } } }]\n";
    let path = sweeps_dir().join("inline.toml");
    let spec = SweepSpec::from_str(text, &path).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let out = run_sweep(&spec, &path, dir.path(), &Fake::new(), no_progress()).unwrap();
    let s = &out.summary[0];
    assert!(s.impact.is_none() && !s.qualifies);
    assert!(s.error.contains("lambda"), "{}", s.error);
    assert!(
        out.recommendation_md.contains("lambda"),
        "{}",
        out.recommendation_md
    );
}

// ---------- adaptive seeds, recommendation on the bounds, neighbours ----------

/// ω RMS = 0.6/fps × (0.95 + 0.3 u), u ∈ [−1, 1) from the seed (the 16 seeds of `fast` draw a
/// mean u of +0.27, so the 30 fps mean is 0.0206, near the 0.02 target): 20 fps clearly fails (0.03),
/// 30 fps straddles the target at every seed count up to 16 (checked on these seeds: the
/// interval is [0.0191, 0.0222] at 16), 60 fps clearly qualifies (0.01) with few seeds.
struct Noisy {
    calls: AtomicUsize,
}

impl Evaluator for Noisy {
    type Error = FakeFailure;
    fn evaluate(
        &self,
        sc: &crate::scenario::Scenario,
        seed: u64,
    ) -> Result<PointMetrics, FakeFailure> {
        self.calls.fetch_add(1, Ordering::SeqCst);
        std::thread::sleep(std::time::Duration::from_millis(seed % 5));
        let u = (seed >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0;
        let fps = sc.frame_timing.fps;
        let mut m = Fake::new().evaluate(sc, seed)?;
        m.omega_rms_rad_s = 0.6 / fps * (0.95 + 0.3 * u);
        m.alpha_rms_rad_s2 = 0.1;
        m.engaged_alpha_noise_rad_s2 = 0.01;
        Ok(m)
    }
}

fn noisy() -> Noisy {
    Noisy {
        calls: AtomicUsize::new(0),
    }
}

/// A one-level axis that pins a differentiator whose impact SNR is known without a run (the
/// default's automatic Kalman λ is not: its points could not qualify at all).
const CENTRAL3_AXIS: &str = "[[axis]]\nname = \"diff\"\nlevels = [{ label = \"central3\", set = \
     { \"estimator.differentiator\" = { kind = \"central3\" } } }]\n";

fn adaptive_spec(max_seeds: usize) -> (SweepSpec, PathBuf) {
    let text = format!(
        "base = \"fast\"\nseeds = 2\n[adaptive]\nmax_seeds = {max_seeds}\n[[axis]]\nname = \"fps\"\n\
         field = \"frame_timing.fps\"\nvalues = [20.0, 30.0, 60.0]\n{CENTRAL3_AXIS}[target]\n\
         omega_rms_rad_s = 0.02\nalpha_rms_rad_s2 = 1.0\n"
    );
    let path = sweeps_dir().join("inline.toml");
    (SweepSpec::from_str(&text, &path).unwrap(), path)
}

#[test]
fn adaptive_seeds_go_to_the_undecided_point_until_the_cap() {
    let (spec, path) = adaptive_spec(16);
    let run = |threads: usize| {
        let root = tempfile::tempdir().unwrap();
        let dir = root.path().join("out");
        let out = pool(threads)
            .install(|| run_sweep(&spec, &path, &dir, &noisy(), no_progress()))
            .unwrap();
        (out, outputs(&dir))
    };
    let (out, one) = run(1);
    let (_, four) = run(4);
    assert_eq!(one, four, "same bytes whatever the thread count");
    let seeds: Vec<usize> = out.summary.iter().map(|s| s.runs_expected).collect();
    assert_eq!(seeds[1], 16, "the point on the target is capped: {seeds:?}");
    assert!(seeds[0] < 16 && seeds[2] < 16, "{seeds:?}");
    use summary::Decision;
    assert_eq!(out.summary[0].decision, Decision::Fails);
    assert_eq!(out.summary[1].decision, Decision::Undecided);
    assert_eq!(out.summary[2].decision, Decision::Qualifies);
    let rec = out.recommendation.unwrap();
    assert_eq!(rec.chosen, Some(2));
    assert_eq!(rec.undecided_cheaper, vec![1]);
    assert!(
        out.recommendation_md
            .contains("Cheaper points left undecided (1)")
            && out.recommendation_md.contains("undecided after 16 seed(s)"),
        "{}",
        out.recommendation_md
    );
}

#[test]
fn an_adaptive_sweep_resumes_and_extends_to_the_bytes_of_a_fresh_run() {
    let (spec16, path) = adaptive_spec(16);
    let (spec4, _) = adaptive_spec(4);
    let root = tempfile::tempdir().unwrap();
    let fresh = root.path().join("fresh");
    let n = noisy();
    run_sweep(&spec16, &path, &fresh, &n, no_progress()).unwrap();
    let fresh_calls = n.calls.load(Ordering::SeqCst);
    // Interrupted after 4 runs, resumed, finished at the cap of 4 ...
    let dir = root.path().join("out");
    let first = noisy();
    let stop = || first.calls.load(Ordering::SeqCst) >= 4;
    let control = Control {
        progress: no_progress(),
        stop: &stop,
    };
    let run = SweepRun {
        shard: None,
        restart: false,
        control: &control,
    };
    let out = pool(1)
        .install(|| run_sweep_with(&spec4, &path, &dir, &first, &run))
        .unwrap();
    assert!(!out.complete);
    let second = noisy();
    let out = run_sweep(&spec4, &path, &dir, &second, no_progress()).unwrap();
    assert!(out.complete);
    let at4 = first.calls.load(Ordering::SeqCst) + second.calls.load(Ordering::SeqCst);
    // ... then extended to a cap of 16 without redoing a run: the same bytes as a fresh run.
    let third = noisy();
    let out = run_sweep(&spec16, &path, &dir, &third, no_progress()).unwrap();
    assert!(out.complete);
    assert_eq!(at4 + third.calls.load(Ordering::SeqCst), fresh_calls);
    let strip = |d: &Path| {
        outputs(d)
            .into_iter()
            .filter(|(name, _)| name != "manifest.json")
            .collect::<Vec<_>>()
    };
    assert_eq!(strip(&dir), strip(&fresh));
    // Already complete: nothing runs.
    let fourth = noisy();
    run_sweep(&spec16, &path, &dir, &fourth, no_progress()).unwrap();
    assert_eq!(fourth.calls.load(Ordering::SeqCst), 0);
    // Adaptive sweeps refuse shards, naming why.
    let shard = SweepRun {
        shard: Some(crate::shard::Shard::new(0, 2).unwrap()),
        restart: false,
        control: &Control::none(),
    };
    let e = run_sweep_with(&spec16, &path, &root.path().join("s"), &noisy(), &shard).unwrap_err();
    assert!(e.to_string().contains("one machine"), "{e}");
}

#[test]
fn a_point_qualifies_on_its_upper_bound_not_its_mean() {
    // Two seeds with ω RMS 0.005 and 0.025: the mean 0.015 meets 0.02, the interval does not.
    let spec = SweepSpec::default();
    let grid = points(&SweepSpec {
        axes: vec![AxisSpec {
            name: "x".into(),
            field: Some("camera.distance_m".into()),
            values: Some(vec![toml::Value::Float(0.3)]),
            levels: None,
        }],
        ..SweepSpec::default()
    });
    let rows: Vec<ResultRow> = [0.005, 0.025]
        .iter()
        .enumerate()
        .map(|(k, w)| ResultRow {
            point: 0,
            key: grid[0].key.clone(),
            labels: grid[0].labels.clone(),
            seed_index: k,
            seed: k as u64,
            metrics: Some(PointMetrics {
                omega_rms_rad_s: *w,
                alpha_rms_rad_s2: 0.1,
                engaged_alpha_noise_rad_s2: 0.001,
                mean_frame_interval_s: 1.0 / 30.0,
                kalman_lambda_per_s6: f64::NAN,
                frames_total: 60,
                frames_detected: 60,
                ..PointMetrics::default()
            }),
            status: Status::Ok,
            error: String::new(),
        })
        .collect();
    let central3 = crate::scenario::load_any("fast").and_then(|fast| {
        let mut kind = toml::map::Map::new();
        kind.insert("kind".into(), toml::Value::String("central3".into()));
        crate::scenario::with_overrides(
            &fast,
            &[("estimator.differentiator".into(), toml::Value::Table(kind))],
            Path::new("inline"),
        )
    });
    let s = summary::summarise(&spec, &grid, &[central3], &rows);
    assert!(s[0].mean("omega_rms_rad_s") < spec.target.omega_rms_rad_s);
    assert!(!s[0].meets_target && !s[0].qualifies);
    assert_eq!(s[0].decision, summary::Decision::Undecided);
    assert!(recommend::reasons(&spec, &s[0]).contains("upper bound not within"));
}

#[test]
fn a_farther_camera_that_looks_better_is_flagged() {
    let text = "base = \"fast\"\n[[axis]]\nname = \"distance_m\"\nfield = \"camera.distance_m\"\n\
                values = [0.3, 0.4, 0.5]\n";
    let spec = SweepSpec::from_str(text, &sweeps_dir().join("inline.toml")).unwrap();
    let mut pts = vec![
        hand_point(0, vec![1.0], true, 0.010),
        hand_point(1, vec![1.0], true, 0.008),
        hand_point(2, vec![1.0], true, 0.012),
    ];
    // Point 1's interval is tight and below point 0's: the reversal is not seed noise.
    pts[0].metrics[1] = crate::budget::MeanCi::of(&[0.0100, 0.0101]);
    pts[1].metrics[1] = crate::budget::MeanCi::of(&[0.0080, 0.0081]);
    let found = monotonic::findings(&spec, &pts);
    let omega: Vec<&monotonic::Finding> = found.iter().filter(|f| f.metric == "ω RMS").collect();
    assert_eq!(omega.len(), 1, "{found:?}");
    assert_eq!(omega[0].points, vec![0, 1]);
    assert!(omega[0].separated);
    let md = monotonic::markdown(&spec, &pts);
    assert!(
        md.contains("Non-monotonic neighbours (1)") && md.contains("intervals separated"),
        "{md}"
    );
    assert!(
        !md.contains("rotation_centre"),
        "no seed centre, no note: {md}"
    );
    // With the seed's whole-pixel rotation centre the note explains the reversal, with the
    // sweep's own θ RMS range (hand points: 1e-3 rad everywhere).
    for p in &mut pts {
        p.seed_rotation_centre = true;
    }
    let md = monotonic::markdown(&spec, &pts);
    assert!(
        md.contains("rotation_centre = \"seed\"") && md.contains("θ RMS 0.0010–0.0010 rad"),
        "{md}"
    );
}

#[test]
fn a_merge_after_a_killed_shard_names_the_missing_runs_not_its_lock() {
    // `sweep merge DIR` after a killed shard read the shard's lock file as a shard
    // ("…/shards/.0.lock/manifest.json: Not a directory").
    let (spec, path) = fast_spec();
    let root = tempfile::tempdir().unwrap();
    let dir = root.path().join("out");
    let first = Fake::new();
    let stop = || first.calls() >= 1;
    let control = Control {
        progress: &|_, _| {},
        stop: &stop,
    };
    let run = SweepRun {
        shard: Some(crate::shard::Shard::new(0, 2).unwrap()),
        restart: false,
        control: &control,
    };
    pool(1)
        .install(|| run_sweep_with(&spec, &path, &dir, &first, &run))
        .unwrap();
    std::fs::write(dir.join("shards/.0.lock"), "pid 1 on host\n").unwrap();
    let found = crate::sweep::sweep_file_of(&dir).unwrap();
    assert_eq!(found, std::path::absolute(&path).unwrap());
    let e = crate::sweep::merge_sweep(&spec, &found, &dir)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("missing") && e.contains("shard 0/2 unfinished") && !e.contains("lock"),
        "{e}"
    );
}
