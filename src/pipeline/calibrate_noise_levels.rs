//! The noise by grey level that a calibration writes (`effects.pixel_noise.level_gain`),
//! measured by [`crate::calibrate::noise_levels`] on every static run of the footage against
//! the electrons the calibration fitted.

use super::calibrate::{float_of, round6};
use crate::calibrate::noise_levels::{
    fit_noise_levels, with_quantisation_dn, without_quantisation_dn, NoiseLevelFit, MIN_DEPARTURE,
    Z_DEPARTURE,
};
use crate::calibrate::output::Override;
use crate::calibrate::{sensor_sigma, Calibration, FootageStats};
use toml::Value;

/// Measures the footage's noise at every level its static runs hold against the calibrated
/// noise model (`ovs`' electrons and tone span) and, when it departs, names the table in `ovs`.
/// The model is anchored on the run the electrons were fitted on (its ink's σ measured there
/// over the model's), so that what the electrons already hold (a sharpening's gain on the
/// noise, which the match by simulation folds into them) is not counted twice. Notes say what
/// was found either way.
pub(crate) fn write_noise_levels(
    stats: &FootageStats,
    ovs: &mut Vec<Override>,
    cal: &mut Calibration,
) {
    let why_not = if cal.imaging.noise.footage_not_identifiable.is_some() {
        Some("the footage's noise is not identifiable")
    } else if cal.imaging.jpeg_quality.is_some() {
        Some("JPEG compression is drawn, and the σ it leaves is not the sensor's")
    } else if float_of(ovs, "effects.lighting.gamma").is_some_and(|g| g != 1.0) {
        Some("the tone curve is not linear")
    } else {
        None
    };
    let model = model_sigma(stats, ovs);
    let (model, black, white) = match (why_not, model) {
        (None, Some(m)) => m,
        (why, _) => {
            cal.notes.push(format!(
                "pixel noise by grey level: not measured ({})",
                why.unwrap_or("no static run of three frames holds the marker's ink")
            ));
            return;
        }
    };
    let fit = fit_noise_levels(&stats.level_noise, &model, black, white);
    if fit.shows_levels() {
        let table = fit.table();
        ovs.push(Override {
            path: "effects.pixel_noise.level_gain".into(),
            value: Value::Array(
                table
                    .iter()
                    .map(|e| {
                        let mut t = toml::map::Map::new();
                        t.insert("level_dn".into(), Value::Float(round6(e.level_dn)));
                        t.insert("gain".into(), Value::Float(round6(e.gain)));
                        Value::Table(t)
                    })
                    .collect(),
            ),
            comment: describe(&fit),
        });
        cal.notes
            .push(format!("pixel noise by grey level: {}", describe(&fit)));
    } else {
        cal.notes.push(format!(
            "pixel noise by grey level: as the electrons draw it at the {} level(s) the static \
             runs hold (no factor departs from 1 by {:.0} % and {} standard errors)",
            fit.points.len(),
            100.0 * MIN_DEPARTURE,
            Z_DEPARTURE
        ));
    }
    cal.noise_levels = Some(fit);
}

/// The model's σ by level (with quantisation), anchored on the electrons' run, and the tone
/// span; `None` without the calibrated noise or that run's ink.
fn model_sigma(stats: &FootageStats, ovs: &[Override]) -> Option<(impl Fn(f64) -> f64, f64, f64)> {
    let black = float_of(ovs, "effects.lighting.black_level_dn")?;
    let white = float_of(ovs, "effects.lighting.white_level_dn")?;
    let fw = float_of(ovs, "effects.pixel_noise.full_well_e")?;
    let read = float_of(ovs, "effects.pixel_noise.read_noise_e")?;
    let analytic = move |level: f64| sensor_sigma(level, black, white, fw, read);
    let anchor = stats.temporal.iter().find(|t| t.what == "disc ink")?;
    let sensor = without_quantisation_dn;
    let model_anchor = sensor(analytic(anchor.noise.level_dn));
    let k = sensor(anchor.noise.sigma_dn) / model_anchor;
    (k.is_finite() && k > 0.0).then_some((
        move |level: f64| with_quantisation_dn(k * sensor(analytic(level))),
        black,
        white,
    ))
}

fn describe(fit: &NoiseLevelFit) -> String {
    let points: Vec<String> = fit
        .points
        .iter()
        .map(|p| {
            format!(
                "{:.0} DN × {:.2} ± {:.2}",
                p.level_dn,
                p.gain,
                1.96 * p.gain_se
            )
        })
        .collect();
    format!(
        "the footage's noise departs from shot + read noise by grey level (a phone's tone curve \
         and denoising): the sensor's σ measured over the static runs against the fitted \
         electrons, {} (95 %)",
        points.join(", ")
    )
}
