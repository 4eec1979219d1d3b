//! `geneva montecarlo`: one scenario run with N seeds (base seed + k), aggregated into a
//! Monte Carlo budget — the single-run `budget.json` layout with every number replaced by its
//! mean over seeds and a `ci95` object beside each statistics block — plus per-seed rows and
//! pooled error histograms.

use super::run::{run, RunError, RunOptions};
use crate::budget::report::Budget;
use crate::budget::MeanCi;
use crate::plot::histogram::histogram_png;
use crate::scenario::Scenario;
use serde_json::{Map, Value};
use std::path::{Path, PathBuf};

#[derive(Debug, thiserror::Error)]
pub enum MonteCarloError {
    #[error("seed {seed}: {source}")]
    Run { seed: u64, source: RunError },
    #[error("monte carlo needs at least one seed")]
    NoSeeds,
    #[error("{file}: {message}")]
    Write { file: PathBuf, message: String },
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
        let out = run(&s, &out_dir.join("seed0"), &run_options, &|_, _| {})
            .map_err(|source| MonteCarloError::Run { seed, source })?;
        if let Some(fused) = out.signals.iter().find(|e| e.signal == "fused") {
            pooled_w.extend(fused.omega_err_rad_s.iter().copied());
            pooled_a.extend(fused.alpha_err_rad_s2.iter().copied());
        }
        files.extend(out.files);
        seeds.push(seed);
        per_seed.push(out.budget);
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

/// A JSON number, or null for NaN/∞ (JSON has neither).
fn number(x: f64) -> Value {
    serde_json::Number::from_f64(x)
        .map(Value::Number)
        .unwrap_or(Value::Null)
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
                        Value::Array(vec![number(m.ci95_low), number(m.ci95_high)]),
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
            number(MeanCi::of(&xs).mean)
        }
        Value::Bool(_) => Value::Bool(values.iter().all(|v| v.as_bool() == Some(true))),
        other => (*other).clone(),
    }
}

fn write_err(file: &Path, e: impl ToString) -> MonteCarloError {
    MonteCarloError::Write {
        file: file.to_path_buf(),
        message: e.to_string(),
    }
}

/// Per-seed CSV columns: (header, value of a budget).
type Column = (&'static str, fn(&Budget) -> f64);

/// Columns of `per_seed.csv`.
pub const COLUMNS: [Column; 16] = [
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
    std::fs::create_dir_all(out_dir).map_err(|e| write_err(out_dir, e))?;
    let json_path = out_dir.join("budget.json");
    let text = serde_json::to_string_pretty(&mc.json).map_err(|e| write_err(&json_path, e))?;
    std::fs::write(&json_path, text + "\n").map_err(|e| write_err(&json_path, e))?;

    let csv_path = out_dir.join("per_seed.csv");
    let mut w = csv::Writer::from_path(&csv_path).map_err(|e| write_err(&csv_path, e))?;
    let mut header = vec!["seed".to_string()];
    header.extend(COLUMNS.iter().map(|c| c.0.to_string()));
    w.write_record(&header)
        .map_err(|e| write_err(&csv_path, e))?;
    for (seed, b) in mc.seeds.iter().zip(&mc.per_seed) {
        let mut row = vec![seed.to_string()];
        row.extend(COLUMNS.iter().map(|c| format!("{:e}", (c.1)(b))));
        w.write_record(&row).map_err(|e| write_err(&csv_path, e))?;
    }
    w.flush().map_err(|e| write_err(&csv_path, e))?;

    let hist_path = out_dir.join("error_histograms.png");
    histogram_png(
        &hist_path,
        &[
            (
                format!("{name}: fused ω2 error, {} seeds pooled", mc.per_seed.len()),
                "ω2 error (rad/s)".to_string(),
                mc.pooled_omega_err_rad_s.clone(),
            ),
            (
                format!("{name}: fused α2 error, {} seeds pooled", mc.per_seed.len()),
                "α2 error (rad/s²)".to_string(),
                mc.pooled_alpha_err_rad_s2.clone(),
            ),
        ],
        40,
    )
    .map_err(|e| write_err(&hist_path, e.message))?;
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
        // t(1) = 12.706, s = √2, half = 12.706·√2/√2 = 12.706.
        let ci = m["omega"]["ci95"]["rms"].as_array().unwrap();
        assert!((ci[0].as_f64().unwrap() - (2.0 - 12.706)).abs() < 1e-9);
        assert!((ci[1].as_f64().unwrap() - (2.0 + 12.706)).abs() < 1e-9);
        assert!(
            m.get("ci95").is_none(),
            "top level is not a statistics block"
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
