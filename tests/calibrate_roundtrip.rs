//! `geneva calibrate` round trip, the small case: footage rendered from random
//! scenarios with known parameters (fixed seed) is calibrated and every fitted value compared
//! with the truth. The whole case (40 scenarios) is `reports/calibration/` (`cargo xtask
//! reports`), which states every criterion with its measured figure.
//!
//! Asserted here, on `GENEVA_ROUNDTRIP_CASES` cases (default 6): ≥ 90 % of the comparisons
//! within their reported 95 % interval; scale within 0.5 %, rotation centre within 0.5 px and
//! blur σ within 10 % on every case; noise σ within 10 % on footage that is neither JPEG-
//! compressed nor clipped at the white level, where the calibration reports it as identifiable.
//! Under compression or clipping the noise target is not met on every case (the report gives
//! the figures; under JPEG the calibration says the sensor's σ is not identifiable), so there
//! the test only guards against a regression (within 35 %); likewise the re-render residual,
//! wanted ≤ 1.2 × the fitted noise and not so on every case, is guarded at ≤ 1.5 ×. The
//! re-render residual holds no structure that the noise model's own residual does not, on every
//! case (`calibrate::residual`: the check that fails on the real frame must pass here), and no
//! texture is written for these uniform markers. Two printed markers (`calibrate_printed`):
//! their texture is measured and the held-out frame renders with no wide structure left.
#![cfg(feature = "opencv-detector")]

use geneva_vision::pipeline::calibrate_printed::run_printed_case;
use geneva_vision::pipeline::calibrate_roundtrip::{
    case_toml, criteria_table, render_and_calibrate, run_case, summary,
};

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
    eprintln!("{}\n{}", criteria_table(&results), summary(&results));
    let all: Vec<_> = results.iter().flat_map(|r| r.checks.iter()).collect();
    let within = all.iter().filter(|c| c.within).count() as f64 / all.len() as f64;
    assert!(
        within >= 0.9,
        "only {:.1} % within the reported uncertainty",
        within * 100.0
    );
    let mut structured = Vec::new();
    for r in &results {
        for c in &r.checks {
            let noise = c.parameter.starts_with("noise");
            if !noise || (r.plain() && c.not_identifiable.is_none()) {
                assert_ne!(
                    c.target_met,
                    Some(false),
                    "case {}: {} misses its accuracy target: {c:?}",
                    r.index,
                    c.parameter
                );
            } else if c.not_identifiable.is_none() || r.compressed {
                assert!(
                    c.error.abs() <= 0.35 * c.truth,
                    "case {}: {} off by more than 35 %: {c:?}",
                    r.index,
                    c.parameter
                );
            }
        }
        assert!(
            !r.texture_written,
            "case {}: a texture written on a uniform marker",
            r.index
        );
        assert_eq!(
            r.compression_found,
            r.compressed,
            "case {}: compression found {} on footage that is{} JPEG-compressed",
            r.index,
            r.compression_found,
            if r.compressed { "" } else { " not" }
        );
        if let Some(q) = r.rerender_ratio {
            assert!(
                q <= 1.5,
                "case {}: re-render residual {q:.3} × the noise",
                r.index
            );
        }
        let k = r.rerender.as_ref().expect("the re-render check ran");
        eprintln!(
            "case {}: noise {}; re-render smoothed {:.3} (model {:.3}), autocorrelation {:.3?} \
             (model {:.3?}), edge energy {:.2} (model {:.2}), render correlation {:.3?} (model {:.3?})",
            r.index,
            r.noise_measured,
            k.structure.footage.smoothed_retention,
            k.structure.model.smoothed_retention,
            k.structure.footage.autocorrelation,
            k.structure.model.autocorrelation,
            k.structure.footage.edge_energy_ratio,
            k.structure.model.edge_energy_ratio,
            k.structure.footage.render_correlation,
            k.structure.model.render_correlation
        );
        if !k.structure.passed() {
            structured.push(format!("case {}: {:?}", r.index, k.structure.failures));
        }
    }
    assert!(
        structured.is_empty(),
        "re-render residuals that hold structure: {structured:#?}"
    );
}

/// Per-engagement speed variation end to end: footage rendered with a crank speed that dips by
/// 30 % in the middle of every engagement (the seed's second-order profile) is calibrated, and
/// the fitted end and mid speeds hold the truth within their reported 95 % intervals.
#[test]
fn calibrate_recovers_a_per_engagement_speed_variation() {
    let dir = tempfile::tempdir().unwrap();
    let text = case_toml(20261123, 3);
    let w: f64 = text
        .lines()
        .find_map(|l| l.strip_prefix("omega1_rad_s = "))
        .and_then(|v| v.parse().ok())
        .expect("the case has a constant speed");
    let (end, mid) = (w, 0.7 * w);
    let text = text
        .replace(
            &format!("kind = \"constant\"\nomega1_rad_s = {w}"),
            &format!("kind = \"polynomial_per_engagement\"\nend_rad_s = {end}\nmid_rad_s = {mid}"),
        )
        .replace("duration_s = 3.0", "duration_s = 4.0");
    assert!(text.contains("polynomial_per_engagement"));
    let path = dir.path().join("truth.toml");
    std::fs::write(&path, &text).unwrap();
    let truth = geneva_vision::scenario::load(&path).unwrap();
    let out = render_and_calibrate(&truth, dir.path()).unwrap();
    let m = out.calibration.motion.expect("motion fitted");
    let (fe, fm) = m.polynomial.unwrap_or_else(|| {
        panic!(
            "speed variation not resolved: mid − end {:?}; notes {:?}",
            m.polynomial_difference, out.calibration.notes
        )
    });
    eprintln!("end {fe} (truth {end}), mid {fm} (truth {mid})");
    assert!(fe.covers(end), "end speed {fe} against {end}");
    assert!(fm.covers(mid), "mid speed {fm} against {mid}");
    let d = m.polynomial_difference.expect("difference reported");
    assert!(
        d.covers(mid - end) && !d.covers(0.0),
        "mid − end {d} against {}",
        mid - end
    );
}

/// Printed markers (the round trip's rigs with a shaded, blotched print; `reports/calibration/`
/// has ten): `calibrate` measures the texture, mosaicked without the re-render check's frame,
/// and the calibrated scenario renders that frame with no structure wider than a few pixels
/// left. Two cases here.
#[test]
fn a_printed_marker_s_texture_is_measured_and_renders_the_held_out_frame() {
    for i in 0..2 {
        let dir = tempfile::tempdir().unwrap();
        let r =
            run_printed_case(20261123, i, dir.path()).unwrap_or_else(|e| panic!("case {i}: {e}"));
        let k = r.check.as_ref().expect("the re-render check ran");
        eprintln!(
            "printed case {i}: paper spread {:.3}, texture {}, held out {}, ratio {:.3}, smoothed {:.3}, edge energy {:.2} (model {:.2}), failures {:?}",
            r.paper_spread,
            r.texture_written,
            r.check_frame_held_out,
            k.ratio(),
            k.structure.footage.smoothed_retention,
            k.structure.footage.edge_energy_ratio,
            k.structure.model.edge_energy_ratio,
            k.failures()
        );
        assert!(
            r.texture_written && r.check_frame_held_out,
            "case {i}: {r:?}"
        );
        assert!(
            k.structure.footage.smoothed_retention
                <= geneva_vision::calibrate::residual::MAX_SMOOTHED_RETENTION,
            "case {i}: {:?}",
            k.failures()
        );
    }
}

/// A still uniform marker under JPEG (round-trip case 20: quality 80, noise measured over 10
/// still frames) shows the codec's fixed block pattern in the mean of its frames, 1–2 DN beyond
/// what the noise leaves there. That is the codec's, not the print's: the texture is judged
/// against renders of the calibrated uniform marker at the same frames, which draw the same
/// pattern, and none is written.
#[test]
fn a_jpeg_s_block_pattern_on_a_still_uniform_marker_is_not_taken_for_a_texture() {
    let dir = tempfile::tempdir().unwrap();
    let r = run_case(20261123, 20, dir.path()).unwrap();
    assert!(r.compressed, "case 20 is the JPEG case this test is about");
    assert!(!r.texture_written, "a texture written on a uniform marker");
    let md = std::fs::read_to_string(dir.path().join("out/calibration.md")).unwrap();
    assert!(
        md.contains("temporal σ of static pixels"),
        "the noise is measured over still frames: {md}"
    );
    assert!(
        md.contains("beyond what the calibrated uniform marker gives"),
        "{md}"
    );
}
