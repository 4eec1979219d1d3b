//! The sweep engine: runs every (point, seed) job not yet in results.csv in parallel (rayon),
//! appends each row as soon as its job finishes, then summarises, recommends and writes the
//! outputs. Resumable: rerunning after an interruption does only the missing jobs.

use super::error::SweepError;
use super::grid::{load_base, point_scenario, points, run_seed, Point};
use super::recommend::{markdown, recommend, Recommendation};
use super::results::{read, Appender, ResultRow, Status};
use super::spec::SweepSpec;
use super::summary::{summarise, write_csv, PointSummary};
use super::Evaluator;
use crate::scenario::Scenario;
use rayon::prelude::*;
use std::collections::HashSet;
use std::path::Path;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::Mutex;

/// Hooks into a running sweep.
pub struct Control<'a> {
    /// Called after each job with (jobs done, jobs in this sweep), including resumed ones.
    pub progress: &'a (dyn Fn(usize, usize) + Sync),
    /// Asked before each job starts; `true` stops the sweep cleanly (jobs already running
    /// finish and are written; the rest are left for the next run).
    pub stop: &'a (dyn Fn() -> bool + Sync),
}

/// What a call of [`run_sweep_with`] did.
#[derive(Debug, Clone)]
pub struct SweepOutcome {
    /// (point, seed) jobs in the whole sweep.
    pub jobs_total: usize,
    /// Jobs already in results.csv at start (skipped).
    pub jobs_resumed: usize,
    /// Jobs done by this call.
    pub jobs_run: usize,
    /// Every job has a row: summary.csv, recommendation.md and the heatmaps were written.
    pub complete: bool,
    /// Per point, grid order (only when complete).
    pub summary: Vec<PointSummary>,
    /// Only when complete.
    pub recommendation: Option<Recommendation>,
    /// recommendation.md text (only when complete).
    pub recommendation_md: String,
}

/// Runs the sweep with no stop hook; see [`run_sweep_with`].
pub fn run_sweep(
    spec: &SweepSpec,
    spec_path: &Path,
    out_dir: &Path,
    evaluator: &dyn Evaluator,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<SweepOutcome, SweepError> {
    run_sweep_with(
        spec,
        spec_path,
        out_dir,
        evaluator,
        &Control {
            progress,
            stop: &|| false,
        },
    )
}

/// Runs every missing (point, seed) job of `spec` into `out_dir/results.csv`; when all are
/// present, writes `summary.csv` and `recommendation.md`. Runs in the current rayon pool.
pub fn run_sweep_with(
    spec: &SweepSpec,
    spec_path: &Path,
    out_dir: &Path,
    evaluator: &dyn Evaluator,
    control: &Control,
) -> Result<SweepOutcome, SweepError> {
    std::fs::create_dir_all(out_dir).map_err(|e| SweepError::io(out_dir, e))?;
    let base = load_base(spec, spec_path)?;
    let grid = points(spec);
    let scenarios: Vec<Result<Scenario, String>> = grid
        .iter()
        .map(|p| point_scenario(&base, p, spec_path))
        .collect();
    let axis_names: Vec<String> = spec.axes.iter().map(|a| a.name.clone()).collect();
    let results_path = out_dir.join("results.csv");
    let existing = read(&results_path, &axis_names)?;
    let keys: HashSet<&str> = grid.iter().map(|p| p.key.as_str()).collect();
    if let Some(stray) = existing
        .iter()
        .find(|r| !keys.contains(r.key.as_str()) || r.seed_index >= spec.seeds)
    {
        return Err(SweepError::HeaderMismatch {
            file: results_path.clone(),
            expected: format!("points of this sweep with seed_index < {}", spec.seeds),
            found: format!("row for `{}` seed_index {}", stray.key, stray.seed_index),
        });
    }
    let done: HashSet<(String, usize)> = existing
        .iter()
        .map(|r| (r.key.clone(), r.seed_index))
        .collect();
    let jobs: Vec<(usize, usize)> = grid
        .iter()
        .flat_map(|p| (0..spec.seeds).map(move |s| (p.index, s)))
        .filter(|(p, s)| !done.contains(&(grid[*p].key.clone(), *s)))
        .collect();
    let jobs_total = grid.len() * spec.seeds;
    let jobs_resumed = jobs_total - jobs.len();

    let appender = Mutex::new(Appender::open(&results_path, &axis_names)?);
    let counter = AtomicUsize::new(jobs_resumed);
    let ran = AtomicUsize::new(0);
    jobs.par_iter()
        .try_for_each(|&(p, s)| -> Result<(), SweepError> {
            if (control.stop)() {
                return Ok(());
            }
            let row = run_job(&grid[p], &scenarios[p], s, base.seed, evaluator);
            // A poisoned lock means another job panicked mid-write; its error surfaces anyway.
            let mut w = appender
                .lock()
                .map_err(|_| SweepError::io(&results_path, "writer lock poisoned"))?;
            w.append(&row)?;
            drop(w);
            ran.fetch_add(1, Ordering::SeqCst);
            let n = counter.fetch_add(1, Ordering::SeqCst) + 1;
            (control.progress)(n, jobs_total);
            Ok(())
        })?;
    let jobs_run = ran.load(Ordering::SeqCst);

    let mut outcome = SweepOutcome {
        jobs_total,
        jobs_resumed,
        jobs_run,
        complete: false,
        summary: Vec::new(),
        recommendation: None,
        recommendation_md: String::new(),
    };
    if jobs_resumed + jobs_run < jobs_total {
        return Ok(outcome);
    }
    let rows = read(&results_path, &axis_names)?;
    let summary = summarise(spec, &grid, &scenarios, &rows);
    write_csv(&out_dir.join("summary.csv"), &axis_names, &summary)?;
    let rec = recommend(spec, &summary);
    let md = markdown(spec, &summary, &rec);
    let md_path = out_dir.join("recommendation.md");
    std::fs::write(&md_path, &md).map_err(|e| SweepError::io(&md_path, e))?;
    super::heatmaps::write_heatmaps(spec, &grid, &summary, &rec, out_dir)?;
    outcome.complete = true;
    outcome.summary = summary;
    outcome.recommendation = Some(rec);
    outcome.recommendation_md = md;
    Ok(outcome)
}

/// One (point, seed) run: invalid settings give an `invalid` row without calling the evaluator.
fn run_job(
    point: &Point,
    scenario: &Result<Scenario, String>,
    seed_index: usize,
    base_seed: u64,
    evaluator: &dyn Evaluator,
) -> ResultRow {
    let seed = run_seed(base_seed, seed_index);
    let mut row = ResultRow {
        point: point.index,
        key: point.key.clone(),
        labels: point.labels.clone(),
        seed_index,
        seed,
        metrics: None,
        status: Status::Invalid,
        error: String::new(),
    };
    match scenario {
        Err(msg) => row.error = msg.clone(),
        Ok(sc) => {
            // The run's scenario carries the run's seed, so seed-driven streams follow it.
            let mut sc = sc.clone();
            sc.seed = seed;
            match evaluator.evaluate(&sc, seed) {
                Ok(m) => {
                    row.metrics = Some(m);
                    row.status = Status::Ok;
                }
                Err(e) => {
                    row.status = Status::Failed;
                    row.error = e.replace('\n', " ");
                }
            }
        }
    }
    row
}
