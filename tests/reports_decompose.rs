//! End-to-end per-source decomposition on `fast` with exactly two effects on (pixel noise and
//! optical blur; lighting switched off in the base): every configuration runs, shares and the
//! interaction sum to one, and the files are written.

#![cfg(feature = "opencv-detector")]

use geneva_vision::pipeline::decompose::decompose_effects;
use geneva_vision::scenario::{load_any, with_overrides};
use std::path::Path;
use toml::Value;

#[test]
fn decomposition_of_fast_with_two_effects() {
    let fast = load_any("fast").unwrap();
    let base = with_overrides(
        &fast,
        &[
            ("effects.lighting.enabled".into(), Value::Boolean(false)),
            ("duration_s".into(), Value::Float(2.0)),
        ],
        Path::new("reports_decompose"),
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let d = decompose_effects(&base, 2, dir.path(), true).expect("decomposition");
    assert_eq!(d.effects_on, vec!["pixel_noise", "optical_blur"]);
    assert!(d.effects_off.contains(&"motion_blur".to_string()));
    for dec in [&d.omega, &d.alpha] {
        assert_eq!(dec.sources.len(), 2);
        let total: f64 = dec.sources.iter().map(|s| s.share).sum::<f64>() + dec.interaction_share;
        assert!((total - 1.0).abs() < 1e-9, "shares sum to {total}");
    }
    for runs in [&d.omega_runs, &d.alpha_runs] {
        // Quantisation alone already gives a non-zero error variance.
        assert!(runs.none > 0.0 && runs.all > 0.0);
        assert!(runs
            .alone
            .iter()
            .chain(&runs.left_out)
            .all(|(_, v)| v.is_finite() && *v > 0.0));
    }
    // With two effects, "pixel noise left out" and "optical blur alone" are the same scenario
    // (and vice versa): the deterministic pipeline must give identical variances.
    for runs in [&d.omega_runs, &d.alpha_runs] {
        assert_eq!(runs.left_out[0].1, runs.alone[1].1);
        assert_eq!(runs.left_out[1].1, runs.alone[0].1);
    }
    for f in [
        "decomposition.csv",
        "decomposition.md",
        "decomposition_omega.png",
        "decomposition_alpha.png",
    ] {
        assert!(dir.path().join(f).exists(), "{f}");
    }
    let md = std::fs::read_to_string(dir.path().join("decomposition.md")).unwrap();
    assert!(md.contains("| pixel_noise |") && md.contains("| interaction |"));
}
