//! The noise's σ by grey level, measured on the footage against the electron model: a phone's
//! tone curve and denoising leave more noise in the dark tones and less near the white than
//! shot and read noise through the scenario's tone curve draw, so a model fitted at the ink and
//! paper of one dwell misstates the noise at every other level the footage holds (the ink at a
//! dwell where a glossy print is darker, the disc, the paper at another angle).
//!
//! Each static run of the footage gives the temporal σ of its ink, paper and surround (each
//! pixel's spread over the run's frames, [`crate::imagestats::temporal_noise`]) at the run's own
//! levels. Against the model's σ at the same level, each gives the factor on the sensor's σ
//! (both with the 1/√12 DN quantisation taken out) that `effects.pixel_noise.level_gain` draws.
//! Points within [`MERGE_DN`] of each other are pooled (weighted by their variances). The
//! footage shows a level dependence the model lacks when a point departs from 1 by more than
//! [`MIN_DEPARTURE`] and by more than [`Z_DEPARTURE`] of its standard errors; the table then
//! holds every pooled point.

use crate::render::effects::pixel_noise::NoiseGainAt;

/// Points closer than this in level (DN) are one level.
pub const MERGE_DN: f64 = 4.0;

/// A factor nearer 1 than this is not worth a table: the noise's σ is within 10 % of the model.
pub const MIN_DEPARTURE: f64 = 0.10;

/// Standard errors a factor's departure from 1 must exceed.
pub const Z_DEPARTURE: f64 = 4.0;

/// Below this measured σ (DN) the σ before quantisation is not identifiable (two adjacent
/// 8-bit levels hold the region: [`super::imaging::QUANTISATION_LIMITED_DN`]).
const MIN_SIGMA_DN: f64 = super::imaging::QUANTISATION_LIMITED_DN;

/// Variance of rounding to whole DN, DN².
pub const QUANTISATION_VAR_DN2: f64 = 1.0 / 12.0;

/// The total σ (DN) of a sensor σ once rounded to whole DN.
pub fn with_quantisation_dn(sensor_dn: f64) -> f64 {
    (sensor_dn * sensor_dn + QUANTISATION_VAR_DN2).sqrt()
}

/// The sensor's σ (DN) within a total σ that holds the rounding to whole DN (0 when the total is
/// the rounding's alone or less).
pub fn without_quantisation_dn(total_dn: f64) -> f64 {
    (total_dn * total_dn - QUANTISATION_VAR_DN2).max(0.0).sqrt()
}

/// A level whose noise the tone curve's clipping at either end would cut by more than this
/// fraction is left out (about 2σ from the end): a fifth of [`MIN_DEPARTURE`], so that clipping
/// alone cannot make a factor.
pub const MAX_CLIP_BIAS: f64 = 0.02;

/// Limits of a factor (those `effects.pixel_noise.level_gain` accepts, kept off zero).
const GAIN_RANGE: (f64, f64) = (0.05, 10.0);

/// One measured level: the temporal σ of a region over a static run.
#[derive(Debug, Clone, PartialEq)]
pub struct LevelNoise {
    /// What was measured (`ink at frames 0–4`, …).
    pub what: String,
    pub level_dn: f64,
    pub sigma_dn: f64,
    pub sigma_stderr_dn: f64,
}

/// A level against the model.
#[derive(Debug, Clone, PartialEq)]
pub struct GainPoint {
    /// The measurements pooled into it.
    pub what: Vec<String>,
    pub level_dn: f64,
    /// Measured σ and the model's at that level, DN (with quantisation).
    pub measured_dn: f64,
    pub model_dn: f64,
    /// The factor on the sensor's σ and its standard error.
    pub gain: f64,
    pub gain_se: f64,
}

impl GainPoint {
    /// Standard errors of the factor's departure from 1.
    pub fn z(&self) -> f64 {
        (self.gain - 1.0).abs() / self.gain_se.max(1e-9)
    }

    /// Departs from the model by enough to be drawn.
    pub fn departs(&self) -> bool {
        (self.gain - 1.0).abs() > MIN_DEPARTURE && self.z() > Z_DEPARTURE
    }
}

/// The measured factors.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseLevelFit {
    /// In increasing level.
    pub points: Vec<GainPoint>,
    /// Measurements left out, and why.
    pub skipped: Vec<String>,
}

impl NoiseLevelFit {
    /// Whether the footage's noise departs from the model at some level.
    pub fn shows_levels(&self) -> bool {
        self.points.iter().any(GainPoint::departs)
    }

    /// The table to draw (`effects.pixel_noise.level_gain`): every point, as measured.
    pub fn table(&self) -> Vec<NoiseGainAt> {
        self.points
            .iter()
            .map(|p| NoiseGainAt {
                level_dn: p.level_dn,
                gain: p.gain,
            })
            .collect()
    }
}

/// The factors of `measured` against `model_sigma_dn` (the model's σ at a level, with the
/// quantisation), for a tone span `black_dn`–`white_dn`: a level so near either end that the
/// curve's clipping cuts its σ by more than [`MAX_CLIP_BIAS`] is left out, as is a σ too small to
/// tell from the quantisation.
pub fn fit_noise_levels(
    measured: &[LevelNoise],
    model_sigma_dn: impl Fn(f64) -> f64,
    black_dn: f64,
    white_dn: f64,
) -> NoiseLevelFit {
    let mut skipped = Vec::new();
    let mut raw: Vec<GainPoint> = Vec::new();
    for m in measured {
        // Far from both ends (or no σ at all) the clipping cuts nothing.
        let ends_sd = ((m.level_dn - black_dn).min(white_dn - m.level_dn) / m.sigma_dn).min(40.0);
        let kept = crate::numeric::dist::censored_normal_sd_ratio(ends_sd);
        if kept.is_nan() || kept < 1.0 - MAX_CLIP_BIAS {
            skipped.push(format!(
                "{} ({:.1} DN): {:.1}σ from the tone curve's end, whose clipping cuts its noise \
                 by {:.0} %",
                m.what,
                m.level_dn,
                ends_sd,
                100.0 * (1.0 - kept.clamp(0.0, 1.0))
            ));
            continue;
        }
        if !(m.sigma_dn >= MIN_SIGMA_DN && m.sigma_stderr_dn.is_finite()) {
            skipped.push(format!(
                "{} ({:.1} DN): σ {:.2} DN, too little to tell from the 8-bit quantisation",
                m.what, m.level_dn, m.sigma_dn
            ));
            continue;
        }
        let model = model_sigma_dn(m.level_dn);
        let model_sensor = without_quantisation_dn(model);
        let sensor = without_quantisation_dn(m.sigma_dn);
        if !(model_sensor > 0.0 && sensor > 0.0) {
            skipped.push(format!(
                "{} ({:.1} DN): the model draws no noise there",
                m.what, m.level_dn
            ));
            continue;
        }
        // d(sensor)/d(σ) = σ / sensor.
        let se = m.sigma_stderr_dn * m.sigma_dn / sensor / model_sensor;
        raw.push(GainPoint {
            what: vec![m.what.clone()],
            level_dn: m.level_dn,
            measured_dn: m.sigma_dn,
            model_dn: model,
            gain: (sensor / model_sensor).clamp(GAIN_RANGE.0, GAIN_RANGE.1),
            gain_se: se.max(1e-6),
        });
    }
    raw.sort_by(|a, b| a.level_dn.total_cmp(&b.level_dn));
    NoiseLevelFit {
        points: pool(raw),
        skipped,
    }
}

/// Pools points within [`MERGE_DN`] of the first of their group, weighted by the inverse
/// variance of their factors.
fn pool(sorted: Vec<GainPoint>) -> Vec<GainPoint> {
    let mut out: Vec<GainPoint> = Vec::new();
    let mut group: Vec<GainPoint> = Vec::new();
    let flush = |group: &mut Vec<GainPoint>, out: &mut Vec<GainPoint>| {
        if group.is_empty() {
            return;
        }
        let w: Vec<f64> = group.iter().map(|p| p.gain_se.powi(-2)).collect();
        let sw: f64 = w.iter().sum();
        let avg = |f: &dyn Fn(&GainPoint) -> f64| {
            group.iter().zip(&w).map(|(p, w)| f(p) * w).sum::<f64>() / sw
        };
        out.push(GainPoint {
            what: group.iter().flat_map(|p| p.what.clone()).collect(),
            level_dn: avg(&|p| p.level_dn),
            measured_dn: avg(&|p| p.measured_dn),
            model_dn: avg(&|p| p.model_dn),
            gain: avg(&|p| p.gain),
            gain_se: sw.powf(-0.5),
        });
        group.clear();
    };
    for p in sorted {
        if group
            .first()
            .is_some_and(|g| p.level_dn - g.level_dn > MERGE_DN)
        {
            flush(&mut group, &mut out);
        }
        group.push(p);
    }
    flush(&mut group, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn at(what: &str, level_dn: f64, sigma_dn: f64) -> LevelNoise {
        LevelNoise {
            what: what.into(),
            level_dn,
            sigma_dn,
            sigma_stderr_dn: 0.02 * sigma_dn,
        }
    }

    fn flat(sensor_dn: f64) -> impl Fn(f64) -> f64 {
        move |_| with_quantisation_dn(sensor_dn)
    }

    #[test]
    fn factors_are_the_sensor_sigma_over_the_model_pooled_by_level() {
        let q = with_quantisation_dn;
        let fit = fit_noise_levels(
            &[
                at("ink, first dwell", 48.0, q(3.5)),
                at("ink, last dwell", 100.0, q(2.5)),
                at("paper, first dwell", 205.0, q(1.0)),
                at("surround, first dwell", 207.0, q(1.0)),
            ],
            flat(2.5),
            30.0,
            240.0,
        );
        assert!(fit.skipped.is_empty(), "{:?}", fit.skipped);
        assert_eq!(fit.points.len(), 3);
        let gains: Vec<f64> = fit.points.iter().map(|p| p.gain).collect();
        for (g, want) in gains.iter().zip([1.4, 1.0, 0.4]) {
            assert!((g - want).abs() < 1e-9, "{gains:?}");
        }
        assert!((fit.points[2].level_dn - 206.0).abs() < 1e-9);
        assert_eq!(fit.points[2].what.len(), 2);
        assert!(fit.shows_levels());
        assert!(fit.points[0].departs() && !fit.points[1].departs());
        let t = fit.table();
        assert_eq!(t.len(), 3);
        assert!(t
            .windows(2)
            .all(|w| w[1].level_dn - w[0].level_dn > MERGE_DN));
    }

    #[test]
    fn noise_as_the_model_draws_it_needs_no_table() {
        let q = with_quantisation_dn;
        // 5 % off, far beyond its standard error: below the departure worth a table.
        let fit = fit_noise_levels(
            &[at("ink", 48.0, q(2.625)), at("paper", 200.0, q(2.5))],
            flat(2.5),
            30.0,
            240.0,
        );
        assert_eq!(fit.points.len(), 2);
        assert!(!fit.shows_levels());
        // 30 % off but measured on too few pixels to tell.
        let mut noisy = at("ink", 48.0, q(3.25));
        noisy.sigma_stderr_dn = 0.5;
        assert!(!fit_noise_levels(&[noisy], flat(2.5), 30.0, 240.0).shows_levels());
    }

    #[test]
    fn clipped_and_quantised_levels_are_left_out_saying_why() {
        let fit = fit_noise_levels(
            &[
                at("ink", 33.0, 2.0),
                at("paper", 239.0, 1.0),
                at("disc", 150.0, 0.3),
            ],
            flat(2.0),
            30.0,
            240.0,
        );
        assert!(fit.points.is_empty());
        assert_eq!(fit.skipped.len(), 3);
        assert!(fit.skipped[0].contains("1.5σ from the tone curve's end"));
        assert!(fit.skipped[0].contains("clipping cuts its noise by 6 %"));
        assert!(fit.skipped[1].contains("1.0σ"));
        assert!(fit.skipped[2].contains("quantisation"));
        assert!(!fit.shows_levels());
    }

    /// A glossy print's ink 2.65σ above the black level (measured on path-traced footage): its
    /// clipping takes 0.4 % of the σ, so the level is measured, not left out.
    #[test]
    fn a_level_more_than_two_sigma_from_the_end_is_measured() {
        let fit = fit_noise_levels(&[at("ink", 48.9, 4.57)], flat(2.29), 36.79, 241.0);
        assert!(fit.skipped.is_empty(), "{:?}", fit.skipped);
        assert_eq!(fit.points.len(), 1);
        assert!(fit.shows_levels());
    }
}
