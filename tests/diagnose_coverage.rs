//! The coverage of a fitted value's stated 95 % interval, over many footages: a drive-speed
//! variation (15 % slower mid-engagement) withheld from corner tracks of the `fast` rig on 4 s,
//! each footage on its own data seed, diagnosed through the binary with the defaults a user
//! runs (3 fit seeds, 2 refits on fresh seeds pooled into the ±) and the drive-speed candidate
//! alone: this is about the interval, not the ranking (`tests/diagnose_sources.rs` ranks every
//! candidate on such a track).
//!
//! The claim is coverage ≥ 95 %. With n footages the count of intervals holding the truth is
//! binomial; the test fails when the count is one that a 95 % coverage gives with probability
//! at most 1 % (the bound follows from n: at n = 5 at least 3 must hold, at n = 40 at least 34).
//! CI runs `GENEVA_COVERAGE_CASES` footages (default 5); `cargo xtask statistics` runs 40.

#![cfg(feature = "opencv-detector")]

use common::geneva_ok as geneva;
use statrs::distribution::{Binomial, DiscreteCDF};

mod common;

const TRUTH: f64 = -0.15;

/// The least count of n intervals that must hold the truth: the smallest k with
/// P(X ≤ k) > `alpha` for X ~ Binomial(n, `coverage`), so any count below k is one a true
/// coverage gives with probability at most `alpha`.
fn least_covered(n: u64, coverage: f64, alpha: f64) -> u64 {
    let x = Binomial::new(coverage, n).expect("a valid binomial");
    (0..=n).find(|&k| x.cdf(k) > alpha).unwrap_or(n)
}

#[test]
fn the_binomial_bound_follows_from_the_count() {
    // P(X ≤ 2 | 5, 0.95) = 0.0012, P(X ≤ 3) = 0.0226: a count of 2 or fewer rejects.
    assert_eq!(least_covered(5, 0.95, 0.01), 3);
    // P(X ≤ 33 | 40, 0.95) = 0.0034, P(X ≤ 34) = 0.0139.
    assert_eq!(least_covered(40, 0.95, 0.01), 34);
}

/// One footage on data seed `seed`: whether the stated 95 % interval holds the truth.
fn covered(seed: u64) -> (bool, String) {
    let tmp = tempfile::tempdir().unwrap();
    let d = tmp.path();
    std::fs::write(
        d.join("nominal.toml"),
        "extend = \"fast\"\nduration_s = 4.0\n",
    )
    .unwrap();
    let resolved = geneva(
        d,
        &[
            "scenario",
            "show",
            "nominal.toml",
            "--with",
            &format!("drive_speed={TRUTH}"),
        ],
    );
    let footage = resolved.replace("\nseed = 7\n", &format!("\nseed = {seed}\n"));
    assert_ne!(footage, resolved, "the footage's seed is set");
    std::fs::write(d.join("footage.toml"), footage).unwrap();
    geneva(d, &["run", "footage.toml", "--out", "run"]);
    geneva(
        d,
        &[
            "diagnose",
            "--scenario",
            "nominal.toml",
            "--tracks",
            "run/tracks.csv",
            "--effects",
            "drive_speed",
            "--out",
            "diagnosis",
        ],
    );
    let text = std::fs::read_to_string(d.join("diagnosis/diagnosis.json")).unwrap();
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    assert_eq!(json["verdict"], "explained", "seed {seed}: {json:#}");
    let best = &json["ranking"][0];
    let v = best["params"]["variation_frac"].as_f64().unwrap();
    let ci = &best["params_ci95"]["variation_frac"];
    let (lo, hi) = (ci[0].as_f64().unwrap(), ci[1].as_f64().unwrap());
    let line = format!("seed {seed}: {v:.4} in [{lo:.4}, {hi:.4}]");
    (lo <= TRUTH && TRUTH <= hi, line)
}

#[test]
fn the_stated_95_percent_interval_holds_the_truth_on_95_percent_of_footages() {
    let n: u64 = std::env::var("GENEVA_COVERAGE_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(5);
    let lines: Vec<(bool, String)> = (0..n).map(|k| covered(1000 + k)).collect();
    let held = lines.iter().filter(|(c, _)| *c).count() as u64;
    for (c, line) in &lines {
        eprintln!("{line}{}", if *c { "" } else { "  (truth outside)" });
    }
    let least = least_covered(n, 0.95, 0.01);
    eprintln!("{held} of {n} intervals hold the truth (at least {least} must)");
    assert!(
        held >= least,
        "{held} of {n} intervals hold the truth {TRUTH}: a 95 % coverage gives {least} or more \
         with probability 0.99"
    );
}
