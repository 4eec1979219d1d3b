//! Helpers shared by the integration tests that run the `geneva` binary.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Command, Output};

/// Runs `geneva ARGS…` in `dir`.
pub fn geneva(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_geneva"))
        .args(args)
        .current_dir(dir)
        .output()
        .unwrap()
}

pub fn stderr(o: &Output) -> String {
    String::from_utf8_lossy(&o.stderr).into_owned()
}

/// Checks a ranked entry of `diagnosis.json` whose refits on fresh seeds were done: each
/// parameter's stated value and ± are the pool of the first fit's and the refits' (the mean of
/// the fits, σ = √(mean σᵢ² + sample variance / n); `diagnose::fit_noise`), recomputed here
/// from the JSON alone. A parameter the first fit left undetermined (± null) must keep its
/// first value. Returns the number of refits.
pub fn check_pooled_refit(entry: &serde_json::Value) -> Result<usize, String> {
    let refit = &entry["refit"];
    if refit["status"] != "done" {
        return Err(format!("refit not done: {entry}"));
    }
    let runs = refit["runs"]
        .as_array()
        .ok_or_else(|| format!("no runs: {entry}"))?;
    let params = entry["params"]
        .as_object()
        .ok_or_else(|| format!("no params: {entry}"))?;
    for (key, stated) in params {
        let stated = stated.as_f64().ok_or_else(|| format!("{key}: {entry}"))?;
        let first = refit["params_first_fit"][key].as_f64();
        let Some(first_sd) = refit["params_std_first_fit"][key].as_f64() else {
            if first != Some(stated) || !entry["params_std"][key].is_null() {
                return Err(format!("{key}: undetermined, yet pooled: {entry}"));
            }
            continue;
        };
        let first = first.ok_or_else(|| format!("{key}: no first value: {entry}"))?;
        let mut fits = vec![(first, first_sd)];
        for run in runs {
            if let (Some(v), Some(s)) =
                (run["params"][key].as_f64(), run["params_std"][key].as_f64())
            {
                fits.push((v, s));
            }
        }
        let n = fits.len() as f64;
        let mean = fits.iter().map(|f| f.0).sum::<f64>() / n;
        let sd = if fits.len() < 2 {
            first_sd
        } else {
            let var = fits.iter().map(|f| (f.0 - mean).powi(2)).sum::<f64>() / (n - 1.0);
            (fits.iter().map(|f| f.1 * f.1).sum::<f64>() / n + var / n).sqrt()
        };
        let stated_sd = entry["params_std"][key]
            .as_f64()
            .ok_or_else(|| format!("{key}: no ±: {entry}"))?;
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-12 * b.abs().max(1e-300);
        if !close(stated, mean) || !close(stated_sd, sd) {
            return Err(format!(
                "{key}: stated {stated} ± {stated_sd}, pooled {mean} ± {sd}: {entry}"
            ));
        }
    }
    Ok(runs.len())
}
