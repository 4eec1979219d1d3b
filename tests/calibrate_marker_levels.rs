//! `geneva calibrate` measures a marker whose level changes with the wheel's angle (a glossy
//! print reflecting the lamp) and writes it as `scene.appearance.marker_levels`, so that the
//! calibrated scenario draws the levels the footage shows at the angles where the marker was
//! seen at rest or slow; footage of a marker at one level gets no table.
#![cfg(feature = "opencv-detector")]

use geneva_vision::scenario::Scenario;
use geneva_vision::scene::marker_levels::level_at;

mod common;
use common::render_and_calibrate_fast;

/// The ink's level in DN that `s` draws where the marker's printed x axis points at `psi_deg`
/// in the image (the wheel angle less the marker's angle on the disc and orientation).
fn ink_dn_at(s: &Scenario, psi_deg: f64) -> f64 {
    let m = &s.scene.marker;
    let theta2 = (psi_deg - m.angle_on_disc_deg - m.orientation_deg).to_radians();
    let r = s.scene.ink_radiance;
    let r = level_at(&s.scene.appearance.marker_levels, theta2).map_or(r, |l| l.radiance(r));
    let l = &s.effects.lighting;
    l.black_level_dn + (l.white_level_dn - l.black_level_dn) * r
}

#[test]
fn a_level_that_changes_with_the_angle_is_calibrated_where_the_marker_was_seen() {
    let dir = tempfile::tempdir().unwrap();
    // The ink's offset every 45°: the two dwells of the footage (90° apart) see different
    // levels whatever angles they sit at.
    let offsets = [0.10, -0.02, 0.08, -0.03, 0.02, 0.09, -0.03, 0.04];
    let mut table = String::new();
    for (k, o) in offsets.iter().enumerate() {
        table.push_str(&format!(
            "[[scene.appearance.marker_levels]]\nangle_deg = {}\ngain = 1.0\noffset = {o}\n",
            45 * k
        ));
    }
    let (truth, cal, log) = render_and_calibrate_fast(dir.path(), &table);
    let levels = &cal.scene.appearance.marker_levels;
    assert!(levels.len() >= 2, "{log}");
    // At every measured angle the calibrated scenario draws the truth's ink level.
    let m = &cal.scene.marker;
    let mut worst: f64 = 0.0;
    let mut spread = (f64::INFINITY, f64::NEG_INFINITY);
    for e in levels {
        let psi = e.angle_deg + m.angle_on_disc_deg + m.orientation_deg;
        let (want, got) = (ink_dn_at(&truth, psi), ink_dn_at(&cal, psi));
        worst = worst.max((want - got).abs());
        spread = (spread.0.min(want), spread.1.max(want));
    }
    // The levels are trimmed means of a few hundred pixels (< 0.2 DN of noise) under a blur
    // whose guard band keeps the edges out; the tone fit leaves about 1 DN.
    assert!(worst < 1.5, "worst {worst:.2} DN off: {levels:?}\n{log}");
    assert!(
        spread.1 - spread.0 > 5.0,
        "the angles seen differ: {spread:?}"
    );
}

#[test]
fn a_marker_at_one_level_gets_no_table() {
    let dir = tempfile::tempdir().unwrap();
    let (_, cal, log) = render_and_calibrate_fast(dir.path(), "");
    assert!(cal.scene.appearance.marker_levels.is_empty(), "{log}");
    assert!(
        log.contains("the marker's level does not change with the wheel's angle"),
        "{log}"
    );
}
