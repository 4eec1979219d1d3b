//! Reproducibility of the committed reports: regenerating `reports/fast/` gives exactly the
//! committed `budget.json` numbers (the whole pipeline is deterministic for a seed), and the
//! Monte Carlo budget has the documented layout.

#![cfg(feature = "opencv-detector")]

use geneva_vision::pipeline::reports::fast_report;
use serde_json::Value;
use std::path::Path;

fn committed() -> Value {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("reports/fast/budget.json");
    let text = std::fs::read_to_string(&path).unwrap_or_else(|e| {
        panic!(
            "{}: {e} (run `geneva reports --out reports`)",
            path.display()
        )
    });
    serde_json::from_str(&text).expect("committed budget.json parses")
}

#[test]
fn fast_report_reproduces_the_committed_budget() {
    let dir = tempfile::tempdir().unwrap();
    let seeds = committed()["seeds"].as_u64().expect("seeds") as usize;
    let mc = fast_report(dir.path(), seeds).expect("fast report");
    let text = std::fs::read_to_string(dir.path().join("budget.json")).unwrap();
    let fresh: Value = serde_json::from_str(&text).unwrap();
    // Parsed from text on both sides (serde_json's default float parsing is not bit-exact
    // against an in-memory f64, but text → value is deterministic).
    assert_eq!(mc.seeds.len(), seeds);
    // The fresh run's numbers, derived again from its own per-frame and per-seed files.
    rms_errors_match_an_independent_derivation(dir.path(), &fresh);
    let old = committed();
    if fresh != old {
        // Name the first differing number so a regression is easy to locate.
        let diff = first_difference(&fresh, &old, String::new());
        panic!("reports/fast/budget.json differs from a fresh run at {diff:?}");
    }
    assert!(dir.path().join("README.md").exists());
    assert!(dir.path().join("error_histograms.png").exists());
    assert!(dir.path().join("per_seed.csv").exists());
}

fn first_difference(a: &Value, b: &Value, path: String) -> Option<(String, Value, Value)> {
    match (a, b) {
        (Value::Object(x), Value::Object(y)) => {
            for (k, v) in x {
                let p = format!("{path}.{k}");
                match y.get(k) {
                    Some(w) => {
                        if let Some(d) = first_difference(v, w, p) {
                            return Some(d);
                        }
                    }
                    None => return Some((p, v.clone(), Value::Null)),
                }
            }
            y.keys()
                .find(|k| !x.contains_key(*k))
                .map(|k| (format!("{path}.{k}"), Value::Null, y[k].clone()))
        }
        _ if a == b => None,
        _ => Some((path, a.clone(), b.clone())),
    }
}

#[test]
fn committed_budget_has_the_documented_layout() {
    let b = committed();
    let n = b["seeds"].as_u64().unwrap();
    assert!(n >= 2, "a Monte Carlo of at least two seeds");
    for q in ["theta", "omega", "alpha"] {
        for stat in ["bias", "rms", "p95", "max"] {
            assert!(b[q][stat].is_number(), "{q}.{stat}");
            let ci = b[q]["ci95"][stat].as_array().expect("ci95 pair");
            let (lo, hi) = (ci[0].as_f64().unwrap(), ci[1].as_f64().unwrap());
            let mean = b[q][stat].as_f64().unwrap();
            assert!(lo <= mean && mean <= hi, "{q}.{stat}: {lo} ≤ {mean} ≤ {hi}");
        }
    }
    assert!(b["phases"]["drive"]["omega"]["rms"].is_number());
    assert!(b["signals"]["centre"]["phases"]["drive"]["alpha"]["ci95"]["rms"].is_array());
    assert!(b["bounds"]["fused"]["theta_exceedance"]["fraction"].is_number());
    let total = b["frames"]["total"].as_u64().unwrap();
    assert!(total >= b["frames"]["detected"].as_u64().unwrap() && total > 0);
}

/// Reads a CSV of a `fast` report folder as (header, rows of fields).
fn report_csv(dir: &Path, name: &str) -> (Vec<String>, Vec<Vec<String>>) {
    let path = dir.join(name);
    let text = std::fs::read_to_string(&path)
        .unwrap_or_else(|e| panic!("{}: {e} (run `cargo xtask reports`)", path.display()));
    let mut lines = text.lines();
    let split = |l: &str| l.split(',').map(str::to_string).collect::<Vec<_>>();
    let header = split(lines.next().expect("a header line"));
    (header, lines.map(split).collect())
}

fn column(header: &[String], name: &str) -> usize {
    header
        .iter()
        .position(|h| h == name)
        .unwrap_or_else(|| panic!("no column `{name}` in {header:?}"))
}

/// The headline θ2/ω2/α2 RMS errors of the committed budget (and, from the test above, of a
/// fresh run), derived again without the
/// pipeline's statistics code: seed 0's RMS straight from its per-frame kinematics
/// (measured − resolvable truth of the fused signal), and the Monte Carlo mean and 95 % interval
/// from the per-seed RMS column, with Student's t for n − 1 dof written out here (t₀.₉₇₅ of 2
/// dof is 4.30265, tables; the library's table rounds it to 4.303, hence the 2e-4 relative
/// tolerance on the half-width).
#[test]
fn committed_rms_errors_match_an_independent_derivation() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("reports/fast");
    rms_errors_match_an_independent_derivation(&dir, &committed());
}

fn rms_errors_match_an_independent_derivation(dir: &Path, b: &Value) {
    let (header, rows) = report_csv(dir, "per_seed.csv");
    let n = rows.len();
    assert_eq!(n as u64, b["seeds"].as_u64().unwrap());
    let t975 = [
        f64::NAN,
        12.706_204_736,
        4.302_652_730,
        3.182_446_305,
        2.776_445_105,
    ];
    assert!(n >= 2 && n < t975.len(), "{n} seeds: extend the t table");
    let (kin_header, kin) = report_csv(dir, "seed0/kinematics.csv");
    let signal = column(&kin_header, "signal");
    for (q, per_seed, measured, truth) in [
        (
            "theta",
            "theta_rms_rad",
            "theta2_rad",
            "resolvable_theta2_rad",
        ),
        (
            "omega",
            "omega_rms_rad_s",
            "omega2_rad_s",
            "resolvable_omega2_rad_s",
        ),
        (
            "alpha",
            "alpha_rms_rad_s2",
            "alpha2_rad_s2",
            "resolvable_alpha2_rad_s2",
        ),
    ] {
        // Seed 0 (the first row) from its frames.
        let (m, r) = (column(&kin_header, measured), column(&kin_header, truth));
        let errors: Vec<f64> = kin
            .iter()
            .filter(|row| row[signal] == "fused")
            .map(|row| row[m].parse::<f64>().unwrap() - row[r].parse::<f64>().unwrap())
            .collect();
        assert!(!errors.is_empty(), "no fused rows in seed0/kinematics.csv");
        let rms0 = (errors.iter().map(|e| e * e).sum::<f64>() / errors.len() as f64).sqrt();
        let col = column(&header, per_seed);
        let values: Vec<f64> = rows.iter().map(|r| r[col].parse().unwrap()).collect();
        assert!(
            (rms0 / values[0] - 1.0).abs() < 1e-9,
            "{q}: seed 0 RMS from kinematics.csv {rms0} vs per_seed.csv {}",
            values[0]
        );
        // The Monte Carlo mean and its interval.
        let mean = values.iter().sum::<f64>() / n as f64;
        let sd = (values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64).sqrt();
        let half = t975[n - 1] * sd / (n as f64).sqrt();
        let headline = b[q]["rms"].as_f64().unwrap();
        let ci = b[q]["ci95"]["rms"].as_array().unwrap();
        let (lo, hi) = (ci[0].as_f64().unwrap(), ci[1].as_f64().unwrap());
        assert!(
            (headline / mean - 1.0).abs() < 1e-12,
            "{q}: committed RMS {headline} vs mean of per-seed RMS {mean}"
        );
        assert!(
            ((hi - lo) / (2.0 * half) - 1.0).abs() < 2e-4
                && ((lo + hi) / 2.0 / mean - 1.0).abs() < 1e-9,
            "{q}: committed 95 % CI [{lo}, {hi}] vs {mean} ± {half}"
        );
    }
}
