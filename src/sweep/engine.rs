//! The sweep engine: a sweep is a study of `points × seeds` work units (`shard`), unit
//! `point · seeds + seed_index`, each unit one results.csv row. Units run in parallel (rayon) and
//! are logged as they finish, so an interrupted sweep resumes without repeating a run; when
//! every unit is done, the rows — in (point, seed) order, whatever order they finished in — are
//! summarised and the output folder is committed all at once. The same study runs as shards
//! (`--shard I/N`) and merges into the same bytes.

use super::error::SweepError;
use super::grid::{load_base, point_scenario, points, run_seed, Point};
use super::recommend::{markdown, recommend, Recommendation};
use super::results::{self, header_line, row_line, ResultRow, Status};
use super::spec::SweepSpec;
use super::summary::{summarise, write_csv, PointSummary};
use super::Evaluator;
use crate::scenario::{Scenario, ScenarioError};
use crate::shard::{self, AdaptiveStudy, Manifest, Shard, ShardError, Study, UnitDirs};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

pub use crate::shard::Control;

/// How to run a sweep.
#[derive(Clone, Copy)]
pub struct SweepRun<'a> {
    /// Only this shard's units, into `DIR/shards/I/` (None: the whole sweep into `DIR`).
    pub shard: Option<Shard>,
    /// Discard rows computed from other inputs instead of refusing them.
    pub restart: bool,
    pub control: &'a Control<'a>,
}

/// What a call of [`run_sweep_with`] or [`merge_sweep`] did.
#[derive(Debug, Clone)]
pub struct SweepOutcome {
    /// (point, seed) jobs of this call: the whole sweep, or the shard's share.
    pub jobs_total: usize,
    /// Jobs already done at start (skipped).
    pub jobs_resumed: usize,
    /// Jobs done by this call.
    pub jobs_run: usize,
    /// The sweep's outputs exist: summary.csv, recommendation.md and the heatmaps (for a shard:
    /// the shard is complete; the outputs come with `merge`).
    pub complete: bool,
    /// Per point, grid order (only when the sweep's outputs exist).
    pub summary: Vec<PointSummary>,
    /// Only when the outputs exist.
    pub recommendation: Option<Recommendation>,
    /// recommendation.md text (only when the outputs exist).
    pub recommendation_md: String,
    /// Final files written by this call.
    pub files: Vec<PathBuf>,
}

/// The sweep as a study of work units.
struct SweepStudy<'a, E> {
    spec: &'a SweepSpec,
    spec_path: &'a Path,
    grid: Vec<Point>,
    scenarios: Vec<Result<Scenario, ScenarioError>>,
    base_seed: u64,
    axis_names: Vec<String>,
    evaluator: &'a E,
    manifest: Manifest,
}

/// An evaluator for merges, which never evaluate.
struct NoEvaluator;

impl Evaluator for NoEvaluator {
    type Error = ShardError;
    fn evaluate(&self, _: &Scenario, _: u64) -> Result<super::PointMetrics, ShardError> {
        Err(ShardError::Mixed {
            dir: PathBuf::new(),
            message: "a merge does not evaluate".into(),
        })
    }
}

impl<'a, E: Evaluator> SweepStudy<'a, E> {
    fn new(spec: &'a SweepSpec, spec_path: &'a Path, evaluator: &'a E) -> Result<Self, SweepError> {
        let base = load_base(spec, spec_path)?;
        let grid = points(spec);
        let scenarios: Vec<Result<Scenario, ScenarioError>> = grid
            .iter()
            .map(|p| point_scenario(&base, p, spec_path))
            .collect();
        // Out-of-range values are a result (an `invalid` row); unknown fields, wrong types and
        // unreadable files are mistakes in the sweep file: refused before any run.
        let mistake = scenarios
            .iter()
            .position(|s| matches!(s, Err(e) if !matches!(e, ScenarioError::Invalid { .. })));
        if let Some(i) = mistake {
            if let Some(Err(source)) = scenarios.into_iter().nth(i) {
                return Err(SweepError::Point {
                    file: spec_path.to_path_buf(),
                    point: grid[i].key.clone(),
                    source: Box::new(source),
                });
            }
            // Infallible: `position` found an `Err` at index i of this same vector.
            unreachable!("position found an error");
        }
        let json = |v: Result<serde_json::Value, serde_json::Error>| v.unwrap_or_default();
        let mut inputs = BTreeMap::new();
        inputs.insert(
            "base scenario".to_string(),
            json(serde_json::to_value(&base)),
        );
        inputs.insert("axes".to_string(), json(serde_json::to_value(&spec.axes)));
        inputs.insert("seeds".to_string(), serde_json::Value::from(spec.seeds));
        // The records' metric columns: a folder whose column holds another quantity under the
        // same position (the dwell σ_α before the engaged α noise) is refused, not reread.
        inputs.insert(
            "metrics".to_string(),
            json(serde_json::to_value(super::results::METRICS)),
        );
        let mut manifest = Manifest::new("sweep", grid.len() * spec.seeds, inputs);
        manifest.origin = std::path::absolute(spec_path)
            .ok()
            .map(|p| p.to_string_lossy().into_owned());
        Ok(Self {
            spec,
            spec_path,
            base_seed: base.seed,
            axis_names: spec.axes.iter().map(|a| a.name.clone()).collect(),
            grid,
            scenarios,
            evaluator,
            manifest,
        })
    }

    fn unit(&self, unit: usize) -> (usize, usize) {
        (unit / self.spec.seeds, unit % self.spec.seeds)
    }

    /// One (point, seed) run: invalid settings give an `invalid` row without calling the evaluator.
    fn run_job(&self, point: usize, seed_index: usize) -> ResultRow {
        let p = &self.grid[point];
        let seed = run_seed(self.base_seed, seed_index);
        let mut row = ResultRow {
            point: p.index,
            key: p.key.clone(),
            labels: p.labels.clone(),
            seed_index,
            seed,
            metrics: None,
            status: Status::Invalid,
            error: String::new(),
        };
        match &self.scenarios[point] {
            Err(e) => row.error = one_line(&crate::errors::full(&e)),
            Ok(sc) => {
                // The run's scenario carries the run's seed, so seed-driven streams follow it.
                let mut sc = sc.clone();
                sc.seed = seed;
                match self.evaluator.evaluate(&sc, seed) {
                    Ok(m) => {
                        row.metrics = Some(m);
                        row.status = Status::Ok;
                    }
                    Err(e) => {
                        row.status = Status::Failed;
                        row.error = one_line(&crate::errors::full(&e));
                    }
                }
            }
        }
        row
    }

    /// Summary and recommendation of a finished results.csv.
    fn outcome(
        &self,
        dir: &Path,
    ) -> Result<(Vec<PointSummary>, Recommendation, String), SweepError> {
        let rows = results::read(&dir.join("results.csv"), &self.axis_names)?;
        let summary = summarise(self.spec, &self.grid, &self.scenarios, &rows);
        let rec = recommend(self.spec, &summary);
        let md = markdown(self.spec, &summary, &rec);
        Ok((summary, rec, md))
    }
}

impl<E: Evaluator> SweepStudy<'_, E> {
    /// results.csv from the rows in (point, seed) order, then summary.csv, recommendation.md and
    /// the heatmaps.
    fn write_outputs(&self, records: &[String], out_dir: &Path) -> Result<(), SweepError> {
        let results_path = out_dir.join("results.csv");
        let mut text = header_line(&self.axis_names).map_err(SweepError::csv(&results_path))?;
        text.push('\n');
        for r in records {
            text.push_str(r);
            text.push('\n');
        }
        std::fs::write(&results_path, &text).map_err(SweepError::write(&results_path))?;
        let rows = results::parse(&text, &results_path, &self.axis_names)?;
        let summary = summarise(self.spec, &self.grid, &self.scenarios, &rows);
        write_csv(&out_dir.join("summary.csv"), &self.axis_names, &summary)?;
        let rec = recommend(self.spec, &summary);
        let md_path = out_dir.join("recommendation.md");
        std::fs::write(&md_path, markdown(self.spec, &summary, &rec))
            .map_err(SweepError::write(&md_path))?;
        super::heatmaps::write_heatmaps(self.spec, &self.grid, &summary, &rec, out_dir)?;
        Ok(())
    }
}

/// Largest seed index + 1 of an adaptive sweep (the unit numbers' range).
const MAX_SEEDS: usize = 1000;

/// The sweep with adaptive seeds: unit `seed_index · points + point`, so a unit's number does
/// not depend on how many seeds any point gets.
struct AdaptiveSweep<'a, E> {
    sweep: SweepStudy<'a, E>,
    manifest: Manifest,
}

impl<'a, E: Evaluator> AdaptiveSweep<'a, E> {
    fn new(sweep: SweepStudy<'a, E>) -> Self {
        let mut inputs = sweep.manifest.inputs.clone();
        inputs.remove("seeds");
        let mut manifest = Manifest::new("adaptive sweep", sweep.grid.len() * MAX_SEEDS, inputs);
        manifest.origin = sweep.manifest.origin.clone();
        Self { sweep, manifest }
    }

    fn point_seed(&self, unit: usize) -> (usize, usize) {
        let p = self.sweep.grid.len();
        (unit % p, unit / p)
    }

    fn unit(&self, point: usize, seed_index: usize) -> usize {
        seed_index * self.sweep.grid.len() + point
    }

    /// The records in (point, seed) order.
    fn ordered(&self, records: &BTreeMap<usize, String>) -> Vec<String> {
        let mut keyed: Vec<((usize, usize), &String)> = records
            .iter()
            .map(|(u, r)| (self.point_seed(*u), r))
            .collect();
        keyed.sort_by_key(|(k, _)| *k);
        keyed.into_iter().map(|(_, r)| r.clone()).collect()
    }
}

impl<E: Evaluator> AdaptiveStudy for AdaptiveSweep<'_, E> {
    type Error = SweepError;

    fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    fn rule(&self) -> serde_json::Value {
        let spec = self.sweep.spec;
        serde_json::json!({
            "seeds": spec.seeds,
            "adaptive": spec.adaptive,
            "target": spec.target,
            "impact": spec.impact,
            "cost": spec.cost,
        })
    }

    fn first_round(&self) -> Vec<usize> {
        (0..self.sweep.spec.seeds)
            .flat_map(|k| (0..self.sweep.grid.len()).map(move |p| (p, k)))
            .map(|(p, k)| self.unit(p, k))
            .collect()
    }

    fn next_round(&self, records: &BTreeMap<usize, String>) -> Result<Vec<usize>, SweepError> {
        let s = &self.sweep;
        let mut text = header_line(&s.axis_names).map_err(SweepError::csv(s.spec_path))?;
        for r in self.ordered(records) {
            text.push('\n');
            text.push_str(&r);
        }
        text.push('\n');
        let rows = results::parse(&text, s.spec_path, &s.axis_names)?;
        let summary = summarise(s.spec, &s.grid, &s.scenarios, &rows);
        let cap = s
            .spec
            .adaptive
            .as_ref()
            .map_or(s.spec.seeds, |a| a.max_seeds);
        Ok(super::adaptive::more_seeds(&summary, cap)
            .into_iter()
            .flat_map(|(p, from, to)| (from..to).map(move |k| (p, k)))
            .map(|(p, k)| self.unit(p, k))
            .collect())
    }

    fn run_unit(&self, unit: usize) -> Result<String, SweepError> {
        let (point, seed_index) = self.point_seed(unit);
        let row = self.sweep.run_job(point, seed_index);
        row_line(&row).map_err(SweepError::csv(self.sweep.spec_path))
    }

    fn finalize(
        &self,
        records: &BTreeMap<usize, String>,
        out_dir: &Path,
    ) -> Result<(), SweepError> {
        self.sweep.write_outputs(&self.ordered(records), out_dir)
    }
}

fn one_line(s: &str) -> String {
    s.replace('\n', " ")
}

impl<E: Evaluator> Study for SweepStudy<'_, E> {
    type Error = SweepError;

    fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    fn run_unit(&self, unit: usize, _work_dir: &Path) -> Result<String, SweepError> {
        let (point, seed_index) = self.unit(unit);
        let row = self.run_job(point, seed_index);
        row_line(&row).map_err(SweepError::csv(self.spec_path))
    }

    fn finalize(&self, records: &[String], _: UnitDirs, out_dir: &Path) -> Result<(), SweepError> {
        self.write_outputs(records, out_dir)
    }

    fn unit_name(&self, unit: usize) -> String {
        let (point, seed) = self.unit(unit);
        format!("point {point} ({}) seed {seed}", self.grid[point].key)
    }
}

/// Runs the whole sweep with no stop hook; see [`run_sweep_with`].
pub fn run_sweep<E: Evaluator>(
    spec: &SweepSpec,
    spec_path: &Path,
    out_dir: &Path,
    evaluator: &E,
    progress: &(dyn Fn(usize, usize) + Sync),
) -> Result<SweepOutcome, SweepError> {
    let control = Control {
        progress,
        stop: &|| false,
    };
    run_sweep_with(
        spec,
        spec_path,
        out_dir,
        evaluator,
        &SweepRun {
            shard: None,
            restart: false,
            control: &control,
        },
    )
}

/// Runs every missing (point, seed) job of `spec` (or of one shard of it), resuming from what an
/// interrupted run left; when the whole sweep is done, commits `results.csv`, `summary.csv`,
/// `recommendation.md` and the heatmaps into `out_dir` at once. Runs in the current rayon pool.
pub fn run_sweep_with<E: Evaluator>(
    spec: &SweepSpec,
    spec_path: &Path,
    out_dir: &Path,
    evaluator: &E,
    run: &SweepRun,
) -> Result<SweepOutcome, SweepError> {
    let study = SweepStudy::new(spec, spec_path, evaluator)?;
    if spec.adaptive.is_some() {
        return run_adaptive_sweep(study, out_dir, run);
    }
    let report = match run.shard {
        Some(s) => shard::run_shard(&study, out_dir, s, run.restart, run.control)?,
        None => shard::run_whole(&study, out_dir, run.restart, run.control)?,
    };
    let mut outcome = SweepOutcome {
        jobs_total: report.units_total,
        jobs_resumed: report.units_resumed,
        jobs_run: report.units_run,
        complete: report.complete,
        summary: Vec::new(),
        recommendation: None,
        recommendation_md: String::new(),
        files: report.files,
    };
    if report.complete && run.shard.is_none() {
        let (summary, rec, md) = study.outcome(out_dir)?;
        outcome.summary = summary;
        outcome.recommendation = Some(rec);
        outcome.recommendation_md = md;
    }
    Ok(outcome)
}

/// An adaptive sweep on this machine (see `shard::adaptive`).
fn run_adaptive_sweep<E: Evaluator>(
    study: SweepStudy<'_, E>,
    out_dir: &Path,
    run: &SweepRun,
) -> Result<SweepOutcome, SweepError> {
    if run.shard.is_some() {
        return Err(SweepError::AdaptiveSharded {
            file: study.spec_path.to_path_buf(),
        });
    }
    let adaptive = AdaptiveSweep::new(study);
    let report = shard::run_adaptive(&adaptive, out_dir, run.restart, run.control)?;
    let mut outcome = SweepOutcome {
        jobs_total: report.units_picked,
        jobs_resumed: report.units_resumed,
        jobs_run: report.units_run,
        complete: report.complete,
        summary: Vec::new(),
        recommendation: None,
        recommendation_md: String::new(),
        files: report.files,
    };
    if report.complete {
        let (summary, rec, md) = adaptive.sweep.outcome(out_dir)?;
        outcome.summary = summary;
        outcome.recommendation = Some(rec);
        outcome.recommendation_md = md;
    }
    Ok(outcome)
}

/// Everything a sweep checks before its first run (its base scenario, every point's settings),
/// without running anything: what `geneva slurm script` asks before it writes a job.
pub fn check(spec: &SweepSpec, spec_path: &Path) -> Result<(), SweepError> {
    SweepStudy::new(spec, spec_path, &NoEvaluator).map(drop)
}

/// Merges the shards in `out_dir/shards/` into the sweep's outputs, byte-identical to a
/// one-machine run (idempotent). A missing unit is named and nothing is written.
pub fn merge_sweep(
    spec: &SweepSpec,
    spec_path: &Path,
    out_dir: &Path,
) -> Result<SweepOutcome, SweepError> {
    if spec.adaptive.is_some() {
        return Err(SweepError::AdaptiveMerge {
            file: spec_path.to_path_buf(),
        });
    }
    let study = SweepStudy::new(spec, spec_path, &NoEvaluator)?;
    let report = shard::merge(&study, out_dir)?;
    let (summary, rec, md) = study.outcome(out_dir)?;
    Ok(SweepOutcome {
        jobs_total: report.units_total,
        jobs_resumed: report.units_resumed,
        jobs_run: 0,
        complete: true,
        summary,
        recommendation: Some(rec),
        recommendation_md: md,
        files: report.files,
    })
}

/// The sweep file the shards of `out_dir` were run from (recorded in their manifests).
pub fn sweep_file_of(out_dir: &Path) -> Result<PathBuf, SweepError> {
    let shards = out_dir.join(shard::SHARDS);
    if let Err(source) = std::fs::read_dir(&shards) {
        return Err(SweepError::NoShards {
            dir: shards.clone(),
            source,
        });
    }
    // Complete shard folders first, then the folders of shards still running or killed (whose
    // merge names what is missing); never a lock file.
    let mut folders = shard::complete_shard_folders(out_dir)?;
    let mut partial: Vec<PathBuf> = std::fs::read_dir(&shards)
        .map(|entries| {
            entries
                .filter_map(Result::ok)
                .filter(|e| {
                    let name = e.file_name().to_string_lossy().into_owned();
                    name.starts_with('.') && name.ends_with(".partial") && e.path().is_dir()
                })
                .map(|e| e.path())
                .collect()
        })
        .unwrap_or_default();
    partial.sort();
    folders.extend(partial);
    for folder in folders {
        if let Some(origin) = Manifest::read(&folder)?.and_then(|m| m.origin) {
            return Ok(PathBuf::from(origin));
        }
    }
    Err(SweepError::NoSweepFile { dir: shards })
}
