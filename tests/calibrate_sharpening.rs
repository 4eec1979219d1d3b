//! `geneva calibrate` measures the unsharp mask a phone applies after its tone curve and the
//! optical blur under it, and writes both so that the calibrated scenario draws the footage's
//! edges: halo and all. Footage without a mask gets none, and its blur is the renderer's.
#![cfg(feature = "opencv-detector")]

use geneva_vision::numeric::dist::normal_cdf;
use geneva_vision::render::effects::optical_blur::effective_sigma_px;
use geneva_vision::scenario::Scenario;

mod common;
use common::render_and_calibrate_fast;

/// The profile across a straight edge (0 → 1 at x = 0) that `s` draws in display space:
/// the optical blur's Gaussian (its effective σ), then the unsharp mask, at `x` px.
fn edge_profile(s: &Scenario, x: f64) -> f64 {
    let blur = effective_sigma_px(s.effects.optical_blur.sigma_px).max(1e-3);
    let m = &s.effects.sharpening;
    let step = |sigma: f64| normal_cdf(x / sigma);
    if m.enabled {
        (1.0 + m.amount) * step(blur) - m.amount * step(blur.hypot(m.sigma_px))
    } else {
        step(blur)
    }
}

/// Largest difference of the two scenarios' edge profiles, as a share of the edge's contrast.
fn profile_gap(a: &Scenario, b: &Scenario) -> f64 {
    (-80..=80)
        .map(|k| {
            let x = k as f64 * 0.05;
            (edge_profile(a, x) - edge_profile(b, x)).abs()
        })
        .fold(0.0, f64::max)
}

#[test]
fn a_sharpened_footage_is_calibrated_to_the_halo_it_shows() {
    let dir = tempfile::tempdir().unwrap();
    let (truth, cal, log) = render_and_calibrate_fast(
        dir.path(),
        "[effects.sharpening]\nenabled = true\namount = 0.8\nsigma_px = 1.2\n",
    );
    assert!(cal.effects.sharpening.enabled, "{log}");
    assert!(log.contains("re-render check passed"), "{log}");
    // The amount, the mask's σ and the blur trade against each other along a shallow valley of
    // the misfit (a wider, weaker mask on a sharper edge draws almost the same halo), which the
    // footage's noise (about 2 DN) leaves open by a few DN on the edges, so the test holds the
    // edge the scenario draws, not each number: the truth's halo changes the edge by up to
    // 18 % of its contrast, and the calibrated edge must stay within a quarter of that of the
    // truth's everywhere across it (2.4 % on this footage).
    let gap = profile_gap(&truth, &cal);
    let unsharpened = {
        let mut s = truth.clone();
        s.effects.sharpening.enabled = false;
        profile_gap(&truth, &s)
    };
    assert!(unsharpened > 0.15, "the truth's halo: {unsharpened}");
    assert!(
        gap < 0.25 * unsharpened,
        "calibrated edge {gap:.3} of the contrast from the truth's: {:?} / {:?}\n{log}",
        cal.effects.sharpening,
        cal.effects.optical_blur
    );
}

#[test]
fn footage_without_a_mask_gets_none_and_the_renderers_blur() {
    let dir = tempfile::tempdir().unwrap();
    let (truth, cal, log) = render_and_calibrate_fast(dir.path(), "");
    assert!(!cal.effects.sharpening.enabled, "{log}");
    assert!(log.contains("re-render check passed"), "{log}");
    // The blur is matched by rendering: the renderer's own σ comes back (the edge model alone
    // reads a sub-pixel blur a few hundredths off, see `calibrate::blur_model`).
    let (want, got) = (
        truth.effects.optical_blur.sigma_px,
        cal.effects.optical_blur.sigma_px,
    );
    assert!(
        (got - want).abs() < 0.03,
        "blur σ {got} against {want}\n{log}"
    );
    assert!(profile_gap(&truth, &cal) < 0.02);
}
