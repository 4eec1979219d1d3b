//! Moment matching: an effect whose parameter one statistic of the gap map carries (optical
//! and motion blur on edge widths, the rolling shutter's readout on the marker's stretch, the
//! compression on blockiness, the pixel noise on the ink's and paper's noise) is matched on it
//! in a few simulations (secant or Newton steps, [`crate::diagnose::moments`]).

use super::{aligned_of, moment_method, with_edge_discrepancy, FitError, Fitter, Found};
use crate::diagnose::gap::GapMap;
use crate::diagnose::moments;
use crate::scenario::effects::Effect;

/// Simulations a moment match takes at most (secant or Newton steps).
pub(super) const MOMENT_SIMULATIONS: usize = 3;

/// Blockiness per percent of JPEG quantisation scale: the first step's slope of a compression
/// match when the nominal's own blockiness gives none. Measured on the second rig's strong case
/// (commit `2a5b40d`: quality 30, scale 167, blockiness 3.1 against 1.0 without
/// JPEG). Later steps take the secant.
const BLOCKINESS_PER_JPEG_SCALE: f64 = 0.0127;

/// The coordinate a one-parameter moment match steps in ([`moments`]).
#[derive(Clone, Copy, Debug, PartialEq)]
enum MomentCoord {
    /// The parameter itself.
    Linear,
    /// Its square (a blur's σ or exposure, against an edge variance).
    Squared,
    /// A JPEG quality's quantisation scale ([`moments::jpeg_scale_of_quality`]).
    JpegScale,
}

impl MomentCoord {
    fn x_of(self, v: f64) -> f64 {
        match self {
            Self::Linear => v,
            Self::Squared => v * v,
            Self::JpegScale => moments::jpeg_scale_of_quality(v),
        }
    }

    fn value_of(self, x: f64) -> f64 {
        match self {
            Self::Linear => x,
            Self::Squared => x.max(0.0).sqrt(),
            Self::JpegScale => moments::quality_of_jpeg_scale(x),
        }
    }

    /// |dv/dx| at `v`, to carry an uncertainty in x over to the parameter.
    fn dv_dx(self, v: f64) -> f64 {
        match self {
            Self::Linear => 1.0,
            Self::Squared => 1.0 / (2.0 * v.max(1e-12)),
            Self::JpegScale => moments::quality_per_jpeg_scale(v),
        }
    }
}

/// The part of a moment's uncertainty that is not sampling: how differently another honest
/// renderer may draw the same statistic. For the compression's blockiness, the gap map's own
/// tolerance of that channel (what the comparison already forgives between renderers), so a
/// quality is never claimed closer than the statistic it rests on can be trusted; the blurs
/// and the rolling shutter carry theirs on the parameter ([`with_edge_discrepancy`]), the
/// others none.
fn moment_render_tolerance(e: Effect, moment: f64) -> f64 {
    match e {
        Effect::Compression => crate::diagnose::cells::channel("blockiness")
            .map_or(0.0, |c| c.tol_abs + c.tol_rel * moment.abs()),
        _ => 0.0,
    }
}

/// Where a moment match's step `x1` goes within the search range `x_range` of its coordinate:
/// clamped into it, or `None` for a compression whose blockiness asks for a quality beyond it.
/// Such a blockiness is not this effect's map (as the noise's match, `noise_by_moments`), and
/// Σ z² over the whole signature judges it instead; on pixel-noise footage every compression
/// match otherwise stopped at the bound.
fn moment_step_in_range(e: Effect, x1: f64, x_range: (f64, f64)) -> Option<f64> {
    let clamped = x1.clamp(x_range.0, x_range.1);
    (e != Effect::Compression || clamped == x1).then_some(clamped)
}

/// What a moment match gives: the fit (values, stds, method, as in [`Fitted`]), or a search of
/// Σ z² instead, with the reason when the match ran and was set aside (for the method's words).
pub(super) enum MomentFit {
    Fitted(Found),
    Search(Option<String>),
}

impl Fitter<'_> {
    /// How much a moment's sampling error grows once the simulation set's own mean (on the
    /// fit seeds) is compared with it: √(1 + 1/seeds).
    pub(super) fn moment_sims_factor(&self) -> f64 {
        (1.0 + 1.0 / self.fit_seeds.len() as f64).sqrt()
    }

    /// Fits `e` by moment matching ([`moments`]) when one statistic of the gap map carries its
    /// parameter: optical blur (edge width along the motion, on σ²), motion blur (extra edge
    /// variance across the motion during the drive, on T²), rolling shutter (the readout implied
    /// by stretch against velocity), compression (8-px grid blockiness, on the JPEG quantisation
    /// scale) and pixel noise (noise at the ink and paper levels, on the coordinates where the
    /// variance is linear). [`MomentFit::Search`] for other effects, or
    /// when the data do not give the statistic (the caller then searches Σ z²).
    pub(super) fn fit_by_moments(
        &self,
        e: Effect,
        prior: &[(Effect, Vec<f64>)],
        start: &[f64],
    ) -> Result<MomentFit, FitError> {
        let motion = ["dwell", "entry", "drive", "exit"];
        let sims_factor = self.moment_sims_factor();
        let gap_at = |v: &[f64]| self.gap_with(prior, e, v);
        let method = |what: &str, n: usize| moment_method(what, n, self.fit_seeds.len());
        if e == Effect::PixelNoise {
            return self.noise_by_moments(prior, start);
        }
        // One-parameter effects: coordinate x = T(v), moment m(gap) → (real target, simulated,
        // the target's standard error), model slope dm/dx.
        let speed = self.drive_speed_px_s();
        let (coord, slope0, what): (MomentCoord, f64, &str) = match e {
            Effect::OpticalBlur => (MomentCoord::Squared, 1.0, "edge width² along the motion"),
            Effect::MotionBlur => (
                MomentCoord::Squared,
                (speed * speed / 12.0).max(1e-9),
                "extra edge variance across the motion during the drive",
            ),
            Effect::RollingShutter => (
                MomentCoord::Linear,
                1.0,
                "rolling-shutter readout implied by stretch",
            ),
            Effect::Compression => (
                MomentCoord::JpegScale,
                BLOCKINESS_PER_JPEG_SCALE,
                "8-px grid blockiness (on the JPEG quantisation scale)",
            ),
            _ => return Ok(MomentFit::Search(None)),
        };
        let moment = |g: &GapMap| -> Option<(f64, f64, f64)> {
            match e {
                Effect::OpticalBlur => {
                    let c = moments::channel_means(g, "edge_along", &motion)?;
                    Some((
                        c.real * c.real,
                        c.sim * c.sim,
                        2.0 * c.real.abs() * c.real_std,
                    ))
                }
                Effect::MotionBlur => {
                    let a = moments::channel_means(g, "edge_across", &["drive"])?;
                    let l = moments::channel_means(g, "edge_along", &["drive"])?;
                    Some((
                        a.real * a.real - l.real * l.real,
                        a.sim * a.sim - l.sim * l.sim,
                        2.0 * ((a.real * a.real_std).powi(2) + (l.real * l.real_std).powi(2))
                            .sqrt(),
                    ))
                }
                Effect::Compression => {
                    let c = moments::channel_means(g, "blockiness", &motion)?;
                    Some((c.real, c.sim, c.real_std))
                }
                _ => {
                    // The sub-pixel shape's readout when the frames were seen, the corner
                    // track's otherwise (a tracks CSV).
                    let c = moments::channel_means(g, "rs_fine", &["all"])
                        .or_else(|| moments::channel_means(g, "rs_readout", &["all"]))?;
                    Some((c.real, c.sim, c.real_std))
                }
            }
        };
        // The compression's blockiness at the nominal's own quality (none when it compresses
        // nothing), read off the nominal's simulations: with the first simulation it gives the
        // slope of this footage's blockiness against the scale, which depends on its content
        // and noise, so the model slope serves only when the two coincide.
        let anchor = (e == Effect::Compression)
            .then(|| {
                let s = &aligned_of(self).scenario;
                let x = if e.is_on(s) {
                    coord.x_of(e.values(s)[0])
                } else {
                    0.0
                };
                moments::channel_means(&self.nominal_gap, "blockiness", &motion).map(|c| (x, c.sim))
            })
            .flatten();
        let mut slope0 = slope0;
        let spec = self.specs(e)[0];
        let (x_lo, x_hi) = {
            let (a, b) = (coord.x_of(spec.search.0), coord.x_of(spec.search.1));
            (a.min(b), a.max(b))
        };
        let mut v = start.to_vec();
        let mut history: Vec<(f64, f64)> = Vec::new();
        for k in 0..MOMENT_SIMULATIONS {
            let x = coord.x_of(v[0]);
            let Some((target, m, m_std)) = moment(&gap_at(&v)?) else {
                return Ok(MomentFit::Search(None));
            };
            if let (0, Some((xa, ma))) = (k, anchor) {
                let s = (m - ma) / (x - xa);
                if s.is_finite() && s > 0.0 && (x - xa).abs() > 1.0 {
                    slope0 = s;
                }
            }
            history.push((x, m));
            let Some((x1, slope)) = moments::secant_step(&history, target, slope0) else {
                return Ok(MomentFit::Search(None));
            };
            let Some(x1) = moment_step_in_range(e, x1, (x_lo, x_hi)) else {
                return Ok(MomentFit::Search(Some(format!(
                    "; searched, not matched: the blockiness asked for a quality beyond {:.0}–{:.0}",
                    spec.search.0, spec.search.1
                ))));
            };
            let done = (m - target).abs() < 0.25 * m_std || k + 1 == MOMENT_SIMULATIONS;
            v[0] = coord.value_of(x1);
            if done {
                let sd_m = (m_std * sims_factor).hypot(moment_render_tolerance(e, target));
                let sd_v = coord.dv_dx(v[0]) * sd_m / slope.abs();
                let mut sd = vec![f64::INFINITY; v.len()];
                sd[0] = if sd_v.is_finite() {
                    with_edge_discrepancy(e, v[0], sd_v)
                } else {
                    f64::INFINITY
                };
                return Ok(MomentFit::Fitted((v, sd, method(what, k + 1))));
            }
        }
        Ok(MomentFit::Search(None))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_compression_match_beyond_its_quality_range_is_handed_to_the_search() {
        let c = MomentCoord::JpegScale;
        let (a, b) = (c.x_of(5.0), c.x_of(98.0));
        let range = (a.min(b), a.max(b));
        let inside = c.x_of(40.0);
        assert_eq!(
            moment_step_in_range(Effect::Compression, inside, range),
            Some(inside)
        );
        // Quality 99.5 and 2 lie beyond 5–98 on either side of the scale.
        for q in [99.5, 2.0] {
            assert_eq!(
                moment_step_in_range(Effect::Compression, c.x_of(q), range),
                None,
                "q {q}"
            );
        }
        // The blurs and the readout keep the bound: their step is clamped, not handed over.
        assert_eq!(
            moment_step_in_range(Effect::OpticalBlur, 9.0, (0.0, 4.0)),
            Some(4.0)
        );
        assert_eq!(
            moment_step_in_range(Effect::RollingShutter, -1.0, (0.0, 0.05)),
            Some(0.0)
        );
    }

    #[test]
    fn a_compression_is_matched_on_the_jpeg_scale_within_the_blockinesss_tolerance() {
        let c = MomentCoord::JpegScale;
        for q in [5.0, 30.0, 49.0, 60.0, 98.0] {
            assert!((c.value_of(c.x_of(q)) - q).abs() < 1e-9, "{q}");
        }
        // Blockiness grows with the scale, so a lower quality is a larger x.
        assert!(c.x_of(30.0) > c.x_of(60.0));
        // An uncertainty in the scale carries over with |dq/dx|: a central difference.
        let (q, h) = (30.0, 1e-3);
        let x = 5000.0 / q;
        let num = (c.value_of(x - h) - c.value_of(x + h)) / (2.0 * h);
        assert!((num - c.dv_dx(q)).abs() < 1e-6, "{num} vs {}", c.dv_dx(q));
        assert_eq!(MomentCoord::Squared.dv_dx(2.0), 0.25);
        assert_eq!(MomentCoord::Linear.x_of(3.0), 3.0);
        // The compression's quality is never stated closer than the blockiness channel's own
        // tolerance between renderers; the other moments carry none here.
        let spec = crate::diagnose::cells::channel("blockiness").unwrap();
        let tol = moment_render_tolerance(Effect::Compression, 3.0);
        assert!((tol - (spec.tol_abs + 3.0 * spec.tol_rel)).abs() < 1e-12 && tol > 0.0);
        assert_eq!(moment_render_tolerance(Effect::RollingShutter, 3.0), 0.0);
        assert_eq!(moment_render_tolerance(Effect::OpticalBlur, 3.0), 0.0);
    }
}
