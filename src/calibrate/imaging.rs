//! Image formation from the per-frame statistics: grey levels of ink, paper and disc, blur σ,
//! pixel noise (shot + read) and JPEG compression, and their mapping onto the renderer's
//! parameters (levels and radiances, `optical_blur.sigma_px`, `pixel_noise` electrons).

use super::exposure::{fit_drift, ContrastSample, ExposureDrift};
use super::noise_levels::QUANTISATION_VAR_DN2;
use super::{blur_model, CalibrateError, Fitted, FootageStats};
use crate::imagestats::{EdgeProfile, RegionStats};
use crate::numeric::robust::{median_in_place as median, sample_sd};
use crate::render::effects::compression::jpeg_round_trip;
use crate::render::effects::pixel_noise::{frame_key, normal_at};

/// The noise model: measured σ at the ink and paper levels and the renderer's electrons.
#[derive(Debug, Clone, PartialEq)]
pub struct NoiseFit {
    /// Measured noise σ at the ink and paper levels, DN (after compression, as in the footage).
    pub ink_sigma_dn: Fitted,
    pub paper_sigma_dn: Fitted,
    /// `effects.pixel_noise.full_well_e` and `read_noise_e` reproducing them.
    pub full_well_e: f64,
    pub read_noise_e: f64,
    /// The noise grows with the level (shot noise resolved).
    pub shot_resolved: bool,
    /// Where the σ came from.
    pub source: String,
    /// How much the measured σ moves per unit of the sensor's σ before compression and
    /// clipping, at the ink and the paper (1 on plain footage; found while matching by
    /// simulation, smaller under JPEG or clipping, where the measured σ tells less).
    pub sensitivity: [f64; 2],
    /// |σ measured on the calibrated scenario's render − σ measured on the footage| at the ink
    /// and the paper after the match, DN: what the two-parameter (shot + read) model leaves
    /// unexplained, a bias the interval must carry.
    pub match_residual_dn: [f64; 2],
    /// Why the sensor's σ before compression cannot be measured to 10 % (`None`: it can).
    pub not_identifiable: Option<String>,
    /// Why the σ the footage shows cannot be told from its texture or processing at all
    /// (`None`: it was measured). Then `ink_sigma_dn` and `paper_sigma_dn` are the base's σ at
    /// the footage's levels (U = 0: not measured), and so are the electrons.
    pub footage_not_identifiable: Option<String>,
    /// Under JPEG: how far the σ before compression moves over the quality range the quantiser
    /// allows, at the ink and the paper, DN (0 without compression).
    pub compression_u_dn: [f64; 2],
    /// The measured σ at the ink / the paper is below [`QUANTISATION_LIMITED_DN`]: the 8-bit
    /// values of the region take essentially two adjacent levels, whose shares the mean level
    /// fixes whatever the σ before quantisation, so that σ is not identifiable there.
    pub quantisation_limited: [bool; 2],
}

/// Below this measured σ (DN) the sensor's σ before quantisation is not identifiable: two
/// adjacent 8-bit levels hold the region's pixels (two levels of shares p and 1 − p have σ
/// √(p(1 − p)) ≤ ½).
pub const QUANTISATION_LIMITED_DN: f64 = 0.5;

/// The total σ (sensor and quantisation) whose region still shows mostly two levels: a sensor σ
/// of ½ DN, √(½² + 1/12) DN.
const QUANTISED_TOTAL_MAX_DN: f64 = 0.577_350_269_189_625_8;

/// The quantisation floor: σ of rounding to whole DN, 1/√12 DN.
const QUANTISATION_FLOOR_DN: f64 = 0.288_675_134_594_812_9;

impl NoiseFit {
    /// The sensor's noise σ at `level_dn` of material `m` (0 ink, 1 paper) before compression,
    /// with the 1/√12 DN quantisation floor, from the fitted electrons under `black`/`white`,
    /// and its 95 % interval: the measured σ's uncertainty through the match's sensitivity,
    /// twice over (the footage's sample and the simulation's), plus the match residual through
    /// the same sensitivity (a bias, added linearly).
    pub fn sensor_sigma_dn(&self, m: usize, level_dn: f64, black: f64, white: f64) -> Fitted {
        let value = sensor_sigma(level_dn, black, white, self.full_well_e, self.read_noise_e);
        let measured = if m == 0 {
            self.ink_sigma_dn
        } else {
            self.paper_sigma_dn
        };
        if self.quantisation_limited[m] {
            // Anything from the floor (no sensor noise) to the largest σ that still keeps the
            // pixels on two levels is consistent with the footage.
            return Fitted::new(
                value,
                (value - QUANTISATION_FLOOR_DN).max(QUANTISED_TOTAL_MAX_DN - value),
            );
        }
        let sens = self.sensitivity[m].max(1e-3);
        Fitted::new(
            value,
            (std::f64::consts::SQRT_2 * measured.u95 + self.match_residual_dn[m]) / sens
                + self.compression_u_dn[m],
        )
    }
}

/// The renderer's noise σ at `level_dn`, DN: shot + read through the tone span, plus the
/// quantisation to whole DN (variance 1/12).
pub fn sensor_sigma(level_dn: f64, black: f64, white: f64, full_well_e: f64, read_e: f64) -> f64 {
    let span = white - black;
    let s = ((level_dn - black) / span).max(0.0);
    (span * span * (s * full_well_e + read_e * read_e) / (full_well_e * full_well_e)
        + QUANTISATION_VAR_DN2)
        .sqrt()
}

/// Image formation of the footage.
#[derive(Debug, Clone, PartialEq)]
pub struct ImagingFit {
    /// Grey levels of the disc marker's ink and paper and of the disc around its paper, DN.
    pub ink_dn: Fitted,
    pub paper_dn: Fitted,
    pub disc_dn: Option<Fitted>,
    /// Frames whose levels were used.
    pub level_frames: usize,
    /// `effects.lighting` black and white levels and the scene radiances that reproduce the
    /// levels with room for the noise on both sides.
    pub black_level_dn: f64,
    pub white_level_dn: f64,
    pub ink_radiance: f64,
    pub paper_radiance: f64,
    pub disc_radiance: Option<f64>,
    /// Blur σ of the continuous PSF from the edge fits, px, and the scenario's
    /// `optical_blur.sigma_px` that renders it.
    pub blur_sigma_px: Option<Fitted>,
    pub blur_sigma_param_px: Option<Fitted>,
    pub blur_edges: usize,
    /// The footage's unsharp mask as measured (drawn when `significant`).
    pub sharpening: Option<super::sharpening::SharpeningFit>,
    pub noise: NoiseFit,
    /// Median 8-px blockiness ratio (Wang–Sheikh–Bovik B/A; ≈ 1 without block coding).
    pub blockiness: Option<f64>,
    /// JPEG quality when the footage is JPEG-quantised: (quality, range, frames agreeing).
    pub jpeg_quality: Option<(u8, (u8, u8), usize)>,
    pub compression_frames: usize,
    /// The reference marker's own levels and blur, when measured.
    pub reference_ink_dn: Option<Fitted>,
    pub reference_paper_dn: Option<Fitted>,
    pub reference_blur_sigma_px: Option<Fitted>,
    /// The light's drift over the footage (`exposure`); the levels above hold at its
    /// reference time, and the black and white levels leave room for its whole range.
    pub exposure: ExposureDrift,
}

/// Median over frames with U = 2·1.2533·sd/√n (the median's standard error), floored.
fn robust_level(values: &[f64], floor: f64) -> Option<Fitted> {
    if values.is_empty() {
        return None;
    }
    let mut v = values.to_vec();
    let m = median(&mut v);
    let n = v.len() as f64;
    let sd = sample_sd(&v);
    Some(Fitted::from_sigma(m, 1.2533 * sd / n.sqrt(), floor))
}

fn blur_of(edges: &[&EdgeProfile]) -> Option<Fitted> {
    let sigmas: Vec<f64> = edges
        .iter()
        .filter(|e| e.sigma_stderr_px.is_finite())
        .map(|e| e.sigma_px)
        .collect();
    let r = robust_level(&sigmas, 0.0)?;
    let se = edges
        .iter()
        .map(|e| e.sigma_stderr_px)
        .filter(|s| s.is_finite())
        .sum::<f64>()
        / edges.len().max(1) as f64;
    // A single edge's own standard error bounds how well one edge can tell; the continuous
    // PSF model and the renderer's kernel sampled at whole pixels differ by up to ~0.03 px.
    Some(Fitted::new(
        r.value,
        r.u95.max(2.0 * se / (sigmas.len() as f64).sqrt()) + 0.01 * r.value + 0.03,
    ))
}

/// Ratio of the noise σ after a JPEG round trip at `quality` to the σ before, for a flat patch
/// at `level_dn` (the renderer adds noise before compressing; the footage shows it after).
fn jpeg_noise_ratio(level_dn: f64, sigma_dn: f64, quality: u8) -> f64 {
    let (w, h) = (64usize, 64usize);
    let key = frame_key(0x4a50_4547, 0);
    let noisy: Vec<f64> = (0..w * h)
        .map(|i| level_dn + sigma_dn * normal_at(key, (i % w) as i64, (i / w) as i64) as f64)
        .collect();
    let q: Vec<u8> = noisy
        .iter()
        .map(|v| (v + 0.5).clamp(0.0, 255.0) as u8)
        .collect();
    let sd = |v: &[f64]| {
        let m = v.iter().sum::<f64>() / v.len() as f64;
        (v.iter().map(|x| (x - m).powi(2)).sum::<f64>() / (v.len() - 1) as f64).sqrt()
    };
    let before = sd(&q.iter().map(|&x| x as f64).collect::<Vec<_>>());
    let Ok(out) = jpeg_round_trip(&q, w, h, quality) else {
        return 1.0;
    };
    let after = sd(&out.iter().map(|&x| x as f64).collect::<Vec<_>>());
    if before > 0.0 {
        after / before
    } else {
        1.0
    }
}

/// The renderer's noise electrons for variances `vars_dn2` (before quantisation) at grey levels
/// `levels_dn` (ink, paper) under `black`/`white` levels: var(DN) = α + β·(DN − black) with
/// β = span/full_well and α = (span·read/full_well)², through the two points, with β at least
/// the value that gives 0.04 DN² of shot variance between ink and paper (so the model stays
/// continuous when the paper is not noisier than the ink) and the read noise inside the
/// scenario's range. Returns (full_well_e, read_noise_e, shot_resolved) where shot noise counts
/// as resolved when the variance difference exceeds `resolvable_dn2`.
pub fn noise_electrons(
    levels_dn: [f64; 2],
    vars_dn2: [f64; 2],
    black: f64,
    white: f64,
    resolvable_dn2: f64,
) -> (f64, f64, bool) {
    let span = (white - black).max(1.0);
    let (li, lp) = (levels_dn[0] - black, levels_dn[1] - black);
    let (vi, vp) = (vars_dn2[0].max(0.0), vars_dn2[1].max(0.0));
    let dl = (lp - li).max(1.0);
    let beta = ((vp - vi) / dl).max(0.04 / dl);
    let alpha = (vi - beta * li.max(0.0)).max(0.0);
    let mut fw = (span / beta).clamp(1.0, 1e7);
    if alpha > 0.0 {
        fw = fw.min(1e4 * span / alpha.sqrt()).max(1.0);
    }
    let read = (alpha.sqrt() * fw / span).clamp(0.0, 1e4);
    (fw, read, vp - vi > resolvable_dn2)
}

/// The base scenario's pixel noise: what the calibrated scenario carries where the footage
/// cannot tell its own.
#[derive(Debug, Clone, PartialEq)]
pub struct BaseNoise {
    pub enabled: bool,
    pub black_level_dn: f64,
    pub white_level_dn: f64,
    pub full_well_e: f64,
    pub read_noise_e: f64,
}

impl BaseNoise {
    pub fn of(base: &crate::scenario::Scenario) -> BaseNoise {
        let fx = &base.effects;
        let span = fx.lighting.span_dn();
        let black = if fx.lighting.enabled {
            fx.lighting.black_level_dn
        } else {
            0.0
        };
        BaseNoise {
            enabled: fx.pixel_noise.enabled,
            black_level_dn: black,
            white_level_dn: black + span,
            full_well_e: fx.pixel_noise.full_well_e,
            read_noise_e: fx.pixel_noise.read_noise_e,
        }
    }

    /// The base's σ at `level_dn` with the 1/√12 DN quantisation (only that when it is off).
    pub fn sigma_dn(&self, level_dn: f64) -> f64 {
        if self.enabled {
            sensor_sigma(
                level_dn,
                self.black_level_dn,
                self.white_level_dn,
                self.full_well_e,
                self.read_noise_e,
            )
        } else {
            QUANTISATION_FLOOR_DN
        }
    }

    pub fn describe(&self) -> String {
        if self.enabled {
            format!(
                "the base's pixel noise (full well {} e⁻, read {} e⁻ over its levels {}–{} DN), \
                 as σ in DN at the footage's levels",
                self.full_well_e, self.read_noise_e, self.black_level_dn, self.white_level_dn
            )
        } else {
            "the base's: no pixel noise".into()
        }
    }
}

/// The footage's σ of material `m` (0 ink, 1 paper) from the weak-texture estimates of its
/// frames: the median over the frames whose estimate is the sensor's white noise, with the
/// larger of the median's spread and one estimate's own standard error; or why there is none.
pub fn spatial_sigma(stats: &FootageStats, m: usize) -> Result<Fitted, String> {
    let est: Vec<&crate::imagestats::WeakTextureNoise> = stats.weak_texture_noise(m).collect();
    if est.is_empty() {
        return Err("no frame holds a region large enough for the weak-texture estimate".into());
    }
    let ok: Vec<_> = est
        .iter()
        .filter(|e| e.not_identifiable().is_none())
        .collect();
    if 2 * ok.len() <= est.len() {
        return Err(est
            .iter()
            .find_map(|e| e.not_identifiable())
            .unwrap_or_default());
    }
    let sigmas: Vec<f64> = ok.iter().map(|e| e.sigma_dn).collect();
    let spread = robust_level(&sigmas, 0.0).ok_or("no estimate")?;
    let mut se: Vec<f64> = ok.iter().map(|e| e.sigma_stderr_dn).collect();
    let se = median(&mut se);
    Ok(Fitted::new(
        spread.value,
        spread.u95.max(2.0 * se) + 0.03 * spread.value,
    ))
}

/// Under JPEG, the plain σ of material `m` (median over frames of the σ about a plane, which
/// holds texture too) when the footage's weak-texture σ agrees with the weak-texture σ of a flat
/// patch at `level_dn` whose noise shows that plain σ after the same codec: then what the region
/// holds is that noise through the codec, not texture. (On a flat patch at quality 85, noise of
/// 0.8 DN leaves a weak-texture σ of 0 and 5 DN leaves 4.5; print mottle or a phone's denoising
/// leaves a plain σ of several DN over flattened patches.)
fn codec_explained(
    stats: &FootageStats,
    m: usize,
    level_dn: f64,
    regions: &[&RegionStats],
    quality: u8,
) -> Result<Fitted, String> {
    let plain = robust_level(
        &regions.iter().map(|s| s.noise_sigma_dn).collect::<Vec<_>>(),
        0.0,
    )
    .ok_or("no region")?;
    let mut weak: Vec<f64> = stats.weak_texture_noise(m).map(|e| e.sigma_dn).collect();
    if weak.is_empty() {
        return Err("no weak-texture estimate to compare with the codec's".into());
    }
    let footage = median(&mut weak);
    // The flat patch: noise before the codec that shows the plain σ after it.
    let mut pre = plain.value;
    for _ in 0..3 {
        pre = plain.value / jpeg_noise_ratio(level_dn, pre, quality).max(0.05);
    }
    let model = jpeg_flat_weak_texture_sigma(level_dn, pre, quality)
        .ok_or("the codec's weak-texture σ could not be simulated")?;
    let tolerance = 0.2 * plain.value + 0.1;
    if (footage - model).abs() <= tolerance {
        Ok(Fitted::new(plain.value, plain.u95 + 0.03 * plain.value))
    } else {
        Err(format!(
            "its plain σ {:.2} DN is not noise through the JPEG at quality {quality}: such noise \
             leaves a weak-texture σ of {model:.2} DN, the footage {footage:.2} DN",
            plain.value
        ))
    }
}

/// The weak-texture σ of a flat 96×96 patch at `level_dn` with white noise of `sigma_dn`
/// after a JPEG round trip at `quality`.
fn jpeg_flat_weak_texture_sigma(level_dn: f64, sigma_dn: f64, quality: u8) -> Option<f64> {
    let n = 96usize;
    let key = frame_key(0x5754_4a50, 0);
    let q: Vec<u8> = (0..n * n)
        .map(|i| {
            let v = level_dn + sigma_dn * normal_at(key, (i % n) as i64, (i / n) as i64) as f64;
            (v + 0.5).clamp(0.0, 255.0) as u8
        })
        .collect();
    let out = jpeg_round_trip(&q, n, n, quality).ok()?;
    let view = crate::detect::GrayView::full(&out, n, n);
    let pixels: Vec<(i64, i64)> = (0..n as i64)
        .flat_map(|y| (0..n as i64).map(move |x| (x, y)))
        .collect();
    crate::imagestats::weak_texture_noise(&view, &pixels, &Default::default())
        .ok()
        .map(|e| e.sigma_dn)
}

/// Fits the image formation.
pub fn fit_imaging(
    stats: &FootageStats,
    base_noise: &BaseNoise,
    notes: &mut Vec<String>,
) -> Result<ImagingFit, CalibrateError> {
    let levels: Vec<_> = stats
        .frames
        .iter()
        .filter_map(|f| f.levels.as_ref())
        .collect();
    if levels.is_empty() {
        return Err(CalibrateError::Unresolved {
            what: "grey levels".into(),
            reason: "no frame shows enough ink and paper well inside the marker (too small, \
                     or too close to the image edge)"
                .into(),
        });
    }
    let pick =
        |f: fn(&crate::imagestats::MarkerLevels) -> Option<&RegionStats>| -> Vec<&RegionStats> {
            levels.iter().filter_map(|l| f(l)).collect()
        };
    let ink_r = pick(|l| Some(&l.ink));
    let paper_r = pick(|l| Some(&l.paper));
    let disc_r = pick(|l| l.surround.as_ref());
    let level_of = |r: &[&RegionStats]| {
        robust_level(
            &r.iter().map(|s| s.trimmed_mean_dn).collect::<Vec<_>>(),
            0.15,
        )
    };
    // A region whose noise piles up at one level in most frames is clipped there (the tone
    // curve's white or black): that level is the tone curve's end, and the noise σ is the
    // censored normal's. When the region's own mean lies well inside (only a tail is cut: ink
    // a few σ above the black level) the level stays the region's and the end is the clip;
    // otherwise the region sits at the end itself.
    let clip_of = |r: &[&RegionStats], high: bool| -> Option<(Fitted, Fitted, bool)> {
        let c: Vec<_> = r
            .iter()
            .filter_map(|s| s.clipping.as_ref())
            .filter(|c| c.high == high)
            .collect();
        if 2 * c.len() <= r.len() {
            return None;
        }
        let level = robust_level(&c.iter().map(|c| c.level_dn).collect::<Vec<_>>(), 0.15)?;
        let sigma = robust_level(&c.iter().map(|c| c.sigma_dn).collect::<Vec<_>>(), 0.0)?;
        let mut means: Vec<f64> = c.iter().map(|c| c.mean_dn).collect();
        let inside = median(&mut means) - level.value;
        let partial = if high { inside < -0.5 } else { inside > 0.5 };
        Some((
            level,
            Fitted::new(sigma.value, sigma.u95 + 0.05 * sigma.value),
            partial,
        ))
    };
    let ink_clip = clip_of(&ink_r, false);
    let paper_clip = clip_of(&paper_r, true);
    match paper_clip {
        Some((_, _, true)) => notes.push("the paper's noise is cut off above by the white level (its upper tail piles up there): white level = that level, noise σ of the censored normal".into()),
        Some(_) => notes.push("the paper is clipped at the white level (its noise is cut off above): white level = paper level, paper radiance 1".into()),
        None => {}
    }
    match ink_clip {
        Some((_, _, true)) => notes.push("the ink's noise is cut off below by the black level (its lower tail piles up there): black level = that level, noise σ of the censored normal".into()),
        Some(_) => notes.push(
            "the ink is clipped at the black level: black level = ink level, ink radiance 0".into(),
        ),
        None => {}
    }
    let (ink_level, paper_level) = (level_of(&ink_r), level_of(&paper_r));
    let at_end = |c: Option<(Fitted, Fitted, bool)>| c.filter(|c| !c.2).map(|c| c.0);
    let ink_level = at_end(ink_clip).or(ink_level);
    let paper_level = at_end(paper_clip).or(paper_level);
    let (Some(ink_dn), Some(paper_dn)) = (ink_level, paper_level) else {
        return Err(CalibrateError::Unresolved {
            what: "grey levels".into(),
            reason: "no ink or paper region".into(),
        });
    };
    let disc_dn = level_of(&disc_r);

    // Compression first: it changes what the noise means.
    let jpeg_found: Vec<_> = stats.jpeg.iter().flatten().collect();
    let jpeg_quality = if !stats.jpeg.is_empty() && 2 * jpeg_found.len() > stats.jpeg.len() {
        let mut qs: Vec<f64> = jpeg_found.iter().map(|j| j.quality as f64).collect();
        let q = median(&mut qs).round() as u8;
        let lo = jpeg_found
            .iter()
            .map(|j| j.quality_range.0)
            .min()
            .unwrap_or(q);
        let hi = jpeg_found
            .iter()
            .map(|j| j.quality_range.1)
            .max()
            .unwrap_or(q);
        Some((q, (lo, hi), jpeg_found.len()))
    } else {
        None
    };
    let blockiness = {
        let mut b: Vec<f64> = stats.blockiness.iter().map(|b| b.ratio).collect();
        (!b.is_empty()).then(|| median(&mut b))
    };
    if jpeg_quality.is_none() && blockiness.is_some_and(|b| b > 1.1) {
        notes.push(format!(
            "the footage shows 8-px blockiness (B/A = {:.2}) without a JPEG quantiser: block \
             coding by a video codec is not modelled (compression stays off)",
            blockiness.unwrap_or(1.0)
        ));
    }

    // Noise: temporal on static runs when measured, else spatial per frame.
    let temporal = |material: &str| -> Option<Fitted> {
        let t: Vec<_> = stats
            .temporal
            .iter()
            .filter(|s| s.what.ends_with(material) && s.what.starts_with("disc"))
            .chain(
                stats
                    .temporal
                    .iter()
                    .filter(|s| s.what.ends_with(material) && !s.what.starts_with("disc")),
            )
            .collect();
        let s = t.first()?;
        Some(Fitted::from_sigma(
            s.noise.sigma_dn,
            s.noise.sigma_stderr_dn,
            0.01 * s.noise.sigma_dn,
        ))
    };
    // Spatially, only what the weak-texture estimate can tell from texture (`spatial_noise`);
    // a clipped region's σ is its censored normal's (below).
    // Under JPEG the noise a frame shows is not white: its plain σ is taken when the
    // weak-texture σ agrees with what the same noise through the same codec leaves.
    let spatial = |m: usize, clipped: bool| -> Result<(Fitted, bool), String> {
        if clipped {
            return Ok((Fitted::new(0.0, 0.0), false));
        }
        let (level, r) = if m == 0 {
            (ink_dn.value, &ink_r)
        } else {
            (paper_dn.value, &paper_r)
        };
        match (spatial_sigma(stats, m), jpeg_quality) {
            (Ok(f), _) => Ok((f, false)),
            (Err(why), Some((q, _, _))) => codec_explained(stats, m, level, r, q)
                .map(|f| (f, true))
                .map_err(|w| format!("{why}; {w}")),
            (Err(why), None) => Err(why),
        }
    };
    let (ink_sigma, paper_sigma, mut source, footage_not_identifiable) =
        match (temporal("ink"), temporal("paper")) {
            (Some(i), Some(p)) => (
                i,
                p,
                format!(
                    "temporal σ of static pixels ({})",
                    stats
                        .temporal
                        .iter()
                        .map(|s| format!(
                            "{}: {} frames × {} px",
                            s.what, s.noise.frames, s.noise.pixels
                        ))
                        .collect::<Vec<_>>()
                        .join(", ")
                ),
                None,
            ),
            _ => match (
                spatial(0, ink_clip.is_some()),
                spatial(1, paper_clip.is_some()),
            ) {
                (Ok((i, ci)), Ok((p, cp))) => (
                    i,
                    p,
                    format!(
                        "spatial σ of the weak-texture patches (Liu, Tanaka & Okutomi 2013: the \
                         patches whose gradient energy white noise explains; σ² from their \
                         covariance's noise eigenvalues, Chen, Zhu & Heng 2015), median over {} \
                         frames{}",
                        stats.spatial_noise.len(),
                        if ci || cp {
                            "; under JPEG, where that σ is not white noise's, the region's plain \
                             σ about a plane, once the weak-texture σ agrees with what the same \
                             noise through the same codec leaves"
                        } else {
                            ""
                        }
                    ),
                    None,
                ),
                (i, p) => {
                    let why: Vec<String> = [("ink", i), ("paper", p)]
                        .into_iter()
                        .filter_map(|(what, r)| r.err().map(|e| format!("at the {what}: {e}")))
                        .collect();
                    let sigma = |level: f64| Fitted::new(base_noise.sigma_dn(level), 0.0);
                    (
                        sigma(ink_dn.value),
                        sigma(paper_dn.value),
                        base_noise.describe(),
                        Some(why.join("; ")),
                    )
                }
            },
        };
    let ink_sigma = ink_clip.map_or(ink_sigma, |c| c.1);
    let paper_sigma = paper_clip.map_or(paper_sigma, |c| c.1);
    if ink_clip.is_some() || paper_clip.is_some() {
        source.push_str("; one-sided σ where clipped");
    }
    // Levels with room for 5σ of noise on both sides (the tone curve clips at 0 and 1), unless
    // the footage is clipped there itself, at the darkest and brightest light of a drift: the
    // ink at gain g_lo sits at black + (ink − black)·g_lo, the paper at g_hi likewise.
    let exposure = exposure_drift(stats, notes);
    let (g_lo, g_hi) = exposure.gain_range();
    let black = match ink_clip {
        Some(c) => c.0.value,
        None => (ink_dn.value - 5.0 * ink_sigma.value / g_lo - 1.0 / g_lo).max(0.0),
    };
    let white = match paper_clip {
        Some(c) => c.0.value,
        // Written so that steady light (g_hi = 1) gives the same bits as paper + 5σ + 1.
        None => (paper_dn.value
            + (paper_dn.value - black) * (g_hi - 1.0)
            + 5.0 * paper_sigma.value
            + 1.0)
            .min(255.0),
    }
    .max(black + 10.0);
    let span = white - black;
    let rad = |dn: f64| ((dn - black) / span).clamp(0.0, 1.0);
    // Undo the JPEG's smoothing of the noise (simulated on a flat patch at each level).
    let pre_at = |level: f64, s: f64, q: u8| -> f64 {
        let mut guess = s;
        for _ in 0..3 {
            let r = jpeg_noise_ratio(level, guess, q).max(0.05);
            guess = s / r;
        }
        guess
    };
    // The base's σ (footage not identifiable) is a sensor's σ before compression already.
    let measured = footage_not_identifiable.is_none();
    let pre = |level: f64, s: f64| -> f64 {
        match jpeg_quality {
            Some((q, _, _)) if measured => pre_at(level, s, q),
            _ => s,
        }
    };
    let (compression_u_dn, not_identifiable) = match jpeg_quality {
        _ if !measured => (
            [0.0, 0.0],
            Some(format!(
                "the footage's own noise cannot be told from its texture or processing ({}): \
                 the scenario carries the base's",
                footage_not_identifiable.clone().unwrap_or_default()
            )),
        ),
        Some((q, (lo, hi), _)) => {
            let spread = |level: f64, s: f64| {
                let p = pre_at(level, s, q);
                [lo, hi]
                    .iter()
                    .map(|&b| (pre_at(level, s, b) - p).abs())
                    .fold(0.0, f64::max)
            };
            (
                [
                    spread(ink_dn.value, ink_sigma.value),
                    spread(paper_dn.value, paper_sigma.value),
                ],
                Some(format!(
                    "JPEG at quality {q} ({lo}–{hi}) quantises the 8×8 block DCT coefficients and \
                     so removes part of the noise, by an amount that depends on the quality and \
                     on what else the blocks hold (the marker's edges): the σ after compression \
                     is matched by simulation, the sensor's σ before it is not measured to 10 %"
                )),
            )
        }
        None => ([0.0, 0.0], None),
    };
    let var = |level: f64, s: f64| (pre(level, s).powi(2) - QUANTISATION_VAR_DN2).max(0.0);
    let (vi, vp) = (
        var(ink_dn.value, ink_sigma.value),
        var(paper_dn.value, paper_sigma.value),
    );
    // The variance difference must exceed its own 95 % uncertainty (U(σ²) ≈ 2σ·U(σ)).
    let u_diff =
        (2.0 * paper_sigma.value * paper_sigma.u95).hypot(2.0 * ink_sigma.value * ink_sigma.u95);
    let (full_well_e, read_noise_e, shot_resolved) = noise_electrons(
        [ink_dn.value, paper_dn.value],
        [vi, vp],
        black,
        white,
        u_diff,
    );
    if let Some(why) = &footage_not_identifiable {
        notes.push(format!(
            "pixel noise: not identifiable from this footage ({why}). One frame cannot tell a \
             sensor's noise from fixed texture or from what the camera's processing left; the \
             scenario carries {} instead, flagged. A video with a static stretch (the wheel's \
             dwell) measures it temporally",
            base_noise.describe()
        ));
    }
    for (what, sigma) in [("ink", ink_sigma), ("paper", paper_sigma)] {
        if measured && sigma.value < QUANTISATION_LIMITED_DN {
            notes.push(format!(
                "pixel noise at the {what}: the measured σ {sigma} DN is below \
                 {QUANTISATION_LIMITED_DN} DN, the region's pixels sit on two adjacent 8-bit \
                 levels: the sensor's σ there is not identifiable (anything from 0 to 0.5 DN \
                 before quantisation fits the footage)"
            ));
        }
    }
    if measured && !shot_resolved {
        notes.push(format!(
            "pixel noise: σ does not grow measurably from ink ({}) to paper ({}) DN: modelled as \
             read noise only",
            ink_sigma, paper_sigma
        ));
    }

    // Blur: static frames' disc-marker edges and the reference marker's.
    // Moving frames add motion blur across some edges: use static poses when there are any.
    let static_edges = stats
        .frames
        .iter()
        .filter(|f| f.static_pose && !f.edges.is_empty())
        .count();
    let edges: Vec<&EdgeProfile> = stats
        .frames
        .iter()
        .filter(|f| f.static_pose || static_edges < 2)
        .flat_map(|f| f.edges.iter())
        .chain(stats.reference_edges.iter())
        .collect();
    let blur_sigma_px = blur_of(&edges);
    if blur_sigma_px.is_none() {
        notes.push(
            "blur: no marker edge could be fitted (marker too small or always moving); the \
             base's optical blur is kept"
                .into(),
        );
    }
    // The scenario's σ whose rendered edges the fit measures as the footage's, at the edges'
    // own orientations (`blur_model`: the kernel sampled at whole pixels is not a Gaussian).
    let mut bins = [0usize; blur_model::ANGLE_BINS];
    for e in &edges {
        bins[blur_model::angle_bin(e.normal)] += 1;
    }
    let jpeg_edges = jpeg_quality.map(|(q, _, _)| blur_model::JpegEdges {
        ink_dn: ink_dn.value,
        paper_dn: paper_dn.value,
        quality: q,
    });
    let blur_sigma_param_px = blur_sigma_px
        .map(|b| b.map(|m| blur_model::sigma_param_for_measured(m, &bins, jpeg_edges.as_ref())));
    let ref_edges: Vec<&EdgeProfile> = stats.reference_edges.iter().collect();
    let ref_level = |f: fn(&crate::imagestats::MarkerLevels) -> f64| {
        robust_level(
            &stats.reference_levels.iter().map(f).collect::<Vec<_>>(),
            0.15,
        )
    };
    Ok(ImagingFit {
        ink_dn,
        paper_dn,
        disc_dn,
        level_frames: levels.len(),
        black_level_dn: black,
        white_level_dn: white,
        ink_radiance: rad(ink_dn.value),
        paper_radiance: rad(paper_dn.value),
        disc_radiance: disc_dn.map(|d| rad(d.value)),
        blur_sigma_px,
        blur_sigma_param_px,
        blur_edges: edges.len(),
        sharpening: stats.sharpening,
        noise: NoiseFit {
            ink_sigma_dn: ink_sigma,
            paper_sigma_dn: paper_sigma,
            full_well_e,
            read_noise_e,
            shot_resolved,
            source,
            sensitivity: [1.0, 1.0],
            match_residual_dn: [0.0, 0.0],
            not_identifiable,
            footage_not_identifiable,
            compression_u_dn,
            quantisation_limited: [
                measured && ink_sigma.value < QUANTISATION_LIMITED_DN,
                measured && paper_sigma.value < QUANTISATION_LIMITED_DN,
            ],
        },
        blockiness,
        jpeg_quality,
        compression_frames: stats.jpeg.len(),
        reference_ink_dn: ref_level(|l| l.ink.trimmed_mean_dn),
        reference_paper_dn: ref_level(|l| l.paper.trimmed_mean_dn),
        reference_blur_sigma_px: blur_of(&ref_edges),
        exposure,
    })
}

/// The light's drift from the marker's contrast frame by frame (`exposure`), with a note when
/// one is found.
fn exposure_drift(stats: &FootageStats, notes: &mut Vec<String>) -> ExposureDrift {
    let samples: Vec<ContrastSample> = stats
        .frames
        .iter()
        .filter_map(|f| {
            let (l, c) = (f.levels.as_ref()?, f.corners_px?);
            // A region with a clipped tail follows the light by its censored normal's mean; one
            // clipped through its middle does not follow it at all.
            let level = |r: &RegionStats| match &r.clipping {
                None => Some(r.trimmed_mean_dn),
                Some(c) if c.fraction < 0.5 => Some(c.mean_dn),
                Some(_) => None,
            };
            Some(ContrastSample {
                t_s: f.t_s,
                contrast_dn: level(&l.paper)? - level(&l.ink)?,
                centre_px: [
                    c.iter().map(|p| p[0]).sum::<f64>() / 4.0,
                    c.iter().map(|p| p[1]).sum::<f64>() / 4.0,
                ],
            })
        })
        .collect();
    let drift = fit_drift(&samples, stats.width_px, stats.height_px);
    if let Some(f) = drift.significant() {
        let (lo, hi) = f.gain_range();
        notes.push(format!(
            "the light drifts over the footage: the marker's contrast changes by {} %/s (95 %) \
             about t = {:.2} s, {:.1} % to {:+.1} % over the footage, {}; written as \
             effects.lighting.gain_drift_per_s, the levels hold at t = {:.2} s",
            f.drift_per_s.map(|d| 100.0 * d),
            f.reference_s,
            100.0 * (lo - 1.0),
            100.0 * (hi - 1.0),
            f.gradient_phrase(),
            f.reference_s
        ));
    }
    drift
}
