//! A sweep on the default estimator (`kalman_rts` with automatic λ, the built-in `fast` rig's)
//! computes the impact SNR like any other differentiator: with the λ its runs resolved on their
//! measured series (the median over the point's runs), never refusing the point with "fix λ".

#![cfg(feature = "opencv-detector")]

use geneva_vision::budget::detectability::detectability;
use geneva_vision::estimate::Differentiator;
use std::path::Path;
use std::process::Command;

const SWEEP: &str = "base = \"fast\"\nseeds = 2\n\n\
[[axis]]\nname = \"fps\"\nfield = \"frame_timing.fps\"\nvalues = [30.0]\n\n\
[target]\nomega_rms_rad_s = 0.02\nalpha_rms_rad_s2 = 1.0\n\n\
[impact]\ndelta_omega_rad_s = 0.05\nduration_s = 0.002\nmin_snr = 3.0\n\n\
[cost]\norder = [\"pixels\", \"fps\"]\n";

fn rows(path: &Path) -> Vec<std::collections::HashMap<String, String>> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let header: Vec<String> = r.headers().unwrap().iter().map(String::from).collect();
    r.records()
        .map(|rec| {
            let rec = rec.unwrap();
            header
                .iter()
                .cloned()
                .zip(rec.iter().map(String::from))
                .collect()
        })
        .collect()
}

fn number(row: &std::collections::HashMap<String, String>, column: &str) -> f64 {
    row[column]
        .parse()
        .unwrap_or_else(|_| panic!("{column}: {}", row[column]))
}

#[test]
fn a_sweep_on_the_default_estimator_computes_the_impact_snr_with_its_runs_lambda() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    std::fs::write(d.join("sweep.toml"), SWEEP).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_geneva"))
        .current_dir(d)
        .args(["sweep", "sweep.toml", "--out", "s"])
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let scenario = geneva_vision::scenario::load_any("fast").unwrap();
    assert_eq!(
        scenario.estimator.differentiator,
        Differentiator::KalmanRts {
            lambda_per_s6: None
        },
        "the built-in fast rig runs the default estimator"
    );

    let runs = rows(&d.join("s/results.csv"));
    assert_eq!(runs.len(), 2);
    let mut lambdas: Vec<f64> = runs
        .iter()
        .map(|r| {
            assert_eq!(r["status"], "ok", "{}", r["error"]);
            number(r, "kalman_lambda_per_s6")
        })
        .collect();
    assert!(
        lambdas.iter().all(|l| l.is_finite() && *l > 0.0),
        "{lambdas:?}"
    );
    lambdas.sort_by(f64::total_cmp);
    let median = 0.5 * (lambdas[0] + lambdas[1]);

    let summary = rows(&d.join("s/summary.csv"));
    assert_eq!(summary.len(), 1);
    let s = &summary[0];
    assert_eq!(s["error"], "", "the point is not refused");
    let snr = number(s, "impact_snr");
    let expected = detectability(
        &Differentiator::KalmanRts {
            lambda_per_s6: Some(median),
        },
        number(s, "mean_frame_interval_s_mean"),
        0.05,
        0.002,
        number(s, "engaged_alpha_noise_rad_s2_mean"),
        3.0,
    )
    .unwrap();
    assert!(snr.is_finite() && snr > 0.0, "{snr}");
    assert!(
        (snr - expected.snr).abs() <= 1e-9 * expected.snr,
        "summary {snr} against {} from the runs' median λ {median}",
        expected.snr
    );
}
