//! `geneva calibrate` measures the pixel noise at every grey level the footage's static runs
//! hold and, where it departs from the shot and read noise it fitted (a phone's tone curve and
//! denoising), writes the factors as `effects.pixel_noise.level_gain`, so that the calibrated
//! scenario draws the noise the footage shows at each level; footage whose noise the electrons
//! draw gets no table.
#![cfg(feature = "opencv-detector")]

use geneva_vision::calibrate::sensor_sigma;
use geneva_vision::scenario::Scenario;

mod common;
use common::render_and_calibrate_fast;

/// The noise σ (DN, with the 8-bit quantisation) that `s` draws at grey level `level_dn`.
fn sigma_dn_at(s: &Scenario, level_dn: f64) -> f64 {
    let (l, n) = (&s.effects.lighting, &s.effects.pixel_noise);
    let q = 1.0 / 12.0;
    let total = sensor_sigma(
        level_dn,
        l.black_level_dn,
        l.white_level_dn,
        n.full_well_e,
        n.read_noise_e,
    );
    let sensor = (total * total - q).sqrt() * n.gain_at(level_dn);
    (sensor * sensor + q).sqrt()
}

/// The disc's grey level around the marker in `s`, DN.
fn disc_dn(s: &Scenario) -> f64 {
    let l = &s.effects.lighting;
    l.black_level_dn + (l.white_level_dn - l.black_level_dn) * s.scene.disc_radiance
}

#[test]
fn noise_that_departs_from_the_electrons_by_level_is_calibrated_as_a_level_table() {
    let dir = tempfile::tempdir().unwrap();
    // The `fast` rig draws ink at 57.2 DN, the disc at 136.25 DN and the paper at 206 DN: the
    // disc's noise 1.6 × what the electrons give, the ink's and the paper's as they give it.
    let (truth, cal, log) = render_and_calibrate_fast(
        dir.path(),
        "[effects.pixel_noise]\nlevel_gain = [{ level_dn = 57.2, gain = 1.0 }, \
         { level_dn = 136.25, gain = 1.6 }, { level_dn = 206.0, gain = 1.0 }]\n",
    );
    let table = &cal.effects.pixel_noise.level_gain;
    assert!(table.len() >= 2, "{log}");
    let disc = disc_dn(&truth);
    let (want, got) = (sigma_dn_at(&truth, disc), sigma_dn_at(&cal, disc));
    // Temporal σ over a dwell's frames and a few thousand pixels: about 1 % standard error;
    // the interpolation between the measured levels and the level's offset on the disc add a
    // few per cent.
    assert!(
        (got / want - 1.0).abs() < 0.08,
        "σ at the disc ({disc:.1} DN): calibrated {got:.3} DN, truth {want:.3} DN; {table:?}\n{log}"
    );
    // Without the table the calibrated electrons would draw the disc's noise a third too low.
    let mut plain = cal.clone();
    plain.effects.pixel_noise.level_gain.clear();
    assert!(sigma_dn_at(&plain, disc) < 0.8 * want);
    assert!(log.contains("effects.pixel_noise.level_gain") || log.contains("by grey level"));
}

#[test]
fn noise_as_the_electrons_draw_it_gets_no_level_table() {
    let dir = tempfile::tempdir().unwrap();
    let (_, cal, log) = render_and_calibrate_fast(dir.path(), "");
    assert!(
        cal.effects.pixel_noise.level_gain.is_empty(),
        "{:?}\n{log}",
        cal.effects.pixel_noise.level_gain
    );
    assert!(
        log.contains("pixel noise by grey level: as the electrons draw it"),
        "{log}"
    );
}
