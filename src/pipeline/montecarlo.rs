//! `geneva montecarlo`: one scenario run with N seeds (base seed + k), aggregated into a
//! Monte Carlo budget — the single-run `budget.json` layout with every number replaced by its
//! mean over seeds and a `ci95` object beside each statistics block — plus per-seed rows and
//! pooled error histograms.
//!
//! As a command it is a study of work units (`shard`): unit k is seed k, its record the seed's
//! budget and fused errors (TOML, exact floats, NaN kept). It resumes after a kill, shows
//! progress, runs as shards (`--shard I/N`) and merges; the outputs are the same bytes whichever
//! way the seeds were run.

use super::run::{run, RunError, RunOptions};
use crate::budget::report::Budget;
use crate::budget::MeanCi;
use crate::errors::FileError;
use crate::io::json::finite_or_null;
use crate::plot::histogram::histogram_png;
use crate::scenario::Scenario;
use crate::shard::{self, Control, Manifest, Shard, ShardError, Study, UnitDirs};
use serde_json::{Map, Value};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum MonteCarloError {
    #[error("seed {seed}")]
    Run { seed: u64, source: RunError },
    #[error("monte carlo needs at least one seed")]
    NoSeeds,
    #[error(transparent)]
    File(#[from] FileError),
    #[error(transparent)]
    Plot(#[from] crate::plot::PlotError),
    #[error(transparent)]
    Output(#[from] crate::io::output_dir::OutputError),
    #[error("{}: no shards to merge", dir.display())]
    NoShards {
        dir: PathBuf,
        source: std::io::Error,
    },
    #[error("{}: no complete shard to merge (run the shards first)", dir.display())]
    NoCompleteShard { dir: PathBuf },
    #[error(transparent)]
    Shard(#[from] ShardError),
    #[error("{file}: unit {unit}: the seed's record")]
    RecordWrite {
        file: PathBuf,
        unit: usize,
        source: toml::ser::Error,
    },
    #[error("{file}: unit {unit}: the seed's record")]
    RecordRead {
        file: PathBuf,
        unit: usize,
        source: Box<toml::de::Error>,
    },
}

/// Options of a Monte Carlo study.
#[derive(Debug, Clone)]
pub struct MonteCarloOptions {
    pub seeds: usize,
    pub roi: bool,
    /// Write budget.json, per_seed.csv and the histograms into the output folder.
    pub write_files: bool,
    /// Also write the first seed's full run (tracks, kinematics, time-series plots) into
    /// `<out>/seed0/`.
    pub first_seed_files: bool,
}

impl Default for MonteCarloOptions {
    fn default() -> Self {
        Self {
            seeds: 3,
            roi: true,
            write_files: true,
            first_seed_files: false,
        }
    }
}

/// What a Monte Carlo study computed.
#[derive(Debug, Clone)]
pub struct MonteCarloBudget {
    /// The seeds that were run, in order.
    pub seeds: Vec<u64>,
    /// Each seed's own budget.
    pub per_seed: Vec<Budget>,
    /// The aggregated budget (what `budget.json` holds).
    pub json: Value,
    /// Fused ω2 and α2 errors of all seeds pooled (for histograms), rad/s and rad/s².
    pub pooled_omega_err_rad_s: Vec<f64>,
    pub pooled_alpha_err_rad_s2: Vec<f64>,
    pub elapsed_s: f64,
    pub files: Vec<PathBuf>,
}

impl MonteCarloBudget {
    /// Mean and 95 % CI over seeds of any per-seed number.
    pub fn metric(&self, f: impl Fn(&Budget) -> f64) -> MeanCi {
        MeanCi::of(&self.per_seed.iter().map(f).collect::<Vec<f64>>())
    }
}

/// Runs `scenario` with seeds `scenario.seed + k`, k < `options.seeds`, one after another (each
/// run is internally parallel), and aggregates.
pub fn monte_carlo(
    scenario: &Scenario,
    out_dir: &Path,
    options: &MonteCarloOptions,
) -> Result<MonteCarloBudget, MonteCarloError> {
    if options.seeds == 0 {
        return Err(MonteCarloError::NoSeeds);
    }
    let started = std::time::Instant::now();
    let mut seeds = Vec::new();
    let mut per_seed = Vec::new();
    let mut pooled_w = Vec::new();
    let mut pooled_a = Vec::new();
    let mut files = Vec::new();
    for k in 0..options.seeds {
        let record = run_one(scenario, k, options, &out_dir.join("seed0"))?;
        pooled_w.extend(record.omega_err_rad_s);
        pooled_a.extend(record.alpha_err_rad_s2);
        files.extend(record.files);
        seeds.push(record.seed);
        per_seed.push(record.budget);
    }
    let json = aggregate(&per_seed);
    let mut mc = MonteCarloBudget {
        seeds,
        per_seed,
        json,
        pooled_omega_err_rad_s: pooled_w,
        pooled_alpha_err_rad_s2: pooled_a,
        elapsed_s: 0.0,
        files,
    };
    if options.write_files {
        mc.files
            .extend(write_outputs(&mc, &scenario.name, out_dir)?);
    }
    mc.elapsed_s = started.elapsed().as_secs_f64();
    Ok(mc)
}

/// What one seed contributes (the record of a work unit).
#[derive(Debug, Clone, serde::Serialize, serde::Deserialize)]
pub struct SeedRecord {
    pub seed: u64,
    pub budget: Budget,
    /// Fused-signal errors per frame, rad/s and rad/s².
    pub omega_err_rad_s: Vec<f64>,
    pub alpha_err_rad_s2: Vec<f64>,
    #[serde(skip)]
    pub files: Vec<PathBuf>,
}

/// Runs seed `scenario.seed + k`; with `first_seed_files`, seed 0 writes its full run into
/// `seed0_dir`.
fn run_one(
    scenario: &Scenario,
    k: usize,
    options: &MonteCarloOptions,
    seed0_dir: &Path,
) -> Result<SeedRecord, MonteCarloError> {
    let seed = scenario.seed.wrapping_add(k as u64);
    let mut s = scenario.clone();
    s.seed = seed;
    let first = k == 0 && options.first_seed_files;
    let run_options = RunOptions {
        roi: options.roi,
        plots: first,
        write_files: first,
        ..RunOptions::default()
    };
    let out = run(&s, seed0_dir, &run_options, &|_, _| {})
        .map_err(|source| MonteCarloError::Run { seed, source })?;
    let fused = out.signals.iter().find(|e| e.signal == "fused");
    Ok(SeedRecord {
        seed,
        omega_err_rad_s: fused.map(|f| f.omega_err_rad_s.clone()).unwrap_or_default(),
        alpha_err_rad_s2: fused
            .map(|f| f.alpha_err_rad_s2.clone())
            .unwrap_or_default(),
        files: out.files,
        budget: out.budget,
    })
}

/// The aggregated study from the records in seed order.
fn from_records(records: Vec<SeedRecord>) -> MonteCarloBudget {
    let mut mc = MonteCarloBudget {
        seeds: Vec::new(),
        per_seed: Vec::new(),
        json: Value::Null,
        pooled_omega_err_rad_s: Vec::new(),
        pooled_alpha_err_rad_s2: Vec::new(),
        elapsed_s: 0.0,
        files: Vec::new(),
    };
    for r in records {
        mc.seeds.push(r.seed);
        mc.pooled_omega_err_rad_s.extend(r.omega_err_rad_s);
        mc.pooled_alpha_err_rad_s2.extend(r.alpha_err_rad_s2);
        mc.per_seed.push(r.budget);
    }
    mc.json = aggregate(&mc.per_seed);
    mc
}

/// How to run a Monte Carlo study as a command.
pub struct MonteCarloRun<'a> {
    pub seeds: usize,
    pub roi: bool,
    /// Only this shard's seeds, into `DIR/shards/I/` (None: all seeds into `DIR`).
    pub shard: Option<Shard>,
    /// Discard seeds computed from other inputs instead of refusing them.
    pub restart: bool,
    pub control: &'a Control<'a>,
}

/// What [`monte_carlo_study`] or [`merge_monte_carlo`] did.
#[derive(Debug, Clone)]
pub struct MonteCarloOutcome {
    pub report: shard::RunReport,
    /// The aggregated study (when this call completed it; None when resumed complete or partial).
    pub budget: Option<MonteCarloBudget>,
}

/// The Monte Carlo study as work units.
struct McStudy<'a> {
    scenario: Option<&'a Scenario>,
    name: String,
    options: MonteCarloOptions,
    manifest: Manifest,
    result: std::sync::Mutex<Option<MonteCarloBudget>>,
}

impl<'a> McStudy<'a> {
    fn new(scenario: &'a Scenario, seeds: usize, roi: bool) -> Self {
        let mut inputs = BTreeMap::new();
        inputs.insert(
            "scenario".to_string(),
            serde_json::to_value(scenario).unwrap_or_default(),
        );
        inputs.insert("roi".to_string(), Value::Bool(roi));
        Self {
            scenario: Some(scenario),
            name: scenario.name.clone(),
            options: MonteCarloOptions {
                seeds,
                roi,
                write_files: true,
                first_seed_files: true,
            },
            manifest: Manifest::new("montecarlo", seeds, inputs),
            result: std::sync::Mutex::new(None),
        }
    }
}

impl Study for McStudy<'_> {
    type Error = MonteCarloError;

    fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    fn run_unit(&self, unit: usize, work_dir: &Path) -> Result<String, MonteCarloError> {
        let scenario = self.scenario.ok_or(MonteCarloError::NoSeeds)?;
        let r = run_one(scenario, unit, &self.options, &work_dir.join("seed0"))?;
        toml::to_string(&r).map_err(|source| MonteCarloError::RecordWrite {
            file: work_dir.into(),
            unit,
            source,
        })
    }

    fn finalize(
        &self,
        records: &[String],
        unit_dirs: UnitDirs,
        out_dir: &Path,
    ) -> Result<(), MonteCarloError> {
        let parsed = records
            .iter()
            .enumerate()
            .map(|(unit, text)| {
                toml::from_str::<SeedRecord>(text).map_err(|source| MonteCarloError::RecordRead {
                    file: unit_dirs(unit),
                    unit,
                    source: Box::new(source),
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        let mut mc = from_records(parsed);
        mc.files = write_outputs(&mc, &self.name, out_dir)?;
        // Seed 0's full run: already in place on one machine, in its shard's folder otherwise.
        let seed0 = unit_dirs(0).join("seed0");
        if unit_dirs(0) != out_dir && seed0.is_dir() {
            crate::io::output_dir::link_tree(&seed0, &out_dir.join("seed0"))?;
        }
        *self.result.lock().unwrap_or_else(|p| p.into_inner()) = Some(mc);
        Ok(())
    }

    fn unit_name(&self, unit: usize) -> String {
        format!("seed index {unit}")
    }

    /// Seed 0's full run, which the outputs carry as `seed0/`.
    fn required_files(&self, unit: usize) -> Vec<String> {
        match unit {
            0 => SEED0_FILES.iter().map(|f| format!("seed0/{f}")).collect(),
            _ => Vec::new(),
        }
    }
}

/// The files of seed 0's full run that a merge requires.
const SEED0_FILES: [&str; 3] = ["tracks.csv", "kinematics.csv", "budget.json"];

/// `geneva montecarlo`: the study into `out_dir` (or one shard of it), resumable, committed all
/// at once; seeds run in parallel in the current rayon pool.
pub fn monte_carlo_study(
    scenario: &Scenario,
    out_dir: &Path,
    run: &MonteCarloRun,
) -> Result<MonteCarloOutcome, MonteCarloError> {
    if run.seeds == 0 {
        return Err(MonteCarloError::NoSeeds);
    }
    let study = McStudy::new(scenario, run.seeds, run.roi);
    let report = match run.shard {
        Some(s) => shard::run_shard(&study, out_dir, s, run.restart, run.control)?,
        None => shard::run_whole(&study, out_dir, run.restart, run.control)?,
    };
    let budget = study.result.into_inner().unwrap_or_else(|p| p.into_inner());
    Ok(MonteCarloOutcome { report, budget })
}

/// Merges the shards of `out_dir` (the study's inputs are read from their manifests).
pub fn merge_monte_carlo(out_dir: &Path) -> Result<MonteCarloOutcome, MonteCarloError> {
    let shards = out_dir.join(shard::SHARDS);
    if let Err(source) = std::fs::read_dir(&shards) {
        return Err(MonteCarloError::NoShards {
            dir: shards.clone(),
            source,
        });
    }
    // The inputs as the first complete shard recorded them (never a lock file or a shard
    // still being written); every shard is checked against them by the merge.
    let mut manifest = None;
    for folder in shard::complete_shard_folders(out_dir)? {
        if let Some(m) = Manifest::read(&folder)? {
            manifest = Some(m);
            break;
        }
    }
    let manifest = manifest.ok_or_else(|| MonteCarloError::NoCompleteShard {
        dir: shards.clone(),
    })?;
    let name = manifest.inputs["scenario"]["name"]
        .as_str()
        .unwrap_or("montecarlo")
        .to_string();
    let study = McStudy {
        scenario: None,
        name,
        options: MonteCarloOptions::default(),
        manifest,
        result: std::sync::Mutex::new(None),
    };
    let report = shard::merge(&study, out_dir)?;
    let budget = study.result.into_inner().unwrap_or_else(|p| p.into_inner());
    Ok(MonteCarloOutcome { report, budget })
}

/// The aggregated budget: the per-seed budgets' JSON averaged leaf by leaf, `seeds` = N, frame
/// counts summed over seeds, and `ci95` beside every statistics block.
pub fn aggregate(per_seed: &[Budget]) -> Value {
    let values: Vec<Value> = per_seed
        .iter()
        .map(|b| serde_json::to_value(b).unwrap_or(Value::Null))
        .collect();
    let mut json = mean_of(&values.iter().collect::<Vec<_>>());
    if let Value::Object(map) = &mut json {
        map.insert("seeds".into(), Value::from(per_seed.len()));
        let total: usize = per_seed.iter().map(|b| b.frames.total).sum();
        let detected: usize = per_seed.iter().map(|b| b.frames.detected).sum();
        let mut frames = Map::new();
        frames.insert("total".into(), Value::from(total));
        frames.insert("detected".into(), Value::from(detected));
        map.insert("frames".into(), Value::Object(frames));
    }
    json
}

fn as_f64(v: &Value) -> f64 {
    v.as_f64().unwrap_or(f64::NAN)
}

/// Leaf-wise mean of JSON trees with the same shape: numbers are averaged, booleans become true
/// only when true for every seed, strings are taken from the first; objects that carry
/// statistics (`rms` or `fraction`) get a `ci95` object with [low, high] per numeric key.
fn mean_of(values: &[&Value]) -> Value {
    let Some(first) = values.first() else {
        return Value::Null;
    };
    match first {
        Value::Object(map) => {
            let mut out = Map::new();
            let mut ci = Map::new();
            for (key, v0) in map {
                let children: Vec<&Value> = values.iter().filter_map(|v| v.get(key)).collect();
                out.insert(key.clone(), mean_of(&children));
                if v0.is_number() || v0.is_null() {
                    let xs: Vec<f64> = children.iter().map(|c| as_f64(c)).collect();
                    let m = MeanCi::of(&xs);
                    ci.insert(
                        key.clone(),
                        Value::Array(vec![
                            finite_or_null(m.ci95_low),
                            finite_or_null(m.ci95_high),
                        ]),
                    );
                }
            }
            if map.contains_key("rms") || map.contains_key("fraction") {
                out.insert("ci95".into(), Value::Object(ci));
            }
            Value::Object(out)
        }
        Value::Number(_) | Value::Null => {
            let xs: Vec<f64> = values.iter().map(|v| as_f64(v)).collect();
            finite_or_null(MeanCi::of(&xs).mean)
        }
        Value::Bool(_) => Value::Bool(values.iter().all(|v| v.as_bool() == Some(true))),
        other => (*other).clone(),
    }
}

/// Per-seed CSV columns: (header, value of a budget).
type Column = (&'static str, fn(&Budget) -> f64);

/// Columns of `per_seed.csv`: the fused signal against the resolvable truth, then against the
/// raw truth, and the aliasing part.
pub const COLUMNS: [Column; 19] = [
    ("frames_total", |b| b.frames.total as f64),
    ("frames_detected", |b| b.frames.detected as f64),
    ("theta_bias_rad", |b| b.theta.bias),
    ("theta_rms_rad", |b| b.theta.rms),
    ("theta_p95_rad", |b| b.theta.p95),
    ("theta_max_rad", |b| b.theta.max),
    ("omega_bias_rad_s", |b| b.omega.bias),
    ("omega_rms_rad_s", |b| b.omega.rms),
    ("omega_p95_rad_s", |b| b.omega.p95),
    ("omega_max_rad_s", |b| b.omega.max),
    ("alpha_bias_rad_s2", |b| b.alpha.bias),
    ("alpha_rms_rad_s2", |b| b.alpha.rms),
    ("alpha_p95_rad_s2", |b| b.alpha.p95),
    ("alpha_max_rad_s2", |b| b.alpha.max),
    ("omega_raw_rms_rad_s", |b| b.raw.overall.omega.rms),
    ("alpha_raw_rms_rad_s2", |b| b.raw.overall.alpha.rms),
    ("alpha_aliasing_rms_rad_s2", |b| {
        b.aliasing.overall.alpha.rms
    }),
    ("theta_exceedance_fraction", |b| {
        b.bounds
            .get("fused")
            .map_or(f64::NAN, |x| x.theta_exceedance.fraction)
    }),
    ("omega_seed_doubled_exceedance_fraction", |b| {
        b.bounds
            .get("fused")
            .map_or(f64::NAN, |x| x.omega_seed_doubled_exceedance.fraction)
    }),
];

fn write_outputs(
    mc: &MonteCarloBudget,
    name: &str,
    out_dir: &Path,
) -> Result<Vec<PathBuf>, MonteCarloError> {
    std::fs::create_dir_all(out_dir).map_err(FileError::io(out_dir))?;
    let json_path = out_dir.join("budget.json");
    let text = serde_json::to_string_pretty(&mc.json).map_err(FileError::json(&json_path))?;
    std::fs::write(&json_path, text + "\n").map_err(FileError::io(&json_path))?;

    let csv_path = out_dir.join("per_seed.csv");
    let mut w = csv::Writer::from_path(&csv_path).map_err(FileError::csv(&csv_path))?;
    let mut header = vec!["seed".to_string()];
    header.extend(COLUMNS.iter().map(|c| c.0.to_string()));
    w.write_record(&header).map_err(FileError::csv(&csv_path))?;
    for (seed, b) in mc.seeds.iter().zip(&mc.per_seed) {
        let mut row = vec![seed.to_string()];
        row.extend(COLUMNS.iter().map(|c| format!("{:e}", (c.1)(b))));
        w.write_record(&row).map_err(FileError::csv(&csv_path))?;
    }
    w.flush().map_err(FileError::io(&csv_path))?;

    let hist_path = out_dir.join("error_histograms.png");
    histogram_png(
        &hist_path,
        &[
            (
                format!(
                    "{name}: fused ω2 error against the resolvable truth, {} seeds pooled",
                    mc.per_seed.len()
                ),
                "ω2 error (rad/s)".to_string(),
                mc.pooled_omega_err_rad_s.clone(),
            ),
            (
                format!(
                    "{name}: fused α2 error against the resolvable truth, {} seeds pooled",
                    mc.per_seed.len()
                ),
                "α2 error (rad/s²)".to_string(),
                mc.pooled_alpha_err_rad_s2.clone(),
            ),
        ],
        40,
    )?;
    Ok(vec![json_path, csv_path, hist_path])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mean_of_averages_numbers_and_adds_ci_to_stat_blocks() {
        let a = serde_json::json!({"omega": {"rms": 1.0, "n": 10}, "ok": true, "name": "x"});
        let b = serde_json::json!({"omega": {"rms": 3.0, "n": 20}, "ok": false, "name": "x"});
        let m = mean_of(&[&a, &b]);
        assert_eq!(m["omega"]["rms"], 2.0);
        assert_eq!(m["omega"]["n"], 15.0);
        assert_eq!(m["ok"], false);
        assert_eq!(m["name"], "x");
        // t₀.₉₇₅(1) = 12.7062, s = √2, half = t·√2/√2 = t.
        let t = crate::numeric::dist::t975(1);
        assert!((t - 12.706_204_736).abs() < 1e-8);
        let ci = m["omega"]["ci95"]["rms"].as_array().unwrap();
        assert!((ci[0].as_f64().unwrap() - (2.0 - t)).abs() < 1e-9);
        assert!((ci[1].as_f64().unwrap() - (2.0 + t)).abs() < 1e-9);
        assert!(
            m.get("ci95").is_none(),
            "top level is not a statistics block"
        );
    }

    #[cfg(feature = "opencv-detector")]
    #[test]
    fn the_study_resumes_shards_and_merges_into_the_bytes_of_one_uninterrupted_run() {
        let scenario = crate::scenario::load_any("fast").unwrap();
        let root = tempfile::tempdir().unwrap();
        let files = [
            "budget.json",
            "per_seed.csv",
            "error_histograms.png",
            "seed0/kinematics.csv",
            "seed0/tracks.csv",
            "manifest.json",
        ];
        let read = |dir: &Path| -> Vec<Vec<u8>> {
            files
                .iter()
                .map(|f| std::fs::read(dir.join(f)).unwrap_or_else(|e| panic!("{f}: {e}")))
                .collect()
        };
        let run = |dir: &Path, shard: Option<Shard>, stop_after: usize| {
            let done = std::sync::atomic::AtomicUsize::new(0);
            let progress = |_: usize, _: usize| {
                done.fetch_add(1, std::sync::atomic::Ordering::SeqCst);
            };
            let stop = || done.load(std::sync::atomic::Ordering::SeqCst) >= stop_after;
            let control = Control {
                progress: &progress,
                stop: &stop,
            };
            let r = MonteCarloRun {
                seeds: 3,
                roi: true,
                shard,
                restart: false,
                control: &control,
            };
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(1)
                .build()
                .unwrap();
            pool.install(|| monte_carlo_study(&scenario, dir, &r))
                .unwrap()
        };
        // Interrupted after one seed, then resumed: the seed is not run again.
        let whole = root.path().join("whole");
        let first = run(&whole, None, 1);
        assert!(!first.report.complete && first.report.units_run == 1);
        assert!(!whole.exists(), "nothing final while seeds are missing");
        let second = run(&whole, None, usize::MAX);
        assert!(second.report.complete);
        assert_eq!(
            (second.report.units_resumed, second.report.units_run),
            (1, 2)
        );
        assert_eq!(second.budget.as_ref().unwrap().seeds.len(), 3);
        // The same as the in-memory study (records round-trip exactly, NaN included).
        let direct = root.path().join("direct");
        let options = MonteCarloOptions {
            seeds: 3,
            first_seed_files: true,
            ..MonteCarloOptions::default()
        };
        monte_carlo(&scenario, &direct, &options).unwrap();
        for f in ["budget.json", "per_seed.csv", "error_histograms.png"] {
            assert_eq!(
                std::fs::read(whole.join(f)).unwrap(),
                std::fs::read(direct.join(f)).unwrap(),
                "{f}"
            );
        }
        // Two shards and a merge: the same bytes.
        let sharded = root.path().join("sharded");
        for i in [1, 0] {
            let r = run(&sharded, Some(Shard::new(i, 2).unwrap()), usize::MAX);
            assert!(r.report.complete);
        }
        let merged = merge_monte_carlo(&sharded).unwrap();
        assert_eq!(merged.budget.unwrap().seeds, second.budget.unwrap().seeds);
        assert_eq!(read(&sharded), read(&whole));
        // A shard that lost seed 0's run is refused, naming it (it merged without seed0/).
        std::fs::remove_dir_all(sharded.join("shards/0/seed0")).unwrap();
        let e = merge_monte_carlo(&sharded).unwrap_err().to_string();
        assert!(e.contains("seed0/") && e.contains("missing"), "{e}");
        assert_eq!(
            read(&sharded),
            read(&whole),
            "the merged folder is untouched"
        );
    }

    #[test]
    fn nan_becomes_null_and_is_skipped() {
        let a = serde_json::json!({"rms": null});
        let b = serde_json::json!({"rms": 4.0});
        let m = mean_of(&[&a, &b]);
        assert_eq!(m["rms"], 4.0);
        assert_eq!(m["ci95"]["rms"][0], Value::Null);
    }
}
