//! The marker's level by the wheel's angle that a calibration writes
//! (`scene.appearance.marker_levels`), measured by [`crate::calibrate::marker_levels`] on the
//! footage's slow frames.

use super::calibrate::{float_of, round6};
use super::calibrate_appearance::MosaicFrame;
use crate::calibrate::appearance::LevelAnchors;
use crate::calibrate::marker_levels::{
    mean_level, measure_level_table, median_level, slow_frame_samples, LevelSample, LevelTable,
    LevelTableError,
};
use crate::calibrate::output::Override;
use crate::calibrate::{Calibration, FootageStats};
use crate::scenario::Scenario;
use toml::Value;

/// The slow frames' samples and the light they are brought to (the calibrated tone curve is
/// linear, gamma 1: black is radiance 0, white 1); `None` without levels or motion.
fn slow_samples(
    stats: &FootageStats,
    ovs: &[Override],
    cal: &Calibration,
    base: &Scenario,
) -> Option<(Vec<LevelSample>, LevelAnchors)> {
    let (Some(black), Some(white)) = (
        float_of(ovs, "effects.lighting.black_level_dn"),
        float_of(ovs, "effects.lighting.white_level_dn"),
    ) else {
        return None;
    };
    cal.motion.as_ref()?;
    let m = &base.scene.marker;
    let angle_on_disc =
        float_of(ovs, "scene.marker.angle_on_disc_deg").unwrap_or(m.angle_on_disc_deg);
    let orientation = float_of(ovs, "scene.marker.orientation_deg").unwrap_or(m.orientation_deg);
    let anchors = LevelAnchors {
        ink_dn: black,
        ink_radiance: 0.0,
        paper_dn: white,
        paper_radiance: 1.0,
    };
    let exposure = &cal.imaging.exposure;
    let to_reference = |t_s: f64, dn: f64| anchors.under_unit_gain(dn, exposure.gain_at(t_s));
    let samples = slow_frame_samples(&stats.frames, angle_on_disc + orientation, &to_reference);
    Some((samples, anchors))
}

/// Lowers the tone curve's black level when the marker's ink, at the darkest angle the slow
/// frames show, leaves less room than 5 σ of its noise + 1 DN above it (the fit puts the black
/// level below the ink's median level, which a glossy ink undercuts at some angles): the render
/// would clip the ink's noise there. Grey levels and the noise in DN stay as fitted. Only an
/// ink darker than the fitted level by [`crate::calibrate::marker_levels::MIN_DEPARTURE_DN`]
/// moves it.
pub(crate) fn make_room_for_darkest_ink(
    stats: &FootageStats,
    ovs: &mut Vec<Override>,
    cal: &mut Calibration,
    base: &Scenario,
) {
    let Some((samples, anchors)) = slow_samples(stats, ovs, cal, base) else {
        return;
    };
    // The bins alone matter here, not the drawn levels.
    let Ok(table) = measure_level_table(&samples, [0.0, 0.0]) else {
        return;
    };
    let darkest = table
        .bins
        .iter()
        .map(|b| b.level_dn[0])
        .fold(f64::INFINITY, f64::min);
    let room = 5.0 * cal.imaging.noise.ink_sigma_dn.value + 1.0;
    let (black, white) = (anchors.ink_dn, anchors.paper_dn);
    let wanted = (darkest - room).max(0.0);
    // Only an ink that darkens at some angle by what a level table would show: a clipped ink
    // sits at its clip at every angle, and the fitted margin holds the rest.
    let darker =
        darkest < cal.imaging.ink_dn.value - crate::calibrate::marker_levels::MIN_DEPARTURE_DN;
    if darker && wanted < black - 1e-6 {
        lower_black_level(ovs, cal, base, [black, white, wanted], darkest);
    }
}

/// Moves the black level from `black` to `new_black` DN (`levels`: black, white, new black) with
/// the white level kept, keeping every grey level and the noise in DN: each radiance r becomes
/// (black − new_black + span·r)/span' and the full well scales by span'/span (the read noise in
/// DN, span·read/full well, stays; the shot noise of the added radiance is left out, the
/// footage's noise having been fitted at its levels).
fn lower_black_level(
    ovs: &mut Vec<Override>,
    cal: &mut Calibration,
    base: &Scenario,
    [black, white, new_black]: [f64; 3],
    darkest_dn: f64,
) {
    let (span, new_span) = (white - black, white - new_black);
    let k = new_span / span;
    let remap = |r: f64| (black - new_black + span * r) / new_span;
    const RADIANCES: [&str; 4] = [
        "scene.ink_radiance",
        "scene.paper_radiance",
        "scene.disc_radiance",
        "scene.background_radiance",
    ];
    for o in ovs.iter_mut() {
        let moved = match o.path.as_str() {
            "effects.lighting.black_level_dn" => Some(new_black),
            p if RADIANCES.contains(&p) => o.value.as_float().map(remap),
            "effects.pixel_noise.full_well_e" => o.value.as_float().map(|f| f * k),
            _ => None,
        };
        if let Some(v) = moved {
            o.value = Value::Float(round6(v));
        }
    }
    let sc = &base.scene;
    let stated = [
        sc.ink_radiance,
        sc.paper_radiance,
        sc.disc_radiance,
        sc.background_radiance,
    ];
    for (path, r) in RADIANCES.iter().zip(stated) {
        if !ovs.iter().any(|o| o.path == *path) {
            ovs.push(Override {
                path: path.to_string(),
                value: Value::Float(round6(remap(r))),
                comment: "the base's, moved with the black level".into(),
            });
        }
    }
    let im = &mut cal.imaging;
    im.black_level_dn = new_black;
    im.ink_radiance = remap(im.ink_radiance);
    im.paper_radiance = remap(im.paper_radiance);
    im.disc_radiance = im.disc_radiance.map(remap);
    im.noise.full_well_e *= k;
    cal.notes.push(format!(
        "appearance: the black level is lowered from {black:.2} to {new_black:.2} DN to hold the \
         ink at its darkest angle ({darkest_dn:.2} DN on slow frames) with room for its noise; \
         radiances and the full well are moved so that every grey level and the noise in DN stay \
         as fitted"
    ));
}

/// Measures the marker's level by wheel angle on `stats` against the levels the calibrated
/// scenario draws (those of the mosaic's frames when the marker is textured, else the median
/// over the footage's frames, as the uniform levels were fitted) and, when the footage shows
/// one, names it in `ovs`. Notes say what was found either way.
pub(crate) fn write_marker_levels(
    stats: &FootageStats,
    mosaic: &[MosaicFrame],
    textured: bool,
    ovs: &mut Vec<Override>,
    cal: &mut Calibration,
    base: &Scenario,
) {
    let Some((samples, anchors)) = slow_samples(stats, ovs, cal, base) else {
        return;
    };
    let (black, white) = (anchors.ink_dn, anchors.paper_dn);
    let exposure = &cal.imaging.exposure;
    let to_reference = |t_s: f64, dn: f64| anchors.under_unit_gain(dn, exposure.gain_at(t_s));
    // What the scenario draws: a texture is the mean of the mosaic's frames, uniform levels
    // the median over the footage's frames.
    let drawn_from = |frame: usize| !textured || mosaic.iter().any(|f| f.0 == frame);
    let reference = [0, 1].map(|k| {
        let levels: Vec<f64> = stats
            .frames
            .iter()
            .filter(|f| drawn_from(f.frame))
            .filter_map(|f| {
                let l = f.levels.as_ref()?;
                let dn = if k == 0 { &l.ink } else { &l.paper }.trimmed_mean_dn;
                Some(to_reference(f.t_s, dn))
            })
            .collect();
        if textured {
            mean_level(&levels)
        } else {
            median_level(&levels)
        }
    });
    let measured = match reference {
        [Some(ink), Some(paper)] => measure_level_table(&samples, [ink, paper]),
        _ => Err(LevelTableError::TooFewFrames),
    };
    let table = match measured {
        Ok(t) => t,
        Err(e) => {
            cal.notes.push(format!(
                "appearance: the marker's level by the wheel's angle was not measured ({e})"
            ));
            return;
        }
    };
    let entries = table.entries(black, white - black);
    if table.shows_levels() && !entries.is_empty() {
        ovs.push(Override {
            path: "scene.appearance.marker_levels".into(),
            value: Value::Array(entries.iter().map(entry_value).collect()),
            comment: describe(&table, entries.len()),
        });
        cal.notes
            .push(format!("appearance: {}", describe(&table, entries.len())));
    } else {
        let d = table.spread_dn();
        cal.notes.push(format!(
            "appearance: the marker's level does not change with the wheel's angle beyond its \
             noise: over {} slow frame(s) in {} angle bin(s), ink and paper vary by at most \
             {:.2} / {:.2} DN between angles ({:.1} standard errors; a table needs {} DN and {} \
             standard errors)",
            table.frames,
            table.bins.len(),
            d[0],
            d[1],
            table.largest_z(),
            crate::calibrate::marker_levels::MIN_DEPARTURE_DN,
            crate::calibrate::marker_levels::Z_DEPARTURE,
        ));
    }
    cal.marker_levels = Some(table);
}

fn entry_value(e: &crate::scene::MarkerLevelAt) -> Value {
    let mut t = toml::map::Map::new();
    t.insert("angle_deg".into(), Value::Float(round6(e.angle_deg)));
    t.insert("gain".into(), Value::Float(round6(e.gain)));
    t.insert("offset".into(), Value::Float(round6(e.offset)));
    Value::Table(t)
}

fn describe(t: &LevelTable, entries: usize) -> String {
    let span = |m: usize| {
        t.bins
            .iter()
            .map(|b| b.level_dn[m])
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            })
    };
    let (ink, paper) = (span(0), span(1));
    format!(
        "the marker's level changes with the wheel's angle (a glossy print reflecting the lamp): \
         over {} slow frame(s) in {entries} angle bin(s) of {}°, ink {:.1}–{:.1} DN and paper \
         {:.1}–{:.1} DN ({:.1} standard errors apart at most) against {:.1} / {:.1} DN drawn",
        t.frames,
        crate::calibrate::marker_levels::BIN_DEG,
        ink.0,
        ink.1,
        paper.0,
        paper.1,
        t.largest_z(),
        t.reference_dn[0],
        t.reference_dn[1],
    )
}
