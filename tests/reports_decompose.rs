//! End-to-end per-source decomposition on a short `fast` run with its sources on and pixel noise
//! ten times its normal σ: the
//! dominant source must come out dominant with an interval that excludes every other row, no
//! random source may lower the error beyond its interval (common random numbers), and the seeds
//! must stop for a stated reason.

#![cfg(feature = "opencv-detector")]

use geneva_vision::budget::decompose::{
    SeedRule, StopReason, ESTIMATOR, INTERACTION, QUANTISATION,
};
use geneva_vision::pipeline::decompose::{decompose_effects, write_outputs, DecomposeOptions};
use geneva_vision::scenario::{load_any, with_overrides};
use std::path::Path;
use toml::Value;

/// Sources without a random draw of their own: their contribution is the same function of each
/// seed's placement in every configuration.
const DETERMINISTIC: &[&str] = &[
    "optical_blur",
    "motion_blur",
    "lighting",
    "rolling_shutter",
    "lens_distortion",
    "perspective_tilt",
    "compression",
];

#[test]
fn a_large_single_effect_dominates_with_a_separated_interval() {
    let fast = load_any("fast").unwrap();
    let noise = &fast.effects.pixel_noise;
    let base = with_overrides(
        &fast,
        &[
            ("duration_s".into(), Value::Float(2.0)),
            // Ten times the noise σ at every level: σ/full well = √(e + r²)/w; with w/100 and
            // r/10 (so e/100 too) it is √(e + r²)/10 / (w/100) = 10 √(e + r²)/w.
            (
                "effects.pixel_noise.read_noise_e".into(),
                Value::Float(noise.read_noise_e / 10.0),
            ),
            (
                "effects.pixel_noise.full_well_e".into(),
                Value::Float(noise.full_well_e / 100.0),
            ),
        ],
        Path::new("reports_decompose"),
    )
    .unwrap();
    let options = DecomposeOptions {
        rule: SeedRule {
            initial: 4,
            cap: 12,
            target_half_width: 0.05,
        },
        roi: true,
    };
    let d = decompose_effects(&base, &options, &|_| {}).expect("decomposition");
    assert!(
        d.sources.contains(&"pixel_noise".to_string()),
        "{:?}",
        d.sources
    );
    assert!(d.sources.len() >= 2, "{:?}", d.sources);
    assert!(matches!(d.stop, StopReason::Settled | StopReason::Capped));
    assert!(d.seeds >= 4 && d.seeds <= 12);
    let mut lowering = Vec::new();
    for (symbol, dec) in [("ω2", &d.omega), ("α2", &d.alpha)] {
        let noise = dec.row("pixel_noise").unwrap();
        assert!(
            noise.share.mean >= 0.9,
            "{symbol}: pixel noise share {:?}",
            noise.share
        );
        for r in dec.rows.iter().filter(|r| r.name != "pixel_noise") {
            assert!(
                r.share.ci95_high < noise.share.ci95_low,
                "{symbol}: `{}` {:?} overlaps pixel noise {:?}",
                r.name,
                r.share,
                noise.share
            );
        }
        // Common random numbers: a random source's alone contribution is never negative beyond
        // its interval (a new noise draw per configuration is what made them negative). A
        // deterministic source (no random draw of its own) may really lower the error — blur
        // smooths the corners' pixel quantisation — and is then annotated.
        for r in dec
            .rows
            .iter()
            .filter(|r| ![QUANTISATION, ESTIMATOR, INTERACTION].contains(&r.name.as_str()))
        {
            if r.variance.ci95_high < 0.0 {
                assert!(
                    DETERMINISTIC.contains(&r.name.as_str()),
                    "{symbol}: random source `{}` alone lowers the error beyond its CI: {:?}",
                    r.name,
                    r.variance
                );
                lowering.push((symbol, r.name.clone()));
            }
        }
        // Seeds place the marker differently on the pixel grid: quantisation is sampled, not
        // one draw reported with a zero-width interval.
        let q = dec.row(QUANTISATION).unwrap();
        assert!(
            q.variance.ci95_high > q.variance.ci95_low,
            "{symbol}: quantisation {:?}",
            q.variance
        );
        // The estimator's own error on exact corners is a row of its own, measured (positive)
        // and smaller than the error the detected corners give with every effect off.
        let e = dec.row(ESTIMATOR).unwrap();
        assert!(
            e.variance.ci95_low > 0.0,
            "{symbol}: estimator {:?}",
            e.variance
        );
        assert!(
            e.variance.mean < dec.none.mean,
            "{symbol}: estimator {:?} vs none {:?}",
            e.variance,
            dec.none
        );
        // The rows add up to the whole, recomputed from the per-seed runs.
        let sum: f64 = dec.rows.iter().map(|r| r.variance.mean).sum();
        assert!(
            (sum - dec.all.mean).abs() <= 1e-9 * dec.all.mean,
            "{symbol}: rows {sum} vs V(all) {}",
            dec.all.mean
        );
        if d.stop == StopReason::Settled {
            assert!(dec.widest_share_half_width() < 0.05);
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let files = write_outputs(&d, dir.path()).unwrap();
    assert_eq!(files.len(), 5);
    let md = std::fs::read_to_string(dir.path().join("decomposition.md")).unwrap();
    assert!(md.contains("| pixel_noise |") && md.contains("| corner quantisation |"));
    assert!(md.contains("| estimator on exact corners |"), "{md}");
    if !lowering.is_empty() {
        assert!(md.contains("lowers the error"), "{lowering:?}\n{md}");
    }
    let csv = std::fs::read_to_string(dir.path().join("per_seed.csv")).unwrap();
    // One line per configuration and seed.
    assert_eq!(csv.lines().count(), 1 + d.configurations.len() * d.seeds);
}
