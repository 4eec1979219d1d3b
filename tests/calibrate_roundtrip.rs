//! `geneva calibrate` round trip: footage rendered from random scenarios with known parameters
//! is calibrated; every fitted value must lie within its reported 95 % interval in ≥ 90 % of the
//! comparisons and meet the accuracy targets (scale 0.5 %, centre 0.5 px, blur σ and noise σ
//! 10 %), and the calibrated scenario must re-render the footage down to its noise (≤ 1.2×).
//! CI runs `GENEVA_ROUNDTRIP_CASES` cases (default 6, fixed seed); `cargo xtask bench` runs more.

use geneva_vision::pipeline::calibrate_roundtrip::{run_case, summary};

#[test]
fn calibrate_recovers_random_rendered_scenarios() {
    let cases: usize = std::env::var("GENEVA_ROUNDTRIP_CASES")
        .ok()
        .and_then(|v| v.parse().ok())
        .unwrap_or(6);
    let mut results = Vec::new();
    for i in 0..cases {
        let dir = tempfile::tempdir().unwrap();
        let r = run_case(20261123, i, dir.path()).unwrap_or_else(|e| panic!("case {i}: {e}"));
        for c in &r.checks {
            if !c.within || c.target_met == Some(false) {
                eprintln!(
                    "case {i}: {} truth {} fitted {} (error {:.5}){}",
                    c.parameter,
                    c.truth,
                    c.fitted,
                    c.error,
                    if c.target_met == Some(false) {
                        " MISSES TARGET"
                    } else {
                        ""
                    }
                );
            }
        }
        results.push(r);
    }
    let text = summary(&results);
    eprintln!("{text}");
    let all: Vec<_> = results.iter().flat_map(|r| r.checks.iter()).collect();
    let within = all.iter().filter(|c| c.within).count() as f64 / all.len() as f64;
    assert!(
        within >= 0.9,
        "only {:.1} % within the reported uncertainty",
        within * 100.0
    );
    for r in &results {
        for c in &r.checks {
            assert_ne!(
                c.target_met,
                Some(false),
                "case {}: {} misses its accuracy target: {c:?}",
                r.index,
                c.parameter
            );
        }
        if let Some(q) = r.rerender_ratio {
            assert!(
                q <= 1.2,
                "case {}: re-render residual {q:.3} × the noise",
                r.index
            );
        }
    }
}
