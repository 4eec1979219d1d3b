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
